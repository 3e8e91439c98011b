"""An SRDF beside a URDF: found by the ROS package layout, its reference state read as the rest pose (heights
against a hand computation), its disabled collision pairs as excludes, its end-effectors as anatomy hints, its
virtual joint as the base; names the URDF lacks are one warning, a malformed SRDF an error at its line."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import TINY_LEGS, TINY_SHIN, TINY_THIGH, example_robot_data_file, tiny_quadruped_urdf

from morphkit.errors import DescriptionError
from morphkit.graph import BaseType, EndEffectorRole
from morphkit.io import read_morphology
from morphkit.io.srdf import STATE_PREFERENCE, find_srdf, parse_srdf
from morphkit.io.urdf import read_urdf

THIGH, SHIN, LEGS = TINY_THIGH, TINY_SHIN, TINY_LEGS
HIP, KNEE = 0.5, -1.0
_quadruped = tiny_quadruped_urdf


def _standing(extra: str = "", hip: float = HIP, knee: float = KNEE) -> str:
    joints = "".join(f'<joint name="{n}_hip" value="{hip}"/><joint name="{n}_knee" value="{knee}"/>' for n in LEGS)
    return ('<?xml version="1.0"?>\n<robot name="tiny">\n'
            '  <group_state name="home" group="all"><joint name="FL_hip" value="0.3"/></group_state>\n'
            f'  <group_state name="standing" group="all"><joint name="root_joint" value="0 0 0.3 0 0 0 1"/>{joints}'
            f'</group_state>\n{extra}</robot>\n')


def _package(tmp_path: Path, urdf: str, srdf: str | None, *, stem: str = "tiny", srdf_stem: str | None = None
             ) -> Path:
    """A ROS description package: ``tiny_description/urdf/<stem>.urdf`` and ``.../srdf/<srdf_stem>.srdf``."""
    pkg = tmp_path / "tiny_description"
    (pkg / "urdf").mkdir(parents=True, exist_ok=True)
    path = pkg / "urdf" / f"{stem}.urdf"
    path.write_text(urdf)
    if srdf is not None:
        (pkg / "srdf").mkdir(exist_ok=True)
        (pkg / "srdf" / f"{srdf_stem or stem}.srdf").write_text(srdf)
    return path


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _foot_depth(hip: float, knee: float, offset) -> float:
    """By hand: a point at ``offset`` on a foot link below the hip (= below the root), two hinges about y."""
    foot = _ry(hip) @ (np.array([0.0, 0.0, -THIGH]) + _ry(knee) @ (np.array([0.0, 0.0, -SHIN]) + offset))
    return float(-foot[2])


def _heights(m) -> tuple[float, float]:
    """The rest height (morphkit's FK) and the SRDF state's (by hand) of the lowest foot end-effector."""
    feet = m.ee_by_role(EndEffectorRole.FOOT)
    assert {e.link for e in feet} == {f"{n}_foot" for n in LEGS}
    rest = float(-m.rest_points()[[len(m.links) + m.end_effectors.index(e) for e in feet], 2].min())
    return rest, max(_foot_depth(HIP, KNEE, np.asarray(e.offset)) for e in feet)


def test_the_reference_state_is_the_rest_pose_at_the_srdf_height(tmp_path):
    path = _package(tmp_path, _quadruped(), _standing())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the root's 7 numbers are the free flyer's, not an unknown joint
        m = read_urdf(path)
    assert dict(m.rest_pose) == {f"{n}_{j}": v for n in LEGS for j, v in (("hip", HIP), ("knee", KNEE))}
    assert "standing" == STATE_PREFERENCE[0]  # preferred over "home"
    assert any("rest pose: SRDF 'standing'" in n for n in m.notes), m.notes
    assert len(m.ee_by_role(EndEffectorRole.FOOT)) == 4
    rest, srdf = _heights(m)
    assert rest == pytest.approx(srdf, abs=1e-9) and srdf > 0.3
    # read_morphology reads it the same way; srdf=False reads the URDF alone: no state, the stance is searched
    assert dict(read_morphology(path).rest_pose) == dict(m.rest_pose)
    alone = read_urdf(path, srdf=False)
    assert not any("SRDF" in n for n in alone.notes)
    assert dict(alone.rest_pose) != dict(m.rest_pose)


def test_an_explicit_srdf_path_and_the_layout_rules(tmp_path):
    path = _package(tmp_path, _quadruped(), None)
    assert find_srdf(path) is None and read_urdf(path, srdf=False).rest_pose == read_urdf(path).rest_pose
    elsewhere = tmp_path / "elsewhere.srdf"
    elsewhere.write_text(_standing(hip=0.4, knee=-0.8))
    m = read_urdf(path, srdf=elsewhere)
    assert dict(m.rest_pose)["FL_knee"] == -0.8
    srdf_dir = path.parent.parent / "srdf"
    srdf_dir.mkdir()
    # one SRDF of the package, for the same robot: baxter.urdf -> srdf/baxter_manipulation.srdf
    (srdf_dir / "tiny_manipulation.srdf").write_text(_standing())
    assert find_srdf(path) == srdf_dir / "tiny_manipulation.srdf"
    # another robot's (its <robot name>) is not taken by the loose rules
    (srdf_dir / "tiny_manipulation.srdf").write_text(_standing().replace('name="tiny"', 'name="other"', 1))
    assert find_srdf(path) is None
    # a shorter stem the URDF's starts with: hyq_no_sensors.urdf -> srdf/hyq.srdf (same robot)
    reduced = path.with_name("tiny_reduced.urdf")
    reduced.write_text(_quadruped())
    (srdf_dir / "tiny.srdf").write_text(_standing())
    assert find_srdf(reduced) == srdf_dir / "tiny.srdf"
    # the same stem wins, beside the URDF before ../srdf/
    (path.parent / "tiny_reduced.srdf").write_text(_standing())
    assert find_srdf(reduced) == path.parent / "tiny_reduced.srdf"


def test_excludes_frames_and_unknown_names(tmp_path):
    extra = ('  <disable_collisions link1="FL_thigh" link2="base" reason="Adjacent"/>\n'
             '  <disable_collisions link1="base" link2="FL_thigh" reason="Adjacent"/>\n'
             '  <disable_collisions link1="FL_shin" link2="HL_shin" reason="Never"/>\n'
             '  <disable_collisions link1="ghost_link" link2="base" reason="Never"/>\n'
             '  <end_effector name="lf_foot" parent_link="FL_foot" group="lf_leg"/>\n'
             '  <group_state name="default" group="all"><joint name="ghost_joint" value="1"/></group_state>\n')
    srdf = _standing(extra).replace('<joint name="FL_hip" value="0.5"/>',
                                    '<joint name="ghost_joint" value="0.5"/><joint name="FL_hip" value="0.5"/>')
    path = _package(tmp_path, _quadruped(), srdf)
    with pytest.warns(UserWarning) as record:
        m = read_urdf(path)
    said = [str(w.message) for w in record]
    assert len(said) == 1, said
    srdf_path = path.parent.parent / "srdf" / "tiny.srdf"
    line = 1 + next(i for i, t in enumerate(srdf.splitlines()) if "ghost_joint" in t)
    assert said[0].startswith(f"{srdf_path}:{line}: the SRDF names 2 joint(s) or link(s) the URDF {path} lacks")
    assert said[0].endswith("left out: ghost_joint, ghost_link")
    assert m.collision_excludes == (("FL_thigh", "base"), ("FL_shin", "HL_shin"))
    assert "lf_foot" in {e.name for e in m.ee_by_role(EndEffectorRole.FOOT)}  # named after the SRDF's


def _arm(root: str = "") -> str:
    """A fixed chain whose link names hint nothing (l0..l3): a floating base nobody declared."""
    out = f'<robot name="arm">\n{root}<link name="l0"><collision><geometry><box size="0.1 0.1 0.1"/></geometry>' \
          '</collision></link>\n'
    for i in range(3):
        out += (f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
                f'<origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>\n'
                f'<link name="l{i + 1}"><collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.03" '
                'length="0.3"/></geometry></collision></link>\n')
    return out + "</robot>\n"


def test_end_effector_hints_virtual_joints_and_hpp_names(tmp_path):
    srdf = ('<robot name="arm">\n'
            '  <gripper name="r_gripper" clearance="0.02"><link name="l3"/><position>0 0 0.35 0 0 0 1</position>'
            '</gripper>\n'
            '  <group_state name="neutral" group="all"><joint name="arm/j1" value="0.25"/>'
            '<joint name="j2" value="3.0"/></group_state>\n</robot>\n')
    path = _package(tmp_path, _arm(), srdf, stem="arm")
    with pytest.warns(UserWarning, match=r"arm\.urdf:\d+: the limits of 1 joint\(s\) are widened to hold SRDF state "
                                         r"'neutral': j2 \[-2, 2\] to hold 3"):
        m = read_urdf(path)
    # no virtual joint, no foot among its end-effectors: MoveIt's fixed root
    assert m.base == BaseType.FIXED
    [tool] = m.end_effectors
    assert (tool.name, tool.link, tool.role) == ("r_gripper", "l3", EndEffectorRole.TOOL)
    assert tool.offset == pytest.approx((0.0, 0.0, 0.35))  # the gripper's position on its link
    # "arm/j1" is HPP's robot-prefixed name; j2 = 3 lies beyond its URDF limit (and 3 - 2π too): widened
    assert dict(m.rest_pose) == {"j1": 0.25, "j2": 3.0}
    assert (m.joint("j2").limit.lower, m.joint("j2").limit.upper) == (-2.0, 3.0)
    alone = read_urdf(path, srdf=False)
    assert alone.base == BaseType.FIXED and alone.end_effectors[0].name != "r_gripper"  # the hint is the SRDF's

    for vtype, base in (("floating", BaseType.FLOATING), ("planar", BaseType.PLANAR)):
        (path.parent.parent / "srdf" / "arm.srdf").write_text(
            f'<robot name="arm"><virtual_joint name="root" type="{vtype}" parent_frame="world" child_link="l0"/>'
            '</robot>')
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a planar base without wheels named
            assert read_urdf(path).base == base


def test_a_value_a_turn_away_is_turned_not_widened(tmp_path):
    urdf = _arm().replace('<limit lower="-2" upper="2"/>', '<limit lower="-6.3" upper="6.3"/>')
    srdf = ('<robot name="arm"><end_effector name="tool" parent_link="l3"/>'
            '<group_state name="home" group="all"><joint name="j0" value="4.71238898038469"/></group_state></robot>')
    path = _package(tmp_path, urdf, srdf, stem="arm")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = read_urdf(path)
    assert dict(m.rest_pose)["j0"] == pytest.approx(4.71238898038469 - 2 * math.pi)  # the same pose, within ±π
    assert m.joint("j0").limit.upper == 6.3


@pytest.mark.parametrize(
    ("srdf", "message", "needle"),
    [
        ('<robot name="tiny">\n<group_state name="standing">\n<joint name="FL_hip" value="x"/></group_state></robot>',
         "SRDF state 'standing' joint 'FL_hip': 'x' is not a list of numbers", 'value="x"'),
        ('<robot name="tiny">\n<group_state name="standing">\n<joint value="1"/></group_state></robot>',
         "SRDF <joint> needs a non-empty attribute 'name'", '<joint value'),
        ('<robot name="tiny">\n<group_state name="standing">\n<joint name="FL_hip" value="1 2"/></group_state>'
         '</robot>', "SRDF state 'standing': joint 'FL_hip' takes one value, got 2", 'value="1 2"'),
        ('<robot name="tiny">\n<end_effector name="e"/>\n</robot>',
         "SRDF <end_effector> needs a non-empty attribute 'parent_link'", "<end_effector"),
        ('<robot name="tiny">\n<virtual_joint name="v" type="hovering" parent_frame="w" child_link="base"/></robot>',
         "SRDF virtual joint type 'hovering'", "hovering"),
        ('<robot name="tiny">\n<group_state name="standing">\n</robot>', "malformed XML", "</robot>"),
        ('<robot name="tiny">\n<disable_collisions link1="a"/></robot>',
         "SRDF <disable_collisions> needs a non-empty attribute 'link2'", "<disable"),
    ],
)
def test_a_malformed_srdf_is_an_error_at_its_line(tmp_path, srdf, message, needle):
    path = _package(tmp_path, _quadruped(), srdf)
    srdf_path = path.parent.parent / "srdf" / "tiny.srdf"
    with pytest.raises(DescriptionError) as info:
        read_urdf(path)
    err = info.value
    assert message in err.message, err.message
    assert err.location.path == str(srdf_path)
    assert err.location.line == 1 + next(i for i, t in enumerate(srdf.splitlines()) if needle in t)
    assert "srdf=False" in err.message  # the user did not name the SRDF: say how to leave it out
    read_urdf(path, srdf=False)


def test_entities_are_refused_in_an_srdf():
    with pytest.raises(DescriptionError, match="not allowed in SRDF files"):
        parse_srdf('<!DOCTYPE r [<!ENTITY a "b">]><robot name="r"/>', source="x.srdf")




@pytest.mark.parametrize("urdf", ["go2_description/urdf/go2.urdf", "talos_data/robots/talos_reduced.urdf",
                                  "solo_description/robots/solo12.urdf"])
def test_collection_robots_stand_at_their_srdf_state(urdf):
    """example-robot-data (the dev extra; skipped without it): the rest pose is the SRDF's reference state, joint
    for joint, within ±π."""
    path = Path(example_robot_data_file(urdf))
    srdf = find_srdf(path)
    state = parse_srdf(srdf.read_text(), source=str(srdf)).reference_state()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = read_urdf(path)
    movable = {j.name for j in m.joints if j.type.name in ("REVOLUTE", "CONTINUOUS", "PRISMATIC") and j.mimic is None}
    want = {n: v[0] for n, v, _ in state.values if n in movable and v[0] != 0.0}
    assert dict(m.rest_pose) == pytest.approx(want)
    assert max(abs(v) for v in want.values()) <= math.pi


def test_an_end_effector_name_that_hints_nothing_leaves_the_links_own(tmp_path):
    """panda.srdf names its TCP ``end_effector``: the link's own name (``..._tcp``) still says where the tool is."""
    urdf = _arm().replace("</robot>", '<link name="hand_tcp"/><joint name="tcp" type="fixed"><parent link="l3"/>'
                          '<child link="hand_tcp"/><origin xyz="0 0 0.4"/></joint>\n</robot>')
    srdf = '<robot name="arm"><end_effector name="end_effector" parent_link="hand_tcp" group="arm"/></robot>'
    path = _package(tmp_path, urdf, srdf, stem="arm")
    m, alone = read_urdf(path), read_urdf(path, srdf=False)
    assert [(e.name, e.link, e.offset) for e in m.end_effectors] == \
        [(e.name, e.link, e.offset) for e in alone.end_effectors] == [("hand_tcp", "hand_tcp", (0.0, 0.0, 0.0))]
    assert m.notes[0] == "base: fixed — the SRDF names end-effectors, none a foot, and no virtual joint (MoveIt's " \
                         "fixed root)"
