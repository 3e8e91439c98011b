"""Conventions, declared once.

Glossary (used in names across morphkit):

- ``p``: position, shape [..., 3], [m].
- ``q`` / ``quat``: unit quaternion in **xyzw** order (Warp's order), shape [..., 4].
- ``T_a_b``: pose of frame ``b`` expressed in frame ``a`` as ``[px, py, pz, qx, qy, qz, qw]``,
  shape [..., 7]; batches are ``Ts_a_b``.
- ``rpy``: roll, pitch, yaw [rad] about fixed x, y, z (URDF's convention): ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
- World frame: z up, x is the creature's forward direction, units metres and radians.

**The heading frame** (:data:`HEADING_FRAME`) of a pose of the root link ``T_world_root`` is
``T_world_heading``: origin **at the root** (its full 3-D position, not on the ground), z along
world up, x along the root's facing direction (its +x axis) projected on the ground plane; where
that projection vanishes, the world x axis (ACE, Li et al. 2023, §6.1). It is the local frame of
the ACE states and Ψ, of ``frame="heading"`` in the kernels and the torch bridge, and of
:func:`morphkit.rotations.heading_frame`. "In the heading frame" means: expressed in its axes,
positions also relative to its origin; velocities are world velocities expressed in its axes
(not differentiated in the moving frame).

**Velocities of a motion** (:data:`VELOCITY_DIFFERENCE`) are backward differences,
``v_t = (p_t - p_{t-1}) fps``, with frame 0 copying frame 1 (zeros for a one-frame motion);
angular velocity is the rotation vector of ``q_t q_{t-1}⁻¹`` times ``fps``.

Any function that changes the quaternion order says so in its name (``quat_wxyz_to_xyzw``). The
quaternion and transform helpers themselves live in :mod:`morphkit.rotations` (NumPy and torch)
and are re-exported here under their usual names.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from morphkit.rotations import (
    matrix_from_quat,
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_from_rpy,
    quat_multiply,
    quat_rotate,
    quat_wxyz_to_xyzw,
    quat_xyzw_to_wxyz,
    rpy_from_quat,
    transform_multiply,
)

__all__ = [
    "FORWARD_AXIS",
    "HEADING_FRAME",
    "QUAT_ORDER",
    "TRANSFORM_LAYOUT",
    "UP_AXIS",
    "VELOCITY_DIFFERENCE",
    "backward_difference",
    "matrix_from_quat",
    "quat_conjugate",
    "quat_from_axis_angle",
    "quat_from_matrix",
    "quat_from_rpy",
    "quat_multiply",
    "quat_rotate",
    "quat_wxyz_to_xyzw",
    "quat_xyzw_to_wxyz",
    "rpy_from_quat",
    "transform_multiply",
]

QUAT_ORDER = "xyzw"
TRANSFORM_LAYOUT = ("px", "py", "pz", "qx", "qy", "qz", "qw")
UP_AXIS = np.array([0.0, 0.0, 1.0])
FORWARD_AXIS = np.array([1.0, 0.0, 0.0])
HEADING_FRAME = "origin at the root, z up, x along the root's facing direction projected on the ground"
"""The one heading frame (see the module docstring)."""
VELOCITY_DIFFERENCE = "backward"
"""``v_t = (p_t - p_{t-1}) fps``, frame 0 copying frame 1 (see the module docstring)."""


def backward_difference(x: Any, axis: int = 0, *, causal: bool = False) -> Any:
    """:data:`VELOCITY_DIFFERENCE` along ``axis``: ``x[t] - x[t-1]``, same shape as ``x`` (NumPy or torch).

    Frame 0 copies frame 1 (zeros for a single frame); multiply by ``fps`` for a velocity. ``causal=True``
    gives frame 0 a zero difference instead, for rules that may not look ahead (frame t from frames 0..t).
    """
    axis = axis % x.ndim
    head = (slice(None),) * axis
    if x.shape[axis] < 2:
        return x * 0.0
    d = x[(*head, slice(1, None))] - x[(*head, slice(None, -1))]
    first = d[(*head, slice(0, 1))] * (0.0 if causal else 1.0)
    if type(x).__module__.split(".", 1)[0] == "torch":
        import torch

        return torch.cat([first, d], dim=axis)
    return np.concatenate([first, d], axis=axis)
