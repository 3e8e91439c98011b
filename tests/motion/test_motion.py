"""Motion container: validation, slicing, resampling (slerp), concatenation, FK views; rotation helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _motion_compare import assert_q_close
from morphkit_testing import every_joint, human_like, spot_like

from morphkit.conventions import matrix_from_quat, quat_from_axis_angle, quat_multiply, quat_rotate
from morphkit.errors import MotionFormatError
from morphkit.motion import Motion
from morphkit.motion.motion import quaternion_slices
from morphkit.rotations import (
    axis_angle_from_quat,
    euler_from_quat,
    quat_from_euler,
    quat_slerp,
    yaw_from_quat,
)


# ---- rotation helpers ------------------------------------------------------------------------
@pytest.mark.parametrize("order", ["xyz", "xzy", "yxz", "yzx", "zxy", "zyx"])
def test_euler_round_trip_every_order_including_gimbal_lock(order: str) -> None:
    rng = np.random.default_rng(0)
    a = rng.uniform(-3.0, 3.0, (500, 3))
    a[:, 1] = rng.uniform(-1.5, 1.5, 500)
    np.testing.assert_allclose(euler_from_quat(quat_from_euler(a, order), order), a, atol=1e-12)
    a[:50, 1] = math.pi / 2
    a[50:100, 1] = -math.pi / 2
    a[100:150, 1] = math.pi / 2 - 1e-9
    q = quat_from_euler(a, order)
    back = quat_from_euler(euler_from_quat(q, order), order)
    np.testing.assert_allclose(matrix_from_quat(back), matrix_from_quat(q), atol=1e-12)


def test_quat_from_euler_is_the_intrinsic_product() -> None:
    # R = Rz(a) Rx(b) Ry(c), built independently from axis-angle quaternions.
    a, b, c = 0.3, -0.7, 1.9
    expected = quat_multiply(
        quat_from_axis_angle(np.array([0, 0, 1.0]), a),
        quat_multiply(quat_from_axis_angle(np.array([1.0, 0, 0]), b), quat_from_axis_angle(np.array([0, 1.0, 0]), c)),
    )
    np.testing.assert_allclose(quat_from_euler(np.array([a, b, c]), "zxy"), expected, atol=1e-15)


def test_slerp_constant_angular_velocity_and_shortest_arc() -> None:
    axis = np.array([0.0, 0.6, 0.8])
    q0 = quat_from_axis_angle(axis, 0.2)
    q1 = quat_from_axis_angle(axis, 1.4)
    for t in (0.0, 0.25, 0.5, 1.0):
        np.testing.assert_allclose(quat_slerp(q0, q1, t), quat_from_axis_angle(axis, 0.2 + 1.2 * t), atol=1e-14)
    # The other representative of q1 gives the same (shortest) path.
    np.testing.assert_allclose(quat_slerp(q0, -q1, 0.5), quat_from_axis_angle(axis, 0.8), atol=1e-14)
    np.testing.assert_allclose(axis_angle_from_quat(quat_from_axis_angle(axis, 0.5)), 0.5 * axis, atol=1e-15)
    assert yaw_from_quat(quat_from_axis_angle(np.array([0, 0, 1.0]), 2.0)) == pytest.approx(2.0)


# ---- container ---------------------------------------------------------------------------
def test_motion_validates_shape_values_and_fps() -> None:
    m = spot_like()
    q = np.tile(m.rest_q(), (4, 1))
    with pytest.raises(MotionFormatError, match="shape"):
        Motion(m, 30, q[:, :-1])
    with pytest.raises(MotionFormatError, match="shape"):
        Motion(m, 30, q[:0])
    bad = q.copy()
    bad[2, 5] = np.nan
    with pytest.raises(MotionFormatError, match="frame 2"):
        Motion(m, 30, bad)
    with pytest.raises(MotionFormatError, match="fps"):
        Motion(m, 0, q)
    motion = Motion(m, 30, q, "rest")
    assert motion.frame_count == 4 and motion.duration == pytest.approx(0.1)
    with pytest.raises(ValueError):
        motion.q[0, 0] = 1.0  # stored read-only


def _spinning_motion(fps: float, frames: int):
    """Every coordinate moves at constant velocity: base translation and rotation, joint angles,
    spherical joints turning about fixed axes."""
    m = every_joint("floating")
    t = np.arange(frames) / fps
    q = np.tile(m.rest_q(), (frames, 1))
    q[:, 0:3] = np.array([0.1, -0.2, 0.9]) + np.outer(t, [0.5, 0.3, -0.1])
    base_axis = np.array([0.2, -0.3, 0.9]) / np.linalg.norm([0.2, -0.3, 0.9])
    q[:, 3:7] = quat_from_axis_angle(base_axis, 0.3 + 1.1 * t)
    for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
        width = m.joint_q_start[m.joint_index(j.name) + 1] - start
        if width == 1:
            q[:, start] = 0.05 + 0.4 * t
        elif width == 4:
            q[:, start : start + 4] = quat_from_axis_angle(np.array([0.0, 0.6, 0.8]), -0.2 + 2.0 * t)
    return Motion(m, fps, q, "spin"), t


def test_resampling_keeps_constant_velocity_motion_exact() -> None:
    motion, _ = _spinning_motion(30.0, 61)
    for fps in (120.0, 45.0, 7.0):
        res = motion.resample(fps)
        assert res.fps == fps
        assert res.frame_count == math.floor(2.0 * fps + 1e-6) + 1
        expected, _ = _spinning_motion(fps, res.frame_count)
        assert_q_close(motion.morphology, res.q, expected.q, atol=1e-12)
    assert motion.resample(30.0) is motion


def test_slice_and_concatenate() -> None:
    motion, _ = _spinning_motion(30.0, 31)
    a, b = motion[:10], motion.slice(10, None)
    assert a.frame_count == 10 and b.frame_count == 21
    joined = Motion.concatenate([a, b])
    np.testing.assert_array_equal(joined.q, motion.q)
    half = motion[::2]
    assert half.fps == 15.0 and half.frame_count == 16
    np.testing.assert_array_equal(half.q, motion.q[::2])
    with pytest.raises(MotionFormatError, match="no frame"):
        motion.slice(40, 50)
    with pytest.raises(MotionFormatError, match="fps"):
        Motion.concatenate([a, half])
    other = Motion(human_like(), 30.0, np.tile(human_like().rest_q(), (3, 1)))
    with pytest.raises(MotionFormatError, match="morpholog"):
        Motion.concatenate([a, other])
    with pytest.raises(MotionFormatError, match="empty"):
        Motion.concatenate([])


def test_quaternion_slices_cover_base_and_spherical_joints() -> None:
    m = every_joint("floating")
    starts = quaternion_slices(m)
    assert starts[0] == 3
    names = m.coordinate_names
    assert all(names[s].endswith("qx") for s in starts)
    assert len(starts) == 1 + sum(1 for n in names if n.endswith(".qx"))


def test_world_positions_come_from_the_kernels() -> None:
    # A fixed-base check against hand-computed positions: the base translated, links at rest offsets.
    m = spot_like()
    q = np.tile(m.rest_q(), (2, 1))
    q[1, 0:3] = [1.0, 2.0, 0.5]
    motion = Motion(m, 30.0, q)
    lp = motion.link_positions()
    rest = m.rest_link_poses()[:, :3]
    np.testing.assert_allclose(lp[0], rest, atol=1e-12)
    np.testing.assert_allclose(lp[1], rest + np.array([1.0, 2.0, 0.5]), atol=1e-12)
    ee = motion.end_effector_positions()
    assert ee.shape == (2, len(m.end_effectors), 3)
    fl = [e.name for e in m.end_effectors].index("fl_foot")
    T_lleg = m.rest_link_poses()[m.link_index("fl_lleg")]
    np.testing.assert_allclose(ee[0, fl], T_lleg[:3] + quat_rotate(T_lleg[3:], np.array([0, 0, -0.3365])), atol=1e-12)
