"""Conventions, declared once.

Glossary (used in names across morphkit):

- ``p``: position, shape [..., 3], [m].
- ``q`` / ``quat``: unit quaternion in **xyzw** order (Warp's order), shape [..., 4].
- ``T_a_b``: pose of frame ``b`` expressed in frame ``a`` as ``[px, py, pz, qx, qy, qz, qw]``,
  shape [..., 7]; batches are ``Ts_a_b``.
- ``rpy``: roll, pitch, yaw [rad] about fixed x, y, z (URDF's convention): ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
- World frame: z up, x is the creature's forward direction, units metres and radians.

Any function that changes the quaternion order says so in its name (``quat_wxyz_to_xyzw``).
These helpers are NumPy-only and broadcast over leading axes.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FORWARD_AXIS",
    "QUAT_ORDER",
    "TRANSFORM_LAYOUT",
    "UP_AXIS",
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


def quat_xyzw_to_wxyz(q: np.ndarray) -> np.ndarray:
    """Reorder [..., 4] quaternions from xyzw to wxyz (USD's and most papers' order)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:4], q[..., 0:3]], axis=-1)


def quat_wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    """Reorder [..., 4] quaternions from wxyz to xyzw."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 1:4], q[..., 0:1]], axis=-1)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of xyzw quaternions, shape [..., 4]."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate (inverse for unit quaternions) of xyzw quaternions."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([-q[..., :3], q[..., 3:4]], axis=-1)


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` [..., 3] by unit xyzw quaternions ``q`` [..., 4]."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_from_axis_angle(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """xyzw quaternion rotating by ``angle`` [rad] about unit ``axis`` [..., 3]."""
    axis = np.asarray(axis, dtype=float)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([axis * np.sin(half), np.cos(half)], axis=-1)


def quat_from_rpy(rpy: np.ndarray) -> np.ndarray:
    """xyzw quaternion of fixed-axis roll, pitch, yaw [..., 3] (``R = Rz Ry Rx``)."""
    rpy = np.asarray(rpy, dtype=float)
    ex = quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), rpy[..., 0])
    ey = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), rpy[..., 1])
    ez = quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), rpy[..., 2])
    return quat_multiply(ez, quat_multiply(ey, ex))


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """3x3 rotation matrices [..., 3, 3] from unit xyzw quaternions [..., 4]."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit xyzw quaternions [..., 4] (w >= 0) from rotation matrices [..., 3, 3]."""
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


def rpy_from_quat(q: np.ndarray) -> np.ndarray:
    """Fixed-axis roll, pitch, yaw [..., 3] of unit xyzw quaternions (inverse of :func:`quat_from_rpy`).

    Stable to ~1e-15 everywhere, gimbal lock included: pitch comes from atan2 (arcsin loses half
    the digits near ±90°), and roll is read from the matrix with yaw removed,
    ``Rz(-yaw) R = Ry(pitch) Rx(roll)``, so any rounding in yaw is absorbed by roll.
    """
    m = matrix_from_quat(q)
    cos_pitch = np.hypot(m[..., 0, 0], m[..., 1, 0])
    pitch = np.arctan2(-m[..., 2, 0], cos_pitch)
    # At gimbal lock (|pitch| = 90 deg) roll and yaw are coupled: put it all in yaw (roll = 0).
    lock = cos_pitch < 1e-12
    yaw = np.where(lock, np.arctan2(-m[..., 0, 1], m[..., 1, 1]), np.arctan2(m[..., 1, 0], m[..., 0, 0]))
    cy, sy = np.cos(yaw), np.sin(yaw)
    # Row 1 of Rz(-yaw) R is (0, cos roll, -sin roll).
    roll = np.arctan2(-(cy * m[..., 1, 2] - sy * m[..., 0, 2]), cy * m[..., 1, 1] - sy * m[..., 0, 1])
    return np.stack([roll, pitch, yaw], axis=-1)


def transform_multiply(T_a_b: np.ndarray, T_b_c: np.ndarray) -> np.ndarray:
    """Compose poses [..., 7] (``[p, q_xyzw]``): returns ``T_a_c``."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    T_b_c = np.asarray(T_b_c, dtype=float)
    p = T_a_b[..., :3] + quat_rotate(T_a_b[..., 3:], T_b_c[..., :3])
    q = quat_multiply(T_a_b[..., 3:], T_b_c[..., 3:])
    return np.concatenate([p, q], axis=-1)
