"""BVH reader, writer and skeleton: a hand-written fixture, every bad-input class, and the real clips.

The fixture ``tests/data/tiny.bvh`` has mixed Euler orders, translation channels on a non-root
joint, a joint without channels and End Sites named like hands, feet and a head. Real data is
read from ``$MORPHKIT_DATA/{human,creatures}`` when the variable is set.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from _bvh_creature import AXES, creature_bvh

from morphkit.errors import ConfigError, DescriptionError, MorphkitError, MotionFormatError
from morphkit.graph import EndEffectorRole, JointType, Morphology, ShapeType
from morphkit.io.bvh import (
    BVH_TO_MORPHKIT,
    BvhFile,
    bvh_frame_rotation,
    bvh_joint_positions,
    detect_bvh_facing,
    detect_bvh_scale,
    detect_bvh_up,
    dump_bvh,
    fold_static_root,
    parse_bvh,
    read_bvh,
    read_bvh_skeleton,
    skeleton_from_bvh,
    write_bvh,
)

TINY = Path(__file__).resolve().parents[1] / "data" / "tiny.bvh"
TINY_TEXT = TINY.read_text()
NAMES = ("Hips", "LeftUpLeg", "LeftFoot", "RightUpLeg", "RightFoot", "Spine", "Head", "LeftHand", "RightHand")


def _line_of(text: str, pattern: str, nth: int = 0) -> int:
    """1-based line of the ``nth`` line matching ``pattern`` (regex, searched per line)."""
    hits = [i + 1 for i, line in enumerate(text.split("\n")) if re.search(pattern, line)]
    return hits[nth]


def _motion_numbers(text: str) -> np.ndarray:
    """The frame lines of a BVH text parsed with plain Python floats (independent of the reader)."""
    lines = text.split("\n")
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    return np.array([[float(t) for t in line.split()] for line in lines[start:] if line.strip()])


# ---- parsing the fixture ---------------------------------------------------------------------
def test_tiny_hierarchy_reads_back_exactly() -> None:
    b = read_bvh(TINY)
    assert b.source == str(TINY)
    assert b.joint_names == NAMES
    assert b.joint_parents == (-1, 0, 1, 0, 3, 0, 5, 5, 5)
    np.testing.assert_array_equal(
        b.joint_offsets,
        [
            [0, 0, 0],
            [10, -5, 0],
            [0, -40, 0],
            [-10, -5, 0],
            [0, -40, 0],
            [0, 20, 0],
            [0, 30, 0],
            [40, 15, 0],
            [-40, 15, 0],
        ],
    )
    # Mixed channel orders are kept exactly as written, translation channels on a non-root joint too.
    assert b.joint_channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    assert b.joint_channels[1] == ("Xrotation", "Yrotation", "Zrotation")
    assert b.joint_channels[2] == ("Yrotation", "Zrotation", "Xrotation")
    assert b.joint_channels[3] == ("Zrotation", "Yrotation", "Xrotation")
    assert b.joint_channels[5] == ("Xposition", "Yposition", "Zposition", "Xrotation", "Zrotation", "Yrotation")
    assert b.joint_channels[6] == ("Yrotation", "Xrotation")
    assert b.joint_channels[7] == ()
    assert b.joint_channel_start == (0, 6, 9, 12, 15, 18, 24, 26, 26, 29)
    assert b.channel_count == 29
    assert [(e.joint, e.parent, e.offset) for e in b.end_sites] == [
        ("LeftFoot", 2, (0.0, -5.0, 10.0)),
        ("RightFoot", 4, (0.0, -5.0, 10.0)),
        ("Head", 6, (0.0, 15.0, 0.0)),
        ("LeftHand", 7, (10.0, 0.0, 0.0)),
        ("RightHand", 8, (-10.0, 0.0, 0.0)),
    ]
    # Lines where each thing was declared.
    assert b.joint_lines[0] == _line_of(TINY_TEXT, r"^ROOT Hips")
    for j, name in enumerate(NAMES[1:], start=1):
        assert b.joint_lines[j] == _line_of(TINY_TEXT, rf"JOINT {name}$")
    assert [e.line for e in b.end_sites] == [_line_of(TINY_TEXT, "End Site", k) for k in range(5)]
    assert b.motion_line == _line_of(TINY_TEXT, "^MOTION")
    assert b.frame_time_line == _line_of(TINY_TEXT, "^Frame Time")
    assert b.frame_lines.tolist() == [b.frame_time_line + 1, b.frame_time_line + 2, b.frame_time_line + 3]
    assert b.joint_index("Spine") == 5
    assert b.children(5) == (6, 7, 8)
    with pytest.raises(DescriptionError, match="no BVH joint 'Tail'"):
        b.joint_index("Tail")


def test_tiny_motion_equals_the_numbers_in_the_file() -> None:
    b = read_bvh(TINY)
    assert b.frame_count == 3
    assert b.frame_time == 0.04
    assert b.fps == pytest.approx(25.0)
    assert b.motion.dtype == np.float64
    assert b.motion.shape == (3, 29)
    np.testing.assert_array_equal(b.motion, _motion_numbers(TINY_TEXT))
    assert b.motion[2, 2] == 0.4 and b.motion[2, 9] == 10.0 and b.motion[2, 10] == -10.0
    assert not b.motion.flags.writeable and not b.joint_offsets.flags.writeable


def test_layout_variants_parse_the_same() -> None:
    """CRLF, CR-only, tabs/spaces, a BOM, '{' on the JOINT line, blank lines and lower-case channels."""
    ref = parse_bvh(TINY_TEXT)
    variants = [
        TINY_TEXT.replace("\n", "\r\n"),
        TINY_TEXT.replace("\n", "\r"),
        "\ufeff" + TINY_TEXT.replace("\t", "    "),
        re.sub(r"(JOINT \w+)\n\s*\{", r"\1 {", TINY_TEXT),
        TINY_TEXT.replace("Zrotation", "zROTATION").replace("Frames: 3", "Frames:\t3") + "\n\n\n",
        TINY_TEXT.replace("MOTION\n", "MOTION\n\n").replace("0.04\n", "0.04\n\n"),
    ]
    for text in variants:
        b = parse_bvh(text)
        assert b.joint_names == ref.joint_names
        assert b.joint_channels == ref.joint_channels
        np.testing.assert_array_equal(b.joint_offsets, ref.joint_offsets)
        np.testing.assert_array_equal(b.motion, ref.motion)
        assert b.end_sites == tuple(e for e in b.end_sites)  # frozen and comparable


def test_zero_frames_is_a_valid_file() -> None:
    text = TINY_TEXT.split("MOTION")[0] + "MOTION\nFrames: 0\nFrame Time: 0.01\n"
    b = parse_bvh(text)
    assert b.motion.shape == (0, 29)
    assert bvh_joint_positions(b).shape == (1, 9 + 5, 3)  # the rest pose


def test_long_clip_parses_vectorised() -> None:
    """A 700-frame clip (the size of a CMU clip) parses to the same numbers as plain float()."""
    rng = np.random.default_rng(3)
    values = rng.uniform(-180, 180, size=(700, 29))
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in values)
    text = re.sub(r"Frames: 3.*", "", TINY_TEXT, flags=re.S) + f"Frames: 700\nFrame Time: 0.0333333\n{body}\n"
    b = parse_bvh(text)
    np.testing.assert_array_equal(b.motion, _motion_numbers(text))


# ---- forward kinematics of the file, against SciPy's Euler convention -------------------------
def test_joint_positions_match_an_independent_euler_composition() -> None:
    Rotation = pytest.importorskip("scipy.spatial.transform").Rotation
    b = read_bvh(TINY)
    pos = bvh_joint_positions(b)
    assert pos.shape == (3, 9 + 5, 3)
    starts = b.joint_channel_start
    for f in range(b.frame_count):
        rot: list[np.ndarray] = []
        world: list[np.ndarray] = []
        for j in range(b.joint_count):
            chans = b.joint_channels[j]
            vals = b.motion[f, starts[j] : starts[j + 1]]
            order = "".join(c[0] for c in chans if c.endswith("rotation"))
            angles = [v for c, v in zip(chans, vals, strict=True) if c.endswith("rotation")]
            # Upper-case SciPy axes are intrinsic: R = R_a1 R_a2 R_a3.
            r = Rotation.from_euler(order, angles, degrees=True).as_matrix() if order else np.eye(3)
            t = b.joint_offsets[j].copy()
            for c, v in zip(chans, vals, strict=True):
                if c.endswith("position"):
                    t["XYZ".index(c[0])] = v
            p = b.joint_parents[j]
            if p < 0:
                rot.append(r)
                world.append(t)
            else:
                rot.append(rot[p] @ r)
                world.append(world[p] + rot[p] @ t)
        ends = [world[e.parent] + rot[e.parent] @ np.asarray(e.offset) for e in b.end_sites]
        np.testing.assert_allclose(pos[f], np.array(world + ends), atol=1e-9)
    # Frame 1 by hand: the root at (1.5, 91, -2.25) turns 90 deg about Y, taking the left hip's
    # offset (10, -5, 0) to (0, -5, -10).
    np.testing.assert_allclose(pos[1, 1], [1.5 + 0.0, 91 - 5, -2.25 - 10], atol=1e-9)
    np.testing.assert_allclose(bvh_joint_positions(b, [1])[0], pos[1])


# ---- writer ----------------------------------------------------------------------------------
def test_dump_parse_round_trip(tmp_path: Path) -> None:
    b = read_bvh(TINY)
    out = tmp_path / "copy.bvh"
    write_bvh(b, out)
    assert [p.name for p in tmp_path.iterdir()] == ["copy.bvh"]  # no temporary left behind
    c = read_bvh(out)
    assert c.joint_names == b.joint_names and c.joint_parents == b.joint_parents
    assert c.joint_channels == b.joint_channels
    assert [(e.joint, e.parent, e.offset) for e in c.end_sites] == [(e.joint, e.parent, e.offset) for e in b.end_sites]
    np.testing.assert_array_equal(c.joint_offsets, b.joint_offsets)
    assert c.frame_time == b.frame_time
    np.testing.assert_allclose(c.motion, b.motion, rtol=1e-9, atol=0)
    assert dump_bvh(c) == dump_bvh(b)


def test_dump_of_a_built_file_with_awkward_numbers() -> None:
    rng = np.random.default_rng(0)
    motion = rng.normal(size=(4, 6)) * np.array([1e-7, 1e5, 1.0, 360.0, -1e-3, 12345.678])
    b = BvhFile(
        joint_names=("root",),
        joint_parents=(-1,),
        joint_offsets=np.array([[1e-7, -2.5e-12, 123456.789]]),
        joint_channels=(("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation"),),
        end_sites=(),
        frame_time=1 / 120,
        motion=motion,
    )
    c = parse_bvh(dump_bvh(b))
    np.testing.assert_array_equal(c.joint_offsets, b.joint_offsets)
    assert c.frame_time == b.frame_time
    np.testing.assert_allclose(c.motion, motion, rtol=1e-9)


# ---- skeleton --------------------------------------------------------------------------------
def test_bvh_to_morphkit_axes() -> None:
    R = BVH_TO_MORPHKIT
    np.testing.assert_array_equal(R, [[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_array_equal(R @ [0, 1, 0], [0, 0, 1])  # BVH up -> z up
    np.testing.assert_array_equal(R @ [0, 0, 1], [1, 0, 0])  # BVH facing -> x forward
    np.testing.assert_array_equal(R @ [1, 0, 0], [0, 1, 0])  # character's left stays left
    for facing, axis in (("+z", [0, 0, 1]), ("-z", [0, 0, -1]), ("+x", [1, 0, 0]), ("-X", [-1, 0, 0])):
        Rf = bvh_frame_rotation(facing)
        np.testing.assert_allclose(Rf @ Rf.T, np.eye(3), atol=1e-15)
        assert np.linalg.det(Rf) == pytest.approx(1.0)
        np.testing.assert_array_equal(Rf @ axis, [1, 0, 0])
        np.testing.assert_array_equal(Rf @ [0, 1, 0], [0, 0, 1])
    with pytest.raises(ConfigError, match="unknown BVH facing"):
        bvh_frame_rotation("+y")


def test_tiny_skeleton() -> None:
    m = read_bvh_skeleton(TINY)
    assert m.name == "tiny" and m.source == str(TINY)
    assert m.base.name == "FLOATING" and m.root == "Hips"
    assert m.link_names == NAMES  # links in BVH order
    assert m.joint_names == NAMES[1:]
    types = {j.name: j.type for j in m.joints}
    assert types["LeftHand"] == JointType.FIXED  # no channels
    assert all(t == JointType.SPHERICAL for n, t in types.items() if n != "LeftHand")
    assert detect_bvh_scale(read_bvh(TINY)) == 0.01  # 115 units tall: centimetres
    bvh = read_bvh(TINY)
    for j in m.joints:
        expected = BVH_TO_MORPHKIT @ bvh.joint_offsets[bvh.joint_index(j.name)] * 0.01
        np.testing.assert_allclose(j.origin.xyz, expected, atol=1e-12)
        assert j.origin.quat == (0.0, 0.0, 0.0, 1.0)
    # The left hip is to the left (+y) and below (-z).
    np.testing.assert_allclose(m.joint("LeftUpLeg").origin.xyz, [0.0, 0.10, -0.05], atol=1e-12)
    assert m.dof == 7 * 3 and m.coordinate_count == 7 + 7 * 4
    assert m.joint("LeftUpLeg").location.line == bvh.joint_lines[1]
    # End-effectors from End Site names, at the End Site offsets.
    ees = {e.name: e for e in m.end_effectors}
    assert set(ees) == {"LeftFoot_end", "RightFoot_end", "Head_end", "LeftHand_end", "RightHand_end"}
    roles = {n: e.role for n, e in ees.items()}
    assert roles == {
        "LeftFoot_end": EndEffectorRole.FOOT,
        "RightFoot_end": EndEffectorRole.FOOT,
        "Head_end": EndEffectorRole.HEAD,
        "LeftHand_end": EndEffectorRole.HAND,
        "RightHand_end": EndEffectorRole.HAND,
    }
    np.testing.assert_allclose(ees["LeftFoot_end"].offset, [0.10, 0.0, -0.05], atol=1e-12)
    assert ees["LeftFoot_end"].link == "LeftFoot"
    assert ees["Head_end"].location.line == bvh.end_sites[2].line
    # Rest height: feet end sites at -50, head end at +65 file units.
    assert m.characteristic_length == pytest.approx(1.15)


def test_tiny_skeleton_capsules_span_the_bones() -> None:
    from morphkit.conventions import quat_rotate

    m = read_bvh_skeleton(TINY, scale=1.0)
    assert m.joint("LeftFoot").origin.xyz == pytest.approx(BVH_TO_MORPHKIT @ [0, -40, 0])
    spine = m.link("Spine")
    assert len(spine.shapes) == 3  # to the head and both hands
    for link in m.links:
        bvh_segments = [m.joint(c).origin.xyz for c in m.children(link.name)]
        bvh_segments += [e.offset for e in m.end_effectors if e.link == link.name and math.dist(e.offset, (0, 0, 0))]
        for shape in link.shapes:
            assert shape.type == ShapeType.CAPSULE
            axis = quat_rotate(np.asarray(shape.origin.quat), [0.0, 0.0, 1.0])
            a = np.asarray(shape.origin.xyz) - 0.5 * shape.length * axis
            b = np.asarray(shape.origin.xyz) + 0.5 * shape.length * axis
            np.testing.assert_allclose(a, 0.0, atol=1e-9)  # from the link origin ...
            assert any(np.allclose(b, s, atol=1e-9) for s in bvh_segments)  # ... to a child
            assert shape.radius == pytest.approx(max(0.08 * shape.length, 0.01))


def test_skeleton_scale_override_and_bad_scale() -> None:
    b = read_bvh(TINY)
    m = skeleton_from_bvh(b, scale=0.0254, name="inches")
    assert m.name == "inches"
    np.testing.assert_allclose(m.joint("Spine").origin.xyz, [0, 0, 20 * 0.0254])
    for bad in (0, -1.0, math.nan, math.inf, "1", True):
        with pytest.raises(ConfigError, match="BVH scale"):
            skeleton_from_bvh(b, scale=bad)  # type: ignore[arg-type]


def test_end_effector_grouping_and_fallbacks() -> None:
    """Fingers merge into one hand at the hand joint; weak keywords (neck), unnamed tips (tool), and a
    foot without an End Site."""
    text = (
        """HIERARCHY
ROOT pelvis
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT lowerneck
  {
    OFFSET 0 0.6 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0.1 0
    }
  }
  JOINT rHand
  {
    OFFSET -0.5 0.4 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT rIndex1
    {
      OFFSET -0.1 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET -0.03 0 0
      }
    }
    JOINT rThumb1
    {
      OFFSET -0.05 0 0.03
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET -0.03 0 0
      }
    }
  }
  JOINT tail_end
  {
    OFFSET 0 0 -0.3
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0 -0.1
    }
  }
  JOINT l_ankle
  {
    OFFSET 0.1 -0.9 0
    CHANNELS 0
    End Site
    {
      OFFSET 0 0 0.1
    }
  }
  JOINT r_ankle
  {
    OFFSET -0.1 -0.9 0
    CHANNELS 0
    JOINT r_toe
    {
      OFFSET 0 0 0.1
      CHANNELS 0
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.1
"""
        + " ".join(["0"] * 21)
        + "\n"
    )
    m = skeleton_from_bvh(parse_bvh(text, source="hand.bvh"))
    ees = {e.name: (e.link, e.role) for e in m.end_effectors}
    assert ees == {
        "lowerneck_end": ("lowerneck", EndEffectorRole.HEAD),
        "rHand": ("rHand", EndEffectorRole.HAND),
        "tail_end": ("tail_end", EndEffectorRole.TOOL),
        "l_ankle_end": ("l_ankle", EndEffectorRole.FOOT),
        "r_toe": ("r_toe", EndEffectorRole.FOOT),  # no End Site: the limb's tip joint
    }
    assert m.end_effector("rHand").offset == (0.0, 0.0, 0.0)


def test_front_paws_named_hands_become_feet() -> None:
    """A quadruped whose front paws are called hands: the hands move at the feet's height."""
    legs = []
    for name, x in (("LeftHand", 0.4), ("LeftFoot", -0.4)):
        legs.append(f"""  JOINT {name}_leg
  {{
    OFFSET {x} 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT {name}
    {{
      OFFSET 0 -0.5 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {{
        OFFSET 0 -0.05 0
      }}
    }}
  }}""")
    text = (
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
        "Yrotation\n"
        + "\n".join(legs)
        + "\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n"
        + "0 0.55 0 "
        + " ".join(["0"] * 15)
        + "\n"
        + "0 0.55 0.1 "
        + " ".join(["0"] * 15)
        + "\n"
    )
    b = parse_bvh(text)
    roles = {e.name: e.role for e in skeleton_from_bvh(b).end_effectors}
    assert roles == {"LeftHand_end": EndEffectorRole.FOOT, "LeftFoot_end": EndEffectorRole.FOOT}
    roles = {e.name: e.role for e in skeleton_from_bvh(b, detect_front_paws=False).end_effectors}
    assert roles["LeftHand_end"] == EndEffectorRole.HAND


def test_front_paws_need_legs_as_long_as_the_legs() -> None:
    """Hands at the feet's height on arms shorter than the legs (a crawling human) stay hands."""
    crawler = creature_bvh(fore="Hand", fore_length=25.0, frames=4)
    roles = sorted(e.role.name for e in skeleton_from_bvh(parse_bvh(crawler)).end_effectors)
    assert roles == ["FOOT", "FOOT", "HAND", "HAND", "HEAD"]
    quadruped = creature_bvh(fore="Hand", fore_length=40.0, frames=4)
    roles = sorted(e.role.name for e in skeleton_from_bvh(parse_bvh(quadruped)).end_effectors)
    assert roles == ["FOOT", "FOOT", "FOOT", "FOOT", "HEAD"]
    # Without frames nothing shows where the hands move: they stay hands.
    still = skeleton_from_bvh(parse_bvh(creature_bvh(fore="Hand", fore_length=40.0, frames=0)))
    assert sorted(e.role.name for e in still.end_effectors).count("HAND") == 2


# ---- static roots ------------------------------------------------------------------------------
STATIC_ROOTS = """HIERARCHY
ROOT world
{
  OFFSET 1 2 3
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT anchor
  {
    OFFSET 0 0 0
    CHANNELS 3 Xposition Yposition Zposition
    JOINT hips
    {
      OFFSET 5 90 -40
      CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
      JOINT spine
      {
        OFFSET 0 20 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 10 0
        }
      }
      JOINT leftfoot
      {
        OFFSET 10 -80 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -5 10
        }
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.04
0 0 0 0 0 0 0 0 0 1 90 2 0 0 0 0 0 0 0 0 0
10 0 -5 0 0 0 1 2 3 3 91 4 10 20 30 5 0 0 0 0 0
20 1 -10 0 0 0 2 4 6 5 92 6 -10 0 45 0 15 0 0 0 -20
"""


def test_static_roots_fold_away_keeping_world_positions() -> None:
    b = parse_bvh(STATIC_ROOTS, source="static.bvh")
    folded = fold_static_root(b)
    # Two roots that never rotate above a translating child: both go, hips is the root.
    assert folded.joint_names == ("hips", "spine", "leftfoot")
    assert folded.joint_parents == (-1, 0, 0)
    assert [s.parent for s in folded.end_sites] == [1, 2]
    assert folded.joint_lines == b.joint_lines[2:] and folded.motion_line == b.motion_line
    # Every joint and End Site stays where it was (the folded roots' translations add up).
    before = bvh_joint_positions(b)
    np.testing.assert_allclose(bvh_joint_positions(folded), before[:, 2:], atol=1e-12)
    np.testing.assert_allclose(folded.motion[:, :3], [[1, 90, 2], [14, 93, 2], [27, 97, 2]], atol=1e-12)
    assert fold_static_root(folded) is folded  # idempotent
    # The skeleton reader folds too: its root is hips.
    m = skeleton_from_bvh(b)
    assert m.root == "hips" and m.link_names == folded.joint_names
    assert m.coordinate_names == skeleton_from_bvh(folded).coordinate_names
    # Nothing folds when the root rotates once, or when no frame tells.
    turning = parse_bvh(STATIC_ROOTS.replace("20 1 -10 0 0 0", "20 1 -10 0 0 0.5"))
    assert fold_static_root(turning) is turning
    lines = STATIC_ROOTS.split("\n")
    cut = "\n".join(lines[: lines.index("Frames: 3")]) + "\nFrames: 0\nFrame Time: 0.04\n"
    empty = parse_bvh(cut)
    assert fold_static_root(empty) is empty


# ---- facing ------------------------------------------------------------------------------------
@pytest.mark.parametrize("head", ["+x", "-x", "+z", "-z"])
def test_facing_follows_the_level_trunk(head: str) -> None:
    b = parse_bvh(creature_bvh(head=head))
    assert detect_bvh_facing(b) == head
    assert detect_bvh_up(b) == "+y"
    # Walking backwards does not fool it: posture comes before travel.
    assert detect_bvh_facing(parse_bvh(creature_bvh(head=head, speed=-30.0))) == head
    # The skeleton then points its trunk and head along morphkit's +x (forward), feet down.
    m = skeleton_from_bvh(b)
    np.testing.assert_allclose(m.joint("Chest").origin.xyz, [0.4, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(m.joint("LeftHindFoot_top").origin.xyz, [0.0, 0.08, 0.0], atol=1e-12)
    assert m.joint("LeftHindFoot").origin.xyz == pytest.approx((0.0, 0.0, -0.4))
    # An explicit facing wins.
    assert skeleton_from_bvh(b, facing="+z").joint("Chest").origin.xyz == pytest.approx(
        tuple(BVH_TO_MORPHKIT @ (0.4 * AXES[head]))
    )


def test_facing_fallbacks() -> None:
    # Front legs named hands but as long as the legs and on the ground: paws, so still detected.
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="-x", fore="Hand"))) == "-x"
    # Skeletons with hands follow the humanoid convention whatever their posture.
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="-x", fore="Hand", fore_length=25.0))) == "+z"
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="-x", fore="Hand")), detect_front_paws=False) == "+z"
    # No head: the direction of travel, when the clip travels.
    headless = {"head_names": ("Crest", "Snout")}
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="+x", **headless))) == "+x"
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="+x", speed=-30.0, **headless))) == "-x"
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="+x", speed=0.1, **headless))) == "+z"  # stays put
    # Too few frames, or an upright body that does not travel: the BVH convention.
    assert detect_bvh_facing(parse_bvh(creature_bvh(head="-x", frames=1))) == "+z"
    assert detect_bvh_facing(read_bvh(TINY)) == "+z"
    with pytest.raises(ConfigError, match="unknown BVH facing"):
        skeleton_from_bvh(read_bvh(TINY), facing="up")


# ---- bad input -------------------------------------------------------------------------------
def _cut_after(pattern: str) -> str:
    lines = TINY_TEXT.split("\n")
    i = _line_of(TINY_TEXT, pattern)
    return "\n".join(lines[:i]) + "\n"


def _frame_line(k: int) -> int:
    return _line_of(TINY_TEXT, "^Frame Time") + 1 + k


def _replace_line(line: int, new: str) -> str:
    lines = TINY_TEXT.split("\n")
    lines[line - 1] = new
    return "\n".join(lines)


_HIER_END = _line_of(TINY_TEXT, "^MOTION") - 1

BAD_CASES = [
    # (id, text, error class, line, message fragment)
    ("empty", "", DescriptionError, 1, "empty BVH"),
    ("blank", "\n\n  \n", DescriptionError, 1, "empty BVH"),
    ("no HIERARCHY", TINY_TEXT.replace("HIERARCHY", "HIERARCHIES"), DescriptionError, 1, "expected HIERARCHY"),
    ("only HIERARCHY", "HIERARCHY\n", DescriptionError, 1, "no ROOT"),
    (
        "EOF in hierarchy",
        _cut_after("JOINT RightFoot"),
        DescriptionError,
        _line_of(TINY_TEXT, "JOINT RightFoot"),
        "never closed",
    ),
    (
        "EOF after OFFSET",
        _cut_after("OFFSET 0 30 0").rstrip("\n") + " ",
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 30 0"),
        "never closed",
    ),
    ("missing MOTION", TINY_TEXT.split("MOTION")[0], MotionFormatError, _HIER_END, "no MOTION"),
    (
        "MOTION without Frames",
        TINY_TEXT.split("MOTION")[0] + "MOTION\n",
        MotionFormatError,
        _HIER_END + 1,
        "expected Frames:",
    ),
    (
        "missing Frame Time",
        TINY_TEXT.split("Frame Time")[0],
        MotionFormatError,
        _line_of(TINY_TEXT, "^Frames"),
        "expected Frame Time:",
    ),
    (
        "fewer frames",
        "\n".join(TINY_TEXT.split("\n")[:-2]) + "\n",
        MotionFormatError,
        _frame_line(1),
        "truncated MOTION",
    ),
    ("more frames", TINY_TEXT.replace("Frames: 3", "Frames: 2"), MotionFormatError, _frame_line(2), "more frame"),
    (
        "frame too short",
        _replace_line(_frame_line(1), " ".join(["1"] * 28)),
        MotionFormatError,
        _frame_line(1),
        "frame 1 has 28 values",
    ),
    (
        "frame too long",
        _replace_line(_frame_line(2), " ".join(["1"] * 30)),
        MotionFormatError,
        _frame_line(2),
        "30 values",
    ),
    (
        "non-numeric",
        _replace_line(_frame_line(1), "1 2 3 4 5 x7 " + " ".join(["1"] * 23)),
        MotionFormatError,
        _frame_line(1),
        "non-numeric value 'x7'",
    ),
    (
        "comma decimal",
        _replace_line(_frame_line(2), "1,5 " + " ".join(["1"] * 28)),
        MotionFormatError,
        _frame_line(2),
        "non-numeric value '1,5'",
    ),
    (
        "nan value",
        _replace_line(_frame_line(0), "nan " + " ".join(["1"] * 28)),
        MotionFormatError,
        _frame_line(0),
        "non-finite",
    ),
    (
        "inf value",
        _replace_line(_frame_line(2), " ".join(["1"] * 28) + " -inf"),
        MotionFormatError,
        _frame_line(2),
        "non-finite",
    ),
    (
        "zero frame time",
        TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: 0"),
        MotionFormatError,
        _frame_line(0) - 1,
        "positive",
    ),
    (
        "negative frame time",
        TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: -0.04"),
        MotionFormatError,
        _frame_line(0) - 1,
        "positive",
    ),
    (
        "nan frame time",
        TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: nan"),
        MotionFormatError,
        _frame_line(0) - 1,
        "positive",
    ),
    (
        "inf frame time",
        TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: inf"),
        MotionFormatError,
        _frame_line(0) - 1,
        "positive",
    ),
    (
        "text frame time",
        TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: fast"),
        MotionFormatError,
        _frame_line(0) - 1,
        "must be a number",
    ),
    (
        "negative frames",
        TINY_TEXT.replace("Frames: 3", "Frames: -3"),
        MotionFormatError,
        _frame_line(0) - 2,
        "non-negative integer",
    ),
    (
        "fractional frames",
        TINY_TEXT.replace("Frames: 3", "Frames: 2.5"),
        MotionFormatError,
        _frame_line(0) - 2,
        "non-negative integer",
    ),
    (
        "unknown channel",
        TINY_TEXT.replace("Yrotation Zrotation Xrotation", "Yrotation Wrotation Xrotation"),
        DescriptionError,
        _line_of(TINY_TEXT, "Yrotation Zrotation Xrotation"),
        "unknown channel 'Wrotation'",
    ),
    (
        "duplicate channel",
        TINY_TEXT.replace("Yrotation Zrotation Xrotation", "Yrotation Zrotation Yrotation"),
        DescriptionError,
        _line_of(TINY_TEXT, "Yrotation Zrotation Xrotation"),
        "listed twice",
    ),
    (
        "channel count too big",
        TINY_TEXT.replace("CHANNELS 0", "CHANNELS 7"),
        DescriptionError,
        _line_of(TINY_TEXT, "CHANNELS 0"),
        "from 0 to 6",
    ),
    (
        "channel count not a number",
        TINY_TEXT.replace("CHANNELS 0", "CHANNELS zero"),
        DescriptionError,
        _line_of(TINY_TEXT, "CHANNELS 0"),
        "from 0 to 6",
    ),
    ("extra closing brace", _replace_line(_HIER_END, "}\n}"), DescriptionError, _HIER_END + 1, "expected MOTION"),
    ("missing closing brace", _replace_line(_HIER_END, ""), DescriptionError, _HIER_END + 1, "never closed"),
    ("brace before ROOT", "HIERARCHY\n}\n" + TINY_TEXT[10:], DescriptionError, 2, "unbalanced"),
    (
        "duplicate joint",
        TINY_TEXT.replace("JOINT RightFoot", "JOINT LeftFoot"),
        DescriptionError,
        _line_of(TINY_TEXT, "JOINT RightFoot"),
        "duplicate joint name 'LeftFoot'",
    ),
    (
        "bad offset",
        TINY_TEXT.replace("OFFSET 0 30 0", "OFFSET 0 thirty 0"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 30 0"),
        "expected an OFFSET number, got 'thirty'",
    ),
    (
        "short offset",
        TINY_TEXT.replace("OFFSET 0 30 0", "OFFSET 0 30"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 30 0") + 1,
        "got 'CHANNELS'",
    ),
    (
        "non-finite offset",
        TINY_TEXT.replace("OFFSET 0 30 0", "OFFSET 0 inf 0"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 30 0"),
        "finite",
    ),
    (
        "second offset",
        TINY_TEXT.replace("OFFSET 0 30 0", "OFFSET 0 30 0 OFFSET 1 1 1"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 30 0"),
        "second OFFSET",
    ),
    (
        "no offset",
        TINY_TEXT.replace("OFFSET 0 30 0", ""),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 15 0") + 2,
        "has no OFFSET",
    ),
    (
        "end site channels",
        TINY_TEXT.replace("OFFSET 0 15 0", "OFFSET 0 15 0 CHANNELS 1 Xrotation"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 15 0"),
        "End Site cannot have CHANNELS",
    ),
    (
        "joint in end site",
        TINY_TEXT.replace("OFFSET 0 15 0", "OFFSET 0 15 0\nJOINT Hat"),
        DescriptionError,
        _line_of(TINY_TEXT, "OFFSET 0 15 0") + 1,
        "End Site cannot have child joints",
    ),
    (
        "joint without name",
        TINY_TEXT.replace("JOINT Head", "JOINT"),
        DescriptionError,
        _line_of(TINY_TEXT, "JOINT Head"),
        "needs a name",
    ),
    (
        "unknown keyword",
        TINY_TEXT.replace("CHANNELS 0", "CHANNELZ 0"),
        DescriptionError,
        _line_of(TINY_TEXT, "CHANNELS 0"),
        "unknown keyword 'CHANNELZ'",
    ),
    ("second root", _replace_line(_HIER_END, "}\nROOT Other"), DescriptionError, _HIER_END + 1, "second ROOT"),
    (
        "End without Site",
        TINY_TEXT.replace("End Site", "End Sight", 1),
        DescriptionError,
        _line_of(TINY_TEXT, "End Site"),
        "expected 'End Site'",
    ),
    ("text after MOTION", TINY_TEXT.replace("MOTION", "MOTION 3"), MotionFormatError, _HIER_END + 1, "after MOTION"),
]


@pytest.mark.parametrize(("text", "cls", "line", "fragment"), [c[1:] for c in BAD_CASES], ids=[c[0] for c in BAD_CASES])
def test_bad_input_is_located(tmp_path: Path, text: str, cls: type, line: int, fragment: str) -> None:
    path = tmp_path / "bad.bvh"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(cls) as info:
        read_bvh(path)
    err = info.value
    assert fragment in err.message, err.message
    assert err.location is not None and err.location.path == str(path)
    assert err.location.line == line, f"{err}"
    # The skeleton reader fails the same way.
    with pytest.raises(cls):
        read_bvh_skeleton(path)


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(DescriptionError, match="not found") as info:
        read_bvh(tmp_path / "missing.bvh")
    assert info.value.location.path == str(tmp_path / "missing.bvh")
    garbage = tmp_path / "garbage.bvh"
    garbage.write_bytes(b"HIERARCHY\nROOT a\n{\n\xff\xfe\x00\x81 OFFSET\n")
    with pytest.raises(DescriptionError, match="not UTF-8") as info:
        read_bvh(garbage)
    assert info.value.location.line == 4
    with pytest.raises(DescriptionError):
        read_bvh(tmp_path)  # a folder
    with pytest.raises(DescriptionError, match="must be a string"):
        parse_bvh(b"HIERARCHY")  # type: ignore[arg-type]


def test_errors_from_text_name_the_source() -> None:
    with pytest.raises(MotionFormatError) as info:
        parse_bvh(TINY_TEXT.replace("Frame Time: 0.04", "Frame Time: 0"), source="clip.bvh")
    assert str(info.value).startswith(f"clip.bvh:{_frame_line(0) - 1}: ")


# ---- real data -------------------------------------------------------------------------------
def _data_files(*groups: str) -> list[Path]:
    root = os.environ.get("MORPHKIT_DATA")
    if not root:
        return []
    return sorted(p for g in groups for p in (Path(root) / g).rglob("*.bvh"))


def _path_length(m: Morphology, a: str, b: str) -> float:
    """Length of the bone path between two end-effectors through the tree (pose-independent) [m]."""

    def up(link: str) -> list[str]:
        out = [link]
        while (j := m.parent_joint(out[-1])) is not None:
            out.append(j.parent)
        return out

    ea, eb = m.end_effector(a), m.end_effector(b)
    pa, pb = up(ea.link), up(eb.link)
    common = next(link for link in pa if link in pb)
    total = float(np.linalg.norm(ea.offset) + np.linalg.norm(eb.offset))
    for chain in (pa, pb):
        total += sum(float(np.linalg.norm(m.parent_joint(link).origin.xyz)) for link in chain[: chain.index(common)])
    return total


HUMAN_FILES = _data_files("human")
CREATURE_FILES = _data_files("creatures")


@pytest.mark.skipif(not HUMAN_FILES, reason="MORPHKIT_DATA is not set (or has no human BVH files)")
def test_every_human_bvh_builds_a_plausible_human() -> None:
    """Every human clip, crawling (CMU 111_03) and sun salutation (144_32) included, has two
    hands, two feet and a head (front-paw detection is on), and Bandai Namco's static
    ``joint_Root`` is folded away."""
    failures = []
    for path in HUMAN_FILES:
        try:
            m = read_bvh_skeleton(path)
        except MorphkitError as exc:  # collect, to report every broken file at once
            failures.append(f"{path}: {exc}")
            continue
        if m.root == "joint_Root":
            failures.append(f"{path}: the static joint_Root was not folded away")
        roles = [e.role for e in m.end_effectors]
        counts = {r: roles.count(r) for r in EndEffectorRole}
        if (counts[EndEffectorRole.HAND], counts[EndEffectorRole.FOOT], counts[EndEffectorRole.HEAD]) != (2, 2, 1):
            failures.append(f"{path}: end-effector roles {counts}")
            continue
        # Standing height, whatever the rest pose (Bandai Namco's rest pose lies along x): the bone
        # path from a foot end-effector to the head end-effector.
        head = m.ee_by_role(EndEffectorRole.HEAD)[0].name
        height = max(_path_length(m, foot.name, head) for foot in m.ee_by_role(EndEffectorRole.FOOT))
        if not 1.4 <= height <= 2.0:
            failures.append(f"{path}: implausible height {height:.3f} m")
        if m.link_count != m.joint_count + 1 or m.base.name != "FLOATING":
            failures.append(f"{path}: bad structure")
    assert not failures, "\n".join(failures[:20])


@pytest.mark.skipif(not CREATURE_FILES, reason="MORPHKIT_DATA is not set (or has no creature BVH files)")
def test_every_creature_bvh_builds() -> None:
    failures = []
    for path in CREATURE_FILES:
        try:
            b = read_bvh(path)
            m = skeleton_from_bvh(b)
        except MorphkitError as exc:
            failures.append(f"{path}: {exc}")
            continue
        if m.link_names != fold_static_root(b).joint_names or b.frame_count == 0:
            failures.append(f"{path}: links differ from BVH joints or no frames")
        if not 0.05 <= m.characteristic_length <= 10.0:
            failures.append(f"{path}: implausible size {m.characteristic_length:.3f} m")
        roles = [e.role for e in m.end_effectors]
        counts = (roles.count(EndEffectorRole.HAND), roles.count(EndEffectorRole.FOOT))
        if "dog" in path.name or "elephant" in path.name:
            if counts != (0, 4):  # front paws named hands are feet
                failures.append(f"{path}: (hands, feet) {counts}, expected (0, 4)")
        elif not counts[1]:
            failures.append(f"{path}: no feet among {[e.name for e in m.end_effectors]}")
    assert not failures, "\n".join(failures[:20])


@pytest.mark.skipif(
    not [p for p in HUMAN_FILES if p.parent.name == "second_skeleton"],
    reason="MORPHKIT_DATA is not set (or has no human/second_skeleton)",
)
def test_info_roots_bandai_namco_skeletons_at_the_hips(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from morphkit.cli import main

    path = next(p for p in HUMAN_FILES if p.parent.name == "second_skeleton")
    assert main(["info", str(path), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["root"] == "Hips"
    assert "joint_Root" not in {e["link"] for e in s["end_effectors"]}
    assert sorted(e["role"] for e in s["end_effectors"]) == ["foot", "foot", "hand", "hand", "head"]
    assert main(["info", str(path)]) == 0
    assert "root link Hips" in capsys.readouterr().out
