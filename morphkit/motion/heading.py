"""The root's velocity in its heading frame: the one computation behind robot commands, synthesis reports and
the contact-aware re-planning.

Velocities are :data:`~morphkit.conventions.VELOCITY_DIFFERENCE` backward differences (frame 0 copies frame 1),
expressed in the axes of the heading frame (:data:`~morphkit.conventions.HEADING_FRAME`) of the frame they
end at; the yaw rate is the backward difference of the unwrapped heading angle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morphkit.conventions import backward_difference
from morphkit.rotations import quat_conjugate, quat_from_yaw, quat_rotate, yaw_from_quat

__all__ = ["HeadingVelocity", "heading_velocity"]


@dataclass(frozen=True)
class HeadingVelocity:
    """A root path's velocity in its heading frame, per frame."""

    linear: np.ndarray
    """[T, 3] world velocity in the heading frame's axes (forward, left, up) [m/s]."""
    yaw_rate: np.ndarray
    """[T] heading angle's rate [rad/s], positive counter-clockwise seen from above."""
    yaw: np.ndarray
    """[T] heading angle, unwrapped [rad]."""


def heading_velocity(root_pose: np.ndarray, fps: float) -> HeadingVelocity:
    """The velocity of root poses ``T_world_root`` [T, 7] sampled at ``fps`` [1/s] in their heading frames."""
    pose = np.asarray(root_pose, dtype=float)
    yaw = np.unwrap(yaw_from_quat(pose[:, 3:]))
    linear = quat_rotate(quat_conjugate(quat_from_yaw(yaw)), backward_difference(pose[:, :3], 0)) * fps
    return HeadingVelocity(linear, backward_difference(yaw, 0) * fps, yaw)
