"""Small vectorised helpers shared by the synthesis modules (NumPy only; rotations are in
:mod:`morphkit.rotations`)."""

from __future__ import annotations

import numpy as np

from morphkit.rotations import quat_conjugate, quat_multiply

__all__ = [
    "coordinate_ascent",
    "nlerp",
    "quat_delta_extrapolate",
    "rotate2",
    "smoothstep",
    "smoothstep_derivative",
]


def smoothstep(x: np.ndarray | float) -> np.ndarray:
    """$3x^2 - 2x^3$ on ``x`` clipped to [0, 1]: 0 to 1 with zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def smoothstep_derivative(x: np.ndarray | float) -> np.ndarray:
    """d smoothstep / dx (0 outside [0, 1])."""
    x = np.asarray(x, dtype=float)
    inside = (x > 0.0) & (x < 1.0)
    return np.where(inside, 6.0 * x * (1.0 - x), 0.0)


def rotate2(c: np.ndarray, s: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate 2-vectors ``v`` [..., 2] by the angle whose cosine and sine are ``c``, ``s`` [...]."""
    x, y = v[..., 0], v[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


def nlerp(q0: np.ndarray, q1: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Normalised linear interpolation of xyzw quaternions [..., 4] (shortest arc), weights [...]."""
    sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0.0, -1.0, 1.0)
    q = q0 + np.asarray(w)[..., None] * (sign * q1 - q0)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_delta_extrapolate(q_prev: np.ndarray, q_prev2: np.ndarray) -> np.ndarray:
    """Constant-angular-velocity prediction ``q_prev (q_prev2^-1 q_prev)`` of unit quaternions [..., 4]."""
    d = quat_multiply(quat_conjugate(q_prev2), q_prev)
    q = quat_multiply(q_prev, d)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def coordinate_ascent(q: np.ndarray, coords: np.ndarray, lower: np.ndarray, upper: np.ndarray, objective,
                      *, passes: int = 3, samples: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``q`` [B, C] with coordinates ``coords`` [K] moved, one after another, to where ``objective`` is highest.

    Each pass tries every coordinate at ``samples`` values from ``lower`` to ``upper`` [K] (all poses at once)
    and keeps a value only where it raises the objective. Meant for joints pinned at their limits, where
    gradient steps stall; ``objective`` maps poses [N, C] to [N] (``-inf`` for a pose that is not allowed).

    Returns:
        The poses and their objective [B].
    """
    q = np.array(q, dtype=float)
    B = len(q)
    best = objective(q)
    for _ in range(passes if len(coords) else 0):
        for c, lo, hi in zip(coords, lower, upper, strict=True):
            values = np.linspace(lo, hi, samples)
            trial = np.repeat(q[None], samples, axis=0)  # [S, B, C]
            trial[:, :, c] = values[:, None]
            f = objective(trial.reshape(samples * B, -1)).reshape(samples, B)
            pick = np.argmax(f, axis=0)
            top = f[pick, np.arange(B)]
            better = top > best
            q[better, c] = values[pick[better]]
            best[better] = top[better]
    return q, best
