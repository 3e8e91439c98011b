"""NKN's configuration (Villegas et al. 2018, §4–5 and App. E) and the presets.

The ``paper`` preset is the configuration of the official release's README command line (the
adversarial-cycle run; ``../shared/notes/trainer-references.md`` §2.6), not the argparse defaults
of its training script: 2 × 512 GRUs with input keep-probability 0.9, β = 0.001, α = 100°,
λ = 10, ω = 0.01, Adam 1e-4 with β1 = 0.5, gradient clipping at global norm 25 for both
networks, discriminator channels 32/64/128/256 with batch norm and input keep-probability 0.7,
the 0.3 margin on the running D(fake) score, P(B = A) = 0.2, 60-frame clips, batch 16.

What the paper and the release leave open is named here as morphkit's choice:

* the shorter presets train with a ten times higher learning rate (1e-3) and smaller networks;
* bone offsets are normalised with their own statistics over the training skeletons (the release
  reuses the joint-position statistics), with a floor of ``offset_min_std`` on the spread;
* root height is an output of the head (the release takes it from the skeleton file), so a
  crouch or a jump survives retargeting; it and the root velocity are predicted per unit of the
  target's leg length (the head's output times leg / mean training leg), so an untrained network
  already stands a short-legged character lower and walks it slower, as the copy baseline does;
* the discriminator's last convolution is global-average pooled, so clip lengths other than 60
  frames work (at 60 frames it is the release's single "valid" output);
* the training skeletons: every skeleton of the data with motion, plus ``train_variants``
  bone-length variants (targets only: no real motion, so no adversarial term) and, for the
  embedded default, ``synth_variants`` variants moved by morphkit's synthesis (real motion).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

from morphkit.retarget.training_data import DataConfig

__all__ = ["PRESETS", "NknConfig", "NknDataConfig", "preset"]


@dataclass(frozen=True)
class NknDataConfig(DataConfig):
    """Where the skeletons and their motion come from (§5 "Dataset", adapted to morphkit's data): every method's
    :class:`~morphkit.retarget.training_data.DataConfig` (the release's clips: Mixamo at 30 fps; ``synth_seed`` also
    seeds the synthesised variants; the creature's synthesis is the cross-morphology mode's), and NKN's skeletons."""

    character_frames: int = 12_000
    """Cross-morphology mode: synthesised frames of the target creature (its real motion for D)."""
    synth_variants: int = 1
    """Embedded default only: bone-length variants of the human moved by morphkit's synthesis (each is
    a training character with its own motion, as the paper's Mixamo characters)."""
    synth_variant_frames: int = 3_000
    """Frames synthesised per such variant."""
    train_variants: int = 6
    """Bone-length variants of each data skeleton used as retargeting targets in training (no motion)."""
    variant_range: float = 0.3
    """Limb-group scale factors of generated variants are drawn from [1 − r, 1 + r] (±30 %)."""
    variant_seed: int = 1
    """Seed of the training variants (the unseen evaluation variants use other seeds)."""
    test_frames: int = 120
    """Frames per evaluation clip (§5: 4-second test clips at 30 fps)."""
    held_out: tuple[str, ...] = ()
    """Clip names (file stems) kept out of training besides the evaluation split, e.g. the CMU trials
    whose other capture serves as a paired truth (``benchmarks/nkn_paired.py``)."""

    def __post_init__(self) -> None:
        if self.human_mirror:
            raise ValueError("data.human_mirror: NKN trains on its clips as captured (mirror images are ACE's)")


@dataclass(frozen=True)
class NknConfig:
    """Everything one NKN run needs; saved as ``config.yaml`` in its run folder."""

    seed: int = 0
    data: NknDataConfig = field(default_factory=NknDataConfig)

    # ---- networks (§4.1, App. E)
    hidden: int = 512
    """GRU units per layer of the encoder and of the decoder (App. E: 512)."""
    layers: int = 2
    """GRU layers of the encoder and of the decoder (App. E: 2)."""
    keep_prob: float = 0.9
    """Keep-probability of the dropout on every GRU layer's input (README: 0.9)."""
    head_init_std: float = 0.002
    """Standard deviation of the output layer's initial weights; its bias is the identity rotation."""
    feature_min_std: float = 0.01
    """Floor on the spread of each feature dimension when normalising [m], [m/s], [rad/s] (morphkit's
    choice: links that barely move relative to the root would otherwise dominate the squared errors)."""
    offset_min_std: float = 0.01
    """Floor [m] on the spread of each bone-offset component when normalising (see the module docs)."""
    d_channels: tuple[int, ...] = (32, 64, 128, 256)
    """Discriminator channels of its four stride-2 convolutions (README ``d_arch=2``)."""
    d_norm: Literal["batch", "instance"] = "batch"
    """Normalisation after D's convolutions 2–4: README batch norm (the paper says instance norm)."""
    d_keep_prob: float = 0.7
    """Keep-probability of the dropout on D's input during D's step (not with instance norm; 1 in G's step)."""

    # ---- losses (Eq. 10–16)
    beta: float = 0.001
    """β, the weight of the adversarial term (Eq. 13)."""
    twist_alpha_deg: float = 100.0
    """α [deg], the free twist about each bone (Eq. 15)."""
    twist_weight: float = 10.0
    """λ, the twist loss weight (Eq. 10)."""
    smooth_weight: float = 0.01
    """ω, the global-motion smoothing weight (Eq. 10, 16)."""
    same_skeleton_prob: float = 0.2
    """P(B = A) per batch item, where Eq. 13 is the square loss (release: 0.2)."""
    adversarial: bool = True
    """False: the cycle-consistency objective alone (Table 1's second row)."""
    d_margin: float = 0.3
    """D is updated only while the running mean of D(fake) is above this (App. E)."""
    d_score_decay: float = 0.99
    """Decay of that running mean (release: 0.99 old + 0.01 new, starting at 0.5)."""

    # ---- optimisation
    lr: float = 1e-4
    """Adam learning rate of both networks (App. E)."""
    betas: tuple[float, float] = (0.5, 0.999)
    """Adam betas (release: β1 = 0.5)."""
    clip_norm: float = 25.0
    """Global gradient-norm clip of both networks (App. E; the release clips D too)."""
    clip_frames: int = 60
    """Frames per training clip (§5: 2-second clips)."""
    batch_size: int = 16
    epochs: int = 50
    steps_per_epoch: int = 1_000
    fk_backend: Literal["warp", "reference"] = "warp"
    """FK of the decoder: morphkit's Warp kernels plus the exact bone-offset correction, or the
    pure-torch reference FK (the oracle; much slower on CPU)."""

    def __post_init__(self) -> None:
        if self.clip_frames < 4:
            raise ValueError(f"clip_frames must be >= 4, got {self.clip_frames}")
        if not 0.0 < self.keep_prob <= 1.0 or not 0.0 < self.d_keep_prob <= 1.0:
            raise ValueError("keep probabilities must be in (0, 1]")
        if not 0.0 <= self.same_skeleton_prob <= 1.0:
            raise ValueError(f"same_skeleton_prob must be in [0, 1], got {self.same_skeleton_prob}")
        if self.hidden < 1 or self.layers < 1 or not self.d_channels:
            raise ValueError("hidden, layers and d_channels must be positive")


def _small(hidden: int, channels: tuple[int, ...], **kw: object) -> NknConfig:
    return NknConfig(hidden=hidden, d_channels=channels, lr=1e-3, **kw)  # type: ignore[arg-type]


PRESETS: dict[str, NknConfig] = {
    # Tests: seconds on 2 CPU cores.
    "smoke": _small(32, (8, 16, 32, 32), clip_frames=16, batch_size=8, epochs=2, steps_per_epoch=8,
                    data=NknDataConfig(human_frames=600, synth_variants=0, train_variants=2, character_frames=600,
                                       test_frames=48)),
    # The main job, a few minutes on 2 CPU cores.
    "quick": _small(128, (16, 32, 64, 128), epochs=6, steps_per_epoch=50,
                    data=NknDataConfig(human_frames=2_400, synth_variants=1, synth_variant_frames=1_200,
                                       train_variants=4, character_frames=6_000)),
    # Quality runs on CPU.
    "default": replace(_small(256, (32, 64, 128, 256), epochs=20, steps_per_epoch=100), lr=5e-4),
    # The release's README configuration (see the module docstring).
    "paper": NknConfig(),
}


def preset(name: str) -> NknConfig:
    """The preset ``name`` (one of :data:`PRESETS`).

    Raises:
        ConfigError: an unknown name, listing the known ones.
    """
    from morphkit.retarget.config import preset_config

    return preset_config(PRESETS, name)
