"""ACE's networks and its feature function on generated states.

* :func:`build_vae` — encoder c and MANN prior π (§4, §6.4), from :mod:`morphkit.retarget.ace.networks`.
* :class:`Generator` — G(x^h_t, x^r_{t-1}) → ẑ_t, an MLP with LeakyReLU (§5.1, §6.4).
* :class:`Discriminator` — D(x^r_{t-1}, x^r_t) → logit, an MLP with SiLU (§5.2, §6.4).
* :class:`FeatureMap` — Ψ (§6.3) of human states and of generated character states, with the
  character's end-effectors taken from **morphkit's FK of the generated joint coordinates** (through
  :mod:`morphkit.torch`), so what the feature loss scores is what is exported.
* :class:`StateCompletion` — π's output made a whole state: stance flags from its logits, derived
  slots from FK and the previous state, the root height and step from the feet (``PriorConfig.contact_flags``,
  ``PriorConfig.derive_slots``, ``PriorConfig.root_height_from_feet``, ``PriorConfig.root_step_from_feet``).

All networks read and write *normalised* states (z-scores with the run's statistics).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

import morphkit.torch as mt
from morphkit.graph import BaseType, EndEffectorRole, Morphology
from morphkit.motion import (
    NormStats,
    Pairing,
    StateLayout,
    compiled_model,
    derive_character_state,
    world_end_effectors,
)
from morphkit.retarget.ace.config import PriorConfig, RetargetConfig
from morphkit.retarget.ace.networks import MotionEncoder, MotionPrior, MotionVAE
from morphkit.retarget.networks import MLP
from morphkit.rotations import quat_from_yaw, quat_normalize, quat_rotate, yaw_from_quat

__all__ = ["FOOT_HEIGHT_SCALE", "FOOT_STEP_SCALE", "Discriminator", "FeatureMap", "Generator", "StateCompletion",
           "build_vae", "foot_indices", "foot_view"]


def foot_indices(creature: Morphology) -> list[int]:
    """Indices of the creature's end-effectors whose role is ``foot``."""
    return [i for i, e in enumerate(creature.end_effectors) if e.role == EndEffectorRole.FOOT]


def build_vae(state_dim: int, cfg: PriorConfig) -> MotionVAE:
    """The encoder c and MANN prior π of ``cfg`` for states of ``state_dim``."""
    encoder = MotionEncoder(state_dim, cfg.latent, hidden=cfg.encoder_hidden, activation="leaky_relu")
    prior = MotionPrior(state_dim, cfg.latent, hidden=cfg.prior_hidden, expert_count=cfg.experts,
                        gate_hidden=cfg.gate_hidden, dropout=cfg.dropout, residual=cfg.residual)
    return MotionVAE(encoder, prior)


class Generator(nn.Module):
    """G(x^h_t, x^r_{t-1}) → ẑ_t (normalised states in, latent out).

    With ``cfg.latent_bound`` b > 0 the MLP's output g is squashed into the prior's latent range,
    ẑ = μ + b·σ·tanh(g/b) (μ, σ: buffers set by :meth:`set_latent_range`, saved with G), so ẑ stays
    within b standard deviations of what the encoder produces on the data whatever g is.
    """

    def __init__(self, human_dim: int, character_dim: int, latent: int, cfg: RetargetConfig) -> None:
        super().__init__()
        self.mlp = MLP(human_dim + character_dim, cfg.generator_hidden, latent, activation="leaky_relu")
        self.bound = float(cfg.latent_bound)
        self.register_buffer("z_mean", torch.zeros(latent))
        self.register_buffer("z_std", torch.ones(latent))

    @torch.no_grad()
    def set_latent_range(self, mean: torch.Tensor, std: torch.Tensor) -> None:
        """The encoder's latent mean and standard deviation on the data [Z] (what the bound is relative to)."""
        self.z_mean.copy_(mean)
        self.z_std.copy_(std)

    def forward(self, x_h: torch.Tensor, x_prev: torch.Tensor) -> torch.Tensor:
        """``x_h`` [..., Sh], ``x_prev`` [..., Sr] → ẑ [..., Z]."""
        return self.latent(self.mlp(torch.cat([x_h, x_prev], dim=-1)))

    def latent(self, g: torch.Tensor) -> torch.Tensor:
        """The MLP's output ``g`` [..., Z] → ẑ [..., Z], squashed into the latent range (unbounded: ``g``)."""
        if self.bound <= 0:
            return g
        return self.z_mean + self.bound * self.z_std * torch.tanh(g / self.bound)


FOOT_STEP_SCALE = 0.01
"""[m]: a foot's ground step enters D as tanh(step / this) (ours: a 7 mm slide reads 0.6, a swing ≈ 1)."""
FOOT_HEIGHT_SCALE = 0.05
"""[m]: a foot's height enters D as tanh(height / this) (ours: GMD's 5 cm contact height)."""


class Discriminator(nn.Module):
    """D(x^r_{t-1}, x^r_t) → logit of "a transition of the character's data" (σ(logit) ∈ [0, 1]).

    With ``foot_count`` F > 0 its input also holds :func:`foot_view` of the transition (3F numbers).
    """

    def __init__(self, character_dim: int, cfg: RetargetConfig, foot_count: int = 0) -> None:
        super().__init__()
        self.mlp = MLP(2 * character_dim + 3 * foot_count, cfg.discriminator_hidden, 1, activation="silu")

    def forward(self, transition: torch.Tensor) -> torch.Tensor:
        """``transition`` [..., 2 Sr (+ 3F)] (``[x_{t-1}, x_t(, feet)]``) → logits [...]."""
        return self.mlp(transition)[..., 0]


def foot_view(layout: StateLayout, feet: list[int], prev: torch.Tensor, cur: torch.Tensor) -> torch.Tensor:
    """What D sees of the feet over transitions ``prev`` → ``cur`` (denormalised states [..., Sr] whose ee
    block is what D is shown): per foot ``tanh(step_xy / FOOT_STEP_SCALE)`` and ``tanh(z / FOOT_HEIGHT_SCALE)``
    in the transition's ground frame [..., 3F] (steps first, then heights)."""
    x = torch.stack([prev, cur], dim=-2)
    ee = x[..., layout.slice("ee_positions")].unflatten(-1, (-1, 3))
    p = world_end_effectors(x, layout, ee)[..., feet, :]
    step = p[..., 1, :, :2] - p[..., 0, :, :2]
    return torch.cat([torch.tanh(step / FOOT_STEP_SCALE).flatten(-2), torch.tanh(p[..., 1, :, 2] / FOOT_HEIGHT_SCALE)],
                     dim=-1)


@dataclass(eq=False)
class FeatureMap:
    """Ψ of both sides, paired by the end-effector mapping (creature ee i ↔ human ee i).

    Attributes:
        creature: The character.
        creature_layout, human_layout: State layouts.
        creature_stats, human_stats: Normalisation statistics of the two state sets.
        pairing: Mapped end-effectors, pair by pair, and the body lengths the two Ψ divide by.
    """

    creature: Morphology
    creature_layout: StateLayout
    human_layout: StateLayout
    creature_stats: NormStats
    human_stats: NormStats
    pairing: Pairing

    @property
    def creature_ees(self) -> tuple[str, ...]:
        return self.pairing.creature_ees

    @property
    def human_ees(self) -> tuple[str, ...]:
        return self.pairing.human_ees

    @property
    def creature_length(self) -> float:
        return self.pairing.creature_length

    @property
    def human_length(self) -> float:
        return self.pairing.human_length

    def __post_init__(self) -> None:
        self.model = compiled_model(self.creature)
        self._ee_slice = self.creature_layout.slice("ee_positions")
        self._joint_slice = self.creature_layout.slice("joint_q")

    def human_psi(self, x_h: torch.Tensor) -> torch.Tensor:
        """Ψ of normalised human states [..., Sh] → [..., 11 + 3k]."""
        return self.pairing.human_psi_of_states(self.human_stats.denormalize(x_h), self.human_layout)

    def local_q(self, x: torch.Tensor) -> torch.Tensor:
        """Coordinates [..., C] that put the root at the heading frame's origin with the state's tilt and joints.

        Heading-frame end-effectors depend only on the root's tilt and the joints, so FK of these
        coordinates gives the state's ee block (denormalised state ``x`` [..., Sr] in).
        """
        m, lay = self.creature, self.creature_layout
        joints = x[..., self._joint_slice]
        if m.base == BaseType.FLOATING:
            zero = torch.zeros_like(x[..., :2])
            return torch.cat([zero, x[..., lay.slice("root_height")], x[..., lay.slice("root_orientation")], joints],
                             dim=-1)
        if m.base in (BaseType.PLANAR, BaseType.WHEELED):
            return torch.cat([torch.zeros_like(x[..., :3]), joints], dim=-1)
        return joints

    def fk_end_effectors(self, x: torch.Tensor) -> torch.Tensor:
        """Heading-frame end-effectors [..., E, 3] [m] of denormalised states [..., Sr], through the Warp FK."""
        q = self.local_q(x)
        lead = q.shape[:-1]
        ee = mt.end_effector_positions(self.model, q.reshape(-1, q.shape[-1]).contiguous(), frame="heading")
        return ee.reshape(*lead, -1, 3)

    def creature_with_fk(self, x_norm: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Denormalised states whose ee block is the FK of their joints, and the gap [..., E] [m]
        between the state's own ee slots and FK."""
        x = self.creature_stats.denormalize(x_norm)
        ee = self.fk_end_effectors(x)
        own = x[..., self._ee_slice].reshape(ee.shape)
        fixed = torch.cat([x[..., : self._ee_slice.start], ee.flatten(-2), x[..., self._ee_slice.stop :]], dim=-1)
        return fixed, (own - ee).detach().norm(dim=-1)

    def psi_of_fixed(self, fixed: torch.Tensor) -> torch.Tensor:
        """Ψ of denormalised states whose ee block is already FK's (:meth:`creature_with_fk`)."""
        return self.pairing.creature_psi_of_states(fixed, self.creature_layout)


STANCE_BAND = 0.01
"""[m] (ours): a foot this close to the ground holds the root step (``StateCompletion.step_feet``) with weight ½ a
frame; the synthesised data's stance feet stand at 0 and their swing feet above 3.7 cm, so any band in between
gives their steps exactly."""
STANCE_SOFTNESS = 0.002
"""[m] (ours): width of the sigmoid around ``STANCE_BAND``."""
OWN_STEP_WEIGHT = 0.01
"""Weight of π's own root step against the feet's (``StateCompletion.step_feet``): only where no foot is down."""

VELOCITY_SLOTS = ("root_linear_velocity", "root_angular_velocity", "ee_velocities")
"""The character state's velocity fields (derived from positions when ``PriorConfig.derive_slots``)."""


@dataclass(eq=False)
class StateCompletion:
    """π's raw output made a whole state (normalised states in and out, any leading shape).

    * ``contacts``: π's output in the ``foot_contacts`` slots is a logit per foot; the state carries the
      flag ``1[σ(logit) > 0.5]`` with the straight-through gradient of σ(logit) (the data's flags are
      0/1, so D cannot tell π's by their softness).
    * ``derive``: the root orientations are made unit, the end-effectors are FK of the tilt and joints
      (:meth:`FeatureMap.fk_end_effectors`), and the velocities follow from them and the previous state
      (:func:`~morphkit.motion.derive_character_state`).
    * ``ground_feet``: the root height is minus the lowest foot's heading-frame height (FK of the tilt and
      joints), so that foot stands on the ground (``PriorConfig.root_height_from_feet``; nothing without feet).
    * ``step_feet``: the root's ground step is the one that keeps the feet on the ground still — the mean over
      feet of the step that holds each where it was at t − 1 (FK of both frames' tilt and joints), weighed by
      how surely the foot is down at both frames, σ((``STANCE_BAND`` − z)/``STANCE_SOFTNESS``) per frame, with
      π's own step weighing ``OWN_STEP_WEIGHT`` (it is the step where no foot is down); the root's linear
      velocity is that step and the height change times the frame rate (``PriorConfig.root_step_from_feet``).

    With none, the output is π's as it is.
    """

    features: FeatureMap
    fps: float
    derive: bool
    contacts: bool
    ground_feet: bool = False
    step_feet: bool = False

    def __post_init__(self) -> None:
        lay = self.features.creature_layout
        feet = foot_indices(self.features.creature)
        self._feet = feet if self.ground_feet and feet else None
        self._step_feet = feet if self.step_feet and feet else None
        self._height = lay.slice("root_height")
        self._flags = lay.slice("foot_contacts") if self.contacts else None
        mask = torch.ones(lay.dim)
        skip = (["foot_contacts"] if self.contacts else []) + (list(VELOCITY_SLOTS) if self.derive else [])
        skip += ["root_linear_velocity"] if self._step_feet is not None and not self.derive else []
        for name in skip:
            mask[lay.slice(name)] = 0.0
        self.regression_mask = mask
        """[D] 1 on the slots π's reconstruction loss weighs: not the stance flags (a logistic loss), nor, when
        derived, the velocities (differences of predicted positions times the frame rate: their error is
        the positions' error ×30, and it would drown the rest; the positions carry it)."""

    def __call__(self, prev: torch.Tensor, raw: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """``prev`` (x_{t-1}) and π's output ``raw`` [..., D] → (completed x_t [..., D], stance logits [..., F]
        or ``None``)."""
        if not (self.derive or self._flags is not None or self._feet is not None or self._step_feet is not None):
            return raw, None
        stats, lay = self.features.creature_stats, self.features.creature_layout
        x = stats.denormalize(raw)
        ee = None
        logits = None
        if self._flags is not None:
            logits = raw[..., self._flags]
            p = torch.sigmoid(logits)
            x = lay.replace(x, {"foot_contacts": (p > 0.5).to(p.dtype) + p - p.detach()})
        if self.derive:
            unit = torch.nn.functional.normalize(x[..., lay.slice("root_orientation")], dim=-1)
            x = lay.replace(x, {"root_orientation": unit})
        if self.derive or self._feet is not None or self._step_feet is not None:
            ee = self.features.fk_end_effectors(x)  # heading frame: independent of the root height
        if self._feet is not None:
            assert ee is not None
            x = lay.replace(x, {"root_height": -ee[..., self._feet, 2].amin(dim=-1, keepdim=True)})
        x_prev = stats.denormalize(prev) if self.derive or self._step_feet is not None else None
        if self._step_feet is not None:
            assert ee is not None and x_prev is not None
            x = self._step_of_feet(x_prev, x, ee[..., self._step_feet, :])
        if self.derive:
            assert ee is not None and x_prev is not None
            x = derive_character_state(x_prev, x, ee, self.fps, lay)
        return stats.normalize(x), logits

    def _step_of_feet(self, prev: torch.Tensor, x: torch.Tensor, feet: torch.Tensor) -> torch.Tensor:
        """``x`` (denormalised) with the root step and linear velocity of the feet on the ground (``step_feet``);
        ``feet`` [..., F, 3]: heading-frame FK of ``x``'s feet."""
        lay = self.features.creature_layout
        h, disp = self._height, lay.slice("root_displacement")
        feet_prev = self.features.fk_end_effectors(prev)[..., self._step_feet, :]
        # frame t−1's feet in frame t's heading axes (as derive_character_state turns them)
        turn = quat_from_yaw(yaw_from_quat(quat_normalize(x[..., lay.slice("previous_root_orientation")])))
        hold = quat_rotate(turn[..., None, :], feet_prev)[..., :2] - feet[..., :2]  # [..., F, 2]
        z_prev = prev[..., h] + feet_prev[..., 2]
        z_cur = x[..., h] + feet[..., 2]
        down = torch.sigmoid((STANCE_BAND - z_prev) / STANCE_SOFTNESS) * torch.sigmoid(
            (STANCE_BAND - z_cur) / STANCE_SOFTNESS)
        down = down.detach()[..., None]  # which feet hold is decided, not optimised: lifting a foot frees the root
        step = ((down * hold).sum(-2) + OWN_STEP_WEIGHT * x[..., disp]) / (down.sum(-2) + OWN_STEP_WEIGHT)
        velocity = torch.cat([step, x[..., h] - prev[..., h]], dim=-1) * self.fps
        return lay.replace(x, {"root_displacement": step, "root_linear_velocity": velocity})

    def flags_of(self, x_norm: torch.Tensor) -> torch.Tensor:
        """The 0/1 stance flags [..., F] of normalised states."""
        assert self._flags is not None
        return self.features.creature_stats.denormalize(x_norm)[..., self._flags].round()
