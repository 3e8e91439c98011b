"""Rotations and rigid transforms: the one place morphkit writes quaternion math outside the kernels.

Quaternions are xyzw, transforms ``[px, py, pz, qx, qy, qz, qw]`` (:mod:`morphkit.conventions`).
Every function broadcasts over leading axes. Unless its docstring says "NumPy only", a function
takes NumPy arrays or torch tensors and returns the same kind (torch when any argument is a
tensor, on that tensor's dtype and device), and the torch path is differentiable: where a formula
is singular (a zero rotation, a vertical facing axis) the value is defined by its limit and the
gradient stays finite. The Warp twins of the few functions the kernels need live in
:mod:`morphkit.kernels.spatial`; tests hold them equal.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "axis_angle_from_quat",
    "euler_from_quat",
    "heading_frame",
    "matrix_from_quat",
    "quat_between_vectors",
    "quat_canonical",
    "quat_conjugate",
    "quat_from_axis_angle",
    "quat_from_euler",
    "quat_from_matrix",
    "quat_from_rotation_vector",
    "quat_from_rpy",
    "quat_from_yaw",
    "quat_multiply",
    "quat_normalize",
    "quat_rotate",
    "quat_rotate_inverse",
    "quat_slerp",
    "quat_wxyz_to_xyzw",
    "quat_xyzw_to_wxyz",
    "rpy_from_quat",
    "transform_inverse",
    "transform_multiply",
    "wrap_angle",
    "yaw_from_quat",
]


# ---- array backend: NumPy or torch, chosen by the arguments -------------------------------------
class _NumPy:
    def asarray(self, x: Any) -> np.ndarray:
        return np.asarray(x, dtype=float)

    def stack(self, xs: list[Any], axis: int) -> np.ndarray:
        return np.stack(xs, axis=axis)

    def cat(self, xs: list[Any], axis: int) -> np.ndarray:
        return np.concatenate(xs, axis=axis)

    def broadcast_to(self, x: Any, shape: tuple[int, ...]) -> np.ndarray:
        return np.broadcast_to(x, shape)

    where = staticmethod(np.where)
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)

    def cross(self, a: Any, b: Any) -> np.ndarray:
        return np.cross(a, b)

    def sum(self, x: Any, keepdims: bool = False) -> np.ndarray:
        return np.sum(x, axis=-1, keepdims=keepdims)


class _Torch:
    def __init__(self, like: Any) -> None:
        import torch

        self.torch = torch
        self.dtype = like.dtype if like.is_floating_point() else torch.get_default_dtype()
        self.device = like.device

    def asarray(self, x: Any) -> Any:
        return self.torch.as_tensor(x, dtype=self.dtype, device=self.device)

    def stack(self, xs: list[Any], axis: int) -> Any:
        return self.torch.stack(self.torch.broadcast_tensors(*xs), dim=axis)

    def cat(self, xs: list[Any], axis: int) -> Any:
        return self.torch.cat(xs, dim=axis)

    def broadcast_to(self, x: Any, shape: tuple[int, ...]) -> Any:
        return x.expand(shape)

    def where(self, c: Any, a: Any, b: Any) -> Any:
        return self.torch.where(c, self.asarray(a), self.asarray(b))

    def sin(self, x: Any) -> Any:
        return self.torch.sin(x)

    def cos(self, x: Any) -> Any:
        return self.torch.cos(x)

    def sqrt(self, x: Any) -> Any:
        return self.torch.sqrt(x)

    def atan2(self, y: Any, x: Any) -> Any:
        return self.torch.atan2(y, x)

    def cross(self, a: Any, b: Any) -> Any:
        a, b = self.torch.broadcast_tensors(a, b)
        return self.torch.linalg.cross(a, b, dim=-1)

    def sum(self, x: Any, keepdims: bool = False) -> Any:
        return self.torch.sum(x, dim=-1, keepdim=keepdims)


_NUMPY = _NumPy()


def _backend(*xs: Any) -> Any:
    for x in xs:
        if type(x).__module__.split(".", 1)[0] == "torch":
            return _Torch(x)
    return _NUMPY


def _args(*xs: Any) -> tuple[Any, ...]:
    xp = _backend(*xs)
    return (xp, *(xp.asarray(x) for x in xs))


# ---- quaternion order ---------------------------------------------------------------------------
def quat_xyzw_to_wxyz(q: Any) -> Any:
    """Reorder [..., 4] quaternions from xyzw to wxyz (USD's and most papers' order)."""
    xp, q = _args(q)
    return xp.cat([q[..., 3:4], q[..., 0:3]], -1)


def quat_wxyz_to_xyzw(q: Any) -> Any:
    """Reorder [..., 4] quaternions from wxyz to xyzw."""
    xp, q = _args(q)
    return xp.cat([q[..., 1:4], q[..., 0:1]], -1)


# ---- quaternion algebra -------------------------------------------------------------------------
def quat_multiply(a: Any, b: Any) -> Any:
    """Hamilton product ``a * b`` of xyzw quaternions, shape [..., 4]."""
    xp, a, b = _args(a, b)
    ax, ay, az, aw = (a[..., i] for i in range(4))
    bx, by, bz, bw = (b[..., i] for i in range(4))
    return xp.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        -1,
    )


def quat_conjugate(q: Any) -> Any:
    """Conjugate (the inverse, for unit quaternions) of xyzw quaternions [..., 4]."""
    xp, q = _args(q)
    return xp.cat([-q[..., :3], q[..., 3:4]], -1)


def quat_rotate(q: Any, v: Any) -> Any:
    """Rotate vectors ``v`` [..., 3] by unit xyzw quaternions ``q`` [..., 4]."""
    xp, q, v = _args(q, v)
    u = q[..., :3]
    t = 2.0 * xp.cross(u, v)
    return v + q[..., 3:4] * t + xp.cross(u, t)


def quat_rotate_inverse(q: Any, v: Any) -> Any:
    """Rotate vectors ``v`` [..., 3] by the inverse of unit quaternions ``q`` [..., 4]."""
    return quat_rotate(quat_conjugate(q), v)


def quat_normalize(q: Any) -> Any:
    """Unit quaternions [..., 4]; a zero quaternion becomes the identity."""
    xp, q = _args(q)
    n2 = xp.sum(q * q, keepdims=True)
    ok = n2 > 1e-24
    ident = xp.asarray([0.0, 0.0, 0.0, 1.0])
    return xp.where(ok, q / xp.sqrt(xp.where(ok, n2, 1.0)), ident)


def quat_canonical(q: Any) -> Any:
    """The representative with ``w >= 0`` of each quaternion's double cover, shape [..., 4]."""
    xp, q = _args(q)
    return xp.where(q[..., 3:4] < 0, -q, q)


def quat_from_axis_angle(axis: Any, angle: Any) -> Any:
    """xyzw quaternions rotating by ``angle`` [...] [rad] about unit ``axis`` [..., 3]."""
    xp, axis, angle = _args(axis, angle)
    half = 0.5 * angle[..., None]
    s = axis * xp.sin(half)
    return xp.cat([s, xp.broadcast_to(xp.cos(half), (*s.shape[:-1], 1))], -1)


def quat_from_rotation_vector(v: Any) -> Any:
    """xyzw quaternions of rotation vectors ``v`` [..., 3] (axis × angle [rad]); inverse of
    :func:`axis_angle_from_quat` for angles in [0, π]."""
    xp, v = _args(v)
    a2 = xp.sum(v * v, keepdims=True)
    small = a2 < 1e-24
    a = xp.sqrt(xp.where(small, 1.0, a2))
    # sin(a/2)/a → 1/2 as a → 0.
    s = xp.where(small, 0.5 - a2 / 48.0, xp.sin(0.5 * a) / a)
    return xp.cat([v * s, xp.where(small, 1.0 - a2 / 8.0, xp.cos(0.5 * a))], -1)


def axis_angle_from_quat(q: Any) -> Any:
    """Rotation vectors [..., 3] (axis × angle [rad], angle in [0, π]) of xyzw quaternions."""
    xp, q = _args(q)
    q = quat_canonical(q)
    v = q[..., :3]
    s2 = xp.sum(v * v, keepdims=True)
    small = s2 < 1e-24
    s = xp.sqrt(xp.where(small, 1.0, s2))
    w = q[..., 3:4]
    # angle / sin(angle / 2) → 2 / w as the angle → 0.
    scale = xp.where(small, 2.0 / xp.where(small, w, 1.0), 2.0 * xp.atan2(s, w) / s)
    return v * scale


def quat_between_vectors(a: Any, b: Any) -> Any:
    """Shortest-arc xyzw rotation taking unit vectors ``a`` onto unit vectors ``b`` [..., 3].

    For opposite vectors the half turn is about an axis perpendicular to ``a`` (``a × x``, or
    ``a × y`` when ``a`` is along x).
    """
    xp, a, b = _args(a, b)
    c = xp.sum(a * b, keepdims=True)
    q = xp.cat([xp.cross(a, b), 1.0 + c], -1)
    ex, ey = xp.asarray([1.0, 0.0, 0.0]), xp.asarray([0.0, 1.0, 0.0])
    perp = xp.cross(a, ex)
    perp = xp.where(xp.sum(perp * perp, keepdims=True) < 1e-12, xp.cross(a, ey), perp)
    half_turn = xp.cat([perp, xp.asarray(np.zeros(1)) * c], -1)
    return quat_normalize(xp.where(c < -1.0 + 1e-12, half_turn, q))


# ---- matrices and Euler angles --------------------------------------------------------------------
def matrix_from_quat(q: Any) -> Any:
    """3x3 rotation matrices [..., 3, 3] from unit xyzw quaternions [..., 4]."""
    xp, q = _args(q)
    x, y, z, w = (q[..., i] for i in range(4))
    return xp.stack(
        [
            xp.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            xp.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            xp.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit xyzw quaternions [..., 4] (w >= 0) from rotation matrices [..., 3, 3]. NumPy only."""
    m = np.asarray(m, dtype=float)
    # Shepperd's method: choose the largest diagonal term for numerical stability.
    tr = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    cands = np.stack(
        [
            np.stack(
                [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1], 1 + tr], -1
            ),
            np.stack(
                [
                    1 + 2 * m[..., 0, 0] - tr,
                    m[..., 0, 1] + m[..., 1, 0],
                    m[..., 0, 2] + m[..., 2, 0],
                    m[..., 2, 1] - m[..., 1, 2],
                ],
                -1,
            ),
            np.stack(
                [
                    m[..., 0, 1] + m[..., 1, 0],
                    1 + 2 * m[..., 1, 1] - tr,
                    m[..., 1, 2] + m[..., 2, 1],
                    m[..., 0, 2] - m[..., 2, 0],
                ],
                -1,
            ),
            np.stack(
                [
                    m[..., 0, 2] + m[..., 2, 0],
                    m[..., 1, 2] + m[..., 2, 1],
                    1 + 2 * m[..., 2, 2] - tr,
                    m[..., 1, 0] - m[..., 0, 1],
                ],
                -1,
            ),
        ],
        axis=-2,
    )
    keys = np.stack([tr, m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1)
    idx = np.argmax(keys, axis=-1)
    q = np.take_along_axis(cands, idx[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


_UNIT = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def quat_from_rpy(rpy: Any) -> Any:
    """xyzw quaternions of fixed-axis roll, pitch, yaw [..., 3] [rad] (URDF's ``R = Rz Ry Rx``)."""
    xp, rpy = _args(rpy)
    ex, ey, ez = (quat_from_axis_angle(xp.asarray(_UNIT[a]), rpy[..., k]) for k, a in enumerate("xyz"))
    return quat_multiply(ez, quat_multiply(ey, ex))


def rpy_from_quat(q: Any) -> Any:
    """Fixed-axis roll, pitch, yaw [..., 3] of unit xyzw quaternions (inverse of :func:`quat_from_rpy`).

    Stable to ~1e-15 everywhere, gimbal lock included: pitch comes from atan2 (arcsin loses half
    the digits near ±90°), and roll is read from the matrix with yaw removed,
    ``Rz(-yaw) R = Ry(pitch) Rx(roll)``, so any rounding in yaw is absorbed by roll.
    """
    xp, q = _args(q)
    m = matrix_from_quat(q)
    cos_pitch = xp.sqrt(m[..., 0, 0] ** 2 + m[..., 1, 0] ** 2)
    pitch = xp.atan2(-m[..., 2, 0], cos_pitch)
    # At gimbal lock (|pitch| = 90 deg) roll and yaw are coupled: put it all in yaw (roll = 0).
    lock = cos_pitch < 1e-12
    yaw = xp.where(lock, xp.atan2(-m[..., 0, 1], m[..., 1, 1]), xp.atan2(m[..., 1, 0], m[..., 0, 0]))
    cy, sy = xp.cos(yaw), xp.sin(yaw)
    # Row 1 of Rz(-yaw) R is (0, cos roll, -sin roll).
    roll = xp.atan2(-(cy * m[..., 1, 2] - sy * m[..., 0, 2]), cy * m[..., 1, 1] - sy * m[..., 0, 1])
    return xp.stack([roll, pitch, yaw], -1)


def quat_from_euler(angles: np.ndarray, order: str) -> np.ndarray:
    """xyzw quaternions of intrinsic Euler rotations, BVH style. NumPy only.

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
        q = quat_multiply(q, quat_from_axis_angle(np.array(_UNIT[axis]), angles[..., k]))
    return q


def euler_from_quat(q: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles [..., 3] [rad] of xyzw quaternions, inverse of :func:`quat_from_euler`.
    NumPy only.

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
    """Spherical linear interpolation between unit quaternions (shortest arc). NumPy only.

    Args:
        q0: [..., 4] unit quaternion at t = 0.
        q1: [..., 4] unit quaternion at t = 1.
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


# ---- yaw and the heading frame ------------------------------------------------------------------
def wrap_angle(a: Any) -> Any:
    """Angles [rad] wrapped into [-π, π)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def yaw_from_quat(q: Any, forward: Any = None) -> Any:
    """Heading angle [rad] of a frame: the yaw of its ``forward`` axis projected on the ground.

    Args:
        q: [..., 4] xyzw orientations of the frame in the world.
        forward: The frame's forward axis in its own coordinates (default +x, morphkit's forward).

    Returns:
        [...] yaw about world z; 0 (with zero gradient) where the forward axis is vertical, as in
        the kernels.
    """
    xp, q = _args(q)
    fwd = xp.asarray(_UNIT["x"] if forward is None else forward)
    f = quat_rotate(q, xp.broadcast_to(fwd, (*q.shape[:-1], 3)))
    degenerate = f[..., 0] ** 2 + f[..., 1] ** 2 <= 1e-12
    return xp.atan2(xp.where(degenerate, 0.0, f[..., 1]), xp.where(degenerate, 1.0, f[..., 0]))


def quat_from_yaw(yaw: Any) -> Any:
    """xyzw quaternions [..., 4] of rotations by ``yaw`` [...] [rad] about world z."""
    xp, yaw = _args(yaw)
    return quat_from_axis_angle(xp.asarray(_UNIT["z"]), yaw)


def heading_frame(root_pose: Any) -> Any:
    """Heading frames ``T_world_heading`` [..., 7] of root poses ``T_world_root`` [..., 7].

    The heading frame (:mod:`morphkit.conventions`): origin at the root, z along world up, x along
    the root's facing direction (its +x axis) projected on the ground.
    """
    xp, root_pose = _args(root_pose)
    return xp.cat([root_pose[..., :3], quat_from_yaw(yaw_from_quat(root_pose[..., 3:]))], -1)


# ---- rigid transforms ---------------------------------------------------------------------------
def transform_multiply(T_a_b: Any, T_b_c: Any) -> Any:
    """Compose poses [..., 7] (``[p, q_xyzw]``): returns ``T_a_c``."""
    xp, T_a_b, T_b_c = _args(T_a_b, T_b_c)
    p = T_a_b[..., :3] + quat_rotate(T_a_b[..., 3:], T_b_c[..., :3])
    return xp.cat([p, quat_multiply(T_a_b[..., 3:], T_b_c[..., 3:])], -1)


def transform_inverse(T_a_b: Any) -> Any:
    """``T_b_a`` from ``T_a_b`` [..., 7] (unit quaternions)."""
    xp, T_a_b = _args(T_a_b)
    q_inv = quat_conjugate(T_a_b[..., 3:])
    return xp.cat([-quat_rotate(q_inv, T_a_b[..., :3]), q_inv], -1)
