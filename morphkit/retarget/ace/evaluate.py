"""ACE's Table-1 metrics (§7.3) for retargeted clips: DIV, FID, L_fea and UFR, and the data set's own row.

* Ψ of a retargeted clip is taken from the **exported** motion (:func:`~morphkit.motion.motion_features`
  of the decoded :class:`~morphkit.motion.Motion`, end-effectors through FK), with the run's mapped
  end-effectors and body length; the human's Ψ from its states with the mapped human end-effectors.
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
from morphkit.motion import Motion, features, human_state_from_motion, human_state_layout, motion_features

__all__ = ["STAGE_LABELS", "TableRow", "dataset_row", "evaluate_clips", "evaluate_run"]


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


def _psi(motions: Sequence[Motion], ee_names: Sequence[str], length: float) -> np.ndarray:
    return np.concatenate([motion_features(m, ee_names=list(ee_names), length=length) for m in motions], axis=0)


def dataset_row(character: Sequence[Motion], ee_names: Sequence[str], length: float, *, seed: int = 0) -> TableRow:
    """The data set's own DIV and UFR (FID 0 by definition)."""
    psi = _psi(character, ee_names, length)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in character])
    return TableRow("Dataset", float(diversity(psi, rng=seed)), 0.0, None, float(ufr.ratio), int(psi.shape[0]))


def evaluate_clips(
    name: str,
    humans: Sequence[Motion],
    retargeted: Sequence[Motion],
    character: Sequence[Motion],
    *,
    creature_ees: Sequence[str],
    human_ees: Sequence[str],
    creature_length: float,
    human_length: float,
    seed: int = 0,
) -> TableRow:
    """DIV, FID, L_fea and UFR of ``retargeted`` clips (pairwise with the ``humans`` they came from)."""
    psi_r = _psi(retargeted, creature_ees, creature_length)
    psi_d = _psi(character, creature_ees, creature_length)
    layout = human_state_layout(humans[0].morphology)
    psi_h = np.concatenate([features(human_state_from_motion(h), layout, length=human_length, ee_names=list(human_ees))
                            for h in humans], axis=0)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in retargeted])
    return TableRow(name, float(diversity(psi_r, rng=seed)), float(fid(psi_d, psi_r)),
                    float(feature_loss(psi_h, psi_r)), float(ufr.ratio), int(psi_r.shape[0]))


STAGE_LABELS = {"retarget": "ACE", "retarget_wofea": "ACEwoFea", "retarget_woadv": "ACEwoAdv",
                "retarget_contact": "ACE+contact"}
"""Table-1 names of a run's retargeter stages."""


def evaluate_run(run_dir: str | os.PathLike[str], clips: Sequence[Motion], *, stages: Sequence[str] | None = None,
                 seed: int = 0, device: str = "cpu") -> tuple[list[TableRow], dict[str, list]]:
    """The data set's row and one row per retargeter stage of an ACE run, on ``clips``.

    Returns:
        ``(rows, retargeted)``: the table rows and, per stage folder name, its
        :class:`~morphkit.retarget.ace.retarget.RetargetedClip` list.
    """
    from pathlib import Path

    from morphkit.retarget.ace.config import DataConfig
    from morphkit.retarget.ace.data import character_motions
    from morphkit.retarget.ace.retarget import AceRetargeter

    run = Path(run_dir)
    names = [s for s in (stages or STAGE_LABELS) if (run / s / "checkpoint.pt").is_file()]
    rows: list[TableRow] = []
    results: dict[str, list] = {}
    character: list[Motion] | None = None
    for name in names:
        model = AceRetargeter(run, retarget_dir=run / name, device=device)
        fmap = model.feature_map(clips[0])
        if character is None:
            d = model.meta.get("data", {})
            data = DataConfig(character_frames=int(d.get("character_frames", DataConfig.character_frames)),
                              fps=model.fps, synth_seed=int(d.get("synth_seed", 0)))
            character = character_motions(model.creature, data, progress=False)
            rows.append(dataset_row(character, fmap.creature_ees, fmap.creature_length, seed=seed))
        out = model.retarget(clips)
        results[name] = out
        rows.append(evaluate_clips(STAGE_LABELS.get(name, name), [r.source for r in out], [r.motion for r in out],
                                   character, creature_ees=fmap.creature_ees, human_ees=fmap.human_ees,
                                   creature_length=fmap.creature_length, human_length=fmap.human_length, seed=seed))
    return rows, results
