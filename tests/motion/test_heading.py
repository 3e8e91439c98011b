"""The root's velocity in its heading frame against closed forms, and its callers agree with it."""

from __future__ import annotations

import numpy as np

from morphkit.motion.heading import heading_velocity
from morphkit.rotations import quat_from_yaw


def _pose(xy: np.ndarray, z: float, yaw: np.ndarray) -> np.ndarray:
    return np.column_stack([xy, np.full(len(yaw), z), quat_from_yaw(yaw)])


def test_a_circle_at_constant_speed_gives_the_chord_in_the_heading_frame() -> None:
    """Root on a circle of radius R, facing along it, dθ a frame: the backward chord 2R sin(dθ/2), seen
    from the heading at frame t, points dθ/2 behind it; the yaw rate is dθ fps every frame. Frame 0 copies
    frame 1's world displacement, seen from its own heading: dθ/2 ahead of it."""
    R, dtheta, fps, T = 1.5, 0.05, 30.0, 200  # 200 frames turn 10 rad: the yaw must be unwrapped
    theta = dtheta * np.arange(T)
    xy = R * np.column_stack([np.sin(theta), 1.0 - np.cos(theta)])  # starts at the origin facing +x, turns left
    v = heading_velocity(_pose(xy, 0.4, theta), fps)
    chord = 2 * R * np.sin(dtheta / 2) * fps
    np.testing.assert_allclose(v.linear[:, 0], chord * np.cos(dtheta / 2), rtol=1e-9)
    np.testing.assert_allclose(v.linear[1:, 1], -chord * np.sin(dtheta / 2), atol=1e-9)
    np.testing.assert_allclose(v.linear[0, 1], chord * np.sin(dtheta / 2), atol=1e-9)
    np.testing.assert_allclose(v.linear[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(v.yaw_rate, dtheta * fps, rtol=1e-9)
    np.testing.assert_allclose(v.yaw, theta, atol=1e-9)


def test_a_sideways_step_of_a_rotated_root_is_its_left_axis() -> None:
    """Facing +y (yaw π/2) and moving toward −x by 1 cm a frame is 0.3 m/s to its left at 30 fps."""
    T = 5
    xy = np.column_stack([-0.01 * np.arange(T), np.zeros(T)])
    v = heading_velocity(_pose(xy, 0.3, np.full(T, np.pi / 2)), 30.0)
    np.testing.assert_allclose(v.linear, np.tile([0.0, 0.3, 0.0], (T, 1)), atol=1e-12)
    np.testing.assert_array_equal(v.yaw_rate, np.zeros(T))


def test_robot_commands_are_the_heading_velocity() -> None:
    from morphkit_testing import shipped_morphology

    from morphkit.motion import Motion
    from morphkit.motion.io_commands import robot_commands

    m = shipped_morphology("spot")
    T = 20
    q = np.tile(m.rest_q(), (T, 1))
    theta = 0.04 * np.arange(T)
    q[:, 0], q[:, 1] = np.cos(theta), 0.5 * np.sin(theta)
    q[:, 3:7] = quat_from_yaw(theta + 0.3)
    motion = Motion(m, 30.0, q)
    columns, rows = robot_commands(motion)
    v = heading_velocity(motion.root_pose(), 30.0)
    np.testing.assert_array_equal(rows[:, columns.index("vx")], v.linear[:, 0])
    np.testing.assert_array_equal(rows[:, columns.index("vy")], v.linear[:, 1])
    np.testing.assert_array_equal(rows[:, columns.index("yaw_rate")], v.yaw_rate)
