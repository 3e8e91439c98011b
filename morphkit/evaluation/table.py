"""ACE's Table-1 metrics (§7.3) for retargeted clips of any method: DIV, FID, L_fea and UFR, the data
set's own row, and the table as markdown and CSV.

* Ψ of a retargeted clip is taken from the **exported** motion (:func:`~morphkit.motion.motion_features`
  of the :class:`~morphkit.motion.Motion`, end-effectors through FK), with the comparison's
  :class:`~morphkit.motion.Pairing`; the human's Ψ from its states with the paired human end-effectors.
* DIV and FID compare frames of all retargeted clips with frames of the creature's synthesised data
  set (:func:`morphkit.metrics.diversity`, :func:`morphkit.metrics.fid`).
* L_fea is Eq. 9 per frame, averaged over all frames of all clips.
* UFR pools every frame of every clip (:func:`morphkit.metrics.unrealistic_frame_ratio`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphkit.metrics import UnrealisticFrames, diversity, feature_loss, fid, unrealistic_frame_ratio
from morphkit.motion import Motion, Pairing
from morphkit.retarget.tables import write_table_files

__all__ = ["TableRow", "dataset_row", "evaluate_clips", "format_table", "write_table"]


@dataclass(frozen=True)
class TableRow:
    """One row of a Table-1-style comparison (``None`` where a metric does not apply)."""

    name: str
    div: float
    fid: float
    feature_loss: float | None
    ufr: float
    frames: int

    def as_dict(self) -> dict[str, object]:
        return {"method": self.name, "DIV": self.div, "FID": self.fid, "L_fea": self.feature_loss,
                "UFR": self.ufr, "frames": self.frames}


def dataset_row(character: Sequence[Motion], pairing: Pairing, *, seed: int = 0) -> TableRow:
    """The data set's own DIV and UFR (FID 0 by definition)."""
    psi = np.concatenate([pairing.creature_psi(m) for m in character], axis=0)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in character])
    return TableRow("Dataset", float(diversity(psi, rng=seed)), 0.0, None, float(ufr.ratio), int(psi.shape[0]))


def evaluate_clips(
    name: str,
    humans: Sequence[Motion],
    retargeted: Sequence[Motion],
    character: Sequence[Motion],
    pairing: Pairing,
    *,
    seed: int = 0,
) -> TableRow:
    """DIV, FID, L_fea and UFR of ``retargeted`` clips (pairwise with the ``humans`` they came from)."""
    psi_r = np.concatenate([pairing.creature_psi(m) for m in retargeted], axis=0)
    psi_d = np.concatenate([pairing.creature_psi(m) for m in character], axis=0)
    psi_h = np.concatenate([pairing.human_psi(h) for h in humans], axis=0)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in retargeted])
    return TableRow(name, float(diversity(psi_r, rng=seed)), float(fid(psi_d, psi_r)),
                    float(feature_loss(psi_h, psi_r)), float(ufr.ratio), int(psi_r.shape[0]))


def _cell(value: float | None, digits: int = 3, percent: bool = False) -> str:
    if value is None:
        return "N/A"
    return f"{100 * value:.{digits}f}%" if percent else f"{value:.{digits}f}"


def format_table(rows: Sequence[TableRow]) -> str:
    """Markdown: ``| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |`` (DIV: closest to the data set's)."""
    lines = ["| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.name} | {_cell(r.div)} | {_cell(r.fid)} | {_cell(r.feature_loss)} | "
                     f"{_cell(r.ufr, percent=True)} | {r.frames} |")
    return "\n".join(lines)


def write_table(rows: Sequence[TableRow], stem: str | os.PathLike[str]) -> str:
    """Write ``stem.md`` and ``stem.csv`` (atomically); returns the markdown."""
    return write_table_files(stem, format_table(rows), [r.as_dict() for r in rows])
