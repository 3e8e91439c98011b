"""What the field's URDF tools read and morphkit reads the same way: xacro leftovers with known defaults, a
four-number mesh scale, a floating (or planar) joint from the root link, meshes named by absolute paths from another
machine, ``package:///`` with an empty package, a mimic of a joint the file lacks, an empty ``<robot>``."""

from __future__ import annotations

import warnings

import pytest

from morphkit.errors import DescriptionError
from morphkit.graph import BaseType, JointType
from morphkit.io.urdf import parse_urdf, read_urdf

XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def _line(text: str, needle: str) -> int:
    return 1 + next(i for i, t in enumerate(text.splitlines()) if needle in t)


def _robot(body: str, attrs: str = "") -> str:
    return (f'<robot name="r" {attrs}>\n<link name="base"><collision><geometry><box size="0.2 0.2 0.2"/></geometry>'
            f'</collision></link>\n{body}</robot>\n')


def _leg(parent: str = "base", origin: str = "0 0 -0.1", upper: str = "1") -> str:
    return (f'<link name="leg"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>\n'
            f'<joint name="hip" type="revolute"><parent link="{parent}"/><child link="leg"/>\n'
            f'<origin xyz="{origin}"/><axis xyz="0 1 0"/><limit lower="-1" upper="{upper}"/></joint>\n')


def test_xacro_leftovers_take_their_defaults_with_one_warning():
    text = _robot('<xacro:arg name="reach" default="-0.3"/>\n'
                  + _leg(origin="0 0 $(arg reach)", upper="$(optenv HIP_UPPER 1.25)"), XACRO)
    with pytest.warns(UserWarning) as record:
        m = parse_urdf(text, source="x.urdf")
    assert m.joint("hip").origin.xyz == pytest.approx((0.0, 0.0, -0.3))
    assert m.joint("hip").limit.upper == 1.25
    said = [str(w.message) for w in record]
    assert said == [f"x.urdf:{_line(text, '$(arg reach)')}: xacro leftover read as xacro would with no arguments: "
                    "$(arg reach) as '-0.3' (2 substitutions in all); expand the file with xacro to choose other "
                    "values"]


@pytest.mark.parametrize(("leftover", "why"), [
    ("$(arg reach)", "an argument without a <xacro:arg ... default=> in the file"),
    ("$(optenv REACH)", "an environment variable without a default"),
    ("$(env REACH)", "not known without xacro"),
])
def test_a_xacro_leftover_without_a_known_value_is_an_error_at_its_line(leftover, why):
    text = _robot('<xacro:arg name="other" default="1"/>\n<xacro:arg name="reach"/>\n'
                  + _leg(origin=f"0 0 {leftover}"), XACRO)
    with pytest.raises(DescriptionError) as info:
        parse_urdf(text, source="x.urdf")
    assert info.value.message == f"xacro leftover {leftover!r}: {why}; expand the file with xacro first"
    assert info.value.location.line == _line(text, leftover)


def test_find_becomes_a_package_uri(tmp_path):
    pkg = tmp_path / "my_robot"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "m.stl").write_text("solid x\nendsolid x\n")
    path = pkg / "urdf" / "r.urdf"
    path.write_text(_robot('<link name="a"><visual><geometry><mesh filename="$(find my_robot)/meshes/m.stl"/>'
                           '</geometry></visual></link>\n<joint name="f" type="fixed"><parent link="base"/>'
                           '<child link="a"/></joint>\n'))
    with pytest.warns(UserWarning, match=r"\$\(find my_robot\) as 'package://my_robot'"):
        m = read_urdf(path)
    assert m.link("a").shapes[0].mesh == str(pkg / "meshes" / "m.stl")


def test_a_four_number_mesh_scale_reads_its_first_three():
    mesh = '<link name="{0}"><visual><geometry><mesh filename="{0}.stl" scale="0.001 0.002 0.003 1"/></geometry>' \
           '</visual></link>\n<joint name="f{0}" type="fixed"><parent link="base"/><child link="{0}"/></joint>\n'
    text = _robot(mesh.format("a") + mesh.format("b"))
    with pytest.warns(UserWarning) as record:
        m = parse_urdf(text, source="s.urdf")
    assert m.link("a").shapes[0].scale == m.link("b").shapes[0].scale == pytest.approx((0.001, 0.002, 0.003))
    said = [str(w.message) for w in record if "scale" in str(w.message)]
    assert said == [f"s.urdf:{_line(text, 'a.stl')}: mesh scale '0.001 0.002 0.003 1' has four numbers: read as its "
                    "first three (as urdfdom does)"]
    with pytest.raises(DescriptionError, match="must be 3 numbers"):
        parse_urdf(text.replace(" 1\"", " 1 1\""), source="s.urdf")


def _same(a, b) -> None:
    assert a.base == b.base and a.root == b.root
    assert [lk.name for lk in a.links] == [lk.name for lk in b.links]
    assert [(j.name, j.type, j.parent, j.child, j.origin.xyz, j.axis) for j in a.joints] == \
        [(j.name, j.type, j.parent, j.child, j.origin.xyz, j.axis) for j in b.joints]
    assert [(e.name, e.link, e.role) for e in a.end_effectors] == [(e.name, e.link, e.role) for e in b.end_effectors]


@pytest.mark.parametrize(("jtype", "base"), [("floating", BaseType.FLOATING), ("planar", BaseType.PLANAR)])
def test_a_floating_or_planar_joint_from_the_root_link_is_the_base(jtype, base):
    """As a ``world`` link's joint (the reader's long-standing rule) gives it: the child is the root."""
    body = _leg()
    odom = _robot(body).replace('<link name="base">', f'<link name="odom"/>\n<joint name="free" type="{jtype}">'
                                '<parent link="odom"/><child link="base"/></joint>\n<link name="base">')
    world = odom.replace('"odom"', '"world"')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = parse_urdf(odom, source="o.urdf")
        _same(m, parse_urdf(world, source="o.urdf"))
    assert m.base == base and m.root == "base" and [j.name for j in m.joints] == ["hip"]
    # an origin on that joint is dropped, as a world joint's is: the base is placed by its coordinates
    moved = odom.replace('<child link="base"/></joint>', '<child link="base"/><origin xyz="0 0 1"/></joint>')
    with pytest.warns(UserWarning, match=rf"o\.urdf:\d+: origin of {jtype} joint 'free' is ignored"):
        _same(parse_urdf(moved, source="o.urdf"), m)


def test_joints_from_the_root_that_are_no_base_stay_as_they_were():
    # a fixed joint from a root link that is not `world` is an ordinary joint (the root keeps its link)
    fixed = _robot(_leg()).replace('<link name="base">', '<link name="mount"/>\n<joint name="bolt" type="fixed">'
                                   '<parent link="mount"/><child link="base"/></joint>\n<link name="base">')
    m = parse_urdf(fixed)
    assert m.root == "mount" and m.joint("bolt").type == JointType.FIXED
    # a floating joint below the root is refused, at its line
    deep = _robot(_leg() + '<link name="foot"/>\n<joint name="ankle" type="floating"><parent link="leg"/>'
                  '<child link="foot"/></joint>\n')
    with pytest.raises(DescriptionError, match="only supported from the 'world' link or the root link") as info:
        parse_urdf(deep, source="d.urdf")
    assert info.value.location.line == _line(deep, 'type="floating"')


def test_meshes_from_another_machine_are_one_warning(tmp_path):
    links = "".join(f'<link name="l{i}"><visual><geometry><mesh filename="/home/someone/ros/src/bot/meshes/l{i}.stl"/>'
                    f'</geometry></visual></link>\n<joint name="j{i}" type="fixed"><parent link="base"/>'
                    f'<child link="l{i}"/></joint>\n' for i in range(3))
    path = tmp_path / "bot.urdf"
    text = _robot(links)
    path.write_text(text)
    with pytest.warns(UserWarning) as record:
        m = read_urdf(path)
    said = [str(w.message) for w in record]
    assert said == [f"{path}:{_line(text, 'l0.stl')}: 3 mesh files not found, e.g. /home/someone/ros/src/bot/meshes/"
                    "l0.stl; their shapes are kept as paths without geometry (drawn as the link's other shapes or a "
                    "stand-in)"]
    assert [m.link(f"l{i}").shapes[0].mesh for i in range(3)] == \
        [f"/home/someone/ros/src/bot/meshes/l{i}.stl" for i in range(3)]


def test_package_uri_with_an_empty_package_is_read_as_pinocchio_does(tmp_path):
    """example-robot-data's talos_full_v2.urdf writes ``package:///example-robot-data/...``."""
    mesh = tmp_path / "share" / "erd" / "robots" / "bot" / "meshes" / "m.stl"
    mesh.parent.mkdir(parents=True)
    mesh.write_text("solid x\nendsolid x\n")
    path = mesh.parent.parent / "bot.urdf"
    path.write_text(_robot('<link name="a"><visual><geometry><mesh filename="package:///erd/robots/bot/meshes/m.stl"/>'
                           '</geometry></visual></link>\n<joint name="f" type="fixed"><parent link="base"/>'
                           '<child link="a"/></joint>\n'))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_urdf(path).link("a").shapes[0].mesh == str(mesh)


def test_a_mimic_of_a_joint_the_file_lacks_is_a_joint_of_its_own():
    """Pinocchio reads such a file (example-robot-data's alex_psyonic_hands.urdf mimics ``index_q1``)."""
    text = _robot(_leg().replace("</joint>", '<mimic joint="index_q1" multiplier="2"/></joint>'))
    with pytest.warns(UserWarning) as record:
        m = parse_urdf(text, source="p.urdf")
    line = _line(text, "<joint name")
    assert [str(w.message) for w in record] == [
        f"p.urdf:{line}: joint 'hip' mimics unknown joint 'index_q1': read as a joint of its own"]
    assert m.joint("hip").mimic is None and m.dof == 1


def test_an_empty_robot_is_an_error_at_its_line():
    text = '<?xml version="1.0"?>\n<!-- xacro output of a file with nothing in it -->\n<robot name="ur3">\n</robot>\n'
    with pytest.raises(DescriptionError) as info:
        parse_urdf(text, source="ur3.urdf")
    assert str(info.value) == "ur3.urdf:3: the <robot> holds no <link>: nothing to read (a xacro file's unexpanded " \
                              "output?)"
