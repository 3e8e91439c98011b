"""Does a clip's motion lie inside the creature's data? A per-clip distance and a threshold taken from the data.

DIV and FID pool every frame of every clip: one clip that leaves the creature's motion (a biped standing on its
tail with both feet in the air) hides among the others' frames, and UFR, which counts contacts, may not see it at
all. :func:`data_envelope` fits the data set's Ψ frames once; :meth:`DataEnvelope.distance` scores one clip and
:meth:`DataEnvelope.outside` compares it with the data's own spread.

The choices that are ours:

- **Distance**: the mean over a clip's frames of each frame's Mahalanobis distance to the Gaussian of the data's Ψ
  frames (FID's own model of the data: its mean and covariance), the covariance given a ridge of
  :data:`FLOOR` ² so that a Ψ column the data never moves (the roll and the feet's sideways place of a creature whose
  legs only pitch) counts a deviation in tenths of a body length, not in its own vanishing spread: without it, a
  kangaroo whose data never rolls had every retargeted clip flagged for a roll of a few degrees.
- **Threshold**: the data's own clips cut into segments of ``segment`` frames (each clip's last, shorter piece is a
  segment too), the same distance of every segment, and their ``quantile`` (default 1: the largest). A clip's
  distance is a frame-weighted mean of its segments', so with the default no clip of the data is ever outside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphkit.errors import ConfigError
from morphkit.metrics._distribution import as_matrix, gaussian_statistics

__all__ = ["FLOOR", "DataEnvelope", "data_envelope"]

FLOOR = 0.1
"""Standard deviation added (as its square, a ridge) to the data's covariance, in Ψ's units (body lengths, body
lengths/s, rad/s, quaternion components); ours: a deviation of a tenth of a body length is one unit where the data
holds a column still."""


@dataclass(frozen=True, eq=False)
class DataEnvelope:
    """The creature data's Ψ Gaussian and the largest per-clip distance its own clips reach."""

    mean: np.ndarray
    """Mean of the data's Ψ frames [D]."""
    whiten: np.ndarray
    """Inverse Cholesky factor of the ridged covariance [D, D]: ``whiten @ (x - mean)`` has unit covariance."""
    threshold: float
    """The ``quantile`` of the data's per-segment distances: a clip above it lies outside the data."""
    quantile: float
    """Which quantile of the data's per-segment distances ``threshold`` is (1: the largest)."""
    segment: int
    """Frames per data segment the threshold was measured on."""
    segments: int
    """Number of data segments measured."""

    def frame_distances(self, psi: Any) -> np.ndarray:
        """Mahalanobis distance of each Ψ frame [T, D] (NumPy or torch) to the data's Gaussian → [T]."""
        x = as_matrix(psi, "DataEnvelope: psi")
        if x.shape[1] != self.mean.shape[0]:
            raise ConfigError(f"DataEnvelope: Ψ has {x.shape[1]} features, the data's {self.mean.shape[0]}")
        return np.linalg.norm((x - self.mean) @ self.whiten.T, axis=1)

    def distance(self, psi: Any) -> float:
        """A clip's distance: the mean of its frames' :meth:`frame_distances`."""
        d = self.frame_distances(psi)
        if d.size == 0:
            raise ConfigError("DataEnvelope: a clip with no frames")
        return float(d.mean())

    def outside(self, psi: Any) -> bool:
        """Whether a clip's :meth:`distance` exceeds the data's :attr:`threshold`."""
        return self.distance(psi) > self.threshold

    def describe(self) -> str:
        """How the threshold was taken, for a warning or a report."""
        which = "largest" if self.quantile >= 1.0 else f"{100 * self.quantile:g} % quantile"
        return (f"threshold {self.threshold:.2f}: the {which} of the data's own distances over {self.segments} "
                f"segments of {self.segment} frames")


def data_envelope(psi_per_clip: Sequence[Any], *, segment: int = 60, quantile: float = 1.0,
                  floor: float = FLOOR) -> DataEnvelope:
    """Fit the data's Ψ Gaussian and measure its own clips' spread (see the module docs).

    Args:
        psi_per_clip: Ψ of each of the data's clips, [T_i, D] (NumPy or torch).
        segment: Frames per segment the data's clips are cut into (>= 1).
        quantile: Quantile of the segments' distances taken as the threshold, in (0, 1].
        floor: :data:`FLOOR`, > 0.

    Raises:
        ConfigError: no frames, clips of different widths, ``segment`` < 1 or ``quantile`` outside (0, 1].
    """
    if int(segment) != segment or segment < 1:
        raise ConfigError(f"data_envelope: segment must be a positive integer, got {segment!r}")
    if not (math.isfinite(floor) and floor > 0.0):
        raise ConfigError(f"data_envelope: floor must be a number above 0, got {floor!r}")
    if not 0.0 < quantile <= 1.0:
        raise ConfigError(f"data_envelope: quantile must lie in (0, 1], got {quantile!r}")
    clips = [as_matrix(p, "data_envelope: psi") for p in psi_per_clip]
    clips = [c for c in clips if c.shape[0]]
    if not clips:
        raise ConfigError("data_envelope: no data frames")
    if len({c.shape[1] for c in clips}) != 1:
        raise ConfigError("data_envelope: the data's clips have different Ψ widths")
    x = np.concatenate(clips, axis=0)
    if x.shape[0] > 1:
        mean, cov = gaussian_statistics(x)  # FID's own model of the data
    else:
        mean, cov = x.mean(axis=0), np.zeros((x.shape[1], x.shape[1]))
    cov = cov + floor**2 * np.eye(cov.shape[0])
    whiten = np.linalg.inv(np.linalg.cholesky(cov))
    probe = DataEnvelope(mean, whiten, np.inf, quantile, int(segment), 0)
    per_segment = [probe.frame_distances(c[i:i + segment]).mean() for c in clips for i in range(0, len(c), segment)]
    threshold = float(np.quantile(per_segment, quantile)) if quantile < 1.0 else float(max(per_segment))
    return DataEnvelope(mean, whiten, threshold, quantile, int(segment), len(per_segment))
