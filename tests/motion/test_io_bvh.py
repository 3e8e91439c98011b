"""BVH motion reading and writing: known angles read back exactly, every creature round-trips."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from _bvh_creature import creature_bvh
from _motion_compare import assert_q_close, reference_link_positions
from morphkit_testing import TEST_CREATURES, random_q

from morphkit.conventions import quat_from_axis_angle, quat_multiply, quat_rotate
from morphkit.errors import MotionFormatError
from morphkit.graph import JointType
from morphkit.io.bvh import parse_bvh
from morphkit.motion import Motion, bvh_to_motion, motion_to_bvh, read_bvh_motion, read_motion, write_bvh_motion
from morphkit.motion._fk import compiled_model

# BVH axes -> morphkit axes for a Y-up, +Z-facing file: X -> y, Y -> z, Z -> x.
AXIS = {"X": np.array([0.0, 1.0, 0.0]), "Y": np.array([0.0, 0.0, 1.0]), "Z": np.array([1.0, 0.0, 0.0])}


def _euler(order: str, degrees: tuple[float, ...]) -> np.ndarray:
    """Expected morphkit quaternion of BVH channels ``order`` (e.g. "ZXY") at ``degrees``, built
    from axis-angle quaternions about the mapped axes."""
    q = np.array([0.0, 0.0, 0.0, 1.0])
    for axis, deg in zip(order, degrees, strict=True):
        q = quat_multiply(q, quat_from_axis_angle(AXIS[axis], math.radians(deg)))
    return q


SYNTH = """HIERARCHY
ROOT pelvis
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT chest
  {
    OFFSET 0 0.3 0
    CHANNELS 3 Yrotation Xrotation Zrotation
    JOINT head
    {
      OFFSET 0 0.25 0.05
      CHANNELS 3 Xrotation Zrotation Yrotation
      End Site
      {
        OFFSET 0 0.2 0
      }
    }
  }
  JOINT lfoot
  {
    OFFSET 0.1 -0.9 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 -0.05 0.1
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.033333
0 1 0 0 0 0 0 0 0 0 0 0 0 0 0
0.5 1.2 -2 0 0 90 90 0 0 0 0 -90 30 0 0
0.1 0.9 0.3 10 20 30 40 50 60 -70 80 -10 15 -25 35
"""


def test_synthetic_bvh_reads_back_exactly() -> None:
    motion = bvh_to_motion(parse_bvh(SYNTH, source="synth.bvh"), scale=1.0, up="+y", ground=False)
    m = motion.morphology
    assert motion.fps == 30.0  # Frame Time 0.033333 snaps to 30 fps
    assert motion.name == "synth"
    assert m.link_names == ("pelvis", "chest", "head", "lfoot")
    assert all(j.type == JointType.SPHERICAL for j in m.joints)
    q = motion.q
    # Root position: BVH (x, y, z) -> morphkit (z, x, y).
    np.testing.assert_allclose(q[:, 0:3], [[0, 0, 1], [-2, 0.5, 1.2], [0.3, 0.1, 0.9]], atol=1e-15)
    frames = [
        ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)),
        ((0, 0, 90), (90, 0, 0), (0, 0, -90), (30, 0, 0)),
        ((10, 20, 30), (40, 50, 60), (-70, 80, -10), (15, -25, 35)),
    ]
    orders = ("ZXY", "YXZ", "XZY", "ZYX")
    links = ("pelvis", "chest", "head", "lfoot")
    for f, angles in enumerate(frames):
        for link, order, deg in zip(links, orders, angles, strict=True):
            start = 3 if link == "pelvis" else m.joint_q_start[m.joint_index(link)]
            got = q[f, start : start + 4]
            want = _euler(order, deg)
            sign = 1.0 if np.dot(got, want) >= 0 else -1.0
            np.testing.assert_allclose(got, sign * want, atol=1e-15, err_msg=f"frame {f} {link}")
    # Frame 1: a 90 degree yaw of the root (BVH Yrotation is about up).
    np.testing.assert_allclose(q[1, 3:7], [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)], atol=1e-15)
    # Offsets became metres in morphkit axes.
    assert m.joint("lfoot").origin.xyz == pytest.approx((0.0, 0.1, -0.9))


def test_units_up_axis_ground_and_fps() -> None:
    cm = SYNTH.replace("0 0.3 0", "0 30 0").replace("0 0.25 0.05", "0 25 5").replace("0.1 -0.9 0", "10 -90 0")
    cm = cm.replace("0 0.2 0", "0 20 0").replace("0 -0.05 0.1", "0 -5 10")
    cm = cm.replace("0 1 0 0 0", "0 100 0 0 0").replace("0.5 1.2 -2", "50 120 -200").replace("0.1 0.9 0.3", "10 90 30")
    a = bvh_to_motion(parse_bvh(SYNTH), scale=1.0, up="+y", ground=False)
    b = bvh_to_motion(parse_bvh(cm), up="auto", ground=False)  # centimetres detected, Y up detected
    np.testing.assert_allclose(b.q, a.q, atol=1e-12)
    grounded = bvh_to_motion(parse_bvh(SYNTH), scale=1.0)
    feet = [i for i, e in enumerate(grounded.morphology.end_effectors) if e.role.name == "FOOT"]
    assert feet, "the lfoot End Site is a foot"
    assert grounded.end_effector_positions()[:, feet, 2].min() == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(grounded.q[:, :2], a.q[:, :2])
    res = bvh_to_motion(parse_bvh(SYNTH), scale=1.0, fps=60.0)
    assert res.fps == 60.0 and res.frame_count == 5


def test_z_up_world_with_y_up_skeleton() -> None:
    # The same motion seen in a Z-up world: the root carries an extra +90 degrees about BVH X.
    text = SYNTH.replace("0 1 0 0 0 0 0 0 0", "0 0 1 0 90 0 0 0 0")
    lines = text.split("\n")
    start = lines.index("Frame Time: 0.033333") + 1
    lines = [*lines[: start + 1], ""]
    lines[lines.index("Frames: 3")] = "Frames: 1"
    motion = bvh_to_motion(parse_bvh("\n".join(lines)), scale=1.0, ground=False)  # up="auto" finds +z
    np.testing.assert_allclose(motion.q[0, :3], [0.0, 0.0, 1.0], atol=1e-15)  # Z-up world: positions kept
    head = motion.link_positions()[0, motion.morphology.link_index("head")]
    assert head[2] > 1.5  # standing upright


def test_translating_root_is_collapsed_and_moving_offsets_warn() -> None:
    text = """HIERARCHY
ROOT origin
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT hips
  {
    OFFSET 5 90 -400
    CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
    JOINT spine
    {
      OFFSET 0 20 0
      CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 10 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 0 0 0 0 0 1 90 2 0 0 0 0 20 0 0 0 0
0 0 0 0 0 0 3 91 4 0 0 10 0 20.000001 0 0 0 0
"""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        motion = bvh_to_motion(parse_bvh(text), ground=False)
    assert motion.morphology.root == "hips"
    np.testing.assert_allclose(motion.q[:, :3], [[0.02, 0.01, 0.9], [0.04, 0.03, 0.91]], atol=1e-12)
    # A root that carries the travel (Bandai Namco's dash clips): its translation adds to the child's.
    travelling = text.replace("0 0 0 0 0 0 3 91 4", "0 0 50 0 0 0 3 91 4")
    moved = bvh_to_motion(parse_bvh(travelling), ground=False)
    assert moved.morphology.root == "hips"
    np.testing.assert_allclose(moved.q[:, :3], [[0.02, 0.01, 0.9], [0.54, 0.03, 0.91]], atol=1e-12)
    stretched = text.replace("0 20.000001 0 0 0 0", "0 26 0 0 0 0")
    with pytest.warns(UserWarning, match="spine"):
        bvh_to_motion(parse_bvh(stretched), ground=False)


def test_truncated_bvh_fails_with_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "cut.bvh"
    path.write_text(SYNTH.rsplit("\n", 2)[0] + "\n")
    with pytest.raises(MotionFormatError) as err:
        read_bvh_motion(path)
    assert err.value.location is not None and err.value.location.path == str(path)
    assert err.value.location.line is not None
    assert "truncated" in str(err.value)


@pytest.mark.parametrize("name", sorted(TEST_CREATURES))
def test_bvh_write_read_round_trip_every_creature(name: str, tmp_path: Path) -> None:
    m = TEST_CREATURES[name]()
    q = random_q(compiled_model(m), 12, seed=3)
    motion = Motion(m, 24.0, q, name)
    path = tmp_path / f"{name}.bvh"
    write_bvh_motion(motion, path)
    back = read_bvh_motion(path, morphology=m)
    assert back.fps == 24.0
    assert_q_close(m, back.q, motion.q, atol=1e-5)
    expected = reference_link_positions(motion)
    np.testing.assert_allclose(reference_link_positions(back), expected, atol=1e-5)
    # Read as a plain BVH skeleton, every link lands in the same place (prismatic joints aside:
    # a rigid BVH skeleton cannot stretch).
    if not any(j.type == JointType.PRISMATIC for j in m.joints):
        plain = read_bvh_motion(path, up="+y", ground=False)
        assert plain.morphology.link_names == m.link_names
        np.testing.assert_allclose(reference_link_positions(plain), expected, atol=1e-5)


def test_bvh_text_is_standard(tmp_path: Path) -> None:
    m = TEST_CREATURES["wheeled"]()
    q = random_q(compiled_model(m), 3, seed=0)
    bvh = motion_to_bvh(Motion(m, 30.0, q))
    assert bvh.joint_channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    path = tmp_path / "w.bvh"
    write_bvh_motion(Motion(m, 30.0, q), path)
    text = path.read_text()
    assert text.startswith("HIERARCHY\nROOT chassis\n")
    assert "\nMOTION\nFrames: 3\nFrame Time: 0.03333333333" in text
    assert text.count("{") == text.count("}")
    assert isinstance(read_motion(path, morphology=m), Motion)


@pytest.mark.parametrize("head", ["+x", "-x", "+z", "-z"])
@pytest.mark.parametrize("speed", [30.0, -30.0])
def test_auto_facing_puts_the_head_forward(head: str, speed: float) -> None:
    """Whatever root-local axis a quadruped's trunk lies along, ``facing="auto"`` makes it the
    root's +x: the chest is straight ahead in the heading frame, and the root moves forwards (or
    backwards, for a clip walking backwards) along it."""
    motion = bvh_to_motion(parse_bvh(creature_bvh(head=head, speed=speed)), ground=False)
    m = motion.morphology
    pos = reference_link_positions(motion)  # [T, L, 3]
    x_axis = quat_rotate(motion.q[:, 3:7], np.broadcast_to([1.0, 0.0, 0.0], (motion.frame_count, 3)))
    np.testing.assert_allclose(x_axis[:, 2], 0.0, atol=1e-12)  # level, so the heading is the root's x
    chest = pos[:, m.link_index("Chest")] - pos[:, 0]
    np.testing.assert_allclose(chest, 0.4 * x_axis, atol=1e-9)
    feet = [e.name for e in m.end_effectors if e.role.name == "FOOT"]
    assert len(feet) == 4 and pos[:, m.link_index("LeftHindFoot"), 2].max() < pos[:, 0, 2].min()  # z up
    step = np.diff(motion.q[:, :3], axis=0)  # [T - 1, 3] world [m]
    np.testing.assert_allclose(step, 0.01 * speed * x_axis[:-1], atol=1e-9)
