"""Comparison helpers for motions: quaternion double cover and angle wrap-around aware."""

from __future__ import annotations

import numpy as np

from morphkit.graph import BaseType, JointType, Morphology
from morphkit.motion import Motion


def assert_q_close(m: Morphology, a: np.ndarray, b: np.ndarray, atol: float) -> None:
    """``a`` and ``b`` [T, C] are the same poses: quaternion blocks up to sign, continuous joints
    and planar/wheeled yaw up to whole turns, everything else directly."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    assert a.shape == b.shape
    done = np.zeros(a.shape[1], dtype=bool)
    quats = [3] if m.base == BaseType.FLOATING else []
    angles = [2] if m.base in (BaseType.PLANAR, BaseType.WHEELED) else []
    for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
        if m.is_driven(j):
            continue
        if j.type == JointType.SPHERICAL:
            quats.append(start)
        elif j.type == JointType.CONTINUOUS:
            angles.append(start)
    for s in quats:
        qa, qb = a[:, s : s + 4], b[:, s : s + 4]
        sign = np.where(np.sum(qa * qb, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        np.testing.assert_allclose(qa, sign * qb, atol=atol, rtol=0)
        done[s : s + 4] = True
    for s in angles:
        d = np.angle(np.exp(1j * (a[:, s] - b[:, s])))
        np.testing.assert_allclose(d, 0.0, atol=atol)
        done[s] = True
    np.testing.assert_allclose(a[:, ~done], b[:, ~done], atol=atol, rtol=0)


def reference_link_positions(motion: Motion) -> np.ndarray:
    """Link positions [T, L, 3] through the pure-torch reference FK (float64).

    Tests compare motions read back from files (whose morphologies differ from the original by
    float round-off) with this oracle, so no FK kernel is generated for each re-read skeleton.
    """
    import torch

    from morphkit.model import compile_model
    from morphkit.torch.reference import fk_reference

    model = compile_model(motion.morphology)
    wheel = motion.wheel_angles() if motion.morphology.wheels is not None else None
    with torch.no_grad():
        T = fk_reference(
            model,
            torch.tensor(np.array(motion.q), dtype=torch.float64),
            wheel_q=None if wheel is None else torch.as_tensor(wheel, dtype=torch.float64),
        )
    return T[..., :3].numpy()
