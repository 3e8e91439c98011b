"""USD reader and writer: round trips, a foreign-style hand-written stage checked against pxr's own
transforms, every shape type, and malformed input.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _compare import assert_morphology_equal
from morphkit_testing import TEST_CREATURES, shipped_morphology

from morphkit.conventions import quat_from_axis_angle, quat_rotate, transform_multiply
from morphkit.errors import DescriptionError, GraphError, MorphkitError
from morphkit.graph import (
    BaseType,
    JointType,
    Limit,
    Morphology,
    MorphologyBuilder,
    Shape,
    ShapeType,
    Transform,
)
from morphkit.io.asset_paths import allow_outside
from morphkit.io.usd import load_usd_mesh, read_usd, write_usd

pxr = pytest.importorskip("pxr")

DATA = Path(__file__).resolve().parents[1] / "data"
ARM = DATA / "tiny_arm.usda"
FINGER = DATA / "meshes" / "finger.obj"
SUFFIXES = (".usda", ".usdc", ".usd")


def every_shape() -> Morphology:
    """A fixed-base creature with every shape type, rotated shape origins and a file mesh."""
    rot = Transform.from_xyz_rpy
    b = MorphologyBuilder("every_shape")
    b.set_base("fixed")
    b.add_link(
        "base",
        shapes=[
            Shape(ShapeType.BOX, rot((0.1, 0.0, 0.05), (0.1, 0.2, 0.3)), size=(0.4, 0.2, 0.1)),
            Shape(ShapeType.SPHERE, rot((0.0, 0.2, 0.0), (0.0, 0.0, 0.0)), radius=0.05),
        ],
    )
    b.add_link(
        "arm",
        shapes=[
            Shape(ShapeType.CAPSULE, rot((0.0, 0.0, 0.15), (0.5, -0.4, 0.0)), radius=0.03, length=0.3),
            Shape(ShapeType.CYLINDER, rot((0.02, 0.0, 0.0), (0.0, math.pi / 2, 0.0)), radius=0.02, length=0.1),
            Shape(ShapeType.MESH, rot((0.0, 0.01, 0.3), (0.0, 0.0, 1.0)), mesh=str(FINGER), scale=(1.0, 2.0, 0.5)),
        ],
    )
    b.add_joint_revolute(
        "shoulder",
        "base",
        "arm",
        origin=rot((0.0, 0.0, 0.1), (0.3, 0.0, 0.0)),
        axis=(0.0, -1.0, 0.0),
        limit=Limit(-1.0, 2.0, velocity=3.0, effort=40.0),
    )
    b.add_end_effector("tip", "arm", offset=(0.0, 0.0, 0.35), role="tool")
    return b.build()


CREATURES = {**TEST_CREATURES, "every_shape": every_shape}


# ---- round trips -----------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", SUFFIXES)
@pytest.mark.parametrize("name", sorted(CREATURES))
def test_round_trip(tmp_path: Path, name: str, suffix: str) -> None:
    """Every joint type (arbitrary axes), every base type, mimic, wheels, every shape: to 1e-6."""
    m = CREATURES[name]()
    path = tmp_path / f"{name}{suffix}"
    write_usd(m, path)
    with allow_outside():  # a mesh file stays where it was: outside the new file's folder
        back = read_usd(path)
    assert_morphology_equal(m, back, 1e-6)
    assert back.source == str(path)
    # Velocity and effort limits survive too.
    for j in m.joints:
        if j.limit is not None and j.limit.velocity is not None:
            assert back.joint(j.name).limit.velocity == pytest.approx(j.limit.velocity)
            assert back.joint(j.name).limit.effort == pytest.approx(j.limit.effort)
    # Writing what was read gives the same file.
    again = tmp_path / f"again{suffix}"
    write_usd(back, again)
    with allow_outside():
        assert_morphology_equal(back, read_usd(again), 1e-6)


def test_file_formats_and_layout(tmp_path: Path) -> None:
    m = TEST_CREATURES["every_joint_fixed"]()
    for suffix, magic in ((".usda", b"#usda 1.0"), (".usdc", b"PXR-USDC"), (".usd", b"PXR-USDC")):
        path = tmp_path / f"robot{suffix}"
        write_usd(m, path)
        assert path.read_bytes().startswith(magic)
    text = (tmp_path / "robot.usda").read_text()
    assert 'upAxis = "Z"' in text and "metersPerUnit = 1" in text
    assert "PhysicsArticulationRootAPI" in text and "PhysicsRigidBodyAPI" in text
    assert 'custom token morphkit:base = "fixed"' in text
    # The fixed base is a world fixed joint: a FixedJoint with body1 = root and no body0.
    from pxr import Usd, UsdPhysics

    stage = Usd.Stage.Open(str(tmp_path / "robot.usda"))
    anchors = [
        p
        for p in stage.Traverse()
        if p.IsA(UsdPhysics.FixedJoint) and not UsdPhysics.Joint(p).GetBody0Rel().GetTargets()
    ]
    assert len(anchors) == 1
    assert [str(t) for t in UsdPhysics.Joint(anchors[0]).GetBody1Rel().GetTargets()] == ["/every_joint_fixed/torso"]
    # Revolute limits are in degrees in USD.
    a_rev = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath("/every_joint_fixed/joints/a_rev"))
    assert a_rev.GetUpperLimitAttr().Get() == pytest.approx(math.degrees(2.5), rel=1e-6)


def test_rest_pose_of_written_links_matches_the_joint_frames(tmp_path: Path) -> None:
    """Each link prim sits at its rest pose, where the two joint frames coincide (as physics expects)."""
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    m = TEST_CREATURES["every_joint_floating"]()
    path = tmp_path / "robot.usda"
    write_usd(m, path)
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.XformCache()
    for prim in stage.Traverse():
        if not prim.IsA(UsdPhysics.Joint) or not UsdPhysics.Joint(prim).GetBody0Rel().GetTargets():
            continue
        j = UsdPhysics.Joint(prim)
        frames = []
        for k, rel in ((0, j.GetBody0Rel()), (1, j.GetBody1Rel())):
            body = stage.GetPrimAtPath(rel.GetTargets()[0])
            world = cache.GetLocalToWorldTransform(body)
            pos = Gf.Vec3d(prim.GetAttribute(f"physics:localPos{k}").Get())
            frames.append(np.array(world.Transform(pos)))
        # Every joint of this creature rests at 0 (all limits contain 0), where its two frames coincide.
        np.testing.assert_allclose(frames[0], frames[1], atol=1e-6, err_msg=prim.GetName())


def test_arbitrary_axis_is_written_as_a_token_axis(tmp_path: Path) -> None:
    m = TEST_CREATURES["every_joint_floating"]()
    path = tmp_path / "robot.usda"
    write_usd(m, path)
    text = path.read_text()
    # a_rev's axis (0.3, 1, -0.2) becomes X of a rotated joint frame; b_rev's (0, 1, 0) stays Y.
    block = text.split('def PhysicsRevoluteJoint "a_rev"')[1].split("}")[0]
    assert 'physics:axis = "X"' in block and "quatf physics:localRot1 = (1, 0, 0, 0)" not in block
    block = text.split('def PhysicsRevoluteJoint "b_rev"')[1].split("}")[0]
    assert 'physics:axis = "Y"' in block and "quatf physics:localRot1 = (1, 0, 0, 0)" in block


def test_awkward_names_survive(tmp_path: Path) -> None:
    b = MorphologyBuilder("my robot-1")
    for n in ("base link", "1st.arm", "joints"):
        b.add_link(n)
    b.add_joint_revolute("hip joint", "base link", "1st.arm", axis=(0, 0, 1), limit=Limit(-1, 1))
    b.add_joint_fixed("joints", "1st.arm", "joints")
    b.add_end_effector("tip/ee", "joints", offset=(0.1, 0, 0), role="hand")
    m = b.build()
    path = tmp_path / "odd.usda"
    write_usd(m, path)
    assert_morphology_equal(m, read_usd(path))


@pytest.mark.parametrize(("creature", "fmt"), [("crab", ".yaml"), ("human", ".yaml"), ("spot", ".urdf")])
def test_shipped_description_to_usd_and_back(tmp_path: Path, creature: str, fmt: str) -> None:
    """YAML -> USD -> YAML and URDF -> USD -> URDF keep structure, origins, axes, limits, ees, shapes."""
    m = shipped_morphology(creature)
    from morphkit.io import read_morphology, write_morphology

    usd = tmp_path / f"{creature}.usdc"
    write_usd(m, usd)
    m_usd = read_usd(usd)
    assert_morphology_equal(m, m_usd, 1e-6)
    out = tmp_path / f"{creature}{fmt}"
    write_morphology(m_usd, out)
    assert_morphology_equal(m, read_morphology(out), 1e-6)


def test_write_is_atomic(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "robot.usda"
    write_usd(TEST_CREATURES["planar_arm"](), path)
    write_usd(TEST_CREATURES["mimic"](), path)  # replaces the old file in place
    assert read_usd(path).name == "gripper"
    assert sorted(p.name for p in path.parent.iterdir()) == ["robot.usda"]
    with pytest.raises(DescriptionError, match="not a USD file suffix"):
        write_usd(TEST_CREATURES["planar_arm"](), tmp_path / "robot.obj")


def test_import_loads_no_pxr() -> None:
    code = "import sys, morphkit.io.usd; assert 'pxr' not in sys.modules, 'pxr imported at module level'"
    subprocess.run([sys.executable, "-c", code], check=True)


# ---- a foreign-style stage, checked against pxr's own transforms -----------------------------
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""+90 degrees about x: the stage's +y (up) becomes +z."""


def _usd_world(prim: object) -> np.ndarray:
    """4x4 world matrix (column-vector convention), from pxr."""
    from pxr import UsdGeom

    return np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim)).T


def _to_morph(p: np.ndarray) -> np.ndarray:
    return Y_UP_TO_Z_UP @ (np.asarray(p) * 0.01)


def _morph_link_world(m: Morphology, q: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Link poses [7] at q (revolute/continuous joints only), by name, computed here independently."""
    q = m.rest_q() if q is None else q
    poses = {m.root: np.array([0, 0, 0, 0, 0, 0, 1.0])}
    for i, j in enumerate(m.joints):
        local = j.origin.as_array()
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            angle = q[m.joint_q_start[i]]
            local = transform_multiply(local, np.array([0, 0, 0, *quat_from_axis_angle(np.asarray(j.axis), angle)]))
        poses[j.child] = transform_multiply(poses[j.parent], local)
    return poses


def test_foreign_stage_reads_to_its_own_geometry() -> None:
    """Y-up, centimetres, non-identity localPos1/localRot1: the rest pose reproduces pxr's world transforms."""
    from pxr import Usd, UsdPhysics

    m = read_usd(ARM)
    assert m.name == "arm" and m.base == BaseType.FLOATING and m.root == "base"
    assert m.link_names == ("base", "upper", "fore")
    assert m.joint("shoulder").type == JointType.REVOLUTE
    assert (m.joint("shoulder").limit.lower, m.joint("shoulder").limit.upper) == pytest.approx(
        (-math.pi / 2, math.pi / 4)
    )
    assert m.joint("elbow").type == JointType.CONTINUOUS  # a revolute joint without limits
    # Colliders only: the visual-only sphere is not a shape.
    assert [s.type for s in m.link("base").shapes] == [ShapeType.BOX]
    assert m.link("base").shapes[0].size == pytest.approx((0.2, 0.1, 0.4))
    assert [s.type for s in m.link("fore").shapes] == [ShapeType.CYLINDER, ShapeType.MESH]

    stage = Usd.Stage.Open(str(ARM))
    poses = _morph_link_world(m)
    # Shape centres and axes where pxr puts them.
    for link, index, prim_path, axis in (
        ("base", 0, "/arm/base/box", None),
        ("upper", 0, "/arm/upper/bone", np.array([1.0, 0, 0])),
        ("fore", 0, "/arm/fore/bone", np.array([0, 1.0, 0])),
        ("fore", 1, "/arm/fore/plate", None),
    ):
        W = _usd_world(stage.GetPrimAtPath(prim_path))
        shape = m.link(link).shapes[index]
        T = transform_multiply(poses[link], shape.origin.as_array())
        np.testing.assert_allclose(T[:3], _to_morph(W[:3, 3]), atol=1e-6, err_msg=prim_path)
        if axis is not None:
            usd_axis = Y_UP_TO_Z_UP @ (W[:3, :3] @ axis)
            usd_axis /= np.linalg.norm(usd_axis)
            np.testing.assert_allclose(quat_rotate(T[3:], [0, 0, 1.0]), usd_axis, atol=1e-6, err_msg=prim_path)
    # The end-effector too.
    tip = m.end_effector("tip")
    W = _usd_world(stage.GetPrimAtPath("/arm/fore/tip"))
    np.testing.assert_allclose(
        transform_multiply(poses["fore"], np.array([*tip.offset, 0, 0, 0, 1]))[:3], _to_morph(W[:3, 3]), atol=1e-6
    )
    assert tip.role.name == "HAND"

    # Joint axes and pivots: turning a joint rotates its child about the USD joint axis through the pivot.
    for name, parent_prim in (("shoulder", "/arm/base"), ("elbow", "/arm/upper")):
        joint_prim = UsdPhysics.Joint(stage.GetPrimAtPath(f"/arm/{name}"))
        Wp = _usd_world(stage.GetPrimAtPath(parent_prim))
        local_pos = np.array(joint_prim.GetLocalPos0Attr().Get(), dtype=float)
        rot0 = joint_prim.GetLocalRot0Attr().Get()
        R0 = np.array(pxr.Gf.Matrix3d(pxr.Gf.Rotation(pxr.Gf.Quatd(rot0))).GetTranspose())
        token = {"X": 0, "Y": 1, "Z": 2}[joint_prim.GetPrim().GetAttribute("physics:axis").Get()]
        pivot = _to_morph(Wp[:3, :3] @ local_pos + Wp[:3, 3])
        axis = Y_UP_TO_Z_UP @ (Wp[:3, :3] @ R0[:, token])
        axis /= np.linalg.norm(axis)
        i = m.joint_index(name)
        child = m.joints[i].child
        q = m.rest_q()
        q[m.joint_q_start[i]] = 0.3
        before = _morph_link_world(m)[child]
        after = _morph_link_world(m, q)[child]
        # The child origin moves on a circle about the axis through the pivot.
        R = pxr.Gf.Matrix3d(pxr.Gf.Rotation(pxr.Gf.Vec3d(*axis), math.degrees(0.3)))
        expected = pivot + np.array(R).T @ (before[:3] - pivot)
        np.testing.assert_allclose(after[:3], expected, atol=1e-6, err_msg=name)


def test_inline_mesh_is_named_by_its_prim() -> None:
    m = read_usd(ARM)
    mesh = next(s for s in m.link("fore").shapes if s.type == ShapeType.MESH)
    assert mesh.mesh == f"{ARM}#/arm/fore/plate"
    assert mesh.scale == pytest.approx((0.01, 0.01, 0.01))  # centimetre points, scaled to metres
    verts, faces = load_usd_mesh(mesh.mesh)
    np.testing.assert_array_equal(verts, [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]])
    np.testing.assert_array_equal(faces, [[0, 1, 2], [0, 2, 3]])  # the quad, fan-triangulated
    with pytest.raises(DescriptionError, match="no mesh prim"):
        load_usd_mesh(f"{ARM}#/arm/fore/bone")


def test_inline_mesh_written_again_keeps_its_points(tmp_path: Path) -> None:
    m = read_usd(ARM)
    out = tmp_path / "arm.usda"
    write_usd(m, out)
    back = read_usd(out)
    mesh = next(s for s in back.link("fore").shapes if s.type == ShapeType.MESH)
    assert mesh.mesh.startswith(f"{out}#")
    verts, faces = load_usd_mesh(mesh.mesh)
    assert verts.shape == (4, 3) and faces.shape == (2, 3)


def test_file_mesh_is_inlined_and_referenced(tmp_path: Path) -> None:
    out = tmp_path / "shapes.usda"
    write_usd(every_shape(), out)
    text = out.read_text()
    assert "asset morphkit:meshPath" in text and "point3f[] points" in text
    with allow_outside():  # the mesh file stays where it was: outside the new file's folder
        back = read_usd(out)
    mesh = next(s for s in back.link("arm").shapes if s.type == ShapeType.MESH)
    assert Path(mesh.mesh) == FINGER.resolve()


# ---- variants of the foreign stage -----------------------------------------------------------
def _write(tmp_path: Path, text: str, name: str = "stage.usda") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


HEADER = '#usda 1.0\n(\n    defaultPrim = "r"\n    metersPerUnit = 1\n    upAxis = "Z"\n)\n\n'


def _two_bodies(joint: str, extra_root: str = "") -> str:
    return (
        HEADER
        + f"""def Xform "r" (
    prepend apiSchemas = ["PhysicsArticulationRootAPI"]
)
{{
{extra_root}
    def Xform "a" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI"]
    )
    {{
    }}

    def Xform "b" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI"]
    )
    {{
    }}

{joint}
}}
"""
    )


def test_fixed_joint_to_world_means_fixed_base(tmp_path: Path) -> None:
    joint = """    def PhysicsFixedJoint "anchor"
    {
        rel physics:body1 = </r/a>
    }

    def PhysicsSphericalJoint "ball"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
        point3f physics:localPos0 = (0, 0, 1)
        float physics:coneAngle0Limit = 30
    }"""
    m = read_usd(_write(tmp_path, _two_bodies(joint)))
    assert m.base == BaseType.FIXED and m.root == "a"
    assert m.joint_names == ("ball",) and m.joint("ball").type == JointType.SPHERICAL
    assert m.joint("ball").origin.xyz == pytest.approx((0, 0, 1))


def test_revolute_joint_to_world_gets_a_world_link(tmp_path: Path) -> None:
    joint = """    def PhysicsRevoluteJoint "spin"
    {
        rel physics:body1 = </r/a>
        point3f physics:localPos0 = (0, 0, 2)
    }

    def PhysicsPrismaticJoint "slide"
    {
        uniform token physics:axis = "Z"
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
        float physics:lowerLimit = 0
        float physics:upperLimit = 0.5
    }"""
    m = read_usd(_write(tmp_path, _two_bodies(joint)))
    assert m.base == BaseType.FIXED and m.root == "world"
    assert m.joint("spin").type == JointType.CONTINUOUS and m.joint("spin").origin.xyz == pytest.approx((0, 0, 2))
    assert m.joint("slide").axis == pytest.approx((0, 0, 1))
    assert (m.joint("slide").limit.lower, m.joint("slide").limit.upper) == pytest.approx((0.0, 0.5))


def test_morphkit_joint_type_and_base_attributes(tmp_path: Path) -> None:
    joint = """    def PhysicsRevoluteJoint "j"
    {
        custom token morphkit:jointType = "continuous"
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
        float physics:lowerLimit = -10
        float physics:upperLimit = 10
    }"""
    m = read_usd(_write(tmp_path, _two_bodies(joint, '    custom token morphkit:base = "planar"')))
    assert m.base == BaseType.PLANAR
    assert m.joint("j").type == JointType.CONTINUOUS and m.joint("j").limit is None


def test_stage_without_articulation_root(tmp_path: Path) -> None:
    text = _two_bodies("""    def PhysicsFixedJoint "glue"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""").replace('    prepend apiSchemas = ["PhysicsArticulationRootAPI"]\n', "")
    m = read_usd(_write(tmp_path, text))
    assert m.link_names == ("a", "b") and m.base == BaseType.FLOATING


# ---- malformed input -------------------------------------------------------------------------
def _line(text: str, needle: str) -> int:
    return next(i + 1 for i, line in enumerate(text.split("\n")) if needle in line)


def test_garbage_files(tmp_path: Path) -> None:
    for suffix in SUFFIXES:
        path = tmp_path / f"garbage{suffix}"
        path.write_bytes(b"\x00\x01garbage\xff\xfe" * 10)
        with pytest.raises(DescriptionError) as info:
            read_usd(path)
        assert info.value.location.path == str(path)
    empty = _write(tmp_path, "", "empty.usda")
    with pytest.raises(DescriptionError, match="cannot read USD"):
        read_usd(empty)
    with pytest.raises(DescriptionError, match="not found"):
        read_usd(tmp_path / "missing.usda")
    with pytest.raises(DescriptionError, match="not a file"):
        read_usd(tmp_path)


def test_syntax_error_reports_the_line(tmp_path: Path) -> None:
    text = HEADER + 'def Xform "r"\n{\n    double3 xformOp:translate = (1, 2\n}\n'
    path = _write(tmp_path, text)
    with pytest.raises(DescriptionError, match="syntax error") as info:
        read_usd(path)
    assert info.value.location.path == str(path)
    assert info.value.location.line == text.count("\n")  # the '}' where the tuple should have closed


BAD_STAGES = [
    (
        "missing body1",
        """    def PhysicsRevoluteJoint "j"
    {
        rel physics:body0 = </r/a>
    }""",
        "",
        DescriptionError,
        "has no body1",
        'PhysicsRevoluteJoint "j"',
    ),
    (
        "body1 does not exist",
        """    def PhysicsRevoluteJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/nope>
    }""",
        "",
        DescriptionError,
        "does not exist",
        'PhysicsRevoluteJoint "j"',
    ),
    (
        "unsupported joint",
        """    def PhysicsDistanceJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        "",
        DescriptionError,
        "unsupported joint type",
        'PhysicsDistanceJoint "j"',
    ),
    (
        "one-sided limit",
        """    def PhysicsRevoluteJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
        float physics:upperLimit = 10
    }""",
        "",
        DescriptionError,
        "only one limit",
        'PhysicsRevoluteJoint "j"',
    ),
    (
        "unlimited prismatic",
        """    def PhysicsPrismaticJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        "",
        GraphError,
        "needs a limit",
        'PhysicsPrismaticJoint "j"',
    ),
    (
        "bad base",
        """    def PhysicsFixedJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        '    custom token morphkit:base = "hovering"',
        DescriptionError,
        "unknown base type 'hovering'",
        'def Xform "r"',
    ),
    (
        "bad joint type attribute",
        """    def PhysicsFixedJoint "j"
    {
        custom token morphkit:jointType = "revolute"
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        "",
        DescriptionError,
        "does not fit",
        'PhysicsFixedJoint "j"',
    ),
    (
        "bad wheel radius",
        """    def PhysicsFixedJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        '    custom string[] morphkit:wheelJoints = ["j"]\n    custom string morphkit:wheelRadius = "big"',
        DescriptionError,
        "must be a finite number",
        'def Xform "r"',
    ),
    (
        "two parents",
        """    def PhysicsFixedJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }

    def PhysicsFixedJoint "k"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""",
        "",
        GraphError,
        "two parents",
        'PhysicsFixedJoint "k"',
    ),
    ("disconnected", "", "", GraphError, "several links have no parent", None),
]


@pytest.mark.parametrize(
    ("joint", "root_attrs", "cls", "fragment", "where"), [c[1:] for c in BAD_STAGES], ids=[c[0] for c in BAD_STAGES]
)
def test_bad_stage_is_located(
    tmp_path: Path, joint: str, root_attrs: str, cls: type, fragment: str, where: str | None
) -> None:
    text = _two_bodies(joint, root_attrs)
    path = _write(tmp_path, text)
    with pytest.raises(cls) as info:
        read_usd(path)
    err = info.value
    assert fragment in err.message, err.message
    assert err.location is not None and err.location.path == str(path)
    if where is not None:
        assert err.location.line == _line(text, where), str(err)


def test_bad_end_effector_role(tmp_path: Path) -> None:
    text = _two_bodies("""    def PhysicsFixedJoint "j"
    {
        rel physics:body0 = </r/a>
        rel physics:body1 = </r/b>
    }""").replace(
        """    def Xform "b" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI"]
    )
    {
    }""",
        """    def Xform "b" (
        prepend apiSchemas = ["PhysicsRigidBodyAPI"]
    )
    {
        def Xform "tip"
        {
            custom token morphkit:endEffectorRole = "tentacle"
        }
    }""",
    )
    path = _write(tmp_path, text)
    with pytest.raises(DescriptionError, match="unknown end-effector role 'tentacle'") as info:
        read_usd(path)
    assert info.value.location.line == _line(text, 'def Xform "tip"')


def test_no_articulation_and_several_roots(tmp_path: Path) -> None:
    with pytest.raises(DescriptionError, match="no articulation"):
        read_usd(_write(tmp_path, HEADER + 'def Xform "r"\n{\n}\n', "empty_stage.usda"))
    two = HEADER + "".join(
        f'def Xform "{n}" (\n    prepend apiSchemas = ["PhysicsArticulationRootAPI"]\n)\n{{\n}}\n' for n in ("p", "q")
    )
    two = two.replace('defaultPrim = "r"\n', "")
    with pytest.raises(DescriptionError, match="several articulation roots"):
        read_usd(_write(tmp_path, two, "two.usda"))


def test_only_morphkit_errors_escape_for_corrupted_copies(tmp_path: Path) -> None:
    """Cut the hand-written stage at every few lines: a located MorphkitError or a valid read, nothing else."""
    lines = ARM.read_text().split("\n")
    for n in range(0, len(lines), 3):
        path = _write(tmp_path, "\n".join(lines[:n]) + "\n", f"cut{n}.usda")
        try:
            read_usd(path)
        except MorphkitError as exc:
            assert exc.location is not None and exc.location.path == str(path)
