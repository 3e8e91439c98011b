"""The motion layer's single door to forward kinematics: the Warp kernels, on the CPU, in float64.

Compiled models are cached per morphology object (motions of one clip set share one skeleton
object, and generated kernels are shared by every morphology of the same topology).
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import numpy as np

from morphkit.conventions import quat_rotate
from morphkit.graph import Morphology

__all__ = ["compiled_model", "link_poses_and_end_effectors"]

_models: dict[int, tuple[weakref.ref, Any]] = {}
_lock = threading.Lock()


def compiled_model(morphology: Morphology) -> Any:
    """The :class:`~morphkit.model.KinematicModel` of ``morphology`` on the CPU (compiled once per object)."""
    key = id(morphology)
    with _lock:
        hit = _models.get(key)
        if hit is not None and hit[0]() is morphology:
            return hit[1]
    from morphkit.model import compile_model

    model = compile_model(morphology, device="cpu")
    with _lock:
        _models[key] = (weakref.ref(morphology, lambda _: _models.pop(key, None)), model)
    return model


def link_poses_and_end_effectors(
    morphology: Morphology, q: np.ndarray, wheel_q: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """World link poses [T, L, 7] and end-effector positions [T, E, 3] of coordinates ``q`` [T, C].

    Args:
        morphology: The creature.
        q: Coordinates in its q layout, shape [T, C].
        wheel_q: Wheel angles [rad], shape [T, W] (``None``: wheels at 0).
    """
    from morphkit.kernels import eval_fk

    model = compiled_model(morphology)
    q = np.ascontiguousarray(q, dtype=np.float64)
    if q.shape[0] == 0:
        return np.zeros((0, model.link_count, 7)), np.zeros((0, model.ee_count, 3))
    poses = eval_fk(model, q, wheel_q=wheel_q, device="cpu").numpy().reshape(q.shape[0], model.link_count, 7)
    if model.ee_count == 0:
        return poses, np.zeros((q.shape[0], 0, 3))
    T = poses[:, model.ee_link]  # [T, E, 7]
    ee = T[..., :3] + quat_rotate(T[..., 3:], np.broadcast_to(model.ee_offset, T[..., :3].shape))
    return poses, ee
