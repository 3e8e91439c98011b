"""NKN's motion representation (§4.1, §5 "Data preprocessing"): local pose and global motion.

Frame ``t`` of a motion becomes $x_t = [p_t, v_t]$:

* $p_t \\in \\mathbb{R}^{3L}$: every link origin in the **ground frame** of frame ``t``: the heading frame
  (:data:`morphkit.conventions.HEADING_FRAME`: z up, x along the root's facing direction) moved down to
  the ground under the root, so the global displacement and the rotation about the vertical are
  removed and the root's height is kept (as the release);
* $v_t \\in \\mathbb{R}^4$: the global motion, the root's velocity expressed in frame ``t``'s heading axes
  [m/s] and the yaw rate [rad/s], backward differences as every velocity in morphkit
  (:data:`morphkit.conventions.VELOCITY_DIFFERENCE`: $v_t$ from frames ``t − 1`` and ``t``, frame 0 copying
  frame 1, zeros for a single frame).

:func:`integrate_global_motion` inverts the second part: from a start position and heading it
integrates $v$ back into the root's ground trajectory. Every function takes NumPy arrays or torch
tensors (through :mod:`morphkit.rotations`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from morphkit.rotations import quat_from_yaw, quat_rotate, quat_rotate_inverse, wrap_angle, yaw_from_quat

__all__ = ["GLOBAL_DIM", "global_motion", "integrate_global_motion", "local_positions"]

GLOBAL_DIM = 4
"""Size of $v_t$: (v_x, v_y, v_z) [m/s] in the heading axes and the yaw rate [rad/s]."""


def _cat(xs: list[Any], axis: int) -> Any:
    if isinstance(xs[0], np.ndarray):
        return np.concatenate(xs, axis=axis)
    import torch

    return torch.cat(xs, dim=axis)


def _zeros_like(x: Any) -> Any:
    return np.zeros_like(x) if isinstance(x, np.ndarray) else x.new_zeros(x.shape)


def local_positions(P_world: Any, root_pose: Any) -> Any:
    """Points in each frame's ground frame [..., T, L, 3], of ``P_world`` [..., T, L, 3] and roots [..., T, 7]."""
    yaw = yaw_from_quat(root_pose[..., 3:])  # [..., T]
    origin = _cat([root_pose[..., :2], _zeros_like(root_pose[..., 2:3])], -1)  # [..., T, 3]
    heading = quat_from_yaw(yaw)[..., None, :]  # [..., T, 1, 4]
    rel = P_world - origin[..., None, :]
    return quat_rotate_inverse(_broadcast(heading, rel), rel)


def _broadcast(q: Any, v: Any) -> Any:
    shape = (*v.shape[:-1], 4)
    return np.broadcast_to(q, shape) if isinstance(q, np.ndarray) else q.expand(shape)


def global_motion(root_pose: Any, fps: float) -> Any:
    """$v_t$ [..., T, 4] of root poses ``T_world_root`` [..., T, 7] sampled at ``fps``."""
    T = root_pose.shape[-2]
    if T < 2:
        return _zeros_like(root_pose[..., :GLOBAL_DIM])
    yaw = yaw_from_quat(root_pose[..., 3:])  # [..., T]
    step = (root_pose[..., 1:, :3] - root_pose[..., :-1, :3]) * fps  # [..., T-1, 3]: frames 1..T-1
    lin = quat_rotate_inverse(quat_from_yaw(yaw[..., 1:]), step)
    rate = wrap_angle(yaw[..., 1:] - yaw[..., :-1]) * fps
    v = _cat([lin, rate[..., None]], -1)  # [..., T-1, 4]
    return _cat([v[..., :1, :], v], -2)


def integrate_global_motion(v: np.ndarray, fps: float, *, start_xy: tuple[float, float] = (0.0, 0.0),
                            start_yaw: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The root's ground trajectory of global motion ``v`` [T, 4]: ``(xy [T, 2], yaw [T])``.

    $\\psi_t = \\psi_{t-1} + \\omega_t / f$ and $xy_t = xy_{t-1} + R(\\psi_t)\\,(v_x, v_y)_t / f$, from
    ``start_xy`` and ``start_yaw`` at frame 0 (the inverse of :func:`global_motion` up to the height;
    ``v_0`` is not used).
    """
    v = np.asarray(v, dtype=float)
    T = v.shape[0]
    yaw = np.empty(T)
    yaw[0] = start_yaw
    if T > 1:
        yaw[1:] = start_yaw + np.cumsum(v[1:, 3]) / fps
    step = quat_rotate(quat_from_yaw(yaw[1:]), np.concatenate([v[1:, :2], np.zeros((T - 1, 1))], axis=1)) / fps
    xy = np.empty((T, 2))
    xy[0] = start_xy
    if T > 1:
        xy[1:] = np.asarray(start_xy) + np.cumsum(step[:, :2], axis=0)
    return xy, yaw
