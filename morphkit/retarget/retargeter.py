"""What every trained retargeter offers: the :class:`Retargeter` protocol and its :class:`RetargetedClip`.

ACE (:class:`~morphkit.retarget.ace.retarget.AceRetargeter`) and NKN
(:class:`~morphkit.retarget.nkn.retarget.NknRetargeter`) implement it; the evaluation, the CLI and
the examples use only it, through :func:`morphkit.retarget.runs.load`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from morphkit.graph import Morphology
from morphkit.motion import ClampReport, Motion, Pairing
from morphkit.retarget.training_data import DataConfig

__all__ = ["RetargetedClip", "Retargeter"]


@dataclass(frozen=True)
class RetargetedClip:
    """One retargeted clip: the creature's motion, the clip it came from, and what decoding clamped."""

    source: Motion
    """The human clip, at the retargeter's frame rate."""
    motion: Motion
    """The creature's motion, placed where the source starts (its root's ground position and heading)."""
    states: np.ndarray | None = None
    """[T, Sr] the method's own denormalised output states, where it has them (ACE)."""
    clamp: ClampReport = field(default_factory=lambda: ClampReport(0.0, 0.0, ()))
    """Joint coordinates decoding had to clamp into their limits (nothing, for methods that do not clamp)."""


@runtime_checkable
class Retargeter(Protocol):
    """A trained retargeter, ready to use (eval mode, no gradients)."""

    label: str
    """Its name in a comparison (Table 1: ``ACE``, ``ACEwoFea``, ``NKN``, ...)."""
    creature: Morphology | None
    """The creature it retargets onto (``None``: NKN between human skeletons)."""
    pairing: Pairing | None
    """Ψ's end-effector pairs and body lengths it was trained with (``None`` where the method has none)."""
    fps: float
    """Frame rate of its output [1/s]; clips at other rates are resampled."""
    data: DataConfig
    """The creature's synthesised data set it was trained with (frames, frame rate, seed)."""
    human_data: str | None
    """The human data folder it was trained on (``None``: the embedded default human motion)."""

    def retarget(self, clips: Sequence[Motion]) -> list[RetargetedClip]:
        """Retarget human clips, batched; one result per clip, in order."""
        ...
