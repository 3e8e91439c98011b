"""Contact-aware export by re-planning: the legs re-stepped along a motion's own root path."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from morphkit_testing import spot_like, wheeled

from morphkit.contact_export import apply_contacts, replan_legs
from morphkit.errors import ConfigError
from morphkit.metrics import foot_contact_figures, unrealistic_frame_ratio
from morphkit.rotations import quat_from_yaw
from morphkit.synth import SynthConfig, synthesize


@pytest.fixture(scope="module")
def walking():
    m = spot_like()
    return synthesize(m, frames=150, seed=1, config=replace(SynthConfig(), rollout_seconds=5.0, batch=1),
                      progress=False).motions[0]


def _leg_coords(m) -> np.ndarray:
    legs = np.zeros(m.coordinate_count, dtype=bool)
    for j, joint in enumerate(m.joints):
        if joint.name[:2] in ("fl", "fr", "hl", "hr"):
            legs[m.joint_q_start[j]:m.joint_q_start[j + 1]] = True
    return legs


def test_replan_keeps_root_path_and_arm_bit_identical_and_plants_sliding_feet(walking):
    m = walking.morphology
    legs = _leg_coords(m)
    q = walking.q.copy()
    # what a raw retargeter does: the body moves on while the legs hold a pose, so the feet drag along
    q[:, legs] = q[0, legs]
    noisy = walking.replace(q=q)
    before = foot_contact_figures(noisy)
    assert before.sliding_rate > 0.05  # the case is a real one
    out = replan_legs(noisy)
    np.testing.assert_array_equal(out.q[:, ~legs], noisy.q[:, ~legs])  # base and arm untouched, bit for bit
    after = foot_contact_figures(out)
    assert after.sliding_rate == 0.0 and after.penetration_rate == 0.0
    assert unrealistic_frame_ratio(out).foot_sliding.mean() == 0.0
    # stance feet stand still in the world: the planted feet's step per frame stays at IK residual level
    feet = out.end_effector_positions()[:, [e.role.name == "FOOT" for e in m.end_effectors]]
    low = feet[1:, :, 2] < 0.005
    steps = np.linalg.norm(np.diff(feet[..., :2], axis=0), axis=-1)
    assert np.median(steps[low & (feet[:-1, :, 2] < 0.005)]) < 1e-3


def test_replan_keeps_a_foot_down_when_the_path_twists_faster_than_the_legs_step(walking):
    m = walking.morphology
    t = np.arange(150) / walking.fps
    q = np.repeat(walking.q[:1], 150, axis=0)
    q[:, 3:7] = quat_from_yaw(0.35 * np.sin(2 * np.pi * 1.5 * t))  # a human twisting in place, up to 3.3 rad/s
    twisting = walking.replace(q=q)
    feet = [e.role.name == "FOOT" for e in m.end_effectors]

    def flight_frames(motion):  # frames with every foot above the contact height of UFR and floating
        return int((motion.end_effector_positions()[:, feet, 2].min(axis=1) >= 0.02).sum())

    assert flight_frames(replan_legs(twisting, min_support=0)) > 0  # the planner alone would leap
    out = replan_legs(twisting)
    assert flight_frames(out) == 0
    np.testing.assert_array_equal(out.q[:, ~_leg_coords(m)], twisting.q[:, ~_leg_coords(m)])
    assert foot_contact_figures(out).sliding_rate == 0.0 and unrealistic_frame_ratio(out).ratio == 0.0


def test_replan_leaves_creatures_without_legs_and_none_alone(walking):
    rover = wheeled()
    q = np.zeros((20, rover.coordinate_count))
    q[:, 0] = np.linspace(0, 1, 20)
    from morphkit.motion import Motion

    motion = Motion(rover, 30.0, q, "drive")
    assert replan_legs(motion) is motion
    assert apply_contacts(walking, "none") is walking
    with pytest.raises(ConfigError, match="contact mode"):
        apply_contacts(walking, "glue")


def test_contacts_command_replans_a_motion_file_and_never_overwrites_it(walking, tmp_path, capsys):
    from morphkit.cli import main
    from morphkit.motion import read_motion, write_motion

    legs = _leg_coords(walking.morphology)
    q = walking.q.copy()
    q[:, legs] = q[0, legs]
    src = tmp_path / "dragging.npz"
    write_motion(walking.replace(q=q), src)
    assert main(["contacts", str(src), str(tmp_path / "planted.npz")]) == 0
    assert "→ 0.0 %" in capsys.readouterr().out
    out = read_motion(tmp_path / "planted.npz")
    assert foot_contact_figures(out).sliding_rate == 0.0
    before = src.read_bytes()
    assert main(["contacts", str(src), str(src)]) == 2
    assert "error: " in capsys.readouterr().err and src.read_bytes() == before
