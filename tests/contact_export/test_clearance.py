"""Keeping the upper body out of the body and above the ground: the smallest joint change per frame."""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.contact_export import apply_contacts, clear_upper_body, replan_legs
from morphkit.io import read_morphology
from morphkit.kernels import eval_self_collision_distance, self_collision_pairs
from morphkit.metrics import unrealistic_frame_ratio
from morphkit.motion import Motion, compiled_model
from morphkit.synth import prepare

# A fixed box (top at z = 0.6 m) and one arm: a capsule (radius 3 cm, segment 0.4 m along the link's x) on a
# hinge 10 cm above the box, on a post that turns about the vertical (two joints from the box, so the pair is
# checked, as the metric checks it); the hinge at θ tips the arm down, its tip's lowest point at
# 0.7 − 0.4 sin θ − 0.03 m. It meets the box where sin θ* = 0.07 / 0.4; turning the post does not lift it.
TABLE_ARM = """\
name: table_arm
base: fixed
root: body
links:
  body:
    shapes: [{type: box, size: [0.6, 0.4, 0.2], origin: {xyz: [0, 0, 0.5]}}]
  post: {}
  arm:
    shapes: [{type: capsule, radius: 0.03, length: 0.4, origin: {xyz: [0.2, 0, 0], rpy: [0, 1.5707963267948966, 0]}}]
joints:
  turn:
    type: revolute
    parent: body
    child: post
    origin: {xyz: [-0.2, 0, 0.7]}
    axis: [0, 0, 1]
    limit: {lower: -1.5, upper: 1.5}
  hinge:
    type: revolute
    parent: post
    child: arm
    axis: [0, 1, 0]
    limit: {lower: -1.5, upper: 1.5}
end_effectors:
  hand: {link: arm, offset: [0.4, 0, 0], role: hand}
"""


@pytest.fixture
def table_arm(tmp_path):
    path = tmp_path / "table_arm.yaml"
    path.write_text(TABLE_ARM)
    return read_morphology(path)


def _tip_gap(theta: np.ndarray) -> np.ndarray:
    """The analytic distance [m] between the arm's capsule and the box top at hinge angle θ."""
    return 0.7 - 0.4 * np.sin(theta) - 0.03 - 0.6


def test_an_arm_pressed_into_a_box_is_lifted_onto_its_surface_and_nowhere_else(table_arm):
    theta = np.concatenate([np.linspace(0.0, 0.5, 11), np.linspace(0.5, 0.0, 11)])
    raw = Motion(table_arm, 30.0, np.stack([np.zeros_like(theta), theta], axis=1), "press")
    out = clear_upper_body(raw)
    got = out.q[:, 1]
    assert np.abs(out.q[:, 0]).max() < 1e-6  # the turn does not lift the arm: the smallest change leaves it
    free = _tip_gap(theta) >= 0.0
    assert free.sum() >= 6 and (~free).sum() >= 10  # the case is a real one: both kinds of frame
    np.testing.assert_array_equal(got[free], theta[free])  # frames that touch nothing: bit for bit
    # the pressed frames: on the surface, at most the 2 mm clearance off it (not swung away)
    gap = _tip_gap(got[~free])
    assert gap.min() >= -1e-6 and gap.max() <= 0.002 + 1e-4
    # the kernels' own distance agrees with the analytic one
    model = compiled_model(table_arm)
    pairs = self_collision_pairs(model)
    d = eval_self_collision_distance(model, pairs, out.link_poses()).numpy().min(axis=1)
    np.testing.assert_allclose(d, _tip_gap(got), atol=1e-6)


def test_clearing_is_causal_frame_t_does_not_depend_on_later_frames(table_arm):
    theta = 0.5 * np.sin(np.linspace(0.0, 3.0 * np.pi, 40)) + 0.1
    raw = Motion(table_arm, 30.0, np.stack([0.2 * theta, theta], axis=1), "wave")
    full = clear_upper_body(raw)
    for t in (1, 9, 23):
        np.testing.assert_array_equal(clear_upper_body(raw.slice(0, t)).q, full.q[:t])


def _folded_spot() -> tuple[Motion, np.ndarray]:
    """Spot standing, its arm folded so that the wrist and fingers sit inside the body box (a pose ACE
    produced on a held-out clip), between frames with the arm raised clear; and the arm's coordinates."""
    m = read_morphology("spot")
    q0 = np.asarray(prepare(m, fps=30.0).q_stance, dtype=float)
    names = ("arm_sh0", "arm_sh1", "arm_el0", "arm_el1", "arm_wr0", "arm_wr1", "arm_f1x")
    arm = np.array([m.joint_q_start[m.joint_index(n)] for n in names])
    folded = np.array([-1.84, -1.31, 2.90, 0.68, 0.97, -1.36, -1.37])
    clear = np.array([0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    s = np.concatenate([np.linspace(0.0, 1.0, 8), np.ones(4), np.linspace(1.0, 0.0, 8)])
    q = np.repeat(q0[None], len(s), axis=0)
    q[:, arm] = (1.0 - s)[:, None] * clear + s[:, None] * folded
    return Motion(m, 30.0, q, "fold"), arm


def test_a_folded_arm_leaves_the_body_and_only_the_arm_moves():
    raw, arm = _folded_spot()
    before = unrealistic_frame_ratio(raw).self_collision
    out = clear_upper_body(raw)
    after = unrealistic_frame_ratio(out).self_collision
    assert before.sum() >= 6 and not after.any()  # the metric's own check, not the clearance's
    model = compiled_model(raw.morphology)
    d = eval_self_collision_distance(model, self_collision_pairs(model, rest_margin=0.005), out.link_poses()).numpy()
    assert d.min() >= -1e-6
    others = np.ones(raw.morphology.coordinate_count, dtype=bool)
    others[arm] = False
    np.testing.assert_array_equal(out.q[:, others], raw.q[:, others])  # root, legs, gripper: bit for bit
    # the smallest way out: the arm stays close to where it was, not swung elsewhere
    assert np.abs(out.q[:, arm] - raw.q[:, arm]).max() < 0.6


def test_the_contact_aware_exports_clear_the_arm_and_the_raw_output_keeps_it():
    raw, _ = _folded_spot()
    assert apply_contacts(raw, "none") is raw
    np.testing.assert_array_equal(apply_contacts(raw, "replan").q, clear_upper_body(replan_legs(raw)).q)
    for mode in ("replan", "lock"):
        assert not unrealistic_frame_ratio(apply_contacts(raw, mode)).self_collision.any()


def test_contacts_command_reports_the_frames_it_took_out_of_the_body(tmp_path, capsys):
    from morphkit.cli import main
    from morphkit.motion import write_motion

    raw, _ = _folded_spot()
    src = tmp_path / "folded.npz"
    write_motion(raw, src)
    assert main(["contacts", str(src), str(tmp_path / "clear.npz"), "--mode", "replan"]) == 0
    printed = capsys.readouterr().out
    share = 100 * unrealistic_frame_ratio(raw).self_collision.mean()
    assert f"self-collision {share:.1f} % → 0.0 % of frames" in printed


def test_wheels_standing_on_the_ground_are_not_a_collision():
    # a wheel is driven by the base (no coordinate of its own) and touches the ground by design: a robot that
    # rolls with its arm clear comes back as it was, object for object
    m = read_morphology("stretch")
    q = np.repeat(np.asarray(prepare(m, fps=30.0).q_stance, dtype=float)[None], 6, axis=0)
    q[:, 0] += 0.02 * np.arange(6)
    rolling = Motion(m, 30.0, q, "roll")
    assert clear_upper_body(rolling) is rolling


def test_fingers_closed_past_each_other_open_though_their_overlap_does_not_change_with_the_joint():
    # Stretch's two gripper fingers overlap by a depth the distance kernel reports flat (2 cm) once the finger joint
    # is past about -0.15 rad: no step finds a way out, so the finger opens towards its standing value instead
    m = read_morphology("stretch")
    q = np.repeat(np.asarray(prepare(m, fps=30.0).q_stance, dtype=float)[None], 5, axis=0)
    finger = m.joint_q_start[m.joint_index("joint_gripper_finger_left")]
    q[:, finger] = np.linspace(-0.6, -0.2, 5)
    closed = Motion(m, 30.0, q, "pinch")
    assert unrealistic_frame_ratio(closed).self_collision.all()
    out = clear_upper_body(closed)
    assert not unrealistic_frame_ratio(out).self_collision.any()
    others = np.ones(m.coordinate_count, dtype=bool)
    others[finger] = False
    np.testing.assert_allclose(out.q[:, others], closed.q[:, others], atol=1e-9)  # the finger alone moved
    assert (out.q[:, finger] > closed.q[:, finger]).all() and (out.q[:, finger] < 0.05).all()  # opened, not flung
