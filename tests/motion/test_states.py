"""ACE states (§6.1–6.2) on analytic trajectories; layouts follow the morphology; normalisation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import TEST_CREATURES, human_like, random_q, wheeled

from morphkit.conventions import quat_from_axis_angle, quat_multiply, quat_rotate
from morphkit.errors import MotionFormatError
from morphkit.motion import (
    Motion,
    NormStats,
    character_state,
    character_state_from_motion,
    character_state_layout,
    human_state,
    human_state_from_motion,
    human_state_layout,
)
from morphkit.motion._fk import compiled_model
from morphkit.rotations import quat_from_yaw, yaw_from_quat

Z = np.array([0.0, 0.0, 1.0])
Y = np.array([0.0, 1.0, 0.0])


def _root(frames: int, fps: float, yaw0: float, yaw_rate: float, vel: np.ndarray, tilt: float) -> np.ndarray:
    """Root poses: straight-line motion at world velocity ``vel``, yawing at ``yaw_rate``, pitched by ``tilt``."""
    t = np.arange(frames) / fps
    pose = np.zeros((frames, 7))
    pose[:, :3] = np.array([0.3, -0.4, 0.9]) + np.outer(t, vel)
    pose[:, 3:] = quat_multiply(quat_from_yaw(yaw0 + yaw_rate * t), quat_from_axis_angle(Y, tilt))
    return pose


def test_human_state_root_terms_are_analytic() -> None:
    fps, frames = 30.0, 8
    vel = np.array([0.8, 0.5, 0.1])
    root = _root(frames, fps, yaw0=0.7, yaw_rate=0.0, vel=vel, tilt=0.2)
    # One link 0.4 m in front of the root along its heading, one end-effector 1 m below it.
    heading = quat_from_yaw(np.full(frames, 0.7))
    links = np.stack([root[:, :3], root[:, :3] + quat_rotate(heading, np.array([0.4, 0.0, 0.0]))], axis=1)
    ee = (root[:, :3] + np.array([0.0, 0.0, -1.0]))[:, None, :]
    x = human_state(root, links, ee, fps)
    assert x.shape == (frames, 1 + 4 + 6 + 3 + 6)
    np.testing.assert_allclose(x[:, 0], root[:, 2])
    np.testing.assert_allclose(x[:, 1:5], np.tile(quat_from_axis_angle(Y, 0.2), (frames, 1)), atol=1e-15)
    local_vel = quat_rotate(quat_from_yaw(-0.7), vel)
    np.testing.assert_allclose(x[:, 5:8], np.tile(local_vel, (frames, 1)), atol=1e-12)
    np.testing.assert_allclose(x[:, 8:11], 0.0, atol=1e-12)
    np.testing.assert_allclose(x[:, 11:14], np.tile([0.4, 0.0, 0.0], (frames, 1)), atol=1e-12)
    np.testing.assert_allclose(x[:, 14:17], np.tile([0.0, 0.0, -1.0], (frames, 1)), atol=1e-12)
    np.testing.assert_allclose(x[:, 17:20], np.tile(local_vel, (frames, 1)), atol=1e-12)


def test_angular_velocity_and_previous_orientation() -> None:
    fps, frames, rate = 60.0, 5, 1.3
    root = _root(frames, fps, yaw0=-2.0, yaw_rate=rate, vel=np.zeros(3), tilt=-0.3)
    m = wheeled()  # any morphology: only its layout matters here
    layout = character_state_layout(m)
    jq = np.zeros((frames, m.coordinate_count - m.base_coordinate_count))
    ee = np.zeros((frames, len(m.end_effectors), 3))
    x = character_state(root, jq, ee, fps)
    assert x.shape == (frames, layout.dim)
    w = x[:, layout.slice("root_angular_velocity")]
    np.testing.assert_allclose(w, np.tile([0.0, 0.0, rate], (frames, 1)), atol=1e-9)
    prev = x[:, layout.slice("previous_root_orientation")]
    expected = quat_multiply(quat_from_yaw(-rate / fps), quat_from_axis_angle(Y, -0.3))
    np.testing.assert_allclose(prev, np.tile(expected, (frames, 1)), atol=1e-12)
    np.testing.assert_allclose(x[:, layout.slice("root_displacement")], 0.0, atol=1e-15)


def test_character_states_integrate_back_to_the_trajectory() -> None:
    """Yaw changes (previous orientation) and steps (displacement) rebuild the world path."""
    rng = np.random.default_rng(4)
    frames, fps = 40, 30.0
    yaw = np.cumsum(rng.normal(0.0, 0.1, frames))
    xy = np.cumsum(rng.normal(0.0, 0.05, (frames, 2)), axis=0)
    root = np.zeros((frames, 7))
    root[:, :2] = xy
    root[:, 2] = 0.5
    root[:, 3:] = quat_multiply(quat_from_yaw(yaw), quat_from_axis_angle(np.array([1.0, 0, 0]), 0.1))
    m = wheeled()
    layout = character_state_layout(m)
    x = character_state(root, np.zeros((frames, 2)), np.zeros((frames, 2, 3)), fps)
    prev = x[:, layout.slice("previous_root_orientation")]
    step = x[:, layout.slice("root_displacement")]
    rec_yaw, rec_xy = [yaw[0]], [xy[0]]
    for t in range(1, frames):
        rec_yaw.append(rec_yaw[-1] - yaw_from_quat(prev[t]))
        c, s = math.cos(rec_yaw[-1]), math.sin(rec_yaw[-1])
        rec_xy.append(rec_xy[-1] + np.array([c * step[t, 0] - s * step[t, 1], s * step[t, 0] + c * step[t, 1]]))
    np.testing.assert_allclose(np.unwrap(rec_yaw), np.unwrap(yaw), atol=1e-9)
    np.testing.assert_allclose(np.array(rec_xy), xy, atol=1e-9)


def test_layout_dimensions_follow_the_morphology() -> None:
    m = human_like()
    e = len(m.end_effectors)
    h = human_state_layout(m)
    assert h.dim == 1 + 4 + 6 + 3 * (m.link_count - 1) + 6 * e
    assert h.names()[0] == "root_height" and h.ee_names == tuple(x.name for x in m.end_effectors)
    r = character_state_layout(m)
    assert r.dim == 1 + 4 + 2 + 4 + 6 + (m.coordinate_count - 7) + 6 * e
    with pytest.raises(KeyError, match="fields"):
        r.slice("nope")
    motion = Motion(m, 30.0, random_q(compiled_model(m), 6, seed=2))
    xh = human_state_from_motion(motion)
    xr = character_state_from_motion(motion)
    assert xh.shape == (6, h.dim) and xr.shape == (6, r.dim)
    # Shared fields agree between the two states.
    for name in ("root_height", "root_orientation", "root_linear_velocity", "ee_positions", "ee_velocities"):
        np.testing.assert_allclose(xh[:, h.slice(name)], xr[:, r.slice(name)], atol=1e-12)
    # Spherical quaternions are put in the w >= 0 half.
    jq = xr[:, r.slice("joint_q")]
    for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
        assert (jq[:, start - 7 + 3] >= 0).all(), j.name
    with pytest.raises(MotionFormatError, match="frames"):
        human_state(motion.root_pose(), motion.link_positions()[:3], motion.end_effector_positions(), 30.0)


def test_norm_stats_floor_a_barely_moving_dimension_at_a_share_of_its_fields_rms() -> None:
    """Field ``a`` (dims 0-1): dim 1 barely moves; its std becomes 0.1 x RMS of the field's values (computed by
    hand); dim 0 (std above the floor) and field ``b`` (dim 2) keep the data's own std; without the floor all do."""
    from morphkit.motion.states import StateLayout

    rng = np.random.default_rng(1)
    x = np.stack([rng.normal(0.0, 2.0, 400), 0.5 + 1e-4 * rng.normal(size=400), rng.normal(3.0, 1e-3, 400)], axis=1)
    layout = StateLayout("human", (("a", 0, 2), ("b", 2, 3)), ())
    floored = NormStats.fit(x, layout=layout, field_floor=0.1)
    plain = NormStats.fit(x)
    np.testing.assert_allclose(plain.std, x.std(0))
    rms_a = math.sqrt(float(np.mean(x[:, :2] ** 2)))
    np.testing.assert_allclose(floored.std, [x[:, 0].std(), 0.1 * rms_a, max(x[:, 2].std(), 0.1 * 3.0)], rtol=1e-3)
    np.testing.assert_array_equal(floored.mean, plain.mean)


def test_norm_stats_round_trip_numpy_torch_and_file(tmp_path: Path) -> None:
    import torch

    rng = np.random.default_rng(0)
    data = [rng.normal(2.0, 3.0, (50, 4)), rng.normal(2.0, 3.0, (30, 4))]
    data[0][:, 2] = data[1][:, 2] = 1.5  # a constant dimension
    stats = NormStats.fit(data)
    allx = np.concatenate(data)
    np.testing.assert_allclose(stats.mean, allx.mean(0))
    assert stats.std[2] == 1.0
    n = stats.normalize(allx)
    np.testing.assert_allclose(n[:, [0, 1, 3]].std(0), 1.0, atol=1e-12)
    np.testing.assert_allclose(stats.denormalize(n), allx, atol=1e-12)
    t = torch.tensor(allx, dtype=torch.float32)
    np.testing.assert_allclose(stats.normalize(t).numpy(), n, atol=1e-5)
    path = tmp_path / "stats.npz"
    stats.save(path)
    back = NormStats.load(path)
    np.testing.assert_array_equal(back.mean, stats.mean)
    np.testing.assert_array_equal(back.std, stats.std)
    np.savez(tmp_path / "bad.npz", mean=np.zeros(3))
    with pytest.raises(MotionFormatError):
        NormStats.load(tmp_path / "bad.npz")


@pytest.mark.parametrize("name", ["every_joint_planar", "every_joint_fixed", "planar_arm"])
def test_states_for_other_bases(name: str) -> None:
    m = TEST_CREATURES[name]()
    motion = Motion(m, 20.0, random_q(compiled_model(m), 5, seed=5))
    x = character_state_from_motion(motion)
    assert x.shape == (5, character_state_layout(m).dim)
    assert np.isfinite(x).all()


@pytest.mark.parametrize("name", ["spot", "stretch"])
def test_derived_slots_are_the_encoders_from_the_states_own_root_and_joints(name: str) -> None:
    """Velocity and end-effector slots scrambled, then derived from the root step, height, orientations,
    joints, FK and the previous state: the encoder's own numbers (to rounding)."""
    from morphkit_testing import shipped_morphology

    from morphkit.motion import derive_character_state
    from morphkit.synth import synthesize

    m = shipped_morphology(name)
    motion = synthesize(m, frames=60, seed=3, progress=False).motions[0]
    lay = character_state_layout(m)
    x = character_state_from_motion(motion)
    rng = np.random.default_rng(0)
    scrambled = x.copy()
    for field in ("root_linear_velocity", "root_angular_velocity", "ee_velocities"):
        scrambled[:, lay.slice(field)] = rng.normal(size=scrambled[:, lay.slice(field)].shape)
    ro = lay.slice("root_orientation")
    scrambled[:, ro] *= 1.7  # not unit: derived slots make it unit again
    ee = x[:, lay.slice("ee_positions")].reshape(len(x), -1, 3)
    got = derive_character_state(x[:-1], scrambled[1:], ee[1:], motion.fps, lay)
    np.testing.assert_allclose(got, x[1:], atol=1e-9)


def test_foot_contact_flags_from_height_and_speed() -> None:
    """A standing human has both feet in stance; gliding at 1 m/s (above the stance speed) or lifted 10 cm
    (above the stance height) it has none; flags follow the morphology's foot end-effectors."""
    from morphkit_testing import shipped_morphology

    from morphkit.contact_rules import STANCE_FLAGS
    from morphkit.motion import foot_contact_flags, foot_names

    STANCE_HEIGHT, STANCE_SPEED = STANCE_FLAGS.height, STANCE_FLAGS.speed

    m = shipped_morphology("human")
    assert len(foot_names(m)) == 2
    q = np.tile(m.rest_q(), (30, 1))
    q[:, 2] += 0.02 - Motion(m, 30.0, q[:1]).end_effector_positions()[0, :, 2].min()  # toes 2 cm up
    standing = foot_contact_flags(Motion(m, 30.0, q))
    assert standing.shape == (30, 2) and standing.all()
    glide = q.copy()
    glide[:, 0] += np.arange(30) * 1.0 / 30.0
    assert 1.0 > STANCE_SPEED and not foot_contact_flags(Motion(m, 30.0, glide)).any()
    lifted = q.copy()
    lifted[15:, 2] += 2 * STANCE_HEIGHT  # the second half up: the clip's 5th percentile stays the ground
    flags = foot_contact_flags(Motion(m, 30.0, lifted))
    assert flags[:15].all() and not flags[15:].any()
