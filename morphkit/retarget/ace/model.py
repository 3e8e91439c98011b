"""ACE's networks and its feature function on generated states.

* :func:`build_vae` — encoder c and MANN prior π (§4, §6.4), from :mod:`morphkit.retarget.ace.networks`.
* :class:`Generator` — G(x^h_t, x^r_{t-1}) → ẑ_t, an MLP with LeakyReLU (§5.1, §6.4).
* :class:`Discriminator` — D(x^r_{t-1}, x^r_t) → logit, an MLP with SiLU (§5.2, §6.4).
* :func:`rollout` — G and π rolled over a human clip (Eq. 4): training and retargeting alike.
* :class:`FeatureMap` — Ψ (§6.3) of human states and of generated character states, with the
  character's end-effectors taken from **morphkit's FK of the generated joint coordinates** (through
  :mod:`morphkit.torch`), so what the feature loss scores is what is exported.

All networks read and write *normalised* states (z-scores with the run's statistics).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

import morphkit.torch as mt
from morphkit.graph import BaseType, EndEffectorRole, Morphology
from morphkit.motion import NormStats, Pairing, StateLayout, compiled_model
from morphkit.retarget.ace.config import PriorConfig, RetargetConfig
from morphkit.retarget.ace.networks import MotionEncoder, MotionPrior, MotionVAE
from morphkit.retarget.networks import MLP

__all__ = ["Discriminator", "FeatureMap", "Generator", "build_vae", "foot_indices", "rollout"]


def foot_indices(creature: Morphology) -> list[int]:
    """Indices of the creature's end-effectors whose role is ``foot``."""
    return [i for i, e in enumerate(creature.end_effectors) if e.role == EndEffectorRole.FOOT]


def build_vae(state_dim: int, cfg: PriorConfig) -> MotionVAE:
    """The encoder c and MANN prior π of ``cfg`` for states of ``state_dim``."""
    encoder = MotionEncoder(state_dim, cfg.latent, hidden=cfg.encoder_hidden, activation="leaky_relu")
    prior = MotionPrior(state_dim, cfg.latent, hidden=cfg.prior_hidden, expert_count=cfg.experts,
                        gate_hidden=cfg.gate_hidden, dropout=cfg.dropout)
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


class Discriminator(nn.Module):
    """D(x^r_{t-1}, x^r_t) → logit of "a transition of the character's data" (σ(logit) ∈ [0, 1])."""

    def __init__(self, character_dim: int, cfg: RetargetConfig) -> None:
        super().__init__()
        self.mlp = MLP(2 * character_dim, cfg.discriminator_hidden, 1, activation="silu")

    def forward(self, transition: torch.Tensor) -> torch.Tensor:
        """``transition`` [..., 2 Sr] (``[x_{t-1}, x_t]``) → logits [...]."""
        return self.mlp(transition)[..., 0]


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


def rollout(
    generator: torch.nn.Module,
    prior: torch.nn.Module,
    x_h: torch.Tensor,
    start: torch.Tensor,
    *,
    tbptt: int = 0,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Autoregressive retargeting: ẑ_t = G(x^h_t, x^r_{t-1}), x̂^r_t = π(ẑ_t, x^r_{t-1}) (Eq. 4).

    Args:
        x_h: Normalised human states [B, T, Sh].
        start: Normalised character start states x^r_0 [B, Sr].
        tbptt: Detach the carried state every this many frames (0: never).

    Returns:
        ``(previous, generated)``, each [B, T, Sr]: the states each step was conditioned on, and its output.
    """
    x_prev, prevs, outs = start, [], []
    for t in range(x_h.shape[1]):
        if tbptt and t and t % tbptt == 0:
            x_prev = x_prev.detach()
        x = prior(generator(x_h[:, t], x_prev), x_prev)
        prevs.append(x_prev)
        outs.append(x)
        x_prev = x
    return torch.stack(prevs, dim=1), torch.stack(outs, dim=1)
