"""NKN's motion representation (§4.1, §5 "Data preprocessing"): local pose and global motion.

Frame ``t`` of a motion becomes $x_t = [p_t, v_t]$:

* $p_t \\in \\mathbb{R}^{3L}$: every link origin in the **heading frame** of frame ``t`` (origin on the
  ground under the root, z up, x along the root's facing direction, ``morphkit.conventions``): the
  global displacement and the rotation about the vertical are removed, the root's height is kept;
* $v_t \\in \\mathbb{R}^4$: the global motion, the root's velocity from frame ``t`` to ``t + 1``
  expressed in frame ``t``'s heading frame [m/s] and the yaw rate [rad/s]; the last frame repeats
  the one before (a single frame has zero velocity).

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
"""Size of $v_t$: (v_x, v_y, v_z) [m/s] in the heading frame and the yaw rate [rad/s]."""


def _cat(xs: list[Any], axis: int) -> Any:
    if isinstance(xs[0], np.ndarray):
        return np.concatenate(xs, axis=axis)
    import torch

    return torch.cat(xs, dim=axis)


def _zeros_like(x: Any) -> Any:
    return np.zeros_like(x) if isinstance(x, np.ndarray) else x.new_zeros(x.shape)


def local_positions(P_world: Any, root_pose: Any) -> Any:
    """Points in each frame's heading frame [..., T, L, 3], of ``P_world`` [..., T, L, 3] and roots [..., T, 7]."""
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
    step = (root_pose[..., 1:, :3] - root_pose[..., :-1, :3]) * fps  # [..., T-1, 3]
    heading = quat_from_yaw(yaw[..., :-1])
    lin = quat_rotate_inverse(heading, step)
    rate = wrap_angle(yaw[..., 1:] - yaw[..., :-1]) * fps
    v = _cat([lin, rate[..., None]], -1)  # [..., T-1, 4]
    return _cat([v, v[..., -1:, :]], -2)


def integrate_global_motion(v: np.ndarray, fps: float, *, start_xy: tuple[float, float] = (0.0, 0.0),
                            start_yaw: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The root's ground trajectory of global motion ``v`` [T, 4]: ``(xy [T, 2], yaw [T])``.

    $\\psi_{t+1} = \\psi_t + \\omega_t / f$ and $xy_{t+1} = xy_t + R(\\psi_t)\\,(v_x, v_y)_t / f$, from
    ``start_xy`` and ``start_yaw`` at frame 0 (the inverse of :func:`global_motion` up to the height).
    """
    v = np.asarray(v, dtype=float)
    T = v.shape[0]
    yaw = np.empty(T)
    yaw[0] = start_yaw
    if T > 1:
        yaw[1:] = start_yaw + np.cumsum(v[:-1, 3]) / fps
    step = quat_rotate(quat_from_yaw(yaw[:-1]), np.concatenate([v[:-1, :2], np.zeros((T - 1, 1))], axis=1)) / fps
    xy = np.empty((T, 2))
    xy[0] = start_xy
    if T > 1:
        xy[1:] = np.asarray(start_xy) + np.cumsum(step[:, :2], axis=0)
    return xy, yaw
