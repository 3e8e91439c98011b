"""YAML creature format: reading the fixture, exact round trips, and every bad-input class with its line."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from _compare import assert_morphology_equal
from morphkit_testing import TEST_CREATURES, shipped_morphology

from morphkit.conventions import quat_from_rpy
from morphkit.errors import DescriptionError, GraphError, MorphkitError
from morphkit.graph import (
    BaseType,
    BodyLengthRule,
    EndEffectorRole,
    JointType,
    Limit,
    MorphologyBuilder,
    ShapeType,
    Transform,
)
from morphkit.io import read_morphology, write_morphology
from morphkit.io.asset_paths import allow_outside
from morphkit.io.yaml_format import dump_yaml, parse_yaml, read_yaml, write_yaml

DATA = Path(__file__).resolve().parents[1] / "data"
TINY = DATA / "tiny_creature.yaml"


# ---- reading -----------------------------------------------------------------------------------
def test_reads_every_feature_of_the_fixture():
    m = read_yaml(TINY)
    assert m.name == "tiny"
    assert m.base == BaseType.WHEELED
    assert m.root == "body"
    assert m.source == str(TINY)
    assert m.link_names[0] == "body"
    assert m.wheels is not None and m.wheels.joints == ("wheel_l", "wheel_r") and m.wheels.radius == 0.1
    # Wheels and the mimic finger follow others: shoulder, lift, finger_a are the only DoFs.
    assert m.dof == 3
    assert m.coordinate_names == ("base_x", "base_y", "base_yaw", "shoulder", "lift", "finger_a")

    shoulder = m.joint("shoulder")
    assert shoulder.type == JointType.REVOLUTE
    assert shoulder.limit == Limit(-1.5, 1.5, 2.0, 10.0)
    np.testing.assert_allclose(shoulder.origin.xyz, (0.1, 0.0, 0.05))
    np.testing.assert_allclose(shoulder.origin.quat, quat_from_rpy(np.array([0.0, 0.1, 0.2])), atol=1e-15)
    np.testing.assert_allclose(shoulder.axis, (0.0, 1.0, 0.0))
    assert m.joint("finger_b").mimic.joint == "finger_a"
    assert m.joint("neck").type == JointType.FIXED

    body = m.link("body")
    assert [s.type for s in body.shapes] == [ShapeType.BOX, ShapeType.SPHERE]
    assert body.shapes[0].size == (0.4, 0.3, 0.1)
    assert body.shapes[1].radius == 0.05 and body.shapes[1].origin.xyz == (0.2, 0.0, 0.05)
    # rpy [pi/2, 0, 0] and quat [sin(pi/4), 0, 0, cos(pi/4)] are the same rotation.
    np.testing.assert_allclose(m.link("wheel_l").shapes[0].origin.quat, m.link("wheel_r").shapes[0].origin.quat,
                               atol=1e-15)
    capsule = m.link("arm").shapes[0]
    assert (capsule.type, capsule.radius, capsule.length) == (ShapeType.CAPSULE, 0.02, 0.3)
    mesh = m.link("finger_b").shapes[0]
    assert mesh.type == ShapeType.MESH and mesh.scale == (0.001, 0.001, 0.001)
    assert Path(mesh.mesh) == DATA / "meshes" / "finger.obj"  # resolved against the YAML file's folder
    assert m.link("finger_a").shapes == ()  # a link written with no value

    gripper = m.end_effector("gripper")
    assert (gripper.link, gripper.offset, gripper.role) == ("forearm", (0.0, 0.0, 0.05), EndEffectorRole.HAND)
    assert m.end_effector("camera").offset == (0.0, 0.0, 0.0)
    # Every element remembers its line.
    assert shoulder.location.path == str(TINY) and shoulder.location.line == 34
    assert gripper.location.line == 67


def test_yaml_1_2_numbers_and_defaults():
    m = parse_yaml(
        "links:\n  a: {shapes: [{type: sphere, radius: 5e-3}]}\n  b:\njoints:\n"
        "  j: {type: continuous, parent: a, child: b}\nend_effectors:\n  e: {link: b}\n"
    )
    assert m.name == "creature" and m.base == BaseType.FLOATING
    assert m.links[0].shapes[0].radius == 0.005  # "5e-3" is a float, not YAML 1.1's string
    assert m.joint("j").axis == (1.0, 0.0, 0.0)
    assert m.end_effector("e").role == EndEffectorRole.TOOL
    assert parse_yaml("links: {a: {}}", source="dir/my_bot.yaml").name == "my_bot"


def test_missing_mesh_warns_not_fails(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("name: c\nlinks:\n  a:\n    shapes: [{type: mesh, file: nowhere/m.stl}]\n")
    with pytest.warns(UserWarning, match=r"c\.yaml:4: mesh file not found: .*nowhere/m\.stl"):
        m = read_yaml(path)
    assert m.links[0].shapes[0].mesh == str(tmp_path / "nowhere" / "m.stl")


# ---- round trips -------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(TEST_CREATURES))
def test_round_trip_creatures_built_in_code(name):
    m = TEST_CREATURES[name]()
    back = parse_yaml(dump_yaml(m))
    assert_morphology_equal(m, back, 1e-9)


def test_round_trip_fixture_through_another_folder(tmp_path):
    m = read_yaml(TINY)
    out = tmp_path / "sub" / "tiny.yaml"
    write_yaml(m, out)
    # The mesh is written relative to the new file's folder, and still names the same file.
    mesh = parse_yaml(out.read_text()).link("finger_b").shapes[0].mesh
    assert not Path(mesh).is_absolute()
    assert (out.parent / mesh).resolve() == (DATA / "meshes" / "finger.obj").resolve()
    with allow_outside():  # the mesh stays where it was: outside the new file's folder
        assert_morphology_equal(m, read_yaml(out), 1e-9)


@pytest.mark.parametrize("name", ["crab", "human"])
def test_round_trip_shipped_yaml(name, tmp_path):
    m = shipped_morphology(name)
    write_morphology(m, tmp_path / f"{name}.yaml")
    assert_morphology_equal(m, read_morphology(tmp_path / f"{name}.yaml"), 1e-9)


def test_body_length_reads_overrides_the_rule_and_round_trips(tmp_path):
    plain = parse_yaml(GOOD, source="err.yaml")
    assert plain.declared_body_length is None and "body_length" not in dump_yaml(plain)
    m = parse_yaml(GOOD.replace("name: err\n", "name: err\nbody_length: 0.55\n"), source="err.yaml")
    assert m.declared_body_length == 0.55 and m.body_length == 0.55
    assert m.body_length_rule == BodyLengthRule.DECLARED and plain.body_length_rule != BodyLengthRule.DECLARED
    write_yaml(m, tmp_path / "c.yaml")
    assert "body_length: 0.55\n" in (tmp_path / "c.yaml").read_text()
    assert read_yaml(tmp_path / "c.yaml").declared_body_length == 0.55


def test_bad_body_length_names_file_and_line(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(GOOD.replace("base: floating\n", "base: floating\nbody_length: -1\n"))
    with pytest.raises(DescriptionError) as info:
        read_yaml(path)
    assert str(info.value) == f"{path}:3: body_length: must be a length > 0 [m], got -1"


def test_round_trip_awkward_values():
    b = MorphologyBuilder("yes")  # names that plain YAML would read as bools, numbers or nulls
    for n in ("null", "1", "a: b", "on", "ünï"):
        b.add_link(n)
    b.add_joint_revolute("true", "null", "1", limit=Limit(-1e-5, 3e-7),
                         origin=Transform.from_xyz_rpy((1e-12, -2.5e8, 0.1), (0.3, math.pi / 2 - 1e-7, 0.2)))
    b.add_joint_revolute("#x", "null", "a: b", limit=Limit(0.0, 0.0),
                         origin=Transform.from_xyz_rpy((0, 0, 0), (0.3, -math.pi / 2, 0.2)))
    b.add_joint_spherical("- y", "1", "on", origin=Transform((0, 0, 0), (0.5, 0.5, 0.5, 0.5)))
    b.add_joint_fixed("f", "on", "ünï", axis=(0, 0, 2))
    m = b.build()
    text = dump_yaml(m)
    assert_morphology_equal(m, parse_yaml(text), 1e-9)


# ---- bad input: each class, with the line of the offending element ------------------------------
GOOD = """\
name: err
base: floating
links:
  body:
    shapes: [{type: box, size: [1, 1, 1]}]
  leg: {}
  foot: {}
joints:
  hip:
    type: revolute
    parent: body
    child: leg
    origin: {xyz: [0, 0, -0.1], rpy: [0, 0, 0]}
    axis: [0, 1, 0]
    limit: {lower: -1, upper: 1}
  knee:
    type: revolute
    parent: leg
    child: foot
    axis: [0, 1, 0]
    limit: {lower: -1.5, upper: 1.5}
end_effectors:
  toe: {link: foot, offset: [0, 0, -0.1], role: foot}
"""


def test_good_text_reads():
    m = parse_yaml(GOOD, source="err.yaml")
    assert m.joint_names == ("hip", "knee") and m.dof == 2


BAD = [
    # (old, new, error class, message fragment, line)
    ("links:\n", "links: [\n", DescriptionError, "malformed YAML", None),
    ("    type: revolute\n    parent: body", "    type: hinge\n    parent: body", DescriptionError,
     "unknown joint type 'hinge'; expected one of: fixed, revolute, continuous, prismatic, spherical", 10),
    ("base: floating", "base: hovering", DescriptionError,
     "unknown base type 'hovering'; expected one of: fixed, floating, planar, wheeled", 2),
    ("role: foot", "role: claw", DescriptionError, "unknown end-effector role 'claw'; expected one of", 23),
    ("type: box", "type: blob", DescriptionError, "unknown shape type 'blob'; expected one of", 5),
    ("axis: [0, 1, 0]\n    limit: {lower: -1,", "axis: [0, 0, 0]\n    limit: {lower: -1,", GraphError,
     "zero axis", 9),
    ("limit: {lower: -1, upper: 1}", "limit: {lower: 2, upper: 1}", DescriptionError, "lower 2.0 > upper 1.0", 15),
    ("axis: [0, 1, 0]\n    limit: {lower: -1,", "axis: [0, 1]\n    limit: {lower: -1,", DescriptionError,
     "expected a list of 3 numbers, got 2 values", 14),
    ("offset: [0, 0, -0.1]", "offset: 0.1", DescriptionError, "expected a list of 3 numbers, got 0.1", 23),
    ("xyz: [0, 0, -0.1]", "xyz: [0, .nan, -0.1]", DescriptionError, "non-finite number nan", 13),
    ("xyz: [0, 0, -0.1]", "xyz: [0, 0, -.inf]", DescriptionError, "non-finite number -inf", 13),
    ("xyz: [0, 0, -0.1]", "xyz: [0, zero, -0.1]", DescriptionError, "expected a number, got 'zero'", 13),
    ("size: [1, 1, 1]", "size: [1, '1', 1]", DescriptionError, "expected a number, got '1'", 5),
    ("upper: 1}", "upper: yes}", DescriptionError, "expected a number, got True", 15),
    ("upper: 1}", "upper: 1, speed: 3}", DescriptionError,
     "unknown key 'speed'; valid keys: lower, upper, velocity, effort", 15),
    ("name: err\n", "name: err\ncolour: red\n", DescriptionError,
     "unknown key 'colour'; valid keys: name, base, root, body_length, links, joints, end_effectors, wheels", 2),
    ("name: err\n", "name: err\nbody_length: 0.55\n", None, None, None),
    ("name: err\n", "name: err\nbody_length: 0\n", DescriptionError, "body_length: must be a length > 0 [m], got 0", 2),
    ("name: err\n", "name: err\nbody_length: -0.5\n", DescriptionError, "must be a length > 0 [m], got -0.5", 2),
    ("name: err\n", "name: err\nbody_length: .nan\n", DescriptionError, "body_length: non-finite number nan", 2),
    ("name: err\n", "name: err\nbody_length: .inf\n", DescriptionError, "body_length: non-finite number inf", 2),
    ("name: err\n", "name: err\nbody_length: tall\n", DescriptionError, "body_length: expected a number, got 'tall'",
     2),
    ("name: err\n", "name: err\nbody_length: [0.5]\n", DescriptionError, "body_length: expected a number, got a list",
     2),
    ("    parent: body\n", "", DescriptionError, "joint 'hip': missing required key 'parent'", 9),
    ("links:", "likns:", DescriptionError, "unknown key 'likns'", 3),
    ("{link: foot,", "{", DescriptionError, "end-effector 'toe': missing required key 'link'", 23),
    ("{type: box, size: [1, 1, 1]}", "{type: sphere}", DescriptionError, "missing required key 'radius'", 5),
    ("{type: box, size: [1, 1, 1]}", "{type: box, size: [1, 1, 0]}", GraphError, "size must be 3 positive", 5),
    ("  knee:\n", "  hip:\n", DescriptionError, "duplicate key 'hip' (first written on line 9)", 16),
    ("  foot: {}\n", "  foot: {}\n  leg: {}\n", DescriptionError, "duplicate key 'leg' (first written on line 6)", 8),
    ("end_effectors:", "  extra: {type: fixed, parent: body, child: foot}\nend_effectors:", GraphError,
     "link 'foot' has two parents (joints 'knee' and 'extra')", 22),
    ("    parent: body\n", "    parent: foot\n", GraphError, "cycle", 9),
    ("link: foot,", "link: hand,", GraphError, "end-effector 'toe' on unknown link 'hand'", 23),
    ("    child: foot\n", "    child: nowhere\n", GraphError, "joint 'knee' names missing link 'nowhere'", 16),
    ("  foot: {}\n", "  foot: {}\n  island: {}\n", GraphError, "several links have no parent (body, island)", 8),
    ("base: floating\n", "base: floating\nroot: body\n", None, None, None),
    ("    limit: {lower: -1, upper: 1}\n", "", GraphError, "revolute joint needs a limit", 9),
    ("rpy: [0, 0, 0]", "rpy: [0, 0, 0], quat: [0, 0, 0, 1]", DescriptionError, "either rpy or quat", 13),
    ("rpy: [0, 0, 0]", "quat: [0, 0, 0, 0]", DescriptionError, "non-zero quaternion", 13),
    ("  leg: {}", "  leg: []", DescriptionError, "link 'leg': expected a mapping, got a list", 6),
    ("  leg: {}", "  3: {}", DescriptionError, "link name: expected a name (a string), got 3 (quote it: '3')", 6),
    ("    child: foot\n    axis", "    child: foot\n    mimic: {joint: ghost}\n    axis", GraphError,
     "joint 'knee' mimics unknown joint 'ghost'", 16),
    ("end_effectors:", "wheels: {joints: [hip], radius: 0.1}\nend_effectors:", GraphError,
     "wheels are only meaningful on a wheeled base", 22),
    ("end_effectors:", "wheels: {joints: [hip], radius: -1}\nend_effectors:", GraphError,
     "wheel radius must be > 0", 22),
    ("base: floating", "base: [floating]", DescriptionError, "unknown base type", 2),
    ("joints:\n", "wheels: 7\njoints:\n", DescriptionError, "wheels: expected a mapping, got 7", 8),
    ("name: err", "name: err\n\tbase: x", DescriptionError, "malformed YAML", 2),
]


@pytest.mark.parametrize(("old", "new", "cls", "message", "line"), BAD, ids=[b[3] or b[1] for b in BAD])
def test_bad_input_is_located(old, new, cls, message, line):
    assert GOOD.count(old) == 1, old
    text = GOOD.replace(old, new)
    if cls is None:  # a control: the change is harmless
        parse_yaml(text, source="err.yaml")
        return
    with pytest.raises(cls) as info:
        parse_yaml(text, source="err.yaml")
    err = info.value
    assert message in err.message, err.message
    assert err.location is not None and err.location.path == "err.yaml"
    if line is not None:
        assert err.location.line == line, str(err)
        assert str(err).startswith(f"err.yaml:{line}: ")
    else:
        assert err.location.line is not None


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        ("", "empty YAML document", 1),
        ("- a\n- b\n", "creature file: expected a mapping, got a list", 1),
        ("name: x\n", "missing required key 'links'", 1),
        ("links: {}\n", "needs at least one link", 1),
        ("links: {a: {}}\n---\nlinks: {b: {}}\n", "malformed YAML", 2),
        ("links: {a: {}}\nname: !!python/object:os.system x\n", "malformed YAML", 2),
        ("links: {a: {}}\nname: \x07\n", "unacceptable character", 2),
        ("links: &l {a: *l}\n", "malformed YAML: found unconstructable recursive node", 1),
        ("links: {a: {shapes: [{type: box, size: [1, 1, 1], <<: {size: [2, 2, 2]}}]}}\n", None, None),
        ("[" * 5000 + "]" * 5000, "malformed YAML", None),
        ("links: {a: {}}\nname: !!binary 'not base64!'\n", "malformed YAML", 2),
        ("links: {a: {}}\nname: !!float 'x'\n", "malformed YAML", None),
        ("links: {a: {}}\nname: 2001-01-01\n", None, None),
        ("links: {a: {}}\nbase: 1e999\n", "unknown base type", 2),
        ("links: {a: {shapes: [{type: sphere, radius: 1e999}]}}\n", "non-finite number inf", 1),
        ("links: {a: {shapes: [{type: sphere, radius: 123456789012345678901234567890e300}]}}\n", "non-finite", 1),
    ],
)
def test_malformed_documents(text, message, line):
    if message is None:
        parse_yaml(text)
        return
    with pytest.raises(DescriptionError) as info:
        parse_yaml(text, source="m.yaml")
    assert message in info.value.message
    assert info.value.location.path == "m.yaml"
    if line is not None:
        assert info.value.location.line == line


def test_builder_errors_from_yaml_name_file_and_line(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(GOOD.replace("link: foot,", "link: hand,"))
    with pytest.raises(MorphkitError) as info:
        read_yaml(path)
    assert str(info.value).startswith(f"{path}:23: end-effector 'toe' on unknown link 'hand'")


# ---- files and dispatch ------------------------------------------------------------------------
def test_file_errors(tmp_path):
    with pytest.raises(DescriptionError, match="not found"):
        read_yaml(tmp_path / "missing.yaml")
    with pytest.raises(DescriptionError, match=r"missing\.yml"):
        read_morphology(tmp_path / "missing.yml")
    (tmp_path / "bad.yaml").write_bytes(b"name: x\nlinks: {a: {}}\n\xff\xfe\n")
    with pytest.raises(DescriptionError, match="not UTF-8") as info:
        read_yaml(tmp_path / "bad.yaml")
    assert info.value.location.line == 3
    (tmp_path / "c.txt").write_text("links: {a: {}}")
    with pytest.raises(DescriptionError, match=r"unknown description format '\.txt'; supported: \.yaml, \.yml"):
        read_morphology(tmp_path / "c.txt")
    with pytest.raises(DescriptionError, match=r"cannot write '\.obj' files; supported: \.yaml"):
        write_morphology(read_yaml(TINY), tmp_path / "c.obj")
    (tmp_path / "d.yaml").mkdir()
    with pytest.raises(DescriptionError, match="is a folder"):
        read_morphology(tmp_path / "d.yaml")


def test_read_morphology_dispatches_on_suffix(tmp_path):
    m = read_yaml(TINY)
    for suffix in (".yaml", ".yml", ".YAML"):
        path = tmp_path / f"c{suffix}"
        write_morphology(m, path)
        with allow_outside():  # the mesh stays where it was: outside the new file's folder
            assert_morphology_equal(m, read_morphology(path), 1e-9)


def test_write_is_atomic_and_leaves_no_temporaries(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("precious")
    write_yaml(read_yaml(TINY), path)
    assert path.read_text().startswith("name: tiny")
    assert [p.name for p in tmp_path.iterdir()] == ["c.yaml"]


def test_no_warnings_reading_the_fixture():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_yaml(TINY)
