"""The motion layer's single door to forward kinematics: the Warp kernels, on the CPU, in float64.

Compiled models are cached per morphology object (motions of one clip set share one skeleton
object, and generated kernels are shared by every morphology of the same topology).
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import numpy as np

from morphkit.graph import Morphology

__all__ = ["compiled_model", "link_poses_and_end_effectors", "wheel_angles"]

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


def wheel_angles(morphology: Morphology, q: np.ndarray) -> np.ndarray:
    """Wheel angles [T, W] [rad] rolling without slip along the base path of ``q`` [T, C] (W = 0 unless wheeled)."""
    from morphkit.kernels import eval_wheel_angles

    model = compiled_model(morphology)
    q = np.ascontiguousarray(q, dtype=np.float64)
    if model.wheel_count == 0 or q.shape[0] == 0:
        return np.zeros((q.shape[0], model.wheel_count))
    return eval_wheel_angles(model, q, device="cpu").numpy().reshape(q.shape[0], model.wheel_count)


def link_poses_and_end_effectors(
    morphology: Morphology, q: np.ndarray, wheel_q: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """World link poses [T, L, 7] and end-effector positions [T, E, 3] of coordinates ``q`` [T, C].

    Args:
        morphology: The creature.
        q: Coordinates in its q layout, shape [T, C].
        wheel_q: Wheel angles [rad], shape [T, W] (``None``: wheels at 0).
    """
    from morphkit.kernels import eval_end_effectors, eval_fk

    model = compiled_model(morphology)
    q = np.ascontiguousarray(q, dtype=np.float64)
    T, L, E = q.shape[0], model.link_count, model.ee_count
    if T == 0:
        return np.zeros((0, L, 7)), np.zeros((0, E, 3))
    links = eval_fk(model, q, wheel_q=wheel_q, device="cpu")
    poses = links.numpy().reshape(T, L, 7)
    if E == 0:
        return poses, np.zeros((T, 0, 3))
    ee, _ = eval_end_effectors(model, q, Ts_world_link=links, wheel_q=wheel_q, device="cpu")
    return poses, ee.numpy().reshape(T, E, 3)
