"""ACE's motion prior (ACE §4, Eq. 1–2; §6.4): the MANN mixture of experts, the encoder, the VAE.

ACE pre-trains, per character, an encoder $c(x_{t-1}, x_t) \\to z_t$ and a prior
$\\pi(z_t, x_{t-1}) \\to x_t$ as a VAE in the manner of MotionVAE (Ling et al. 2020), with a
Mode-Adaptive Neural Network (MANN, Zhang et al. 2018) as $\\pi$. Shapes use ``B`` for the
batch (any leading dimensions are accepted and kept), ``S`` for the state size, ``Z`` for the
latent size (32 in ACE) and ``K`` for the number of experts (8 in ACE). States are the
normalised (z-scored) ACE states of ``morphkit.motion.states``: the networks are unit-free.

Choices the paper leaves open, and what is done here (sources: ``trainer-references.md`` §3–4):

* **Expert blending.** MANN blends expert *weights* per sample, $W(\\alpha) = \\sum_k \\alpha_k W_k$.
  :class:`ExpertLinear` blends expert *outputs* of each layer, $\\sum_k \\alpha_k (x W_k + b_k)$,
  which is the same function (the blend is taken before the nonlinearity), computed as one GEMM
  ``x @ W.reshape(in, K·out)`` plus a per-sample weighted sum over K.
* **Gate inputs.** MANN gates on a hand-picked subset of its input (foot velocities, commands);
  ACE's states have no such subset fixed, so the gate sees $[z, x_{t-1}]$, as MotionVAE's mixed
  decoder does. One gate serves every layer.
* **Latent at every layer.** As MotionVAE's mixed decoder, $z$ is concatenated to the input of
  every expert layer (``latent_every_layer=True``; ``False`` feeds it to the first layer only).
* **Sizes.** Defaults are the paper's: prior 8 experts × 512 units (two hidden layers, MANN's
  three-layer network), encoder [512]×4 with LeakyReLU (ACE §6.4 names LeakyReLU for the encoder
  and MANN's ELU stays in the prior). The gate's hidden sizes (64, 64) are MotionVAE's (MANN used
  32, 32 on 19 inputs; ACE's gate sees the whole state and latent).
* **Dropout.** 0.3 on the input of every expert layer (MANN's keep-probability 0.7), none on the
  gate (the ACE author's MANN port); the latent is never dropped.
* **Initialisation.** Expert weights as ``nn.Linear``'s default (uniform, ±1/√fan_in), expert
  biases zero (MANN).
* **Output.** $\\pi$ predicts $x_t$ directly (MotionVAE).
* **KL.** :func:`kl_divergence` averages over latent elements by default (MotionVAE's ``kl_beta``
  convention); the weight β is the trainer's config.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Literal, NamedTuple

import torch
from torch import nn

from morphkit.retarget.networks import MLP, Activation

__all__ = [
    "ExpertLinear",
    "GatingNetwork",
    "MixtureOfExperts",
    "MotionEncoder",
    "MotionPrior",
    "MotionVAE",
    "VAEOutput",
    "kl_divergence",
    "reparameterize",
]

class ExpertLinear(nn.Module):
    """K linear experts blended per sample: $y = \\sum_k \\alpha_k (x W_k + b_k)$.

    Equal to applying the blended weights $W = \\sum_k \\alpha_k W_k$, $b = \\sum_k \\alpha_k b_k$
    (MANN), computed as one GEMM over all experts, [B, in] @ [in, K·out], then a batched
    weighted sum over K.

    Args:
        in_features: Input size.
        out_features: Output size.
        expert_count: K.
    """

    def __init__(self, in_features: int, out_features: int, expert_count: int) -> None:
        super().__init__()
        self.in_features, self.out_features, self.expert_count = in_features, out_features, expert_count
        self.weight = nn.Parameter(torch.empty(in_features, expert_count, out_features))
        """Expert weights, shape [in, K, out] (so ``view(in, K·out)`` is free)."""
        self.bias = nn.Parameter(torch.zeros(expert_count, out_features))
        """Expert biases, shape [K, out]."""
        bound = 1.0 / math.sqrt(in_features)
        nn.init.uniform_(self.weight, -bound, bound)

    def matmul_flops(self, batch_size: int) -> int:
        """Matrix-multiply FLOPs of one forward (:func:`~morphkit.retarget.networks.matmul_flops`):
        2·B·in·K·out for the expert GEMM, 2·B·K·out for the blend, 2·B·K·out for the blended bias."""
        k, i, o = self.expert_count, self.in_features, self.out_features
        return 2 * batch_size * (i * k * o + 2 * k * o)

    def forward(self, x: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
        """Blend the experts. ``x`` [..., in], ``alpha`` [..., K] (rows summing to 1) → [..., out]."""
        lead = x.shape[:-1]
        x2, a2 = x.reshape(-1, self.in_features), alpha.reshape(-1, self.expert_count)
        y = (x2 @ self.weight.view(self.in_features, -1)).view(-1, self.expert_count, self.out_features)
        out = torch.bmm(a2.unsqueeze(1), y).squeeze(1) + a2 @ self.bias  # [N, out]
        return out.view(*lead, self.out_features)

    def extra_repr(self) -> str:
        return f"in_features={self.in_features}, out_features={self.out_features}, expert_count={self.expert_count}"


class GatingNetwork(nn.Module):
    """MANN's gating network: an ELU MLP whose softmax gives the expert blend weights.

    Args:
        in_features: Gate input size.
        expert_count: K.
        hidden: Hidden sizes.
        dropout: Dropout on the gate input and after each hidden activation.
    """

    def __init__(self, in_features: int, expert_count: int, *, hidden: Sequence[int] = (64, 64), dropout: float = 0.0):
        super().__init__()
        self.input_dropout = nn.Dropout(dropout) if dropout > 0 else nn.Identity()
        self.mlp = MLP(in_features, hidden, expert_count, activation="elu", dropout=dropout)

    def forward(self, g: torch.Tensor) -> torch.Tensor:
        """Blend weights α, shape [..., K], non-negative, summing to 1 over K."""
        return torch.softmax(self.mlp(self.input_dropout(g)), dim=-1)


class MixtureOfExperts(nn.Module):
    """MANN's motion-prediction network: expert layers blended by one gate, ELU between, dropout.

    Layer ``l`` maps $[c, h_l]$ to $h_{l+1}$ (``c`` the conditioning vector, concatenated at every
    layer or at the first only), with $h_0 = x$; every layer is an :class:`ExpertLinear` blended by
    the same α = gate(g).

    Args:
        in_features: Size of ``x``.
        out_features: Output size.
        gate_features: Size of the gate input ``g``.
        condition_features: Size of ``c`` (0: none).
        hidden: Hidden sizes of the expert layers (MANN: (512, 512)).
        expert_count: K (MANN and ACE: 8).
        gate_hidden: Hidden sizes of the gate.
        dropout: Dropout on each expert layer's ``h`` input (not on ``c``).
        gate_dropout: Dropout inside the gate.
        condition_every_layer: Concatenate ``c`` at every layer (MotionVAE) or only the first.
    """

    def __init__(
        self,
        in_features: int,
        out_features: int,
        gate_features: int,
        *,
        condition_features: int = 0,
        hidden: Sequence[int] = (512, 512),
        expert_count: int = 8,
        gate_hidden: Sequence[int] = (64, 64),
        dropout: float = 0.3,
        gate_dropout: float = 0.0,
        condition_every_layer: bool = True,
    ) -> None:
        super().__init__()
        self.condition_features, self.condition_every_layer = condition_features, condition_every_layer
        self.gate = GatingNetwork(gate_features, expert_count, hidden=gate_hidden, dropout=gate_dropout)
        sizes = [in_features, *hidden, out_features]
        self.layers = nn.ModuleList(
            ExpertLinear(a + (condition_features if (i == 0 or condition_every_layer) else 0), b, expert_count)
            for i, (a, b) in enumerate(itertools.pairwise(sizes))
        )
        self.dropout = nn.Dropout(dropout) if dropout > 0 else nn.Identity()
        self.activation = nn.ELU()

    def forward(
        self, x: torch.Tensor, g: torch.Tensor, c: torch.Tensor | None = None, *, return_weights: bool = False
    ) -> torch.Tensor | tuple[torch.Tensor, torch.Tensor]:
        """``x`` [..., in], ``g`` [..., gate_features], ``c`` [..., condition_features] → [..., out].

        With ``return_weights`` also the blend weights α [..., K].
        """
        alpha = self.gate(g)
        h = x
        for i, layer in enumerate(self.layers):
            h = self.dropout(h)
            if c is not None and (i == 0 or self.condition_every_layer):
                h = torch.cat([c, h], dim=-1)
            h = layer(h, alpha)
            if i < len(self.layers) - 1:
                h = self.activation(h)
        return (h, alpha) if return_weights else h


class MotionPrior(nn.Module):
    """ACE's motion prior $\\pi(z_t, x_{t-1}) \\to x_t$ (Eq. 2): a MANN gated on $[z, x_{t-1}]$.

    Args:
        state_features: S.
        latent_features: Z (ACE: 32).
        hidden: Expert layer sizes (ACE: 512 units).
        expert_count: K (ACE: 8).
        gate_hidden: Gate hidden sizes.
        dropout: Expert-layer dropout.
        gate_dropout: Gate dropout.
        latent_every_layer: Concatenate z at every expert layer (MotionVAE) or at the first only.
    """

    def __init__(
        self,
        state_features: int,
        latent_features: int = 32,
        *,
        hidden: Sequence[int] = (512, 512),
        expert_count: int = 8,
        gate_hidden: Sequence[int] = (64, 64),
        dropout: float = 0.3,
        gate_dropout: float = 0.0,
        latent_every_layer: bool = True,
    ) -> None:
        super().__init__()
        self.state_features, self.latent_features = state_features, latent_features
        self.mann = MixtureOfExperts(
            state_features,
            state_features,
            latent_features + state_features,
            condition_features=latent_features,
            hidden=hidden,
            expert_count=expert_count,
            gate_hidden=gate_hidden,
            dropout=dropout,
            gate_dropout=gate_dropout,
            condition_every_layer=latent_every_layer,
        )

    def forward(self, z: torch.Tensor, x_prev: torch.Tensor) -> torch.Tensor:
        """``z`` [..., Z], ``x_prev`` [..., S] → predicted $x_t$ [..., S]."""
        out = self.mann(x_prev, torch.cat([z, x_prev], dim=-1), z)
        assert isinstance(out, torch.Tensor)
        return out


class MotionEncoder(nn.Module):
    """ACE's state-transition encoder $c(x_{t-1}, x_t)$ (Eq. 1): an MLP giving the posterior's (μ, log σ²).

    Args:
        state_features: S.
        latent_features: Z (ACE: 32).
        hidden: Hidden sizes (ACE §6.4: [512]×4).
        activation: Nonlinearity (ACE §6.4: LeakyReLU).
        dropout: Dropout after each hidden activation.
    """

    def __init__(
        self,
        state_features: int,
        latent_features: int = 32,
        *,
        hidden: Sequence[int] = (512, 512, 512, 512),
        activation: Activation = "leaky_relu",
        dropout: float = 0.0,
    ) -> None:
        super().__init__()
        self.latent_features = latent_features
        self.mlp = MLP(2 * state_features, hidden, 2 * latent_features, activation=activation, dropout=dropout)

    def forward(self, x_prev: torch.Tensor, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``x_prev``, ``x`` [..., S] → (μ, log σ²), each [..., Z]."""
        mu, logvar = self.mlp(torch.cat([x_prev, x], dim=-1)).chunk(2, dim=-1)
        return mu, logvar


def reparameterize(mu: torch.Tensor, logvar: torch.Tensor, *, generator: torch.Generator | None = None) -> torch.Tensor:
    """$z = \\mu + \\sigma \\epsilon$, $\\epsilon \\sim N(0, I)$, differentiable in μ and log σ² (shape of ``mu``).

    ``generator`` (on ``mu``'s device) makes the draw come from a run-owned stream.
    """
    eps = torch.randn(mu.shape, generator=generator, device=mu.device, dtype=mu.dtype)
    return mu + torch.exp(0.5 * logvar) * eps


def kl_divergence(
    mu: torch.Tensor, logvar: torch.Tensor, reduction: Literal["mean", "batchmean", "none"] = "mean"
) -> torch.Tensor:
    """$KL(N(\\mu, \\sigma^2) \\| N(0, I)) = -\\tfrac12 \\sum (1 + \\log\\sigma^2 - \\mu^2 - \\sigma^2)$.

    Args:
        mu: Posterior means, [..., Z].
        logvar: Posterior log-variances, [..., Z].
        reduction: ``"mean"`` over every element (MotionVAE), ``"batchmean"`` summed over Z and
            averaged over samples, ``"none"`` per element [..., Z].
    """
    kl = -0.5 * (1 + logvar - mu.square() - logvar.exp())
    if reduction == "none":
        return kl
    if reduction == "batchmean":
        return kl.sum(-1).mean()
    return kl.mean()


class VAEOutput(NamedTuple):
    """What :class:`MotionVAE` returns."""

    x: torch.Tensor
    """Reconstructed $x_t$, [..., S]."""
    mu: torch.Tensor
    """Posterior mean, [..., Z]."""
    logvar: torch.Tensor
    """Posterior log-variance, [..., Z]."""
    z: torch.Tensor
    """The sampled latent, [..., Z]."""


class MotionVAE(nn.Module):
    """Encoder and prior trained jointly (ACE §4): $z \\sim c(x_{t-1}, x_t)$, $\\hat x_t = \\pi(z, x_{t-1})$.

    Args:
        encoder: The transition encoder c.
        prior: The motion prior π (kept for the retargeting stage).
    """

    def __init__(self, encoder: MotionEncoder, prior: MotionPrior) -> None:
        super().__init__()
        if encoder.latent_features != prior.latent_features:
            raise ValueError(f"encoder latent {encoder.latent_features} != prior latent {prior.latent_features}")
        self.encoder, self.prior = encoder, prior

    def forward(self, x_prev: torch.Tensor, x: torch.Tensor, *, generator: torch.Generator | None = None) -> VAEOutput:
        """``x_prev``, ``x`` [..., S] → reconstruction, posterior and latent (sampled; μ in eval mode)."""
        mu, logvar = self.encoder(x_prev, x)
        z = reparameterize(mu, logvar, generator=generator) if self.training else mu
        return VAEOutput(self.prior(z, x_prev), mu, logvar, z)
