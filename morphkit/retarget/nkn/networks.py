"""NKN's networks for a run, built the same way for training and retargeting, and the CPU threads they run on."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import torch

from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.motion import NormStats
from morphkit.retarget.nkn.config import NknConfig
from morphkit.retarget.nkn.model import NknDiscriminator, NknGenerator, Side

__all__ = ["build_networks", "cpu_threads"]


@contextlib.contextmanager
def cpu_threads(count: int | None) -> Iterator[None]:
    """torch's intra-op CPU threads set to ``count`` inside the block (``None``: unchanged), restored after.

    NKN runs one small step per frame: on a CPU more threads gain nothing, and on a busy machine each
    parallel region waits for a core (measured: a 32-unit GRU cell 0.2 ms on one thread, 24 ms on two).
    """
    before = torch.get_num_threads()
    if count is not None:
        torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def build_networks(cfg: NknConfig, template: Morphology, source_features: NormStats, source_offsets: NormStats,
                   creature: Morphology | None = None, target_features: NormStats | None = None,
                   target_offsets: NormStats | None = None,
                   creature_joint_init: np.ndarray | None = None) -> dict[str, torch.nn.Module]:
    """The run's networks: ``generator`` (skeletons) or ``generator``/``inverse`` (cross), and ``discriminator``."""
    source = Side(template, source_features, source_offsets, fk_backend=cfg.fk_backend)
    frames = cfg.clip_frames - 1
    if creature is None:
        gen = NknGenerator(source.feature_dim, source, cfg)
        disc = NknDiscriminator(source.feature_dim, 3 * source.joint_count, frames, cfg)
        return {"generator": gen, "discriminator": disc}
    if target_features is None or target_offsets is None:
        raise ConfigError("the cross-morphology mode needs the creature's feature and offset statistics")
    target = Side(creature, target_features, target_offsets, fk_backend=cfg.fk_backend, joint_init=creature_joint_init)
    return {
        "generator": NknGenerator(source.feature_dim, target, cfg),
        "inverse": NknGenerator(target.feature_dim, source, cfg),
        "discriminator": NknDiscriminator(target.feature_dim, 3 * target.joint_count, frames, cfg),
    }
