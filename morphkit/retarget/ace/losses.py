"""ACE's losses: the motion prior's (§4), the discriminator's (Eq. 5) and the generator's (Eq. 3–10).

Each ``*_loss`` is a pure function of the networks, a batch and the config, returning ``(loss, figures)``:
the scalar to back-propagate and the detached 0-d tensors :meth:`~morphkit.retarget.training_run.Run.log` records,
in the order of ``metrics.csv``'s columns. :mod:`~morphkit.retarget.ace.train` only orchestrates (data,
optimisers, steps, checkpoints). The terms beyond the paper (the prior's foot term, G's hand weights and
hand-velocity term, the contact term) are here too, each with its config switch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch.nn import functional as F

import morphkit.torch as mt
from morphkit.contact_rules import PRIOR_PLANTED, PRIOR_PLANTED_STEP
from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.metrics import feature_loss
from morphkit.motion import GROUND_MOTION_FEATURES, ROOT_FEATURE_DIM, feature_dim, world_end_effectors
from morphkit.retarget.ace.config import PriorConfig, RetargetConfig
from morphkit.retarget.ace.model import FeatureMap, foot_indices
from morphkit.retarget.ace.networks import kl_divergence
from morphkit.retarget.networks import frozen_parameters

__all__ = [
    "Figures",
    "GeneratorTerms",
    "contact_term",
    "disc_logits",
    "discriminator_loss",
    "feature_weights",
    "generator_loss",
    "gradient_penalty",
    "hand_blocks",
    "hand_spread_factors",
    "hand_velocity_term",
    "prior_foot_term",
    "prior_loss",
    "spread_ground_motion_factor",
]

Figures = dict[str, torch.Tensor]
"""Detached 0-d tensors a step logs, by ``metrics.csv`` column."""


# ---- stage 1: the motion prior ----------------------------------------------------------------


def prior_loss(model: torch.nn.Module, windows: torch.Tensor, p_own: float, generator: torch.Generator,
               fmap: FeatureMap, feet: Sequence[int], cfg: PriorConfig) -> tuple[torch.Tensor, Figures]:
    """The VAE's loss over one scheduled-sampling rollout of normalised state ``windows`` [B, T, Sr] (Eq. 1–2).

    A step conditions on its own detached prediction with probability ``p_own`` (drawn from ``generator``),
    else on the data. Per step: reconstruction (mean squared error per state dimension), β·KL and, with
    ``cfg.foot_weight`` and ``feet``, :func:`prior_foot_term`; the sum is averaged over the steps.
    """
    w = windows
    x_prev, recon, kl = w[:, 0], 0.0, 0.0
    prevs, preds = [], []
    for t in range(1, w.shape[1]):
        out = model(x_prev, w[:, t], generator=None)
        x_hat = out.x
        recon = recon + (x_hat - w[:, t]).square().sum(-1).mean() / w.shape[-1]
        kl = kl + kl_divergence(out.mu, out.logvar)
        prevs.append(x_prev)
        preds.append(x_hat)
        own = torch.rand(w.shape[0], 1, generator=generator).to(w.device) < p_own
        x_prev = torch.where(own, x_hat.detach(), w[:, t])
    steps = w.shape[1] - 1
    foot = w.new_zeros(())
    if cfg.foot_weight > 0 and feet:
        foot = steps * prior_foot_term(fmap, feet, torch.stack(prevs, 1), torch.stack(preds, 1), w[:, :-1], w[:, 1:],
                                       planted_boost=cfg.foot_planted_boost, planted_step=cfg.planted_step)
    loss = (recon + cfg.kl_beta * kl + cfg.foot_weight * foot) / steps
    return loss, {"prior_loss": loss.detach(), "prior_recon": recon.detach() / steps, "prior_kl": kl.detach() / steps,
                  "prior_foot": foot.detach() / steps}


def prior_foot_term(fmap: FeatureMap, feet: Sequence[int], prev: torch.Tensor, pred: torch.Tensor,
                    prev_data: torch.Tensor, data: torch.Tensor, *, planted_boost: float = 0.0,
                    planted_step: float = PRIOR_PLANTED_STEP,
                    contact_height: float = PRIOR_PLANTED.height) -> torch.Tensor:
    """Beyond the paper: the prior's foot term (``PriorConfig.foot_weight``), in squared body lengths.

    For each transition ``prev`` → ``pred`` (normalised states [..., Sr]; ``pred`` = π's output) the
    feet's step in the transition's ground frame — FK of the predicted joints placed on the
    integrated root path (:func:`~morphkit.motion.world_end_effectors`), as exported — is compared
    with the data's step ``prev_data`` → ``data``, and the predicted feet's height with the data's.
    A planted foot's data step is zero, so this is what keeps π's planted feet planted; feet the
    data has planted (step below ``planted_step``, below ``contact_height``) weigh ``1 + planted_boost``.
    """
    lay, stats = fmap.creature_layout, fmap.creature_stats
    x = stats.denormalize(torch.stack([prev, pred], dim=-2))
    p_hat = world_end_effectors(x, lay, fmap.fk_end_effectors(x))[..., feet, :]
    d = stats.denormalize(torch.stack([prev_data, data], dim=-2))
    p = world_end_effectors(d, lay, d[..., lay.slice("ee_positions")].unflatten(-1, (-1, 3)))[..., feet, :]
    step = p[..., 1, :, :] - p[..., 0, :, :]
    step_error = (p_hat[..., 1, :, :] - p_hat[..., 0, :, :]) - step
    planted = (step.norm(dim=-1) < planted_step) & (p[..., 1, :, 2] < contact_height)
    weight = 1.0 + planted_boost * planted.to(step.dtype)
    height_error = p_hat[..., 1, :, 2] - p[..., 1, :, 2]
    return ((weight * step_error.square().sum(-1)).mean() + height_error.square().mean()) / fmap.creature_length**2


# ---- stage 2: the discriminator ---------------------------------------------------------------


def gradient_penalty(disc: torch.nn.Module, real: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """D's logits on real transitions [N, 2 Sr] and E‖∇_x D(x)‖² over them (Eq. 5, before the w_gp/2 weight)."""
    real = real.detach().requires_grad_(True)
    logits = disc(real)
    (grad,) = torch.autograd.grad(logits.sum(), real, create_graph=True)
    return logits, grad.square().sum(-1).mean()


def discriminator_loss(disc: torch.nn.Module, real: torch.Tensor, fake: torch.Tensor,
                       w_gp: float) -> tuple[torch.Tensor, Figures]:
    """D's loss (Eq. 5): softplus on the logits of ``real`` and of ``fake`` transitions [N, 2 Sr] (``fake``
    detached: only D learns here) plus ``w_gp``/2 × the gradient penalty on the real ones."""
    d_real, gp = gradient_penalty(disc, real)
    d_fake = disc(fake.detach())
    loss = F.softplus(-d_real).mean() + F.softplus(d_fake).mean() + 0.5 * w_gp * gp
    return loss, {"loss_d": loss.detach(), "d_gp": gp.detach(), "d_real_acc": (d_real > 0).float().mean(),
                  "d_fake_acc": (d_fake < 0).float().mean()}


def disc_logits(d_model: torch.nn.Module, disc: torch.nn.Module, transitions: torch.Tensor) -> torch.Tensor:
    """D's logits for the generator step, with D's parameters out of the graph (only G learns here)."""
    with frozen_parameters(disc):
        return d_model(transitions)


# ---- stage 2: the generator -------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GeneratorTerms:
    """What G's loss needs besides the batch, fixed for a run (:meth:`build`)."""

    config: RetargetConfig
    """The variant's retarget config: the terms' weights and switches."""
    fmap: FeatureMap
    """Ψ of both sides through FK."""
    hands: tuple[slice, ...]
    """Ψ's columns of the creature's hand and tool end-effectors (:func:`hand_blocks`)."""
    feet: tuple[int, ...]
    """The creature's feet among its end-effectors (:func:`~.model.foot_indices`)."""
    weights: torch.Tensor | None
    """Per-column factors on Ψ [11 + 3k] in G's feature term (:func:`feature_weights`; ``None``: all 1)."""
    human_scale: torch.Tensor | None
    """Per-column factors on the human's Ψ in G's terms (:func:`hand_spread_factors`; ``None``: off)."""
    fps: float
    """Frame rate of the states [Hz]."""
    note: str | None = None
    """What the hand spread chose, for the run's log (``None``: off)."""
    root_range: tuple[torch.Tensor, torch.Tensor] | None = None
    """The data's range (:data:`ROOT_RANGE_QUANTILES`) of Ψ's root height and orientation columns
    (:data:`ROOT_POSE_COLUMNS`), low and high [5] each, for :func:`root_range_term` (``None``: off)."""

    @property
    def plain(self) -> bool:
        """Whether G's feature term is the logged Eq. 9 itself (no second norm to compute)."""
        return self.weights is None and self.human_scale is None

    @staticmethod
    def build(cfg: RetargetConfig, fmap: FeatureMap, creature: Morphology, human_states: Sequence[np.ndarray],
              character_states: Sequence[np.ndarray], fps: float, device: torch.device) -> GeneratorTerms:
        """G's terms for ``creature`` under ``cfg``; the hand spread (``cfg.hand_spread``) is measured on the
        training ``human_states`` and ``character_states`` (raw, one array per clip)."""
        hands = hand_blocks(creature, fmap.creature_ees)
        human_scale, root, note = None, 1.0, None
        if cfg.hand_spread and hands:
            human_scale = hand_spread_factors(
                fmap.pairing.human_psi_of_states(np.concatenate(human_states), fmap.human_layout),
                fmap.pairing.creature_psi_of_states(np.concatenate(character_states), fmap.creature_layout),
                hands)
            root = spread_ground_motion_factor(human_scale, hands, cfg.hand_spread_root_limit)
            note = "hand spread (creature / human data): " + ", ".join(
                f"{fmap.creature_ees[(b.start - ROOT_FEATURE_DIM) // 3]} ×{human_scale[b.start]:.2f}" for b in hands
            ) + f"; ground motion ×{root:.2f}"
            human_scale = human_scale.to(device)
        weights = feature_weights(creature, fmap.creature_ees, cfg, ground_motion_factor=root)
        if weights is not None:
            weights = weights.to(device)
        root_range = None
        if cfg.root_range_weight > 0:
            states = np.concatenate(list(character_states))
            psi = np.asarray(fmap.pairing.creature_psi_of_states(states, fmap.creature_layout))
            lo, hi = np.quantile(psi[:, ROOT_POSE_COLUMNS], ROOT_RANGE_QUANTILES, axis=0)
            root_range = (torch.as_tensor(lo, dtype=torch.float32, device=device),
                          torch.as_tensor(hi, dtype=torch.float32, device=device))
        return GeneratorTerms(cfg, fmap, tuple(hands), tuple(foot_indices(creature)), weights, human_scale, fps, note,
                              root_range)


ROOT_POSE_COLUMNS = slice(0, 5)
"""Ψ's root height and root orientation (heading-frame quaternion) columns."""
ROOT_RANGE_QUANTILES = (0.005, 0.995)
"""The quantiles of the character data's Ψ that bound :func:`root_range_term` (ours: the data's range, less its
rarest 1 %)."""


def root_range_term(psi_r: torch.Tensor, low: torch.Tensor, high: torch.Tensor) -> torch.Tensor:
    """Mean over frames of the squared distance by which the root's height and orientation (Ψ columns
    :data:`ROOT_POSE_COLUMNS`) leave the character data's range [``low``, ``high``]: 0 inside it. A body whose
    hands or head cannot reach where the human's go is otherwise free to pitch its whole body up (a kangaroo standing
    on its tail) or over, which its data never does."""
    pose = psi_r[..., ROOT_POSE_COLUMNS]
    out = F.relu(pose - high) + F.relu(low - pose)
    return (out * out).sum(-1).mean()


def generator_loss(terms: GeneratorTerms, human: torch.Tensor, fixed: torch.Tensor, fake: torch.Tensor,
                   critic: Callable[[torch.Tensor], torch.Tensor]) -> tuple[torch.Tensor, Figures]:
    """G's loss: w_adv·L_adv (Eq. 6) + w_fea·L_fea (Eq. 9, with :class:`GeneratorTerms`' weights and hand-velocity
    term) + w_contact·:func:`contact_term`, each where its switch is on.

    Args:
        terms: The run's fixed terms.
        human: Normalised human windows [B, T, Sh].
        fixed: The generated character states with end-effectors from FK of the joints [B, T, Sr] (denormalised).
        fake: The transitions D is shown [B·T, 2 Sr].
        critic: D's logits with D's parameters frozen (:func:`disc_logits`); called only with ``adversarial``.

    Returns:
        The loss and ``loss_g``, ``loss_g_adv``, ``loss_g_fea``, ``loss_g_contact`` and the unweighted Eq. 9
        ``feature_loss``.
    """
    cfg, fmap = terms.config, terms.fmap
    psi_h = fmap.human_psi(human)
    psi_r = fmap.psi_of_fixed(fixed)
    fea = feature_loss(psi_h, psi_r)
    psi_hg = psi_h if terms.human_scale is None else psi_h * terms.human_scale  # what G's terms ask of the creature
    fea_g = fea if terms.plain else feature_loss(psi_hg, psi_r, weights=terms.weights)
    if cfg.hand_velocity_weight:
        fea_g = fea_g + cfg.hand_velocity_weight * hand_velocity_term(psi_hg, psi_r, terms.hands, terms.fps)
    g_adv = cfg.w_adv * F.softplus(-critic(fake)).mean() if cfg.adversarial else fea.new_zeros(())
    g_fea = cfg.w_fea * fea_g if cfg.feature_loss else fea.new_zeros(())
    g_contact = fea.new_zeros(())
    if cfg.w_contact > 0:
        g_contact = cfg.w_contact * contact_term(fmap, terms.feet, fixed, terms.fps)
    loss = g_adv + g_fea + g_contact
    figures: Figures = {}
    if terms.root_range is not None:  # beyond the paper (ours, off in the dataclass): a term of its own
        g_range = cfg.root_range_weight * root_range_term(psi_r, *terms.root_range)
        loss = loss + g_range
        figures["loss_g_range"] = g_range.detach()
    return loss, {"loss_g": loss.detach(), "loss_g_adv": g_adv.detach(), "loss_g_fea": g_fea.detach(),
                  "loss_g_contact": g_contact.detach(), "feature_loss": fea.detach(), **figures}


def hand_blocks(creature: Morphology, ees: Sequence[str]) -> list[slice]:
    """The columns of Ψ [11 + 3k] holding the creature's hand and tool end-effectors among ``ees``, one slice each."""
    roles = {e.name: e.role for e in creature.end_effectors}
    return [slice(ROOT_FEATURE_DIM + 3 * i, ROOT_FEATURE_DIM + 3 * i + 3) for i, name in enumerate(ees)
            if roles[name].on_arm]


def feature_weights(creature: Morphology, ees: Sequence[str], rc: RetargetConfig,
                    ground_motion_factor: float = 1.0) -> torch.Tensor | None:
    """Per-column factors on Ψ [11 + 3k] in G's feature term: ``rc.ground_motion_weight`` × ``ground_motion_factor``
    (:func:`spread_ground_motion_factor` with ``rc.hand_spread``) on the root's ground motion, ``rc.hand_weight`` on
    the blocks of the creature's hand and tool end-effectors ``ees``, 1 elsewhere (``None`` when all are 1: Eq. 9 as
    written)."""
    ground = rc.ground_motion_weight * ground_motion_factor
    if ground == 1.0 and rc.hand_weight == 1.0:
        return None
    w = torch.ones(feature_dim(len(ees)))
    w[list(GROUND_MOTION_FEATURES)] = ground
    for block in hand_blocks(creature, ees):
        w[block] = rc.hand_weight
    return w


def hand_spread_factors(psi_human: np.ndarray, psi_creature: np.ndarray, blocks: Sequence[slice]) -> torch.Tensor:
    """Beyond the paper: per-column factors [11 + 3k] on the human's Ψ in G's terms, each hand ``block`` scaled by the
    ratio of the two data sets' spreads of it — the RMS distance of the block from its mean over the frames of
    ``psi_creature`` [M, 11 + 3k] over that of ``psi_human`` [N, 11 + 3k] — and 1 elsewhere (and where the human's
    block never moves). A human hand moving through its usual range then asks the creature's hand to move through
    the creature data's own range, not through the human's range measured in the creature's body lengths: per body
    length a six-legged creature's claws spread 2–3× as far as a human's hands."""
    factors = torch.ones(psi_human.shape[-1], dtype=torch.float32)

    def spread(psi: np.ndarray, block: slice) -> float:
        part = psi[:, block]
        return float(np.sqrt(np.square(part - part.mean(axis=0)).sum(axis=1).mean()))

    for block in blocks:
        h = spread(psi_human, block)
        if h > 1e-9:  # rounding leaves a still hand's spread at ~1e-17 body lengths, not 0
            factors[block] = spread(psi_creature, block) / h
    return factors


def spread_ground_motion_factor(factors: torch.Tensor, blocks: Sequence[slice], limit: float) -> float:
    """The factor :attr:`RetargetConfig.hand_spread` puts on Ψ's ground-motion rows: the mean of the hand ``blocks``'
    :func:`hand_spread_factors` ``factors``, within [1, ``limit``] (1 for no blocks). The scaled hands' residual grows
    with their factors, and Eq. 9's norm shares one pull among all rows: the root's ground motion grows with them to
    keep its share.

    Raises:
        ConfigError: ``limit`` below 1.
    """
    if limit < 1.0:
        raise ConfigError(f"retarget.hand_spread_root_limit must be at least 1, got {limit}")
    if not blocks:
        return 1.0
    return min(max(float(np.mean([float(factors[b].mean()) for b in blocks])), 1.0), limit)


def hand_velocity_term(psi_human: torch.Tensor, psi_creature: torch.Tensor, blocks: Sequence[slice],
                       fps: float) -> torch.Tensor:
    """Beyond the paper: ‖(Ψ^h_t − Ψ^h_{t−1}) − (Ψ^r_t − Ψ^r_{t−1})‖ · fps over each hand block [body lengths/s],
    averaged over the frames of windows ``psi_*`` [B, T, 11 + 3k] and summed over the ``blocks``
    (:func:`hand_blocks`). Eq. 9 compares where a hand is; this, how it moves — blind to where each side's hand
    usually is, it asks an arm to rest while the human's hand rests (zero for no blocks or one frame)."""
    term = psi_human.new_zeros(())
    if psi_human.shape[-2] < 2:
        return term
    for block in blocks:
        step = psi_human[..., 1:, block] - psi_human[..., :-1, block]
        step = step - (psi_creature[..., 1:, block] - psi_creature[..., :-1, block])
        term = term + fps * step.norm(dim=-1).mean()
    return term


def contact_term(fmap: FeatureMap, feet: Sequence[int], fixed_states: torch.Tensor, fps: float) -> torch.Tensor:
    """Beyond the paper: foot sliding [m/s] + 10 × ground penetration [m] of the generated motion ``fixed_states``
    [B, T, Sr] (denormalised), through FK (zero without ``feet``).

    Feet are placed on the window's integrated root path (:func:`~morphkit.motion.world_end_effectors`),
    so a planted foot must stay put while the body moves.
    """
    if not feet:
        return fixed_states.new_zeros(())
    ee = world_end_effectors(fixed_states, fmap.creature_layout, fmap.fk_end_effectors(fixed_states))
    slide = mt.sliding_speed(ee, fps, feet=list(feet)).mean()
    pen = mt.penetration_depth(ee.flatten(0, 1), feet=list(feet)).mean()
    return slide + 10.0 * pen
