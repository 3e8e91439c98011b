"""NKN's objective (Eq. 10–16) as separate terms.

The scale follows the release (``../shared/notes/trainer-references.md`` §2.5): squared errors are
summed over feature dimensions and averaged over frames (a per-frame sum of squares), which is the
scale β, λ and ω were chosen for.

* cycle consistency (Eq. 14): $C = \\lVert x^A - \\hat x^A \\rVert^2$ on the normalised features;
* the same-skeleton branch of Eq. 13: $\\lVert \\hat x^B - x^A \\rVert^2$ where B = A;
* adversarial (Eq. 11–13), the release's non-saturating form: G minimises
  $\\beta\\,\\mathrm{BCE}(g(\\hat x^B), 1)$, D minimises $\\mathrm{BCE}(g(x), 1) + \\mathrm{BCE}(g(\\hat x^B), 0)$;
* twist (Eq. 15): $J = \\operatorname{mean}\\max(0, |\\theta| - \\alpha)^2$ with $\\theta$ the rotation of
  each ball joint about its bone axis (swing–twist: $\\theta = 2\\operatorname{atan2}(q_{xyz} \\cdot a, q_w)$,
  the release's ``euler_y`` with the bone along y);
* smoothing (Eq. 16): $S = \\lVert \\hat v_{2:T} - \\hat v_{1:T-1} \\rVert^2$ of the denormalised global motion.
"""

from __future__ import annotations

import math

import torch
from torch.nn import functional as F

__all__ = [
    "discriminator_loss",
    "generator_adversarial_loss",
    "smoothing_loss",
    "squared_error",
    "twist_angles",
    "twist_loss",
]


def squared_error(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """Per-frame sum of squares over the last dimension, averaged over frames [B, T] (where ``mask`` [B] is set)."""
    per_frame = (pred - target).square().sum(-1)  # [B, T]
    if mask is None:
        return per_frame.mean()
    w = mask.to(per_frame.dtype)[:, None].expand_as(per_frame)
    return (per_frame * w).sum() / w.sum().clamp_min(1.0)


def twist_angles(quats: torch.Tensor, axes: torch.Tensor) -> torch.Tensor:
    """Twist [rad] in [-π, π) of unit quaternions [..., S, 4] (xyzw) about unit axes [S, 3]: shape [..., S]."""
    along = (quats[..., :3] * axes.to(quats.dtype)).sum(-1)
    w = quats[..., 3]
    degenerate = along.square() + w.square() < 1e-12  # a half-turn swing: no defined twist
    angle = 2.0 * torch.atan2(torch.where(degenerate, torch.zeros_like(along), along),
                              torch.where(degenerate, torch.ones_like(w), w))
    return torch.remainder(angle + math.pi, 2.0 * math.pi) - math.pi


def twist_loss(quats: torch.Tensor, axes: torch.Tensor, alpha: float) -> torch.Tensor:
    """Eq. 15 for one motion: mean over joints and frames of $\\max(0, |\\theta| - \\alpha)^2$ (``alpha`` [rad])."""
    if quats.shape[-2] == 0:
        return quats.new_zeros(())
    return F.relu(twist_angles(quats, axes).abs() - alpha).square().mean()


def smoothing_loss(v: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """Eq. 16 for one motion: per-frame sum over the 4 dims of the squared frame-to-frame change of ``v`` [B, T, 4]."""
    return squared_error(v[:, 1:], v[:, :-1], mask)


def _masked_mean(x: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
    if mask is None:
        return x.mean()
    w = mask.to(x.dtype)
    return (x * w).sum() / w.sum().clamp_min(1.0)


def generator_adversarial_loss(fake_logits: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
    """$\\mathrm{BCE}(g(\\hat x^B), 1)$ per clip [B], averaged over the clips in ``mask``."""
    return _masked_mean(F.softplus(-fake_logits), mask)


def discriminator_loss(real_logits: torch.Tensor, fake_logits: torch.Tensor,
                       mask: torch.Tensor | None = None) -> torch.Tensor:
    """$\\mathrm{BCE}(g(x), 1) + \\mathrm{BCE}(g(\\hat x^B), 0)$, averaged over the clips in ``mask``."""
    return _masked_mean(F.softplus(-real_logits), mask) + _masked_mean(F.softplus(fake_logits), mask)
