"""ACE's configuration (Li et al. 2023, §4–7): one frozen dataclass per stage, and the presets.

Sizes, losses and weights the paper gives are its values at ``paper``; what it leaves open (β, schedules, learning
rates, ``w_adv``, the rollout window, start states) is morphkit's choice, each field saying where it comes from. The
measurements behind each choice are in docs/experiments/. ``--set prior.foot_weight=0 --set
retarget.discriminate_exported=false --set retarget.hand_velocity_weight=0 --set retarget.w_gp=0.1`` trains the
paper's ACE (``w_adv`` is ours).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from morphkit.contact_rules import PRIOR_PLANTED_STEP
from morphkit.retarget.training_data import DataConfig

__all__ = ["PRESETS", "AceConfig", "DataConfig", "PriorConfig", "RetargetConfig", "preset"]


@dataclass(frozen=True)
class PriorConfig:
    """The motion prior: encoder c(x_{t-1}, x_t) → z and MANN π(z, x_{t-1}) → x_t (§4, §6.4)."""

    retired: ClassVar[dict[str, Any]] = {
        "residual": False, "contact_flags": False, "contact_weight": ..., "derive_slots": False,
        "root_height_from_feet": False, "root_step_from_feet": False,
    }
    """Deleted experiments and their off values: a run's config naming them is read where they are off
    (docs/experiments/bringing-back.md; ``...``: inert at any value)."""

    latent: int = 32
    """Latent size Z (§6.4)."""
    encoder_hidden: tuple[int, ...] = (512, 512, 512, 512)
    """Encoder layer widths (§6.4)."""
    prior_hidden: tuple[int, ...] = (512, 512)
    """π's expert layer widths (§6.4)."""
    experts: int = 8
    """π's experts (§6.4, MANN)."""
    gate_hidden: tuple[int, ...] = (64, 64)
    """π's gating network widths (§6.4)."""
    dropout: float = 0.3
    """Dropout in π (§6.4)."""
    kl_beta: float = 0.1
    """β of the VAE's KL term, averaged per latent element. Ours: MotionVAE's 1 collapses z on these states
    (docs/experiments/kl-beta.md)."""
    foot_weight: float = 30.0
    """Weight of the prior's foot term: the feet's ground-frame step and height through FK of π's joints against the
    data's [body lengths²]. Ours (0: the paper's prior; docs/experiments/prior-foot-term.md)."""
    foot_planted_boost: float = 10.0
    """Extra weight of the foot term's step error where the data's foot is planted (ours, as motion diffusion)."""
    planted_step: float = PRIOR_PLANTED_STEP
    """A data foot is planted over a transition when its ground step is below this [m] and it is below the contact
    rule's ``prior planted`` height (:data:`~morphkit.contact_rules.PRIOR_PLANTED`: 2 mm, 2 cm)."""
    rollout: int = 8
    """Steps of a scheduled-sampling rollout (MotionVAE: 8)."""
    teacher_fraction: float = 0.15
    """Fraction of the epochs with teacher forcing only (MotionVAE: 20 of 140)."""
    ramp_fraction: float = 0.15
    """Fraction of the epochs over which the own-prediction probability ramps 0 → 1 (MotionVAE's schedule)."""
    epochs: int = 140
    """Epochs (MotionVAE: 140)."""
    steps_per_epoch: int = 400
    """Optimiser steps per epoch (ours)."""
    batch_size: int = 64
    """Windows per step (ours)."""
    lr: float = 1e-3
    """Adam's first learning rate (ours; ``paper``: MotionVAE's 1e-4)."""
    lr_final: float = 1e-5
    """Learning rate at the last epoch, decayed linearly (MotionVAE's 1e-4 → 1e-7 scaled up: our presets are short)."""


@dataclass(frozen=True)
class RetargetConfig:
    """The adversarial correspondence embedding: G(x^h_t, x^r_{t-1}) → ẑ, D(x^r_{t-1}, x^r_t) (§5, §6.4)."""

    retired: ClassVar[dict[str, Any]] = {"ground_drift_weight": 0.0, "discriminator_feet": False,
                                         "lr_final_fraction": 1.0}
    """Deleted experiments and their off values (as :attr:`PriorConfig.retired`)."""

    generator_hidden: tuple[int, ...] = (512, 512, 512)
    """G's layer widths (§6.4)."""
    discriminator_hidden: tuple[int, ...] = (512, 512, 512)
    """D's layer widths (§6.4)."""
    w_adv: float = 0.3
    """Weight of G's adversarial term (the paper gives none; ours: docs/experiments/adversarial-weights.md)."""
    w_fea: float = 1.0
    """Weight of G's feature term L_fea (Eq. 9)."""
    ground_motion_weight: float = 1.0
    """Factor on Ψ's root motion over the ground (``morphkit.motion.GROUND_MOTION_FEATURES``) in G's feature term;
    ours, 1: Eq. 9 (docs/experiments/ground-motion-weight.md). The logged L_fea stays Eq. 9."""
    hand_velocity_weight: float = 0.3
    """Weight of G's hand-velocity term (:func:`~morphkit.retarget.ace.losses.hand_velocity_term`): how each hand or
    tool moves, frame to frame, against its human hand's motion, so a hand the human rests asks for an arm at rest;
    ours, 0.3, chosen on the development split (0: Eq. 9 alone; docs/experiments/restless-arms.md). The logged L_fea
    stays Eq. 9."""
    hand_spread: bool = False
    """Scale the human's hand blocks of Ψ in G's feature and hand-velocity terms by the ratio of the two data sets'
    spreads of them (:func:`~morphkit.retarget.ace.losses.hand_spread_factors`), so each body's hand moves through its
    own range, and the ground-motion rows by the factors' mean, from 1 up to ``hand_spread_root_limit``, to keep the
    root's share; ours, False in every preset: Eq. 9's body lengths on both sides (on, it lowered the matched FID of
    the bodies whose hands spread wider than a human's, but cost the main job's hand on mocap it never saw;
    docs/experiments/hand-spread.md). The logged L_fea stays Eq. 9."""
    hand_spread_root_limit: float = 2.0
    """Largest factor ``hand_spread`` puts on the ground-motion rows (ours: ×2 was measured with hands scaled ×2.1–2.7;
    docs/experiments/hand-spread.md)."""
    hand_weight: float = 1.0
    """Factor on Ψ's hand and tool end-effector blocks in G's feature term; ours, 1: Eq. 9
    (docs/experiments/hand-weight.md)."""
    w_gp: float = 1.0
    """Gradient-penalty weight on real transitions (Eq. 5 gives 0.1, kept by ``paper``; ours:
    docs/experiments/adversarial-weights.md)."""
    discriminate_exported: bool = True
    """D judges the exported motion: the end-effectors of FK of the generated joints, G's adversarial gradient
    through FK (ours; False: the paper's D)."""
    root_range_weight: float = 0.0
    """Weight of G's root-range term (:func:`~morphkit.retarget.ace.losses.root_range_term`): the root's height and
    orientation held within the character data's range; ours, 0: the paper's G; ``quick`` and ``default`` 10 (a
    kangaroo whose short arms could not reach the human's hands stood its body up on its tail;
    docs/experiments/inside-the-data.md)."""
    w_contact: float = 0.0
    """Weight of foot sliding [m/s] + 10 × penetration [m] of the FK'd motion in G's loss; beyond the paper, set by
    ``AceVariant`` (ACE+contact only)."""
    latent_bound: float = 3.0
    """Bound b of G's output, ẑ = μ + b·σ·tanh(G/b) with the encoder's posterior mean and deviation [σ]; ours, 0:
    the paper's unbounded G (docs/experiments/latent-bound.md)."""
    feature_loss: bool = True
    """Train with w_fea·L_fea (False: ACEwoFea; set by ``AceVariant``)."""
    adversarial: bool = True
    """Train with w_adv·L_adv and D (False: ACEwoAdv; set by ``AceVariant``)."""
    validation_share: float = 0.0
    """Share of the human clips held out to choose G's epoch by L_fea; ours, 0: the last step's G, as the paper
    (docs/experiments/validation-share.md)."""
    choose_inside_data: bool = False
    """Choose G's epoch among those whose held-out output lies inside the creature's data (matched FID at most
    ``inside_fid``, DIV within ``inside_div_band`` of the data's), by the lowest L_fea; when none does, the epoch
    nearest the data in units of those bounds. Ours, False: the lowest L_fea alone; ``quick`` and ``default`` set it
    (docs/experiments/inside-the-data.md)."""
    inside_fid: float = 3.0
    """Largest matched FID of an epoch inside the data (ours: issue 65's target)."""
    inside_div_band: tuple[float, float] = (0.5, 2.0)
    """DIV of an epoch inside the data, as multiples of the data's matched DIV (ours: issue 65's target)."""
    window: int = 32
    """Human frames per training rollout (ours)."""
    tbptt: int = 8
    """Truncated backpropagation: the carried character state is detached every this many frames (ours)."""
    epochs: int = 60
    """Epochs (ours)."""
    steps_per_epoch: int = 200
    """G steps per epoch (ours)."""
    batch_size: int = 64
    """Windows per step (ours)."""
    lr_generator: float = 1e-4
    """G's Adam learning rate (§6.4)."""
    lr_discriminator: float = 1e-4
    """D's Adam learning rate (§6.4)."""
    generator_average: float = 0.0
    """Decay of an exponential moving average of G's weights, the G that retargets; ours, 0: the last step's G
    (docs/experiments/generator-average.md)."""
    betas: tuple[float, float] = (0.5, 0.999)
    """Adam's betas for G and D (ASE's GAN stage)."""
    discriminator_steps: int = 1
    """D updates per G update (ours)."""


@dataclass(frozen=True)
class AceConfig:
    """Everything one ACE run needs; saved as ``config.yaml`` in its run folders."""

    seed: int = 0
    """Seed of the run's random stream."""
    kl_only_mapping: bool = False
    """Map end-effectors by KL alone (the paper's Eq. 11); default (ours): KL among end-effectors of a compatible
    role (foot → foot, hand/tool → hand), since KL alone mapped a quadruped's feet to a human's hands."""
    pair_tails: bool = False
    """Map a tail's end-effector (a tool named like a tail, or on the midline behind the body at rest) to a human
    end-effector as KL would (a hand, within roles); ours, False: §6.1's Ψ has foot, hand and head blocks and a tail
    is none of them, so it is left out of Ψ, to the prior and D (docs/experiments/inside-the-data.md)."""
    active_hand: bool = True
    """A lone hand or tool follows whichever human hand moves (ours, :data:`~morphkit.motion.ACTIVE_HAND`); False:
    the one KL prefers, which misses a human waving with the other hand."""
    centre_features: bool = True
    """Centre each side's Ψ end-effector blocks and root height on its data set's mean; ours, False: the paper's Ψ
    (docs/experiments/centre-features.md)."""
    human_std_floor: float = 0.5
    """Floor of each human state dimension's normalising std, as a fraction of its field's RMS (0: none, the data's
    own std, as runs before it). Ours: G never sees a dimension the training humans barely move scaled into
    hundreds of deviations when another human moves it (docs/experiments/human-std-floor.md)."""
    data: DataConfig = field(default_factory=DataConfig)
    """Where the training states come from."""
    prior: PriorConfig = field(default_factory=PriorConfig)
    """The motion prior stage."""
    retarget: RetargetConfig = field(default_factory=RetargetConfig)
    """The retargeting stage."""


def _small(width: int, experts: int) -> tuple[PriorConfig, RetargetConfig]:
    return (
        PriorConfig(encoder_hidden=(width,) * 3, prior_hidden=(width, width), experts=experts,
                    gate_hidden=(32, 32)),
        RetargetConfig(generator_hidden=(width,) * 3, discriminator_hidden=(width,) * 3),
    )


_SMOKE_PRIOR, _SMOKE_RET = _small(64, 2)
_QUICK_PRIOR, _QUICK_RET = _small(128, 4)
_DEFAULT_PRIOR, _DEFAULT_RET = _small(256, 4)

PRESETS: dict[str, AceConfig] = {
    # ≤ 60 s on 2 cores: for tests.
    "smoke": AceConfig(
        data=DataConfig(character_frames=1_200, human_frames=600),
        prior=replace(_SMOKE_PRIOR, epochs=3, steps_per_epoch=10, batch_size=32, rollout=4),
        retarget=replace(_SMOKE_RET, epochs=3, steps_per_epoch=6, batch_size=8, window=8, tbptt=4),
    ),
    # The whole main job ≤ 5 min on 2 cores, from a cold cache. G's learning rate doubled for its 240 steps: its
    # feature loss was still falling when D took over. Ground motion ×4 and hand ×2: docs/experiments/hand-weight.md.
    # Turns to ±3 rad/s: docs/experiments/turn-range.md.
    "quick": AceConfig(
        data=DataConfig(character_frames=12_000, human_frames=3_000, arm_hang_share=0.3, human_mirror=True,
                        yaw_rate=3.0),
        prior=replace(_QUICK_PRIOR, epochs=8, steps_per_epoch=60, batch_size=64),
        retarget=replace(_QUICK_RET, epochs=8, steps_per_epoch=30, batch_size=32, window=24, generator_average=0.95,
                         lr_generator=2e-4, ground_motion_weight=4.0, hand_weight=2.0, validation_share=0.05,
                         choose_inside_data=True, root_range_weight=10.0),
    ),
    # Quality runs: prior + one retargeter ≤ 20 min on 2 cores. Hanging arms, G's average and mirrored clips:
    # docs/experiments/generator-average.md; ground motion ×2: ground-motion-weight.md; 40 epochs, the epoch chosen
    # on 5 % held out: validation-share.md.
    "default": AceConfig(
        data=DataConfig(character_frames=60_000, arm_hang_share=0.3, human_mirror=True, yaw_rate=3.0),
        prior=replace(_DEFAULT_PRIOR, epochs=16, steps_per_epoch=100, batch_size=128),
        retarget=replace(_DEFAULT_RET, epochs=40, steps_per_epoch=40, batch_size=64, generator_average=0.95,
                         ground_motion_weight=2.0, validation_share=0.05, choose_inside_data=True,
                         root_range_weight=10.0),
    ),
    # The paper's sizes (§6.4, §7.1).
    "paper": AceConfig(prior=PriorConfig(lr=1e-4, lr_final=1e-7), retarget=RetargetConfig(w_gp=0.1)),
}


def preset(name: str) -> AceConfig:
    """The preset ``name`` (one of :data:`PRESETS`).

    Raises:
        ConfigError: an unknown name, listing the known ones.
    """
    from morphkit.retarget.config import preset_config

    return preset_config(PRESETS, name)
