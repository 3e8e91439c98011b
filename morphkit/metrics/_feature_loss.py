"""The feature loss $L_{fea}$ of ACE (Li et al. 2023, Eq. 9), as a training term and a metric."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from morphkit.errors import ConfigError

__all__ = ["feature_loss"]


def feature_loss(psi_human: Any, psi_creature: Any, *, reduction: Literal["mean", "none"] = "mean",
                 weights: Any = None) -> Any:
    """ACE's feature loss, Eq. 9: the Euclidean distance between the human's and the creature's Ψ.

    $$L_{fea} = \\lVert \\Psi(\\mathbf{x}_t^h) - \\Psi(\\hat{\\mathbf{x}}_t^r) \\rVert_2$$

    per frame $t$, with Ψ of §6.3 (root height, root orientation, root linear and angular
    velocity, end-effector positions; lengths divided by each body's own length, so the two
    characters compare at their own scale: :func:`morphkit.motion.features`). The human's
    end-effector block must list the human end-effectors paired with the creature's, in the
    creature's order (the KL mapping, Eq. 11). The paper writes a norm without a subscript and
    reports one number per method (Table 1: 0.606 for ACE on Spot); morphkit reads it as the
    L2 norm per frame, averaged over frames. The L2 norm is not squared.

    Runs on NumPy arrays and on torch tensors (differentiable; the gradient at a zero
    difference is 0), so the same function is the trainer's term and the evaluation metric.

    Args:
        psi_human: Ψ of the human states, shape [..., D]; NumPy array or torch tensor.
        psi_creature: Ψ of the retargeted creature states, the same shape and type.
        reduction: ``"mean"``: the mean over every frame (all leading dims); ``"none"``: the
            per-frame distances [...].
        weights: Per-column factors [D] on the difference, ‖w ⊙ (Ψ^h − Ψ^r)‖ (a training choice beyond
            Eq. 9; ``None``: Eq. 9, as the metric). The input's type.

    Returns:
        A float (NumPy, ``"mean"``), a 0-d tensor (torch, ``"mean"``), or per-frame distances [...]
        of the input's type. Unit-free for ACE's Ψ.

    Raises:
        ConfigError: on different shapes, an input without a feature axis, no frames, or an
            unknown ``reduction``.
    """
    if reduction not in ("mean", "none"):
        raise ConfigError(f"feature_loss: unknown reduction {reduction!r}; expected one of: mean, none")
    is_torch = [hasattr(x, "detach") and hasattr(x, "requires_grad") for x in (psi_human, psi_creature)]
    if is_torch[0] != is_torch[1]:
        raise ConfigError(
            f"feature_loss: expected two NumPy arrays or two torch tensors, got "
            f"{type(psi_human).__name__} and {type(psi_creature).__name__}"
        )
    if not is_torch[0]:
        psi_human = np.asarray(psi_human, dtype=np.float64)
        psi_creature = np.asarray(psi_creature, dtype=np.float64)
    shape_h, shape_c = tuple(psi_human.shape), tuple(psi_creature.shape)
    if shape_h != shape_c:
        raise ConfigError(f"feature_loss: Ψ shapes differ: {list(shape_h)} (human) and {list(shape_c)} (creature)")
    if len(shape_h) < 1:
        raise ConfigError("feature_loss: expected Ψ of shape [..., D], got a scalar")
    diff = psi_human - psi_creature
    if weights is not None:
        if not is_torch[0]:
            weights = np.asarray(weights, dtype=np.float64)
        if tuple(weights.shape) != shape_h[-1:]:
            raise ConfigError(f"feature_loss: weights of shape {list(weights.shape)}, expected [{shape_h[-1]}]")
        diff = diff * weights
    if not is_torch[0]:
        dist = np.linalg.norm(diff, axis=-1)  # [...]
        if reduction == "none":
            return dist
        if dist.size == 0:
            raise ConfigError("feature_loss: no frames")
        return float(dist.mean())
    import torch

    dist = torch.linalg.vector_norm(diff, dim=-1)  # [...]
    if reduction == "none":
        return dist
    if dist.numel() == 0:
        raise ConfigError("feature_loss: no frames")
    return dist.mean()
