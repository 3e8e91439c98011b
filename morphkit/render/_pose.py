"""Link poses for rendering: morphkit's forward kinematics (Warp kernels, float32, CPU).

For a clip (several frames) the wheels of a wheeled base roll along the base's path
(:func:`~morphkit.kernels.eval_wheel_angles`); a single pose shows them at angle 0.
"""

from __future__ import annotations

import numpy as np

from morphkit.errors import MotionFormatError
from morphkit.graph import Morphology

__all__ = ["as_q", "link_poses"]


def as_q(m: Morphology, q: object, *, what: str = "q") -> np.ndarray:
    """``q`` as a float array [T, coordinate_count] (a single pose [coordinate_count] becomes T = 1).

    Raises:
        MotionFormatError: Wrong width, rank, or a non-finite value.
    """
    if hasattr(q, "detach"):  # a torch tensor: render what it holds, without importing torch here
        q = q.detach().cpu().numpy()  # type: ignore[attr-defined]
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != m.coordinate_count:
        raise MotionFormatError(
            f"{what}: expected shape [frames, {m.coordinate_count}] for {m.name!r} "
            f"({m.coordinate_count} coordinates), got {list(np.shape(q))}"
        )
    if arr.shape[0] == 0:
        raise MotionFormatError(f"{what}: no frames")
    if not np.isfinite(arr).all():
        bad = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise MotionFormatError(f"{what}: non-finite value in frame {bad}")
    return arr


def link_poses(m: Morphology, q: object) -> np.ndarray:
    """World transforms of every link, shape [T, link_count, 7] (``[p, q_xyzw]``, float32).

    Args:
        m: The creature.
        q: Coordinates [T, coordinate_count] (a clip: wheels roll with the base) or one pose
            [coordinate_count] (NumPy, list or tensor).
    """
    arr = as_q(m, q)
    from morphkit.kernels import eval_fk, eval_wheel_angles
    from morphkit.model import compile_model

    # float32 on the CPU: plenty for pixels, and no device needed to render.
    model = compile_model(m, device="cpu")
    q32 = np.ascontiguousarray(arr, dtype=np.float32)
    wheel_q = eval_wheel_angles(model, q32, device="cpu") if model.wheel_count and len(q32) > 1 else None
    out = eval_fk(model, q32, wheel_q=wheel_q, device="cpu").numpy()
    return np.asarray(out, dtype=np.float32).reshape(arr.shape[0], m.link_count, 7)
