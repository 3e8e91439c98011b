"""Vectorised rotation helpers the motion layer needs beyond :mod:`morphkit.conventions`.

Quaternions are xyzw (see :mod:`morphkit.conventions`); every function broadcasts over leading
axes and is NumPy-only.
"""

from __future__ import annotations

import numpy as np

from morphkit.conventions import matrix_from_quat, quat_conjugate, quat_from_axis_angle, quat_multiply, quat_rotate

__all__ = [
    "axis_angle_from_quat",
    "euler_from_quat",
    "quat_canonical",
    "quat_from_euler",
    "quat_from_yaw",
    "quat_normalize",
    "quat_slerp",
    "yaw_from_quat",
]

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternions [..., 4]; a zero quaternion becomes the identity."""
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    ident = np.zeros_like(q)
    ident[..., 3] = 1.0
    return np.where(n > 1e-12, q / np.where(n > 1e-12, n, 1.0), ident)


def quat_canonical(q: np.ndarray) -> np.ndarray:
    """The representative with ``w >= 0`` of each quaternion's double cover, shape [..., 4]."""
    q = np.asarray(q, dtype=float)
    return np.where(q[..., 3:4] < 0, -q, q)


def quat_from_euler(angles: np.ndarray, order: str) -> np.ndarray:
    """xyzw quaternions of intrinsic Euler rotations, BVH style.

    ``order`` names the axes in the order the angles are given (e.g. ``"zyx"`` for a BVH joint
    with ``Zrotation Yrotation Xrotation`` channels); the rotation is ``R = R_order[0](a0)
    R_order[1](a1) R_order[2](a2)``, which is how BVH composes its channels.

    Args:
        angles: [..., len(order)] angles [rad].
        order: Axis letters from ``"xyz"`` (one to three of them, repeats allowed).

    Returns:
        [..., 4] unit quaternions.
    """
    angles = np.asarray(angles, dtype=float)
    q = np.zeros((*angles.shape[:-1], 4))
    q[..., 3] = 1.0
    for k, axis in enumerate(order.lower()):
        q = quat_multiply(q, quat_from_axis_angle(_AXES[axis], angles[..., k]))
    return q


def euler_from_quat(q: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles [..., 3] [rad] of xyzw quaternions, inverse of :func:`quat_from_euler`.

    ``order`` is a permutation of ``"xyz"``. The middle angle lies in [-π/2, π/2]. The last two
    angles come from one row of the matrix and the first from what remains, so the angles
    recompose to the input rotation to machine precision even at gimbal lock.
    """
    order = order.lower()
    if sorted(order) != ["x", "y", "z"]:
        raise ValueError(f"Euler order must be a permutation of 'xyz', got {order!r}")
    i, j, k = ("xyz".index(a) for a in order)
    m = matrix_from_quat(q)
    # Parity of the permutation decides the signs: R = Ri Rj Rk gives R[i, k] = ±sin(b).
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    # Row i of Ri(a) Rj(b) Rk(c) does not depend on a.
    b = np.arctan2(sign * m[..., i, k], np.hypot(m[..., i, i], m[..., i, j]))
    c = np.arctan2(-sign * m[..., i, j], m[..., i, i])
    rest = m @ np.swapaxes(matrix_from_quat(quat_from_euler(np.stack([b, c], axis=-1), order[1:])), -1, -2)
    a = np.arctan2(sign * rest[..., k, j], rest[..., j, j])
    return np.stack([a, b, c], axis=-1)


def quat_slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Spherical linear interpolation between unit quaternions (shortest arc).

    Args:
        q0, q1: [..., 4] unit quaternions.
        t: Interpolation parameter in [0, 1], broadcast against ``q0[..., 0]``.
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0, -q1, q1)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    s = np.sin(theta)
    # Near-parallel quaternions: the linear blend is exact to first order and avoids 0/0.
    small = s < 1e-8
    safe = np.where(small, 1.0, s)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


def axis_angle_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vectors [..., 3] (axis × angle [rad], angle in [0, π]) of xyzw quaternions."""
    q = quat_canonical(q)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., 3:4])
    # angle / sin(angle / 2) → 2 as the angle → 0.
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * scale


def yaw_from_quat(q: np.ndarray, forward: np.ndarray | None = None) -> np.ndarray:
    """Heading angle [rad] of a frame: the yaw of its ``forward`` axis projected on the ground.

    Args:
        q: [..., 4] xyzw orientations of the frame in the world.
        forward: The frame's forward axis in its own coordinates (default +x, morphkit's forward).

    Returns:
        [...] yaw about world z; 0 where the forward axis points straight up or down.
    """
    fwd = np.array([1.0, 0.0, 0.0]) if forward is None else np.asarray(forward, dtype=float)
    f = quat_rotate(q, np.broadcast_to(fwd, (*np.shape(q)[:-1], 3)))
    return np.arctan2(f[..., 1], f[..., 0])


def quat_from_yaw(yaw: np.ndarray | float) -> np.ndarray:
    """xyzw quaternions [..., 4] of rotations by ``yaw`` [rad] about world z."""
    return quat_from_axis_angle(_AXES["z"], np.asarray(yaw, dtype=float))


def quat_between_frames(q_prev: np.ndarray, q_next: np.ndarray) -> np.ndarray:
    """World-frame rotation taking ``q_prev`` to ``q_next``: ``q_next * q_prev⁻¹``, shape [..., 4]."""
    return quat_multiply(q_next, quat_conjugate(q_prev))
