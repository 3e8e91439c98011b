"""Contact-aware export by locking: stance feet held at their touchdown points, the retargeter's own steps kept."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from morphkit_testing import spot_like, wheeled

from morphkit.contact_export import CONTACT_MODES, apply_contacts, lock_feet, stance_flags
from morphkit.contact_rules import LOCK
from morphkit.io import read_morphology
from morphkit.metrics import foot_contact_figures, skating_ratio
from morphkit.motion import Motion
from morphkit.synth import SynthConfig, prepare, synthesize


def _legs(m) -> tuple[list[int], np.ndarray]:
    """Foot end-effector columns and the coordinates the legs own, from the synthesis' body plan."""
    plan = prepare(m, fps=30.0).plan
    names = [leg.end_effector for leg in plan.legs]
    coords = np.zeros(m.coordinate_count, dtype=bool)
    coords[[c for leg in plan.legs for c in leg.coordinates]] = True
    return [i for i, e in enumerate(m.end_effectors) if e.name in names], coords


def _sliding_stance(m, frames: int = 12) -> Motion:
    """The stance pose with the body carried 1 cm per frame and the legs frozen: every foot drags along."""
    q = np.repeat(np.asarray(prepare(m, fps=30.0).q_stance, dtype=float)[None], frames, axis=0)
    q[:, 0] += 0.01 * np.arange(frames)
    return Motion(m, 30.0, q, "drag")


@pytest.mark.parametrize("name", ["spot", "crab", "human"])
def test_a_dragged_stance_foot_is_held_while_root_and_other_joints_stay(name):
    m = read_morphology(name)
    cols, legs = _legs(m)
    raw = _sliding_stance(m)
    out = lock_feet(raw)
    before, after = raw.end_effector_positions()[:, cols], out.end_effector_positions()[:, cols]
    assert np.linalg.norm(before[-1, :, :2] - before[0, :, :2], axis=-1).min() > 0.1  # the case is a real one
    steps = np.linalg.norm(np.diff(after[..., :2], axis=0), axis=-1)
    assert steps.max() <= 2e-3
    np.testing.assert_array_equal(out.q[:, ~legs], raw.q[:, ~legs])  # root and non-leg joints, bit for bit
    assert not np.array_equal(out.q[:, legs], raw.q[:, legs])


def test_lock_is_causal_frame_t_does_not_depend_on_later_frames():
    m = spot_like()
    walk = synthesize(m, frames=90, seed=3, config=replace(SynthConfig(), rollout_seconds=3.0, batch=1),
                      progress=False).motions[0]
    q = walk.q.copy()
    _, legs = _legs(m)
    q[:, legs] = q[0, legs]  # the legs hold one pose while the body moves: feet drag, touch down, lift
    noisy = walk.replace(q=q)
    full = lock_feet(noisy)
    for t in (1, 17, 45):
        np.testing.assert_array_equal(lock_feet(noisy.slice(0, t)).q, full.q[:t])


def test_lock_removes_most_sliding_of_a_dragging_walk_and_keeps_feet_above_the_ground():
    m = spot_like()
    walk = synthesize(m, frames=150, seed=0, config=replace(SynthConfig(), rollout_seconds=5.0, batch=1),
                      progress=False).motions[0]
    _, legs = _legs(m)
    q = walk.q.copy()
    q[:, legs] = q[0, legs]
    noisy = walk.replace(q=q)
    out = lock_feet(noisy)
    before, after = foot_contact_figures(noisy), foot_contact_figures(out)
    assert before.sliding_rate > 0.05  # the case is a real one
    assert after.sliding_rate < 0.25 * before.sliding_rate
    assert skating_ratio(out) <= skating_ratio(noisy)
    assert after.penetration_rate == 0.0
    assert out.link_positions()[..., 2].min() >= -1e-9


def test_stance_flags_follow_height_and_speed_thresholds():
    fps = 30.0
    t = np.arange(6)
    feet = np.zeros((6, 3, 3))
    feet[:, 1, 2] = 0.08  # hovering 8 cm up: swing
    feet[:, 2, 0] = 0.04 * t  # 1.2 m/s along the ground: swing from frame 1 on
    flags = stance_flags(feet, np.zeros(3), fps, rule=replace(LOCK, height=0.05, speed=0.5))
    assert flags[:, 0].all() and not flags[:, 1].any()
    assert flags[0, 2] and not flags[1:, 2].any()


def test_lock_is_a_contact_mode_and_leaves_creatures_without_legs_alone():
    assert "lock" in CONTACT_MODES
    rover = wheeled()
    q = np.zeros((20, rover.coordinate_count))
    q[:, 0] = np.linspace(0, 0.1, 20)  # 0.16 m/s: within the rover's top speed, so the drive leaves it as it is
    motion = Motion(rover, 30.0, q, "drive")
    assert apply_contacts(motion, "lock") is motion
    m = read_morphology("spot")
    raw = _sliding_stance(m, frames=6)
    np.testing.assert_array_equal(apply_contacts(raw, "lock").q, lock_feet(raw).q)


def test_lock_holds_the_retargeters_own_stance_flags_when_given():
    """The dragged feet are held when the flags say stance; flagged in swing they follow their own path
    (1 cm per frame), although height and speed alone would have held them; flags in foot_names order."""
    from morphkit.motion import foot_names

    m = read_morphology("spot")
    cols, _ = _legs(m)
    raw = _sliding_stance(m)
    F = len(foot_names(m))
    step = {}
    for label, flags in (("stance", np.ones((raw.frame_count, F))), ("swing", np.zeros((raw.frame_count, F))),
                         ("detected", None)):
        feet = apply_contacts(raw, "lock", stance=flags).end_effector_positions()[:, cols]
        step[label] = np.linalg.norm(np.diff(feet[..., :2], axis=0), axis=-1)
    assert step["stance"].max() <= 2e-3 and step["detected"].max() <= 2e-3
    np.testing.assert_allclose(step["swing"][3:], 0.01, atol=1e-3)  # after the blend, each foot moves with the body
    one = np.ones((raw.frame_count, F))
    one[:, 0] = 0.0  # only the first foot in swing: that one slides, the others stay
    feet = apply_contacts(raw, "lock", stance=one).end_effector_positions()[:, cols]
    moved = np.linalg.norm(feet[-1, :, :2] - feet[0, :, :2], axis=-1)
    names = [m.end_effectors[c].name for c in cols]
    assert moved[names.index(foot_names(m)[0])] > 0.08 and np.delete(moved, names.index(foot_names(m)[0])).max() < 0.01
