"""The state codec: Motion → states → Motion round trips, clamping, and the torch twins against NumPy and
finite differences; one heading frame across states and the torch bridge."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from morphkit_testing import creature, every_joint, random_q, shipped_morphology

import morphkit.torch as mt
from morphkit.errors import MotionFormatError
from morphkit.motion import Motion, character_state_from_motion, character_state_layout, human_state_from_motion
from morphkit.motion._fk import compiled_model
from morphkit.motion.codec import character_state_from_q, decode_character_states, human_state_from_q
from morphkit.rotations import quat_canonical, wrap_angle

SHIPPED = ("spot", "crab", "stretch", "human")


def _synth(m, frames=48, seed=0) -> Motion:
    from morphkit.synth import SynthConfig, synthesize

    cfg = replace(SynthConfig(), rollout_seconds=frames / 30.0, batch=1)
    return synthesize(m, frames=frames, seed=seed, config=cfg, progress=False).motions[0]


def _same_motion(a: Motion, b: Motion, atol: float) -> None:
    """Equal coordinates (quaternions up to sign, yaw up to 2π) and equal FK."""
    qa, qb = a.q.copy(), b.q.copy()
    from morphkit.motion.motion import quaternion_slices

    for s in quaternion_slices(a.morphology):
        qa[:, s : s + 4], qb[:, s : s + 4] = quat_canonical(qa[:, s : s + 4]), quat_canonical(qb[:, s : s + 4])
    if a.morphology.base_coordinate_count == 3:
        qb[:, 2] = qa[:, 2] + wrap_angle(qb[:, 2] - qa[:, 2])
    np.testing.assert_allclose(qb, qa, atol=atol)
    np.testing.assert_allclose(b.end_effector_positions(), a.end_effector_positions(), atol=atol)


@pytest.fixture(scope="module")
def synthesized() -> dict[str, Motion]:
    out = {name: _synth(shipped_morphology(name)) for name in SHIPPED}
    out["fixed_arm"] = _synth(every_joint("fixed"))
    return out


@pytest.mark.parametrize("name", [*SHIPPED, "fixed_arm"])
def test_round_trip_on_synthesised_clips(synthesized, name):
    motion = synthesized[name]
    x = character_state_from_motion(motion)
    back, report = decode_character_states(x, motion.morphology, motion.fps, initial_pose=motion.root_pose()[0])
    _same_motion(motion, back, atol=1e-5)
    assert report.max_violation == 0.0 and not report.coordinates
    # Decoding the re-encoded motion changes nothing either.
    np.testing.assert_allclose(character_state_from_motion(back), x, atol=1e-5)


def test_the_path_follows_the_velocity_slots_where_the_step_slots_disagree(synthesized):
    """A model's states need not agree with themselves: the root path is integrated from the velocity slots
    (what Ψ reads), whatever the step slots say. Constant forward speed v and yaw rate w from the origin: every
    step is v/fps long and turns w/fps, so the roots lie on the regular polygon's circle, radius
    (v/fps) / (2 sin(w / 2 fps)), heading w t/fps; the step slots (zero, and a tilt with no turn) are ignored."""
    motion = synthesized["spot"]
    lay = character_state_layout(motion.morphology)
    x = character_state_from_motion(motion)
    fps, v, w = motion.fps, 0.8, 0.6
    x[:, lay.slice("root_orientation")] = [0.0, 0.0, 0.0, 1.0]
    x[:, lay.slice("root_linear_velocity")] = [v, 0.0, 0.0]
    x[:, lay.slice("root_angular_velocity")] = [0.0, 0.0, w]
    x[:, lay.slice("root_displacement")] = 0.0
    x[:, lay.slice("previous_root_orientation")] = [0.0, 0.0, 0.0, 1.0]
    back, _ = decode_character_states(x, motion.morphology, fps)
    root = back.root_pose()
    t = np.arange(len(x))
    from morphkit.rotations import yaw_from_quat

    np.testing.assert_allclose(np.unwrap(yaw_from_quat(root[:, 3:])), w * t / fps, atol=1e-9)
    theta = w / fps  # each chord turns by theta; chord t (from root t-1 to t) points along heading t
    r = (v / fps) / (2.0 * np.sin(theta / 2.0))
    mid, psi = 0.5 * (root[1, :2] + root[2, :2]), 2.0 * theta
    centre = mid + r * np.cos(theta / 2.0) * np.array([-np.sin(psi), np.cos(psi)])
    np.testing.assert_allclose(np.linalg.norm(root[1:, :2] - centre, axis=1), r, rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(np.diff(root[:, :2], axis=0), axis=1)[1:], v / fps, rtol=1e-9)


def test_default_initial_pose_is_the_origin_facing_x(synthesized):
    motion = synthesized["spot"]
    back, _ = decode_character_states(character_state_from_motion(motion), motion.morphology, motion.fps)
    np.testing.assert_allclose(back.root_pose()[0, :2], 0.0, atol=1e-12)
    # The path is the same up to the rigid ground motion that takes frame 0 to the origin.
    d_in = np.linalg.norm(np.diff(motion.root_pose()[:, :2], axis=0), axis=1)
    d_out = np.linalg.norm(np.diff(back.root_pose()[:, :2], axis=0), axis=1)
    np.testing.assert_allclose(d_out, d_in, atol=1e-9)


def test_clamping_is_reported_and_quaternions_renormalised():
    m = creature("spot_like")
    k = compiled_model(m)
    q = random_q(k, 6, seed=1)
    motion = Motion(m, 30.0, q)
    x = character_state_from_motion(motion)
    layout = character_state_layout(m)
    js = layout.slice("joint_q")
    _, upper = m.coordinate_limits
    b = m.base_coordinate_count
    col = next(i for i in range(b, m.coordinate_count) if np.isfinite(upper[i]))
    x[2, js.start + col - b] = upper[col] + 0.25
    x[:, layout.slice("root_orientation")] *= 3.0  # not unit: decoding renormalises
    back, report = decode_character_states(x, m, 30.0, initial_pose=motion.root_pose()[0])
    assert back.q[2, col] == pytest.approx(upper[col])
    assert report.max_violation == pytest.approx(0.25)
    assert report.coordinates == (m.coordinate_names[col],)
    np.testing.assert_allclose(np.linalg.norm(back.q[:, 3:7], axis=1), 1.0)
    with pytest.raises(MotionFormatError, match="expected shape"):
        decode_character_states(x[:, :-1], m, 30.0)


@pytest.mark.skipif(not os.environ.get("MORPHKIT_DATA"), reason="MORPHKIT_DATA not set")
def test_round_trip_on_a_cmu_clip():
    from morphkit.motion import read_bvh_motion

    clips = sorted((Path(os.environ["MORPHKIT_DATA"]) / "human" / "cmu").rglob("*.bvh"))
    motion = read_bvh_motion(clips[0]).slice(0, 120)
    x = character_state_from_motion(motion)
    back, _ = decode_character_states(x, motion.morphology, motion.fps, initial_pose=motion.root_pose()[0])
    _same_motion(motion, back, atol=1e-5)


@pytest.mark.parametrize("name", SHIPPED)
def test_state_end_effectors_equal_the_torch_bridge_in_the_one_heading_frame(name):
    """For random poses, the state's ee block is the bridge's heading-frame ee (≤ 1e-6 m), velocities agree."""
    m = shipped_morphology(name)
    k = compiled_model(m)
    q = random_q(k, 7, seed=3)
    motion = Motion(m, 30.0, q)
    layout = character_state_layout(m)
    x = character_state_from_motion(motion)
    qt = torch.tensor(q)
    ee = mt.end_effector_positions(k, qt, frame="heading", time_series=True).numpy()
    np.testing.assert_allclose(x[:, layout.slice("ee_positions")], ee.reshape(7, -1), atol=1e-6)
    vel = mt.end_effector_velocities(k, qt, dt=1 / 30.0, frame="heading").numpy()
    np.testing.assert_allclose(x[:, layout.slice("ee_velocities")], vel.reshape(7, -1), atol=1e-6)


@pytest.mark.parametrize("name", ["spot", "stretch", "human"])
def test_torch_twins_equal_the_numpy_encoders(name):
    m = shipped_morphology(name)
    k = compiled_model(m)
    q = random_q(k, (2, 5), seed=4)
    xt = character_state_from_q(m, torch.tensor(q), 30.0)
    ht = human_state_from_q(m, torch.tensor(q), 30.0)
    for b in range(2):
        motion = Motion(m, 30.0, q[b])
        np.testing.assert_allclose(xt[b].numpy(), character_state_from_motion(motion), atol=1e-5)
        np.testing.assert_allclose(ht[b].numpy(), human_state_from_motion(motion), atol=1e-5)


def test_torch_twins_gradients_match_finite_differences():
    m = creature("spot_like")
    k = compiled_model(m)
    q = torch.tensor(random_q(k, (1, 3), seed=5), requires_grad=True)
    from morphkit.motion import features

    layout = character_state_layout(m)
    assert torch.autograd.gradcheck(lambda v: features(character_state_from_q(m, v, 30.0), layout, length=0.5),
                                    (q,), atol=1e-5, rtol=1e-4)
    h = creature("human_like")
    kh = compiled_model(h)
    qh = torch.tensor(random_q(kh, (1, 3), seed=6), requires_grad=True)
    assert torch.autograd.gradcheck(lambda v: human_state_from_q(h, v, 30.0), (qh,), atol=1e-5, rtol=1e-4)


@pytest.mark.parametrize("name", ["spot", "crab", "stretch"])
def test_world_end_effectors_equal_the_motions_own_in_frame_0s_ground_frame(synthesized, name):
    """The ground path integrated from the states puts every end-effector where the motion's FK has it
    (world positions re-expressed in frame 0's ground frame), in NumPy and in torch."""
    from morphkit.motion import world_end_effectors
    from morphkit.rotations import quat_from_yaw, quat_rotate_inverse, yaw_from_quat

    motion = synthesized[name]
    x = character_state_from_motion(motion)
    lay = character_state_layout(motion.morphology)
    local = x[:, lay.slice("ee_positions")].reshape(x.shape[0], -1, 3)
    root = motion.root_pose()
    rel = motion.end_effector_positions() - np.array([root[0, 0], root[0, 1], 0.0])
    truth = quat_rotate_inverse(quat_from_yaw(np.full(rel.shape[:2], yaw_from_quat(root[0, 3:]))), rel)
    np.testing.assert_allclose(world_end_effectors(x, lay, local), truth, atol=1e-6)
    got = world_end_effectors(torch.tensor(x[None]), lay, torch.tensor(local[None]))[0].numpy()
    np.testing.assert_allclose(got, truth, atol=1e-6)


@pytest.mark.parametrize("name", ["spot", "crab"])
def test_stance_flags_round_trip_through_the_codec(name):
    """The synthesis' per-foot stance plan rides through encode → decode unchanged, and decoding the
    flagged states gives the same motion as the flag-less ones."""
    from morphkit.motion import foot_names, stance_flags_of
    from morphkit.synth import SynthConfig, synthesize

    m = shipped_morphology(name)
    result = synthesize(m, frames=90, seed=2, config=replace(SynthConfig(), rollout_seconds=3.0, batch=1),
                        progress=False)
    motion, plan = result.motions[0], result.contact[0]
    legs = [leg.end_effector for leg in result.rig.plan.legs]
    flags = plan[:, [legs.index(n) for n in foot_names(m)]].astype(float)
    assert 0.2 < flags.mean() < 1.0  # some steps: the flags are not constant
    lay = character_state_layout(m, contacts=True)
    x = character_state_from_motion(motion, contacts=flags)
    assert x.shape[1] == lay.dim == character_state_layout(m).dim + len(foot_names(m))
    np.testing.assert_array_equal(stance_flags_of(x, lay), flags > 0.5)
    back, _ = decode_character_states(x, m, motion.fps, initial_pose=motion.root_pose()[0], layout=lay)
    plain, _ = decode_character_states(character_state_from_motion(motion), m, motion.fps,
                                       initial_pose=motion.root_pose()[0])
    np.testing.assert_array_equal(back.q, plain.q)
    again = character_state_from_motion(back, contacts=stance_flags_of(x, lay).astype(float))
    np.testing.assert_array_equal(stance_flags_of(again, lay), flags > 0.5)
    with pytest.raises(MotionFormatError, match="stance flags"):
        stance_flags_of(character_state_from_motion(motion), character_state_layout(m))
