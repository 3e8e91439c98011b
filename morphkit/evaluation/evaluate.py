"""Retarget held-out clips with every method and score them on one footing (ACE §7.3, Table 1).

Every method of a comparison is scored against one :class:`Reference`: the creature's synthesised
data set (the frames FID and the data set's DIV are taken from) and one Ψ pairing (end-effector
mapping and body lengths) for L_fea. It is the first ACE run's — its ``ace.yaml``, ``mapping.json``
and data configuration —, so the numbers are those of :func:`morphkit.retarget.ace.evaluate.evaluate_run`.
A comparison of NKN runs alone pairs end-effectors as ACE does (KL within compatible roles, Eq. 11)
on the creature's data and the evaluation clips, and takes both body lengths from the same motion.

Rows come from :func:`morphkit.retarget.ace.evaluate.dataset_row` and
:func:`~morphkit.retarget.ace.evaluate.evaluate_clips` (Ψ of the exported motion, DIV and FID on
Ψ against the data set's frames, L_fea per frame, UFR over every frame), plus the share of frames
of each unrealistic effect (:meth:`morphkit.metrics.UnrealisticFrames.cause_ratios`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from morphkit.errors import ConfigError
from morphkit.evaluation.methods import Method
from morphkit.graph import Morphology
from morphkit.metrics import UnrealisticFrames, unrealistic_frame_ratio
from morphkit.motion import Motion, body_length, ee_distributions, map_end_effectors
from morphkit.retarget.ace.config import DataConfig
from morphkit.retarget.ace.data import character_motions, evaluation_clips
from morphkit.retarget.ace.evaluate import TableRow, dataset_row, evaluate_clips
from morphkit.retarget.ace.retarget import AceRetargeter
from morphkit.retarget.nkn import NknRetargeter

__all__ = ["Evaluation", "MethodResult", "Reference", "evaluate_methods", "reference_for", "retarget"]


@dataclass(eq=False)
class Reference:
    """What every method of one comparison is measured against."""

    creature: Morphology
    data: DataConfig
    """Frames, rate and seed of the creature's synthesised data set (and of the embedded evaluation clips)."""
    creature_ees: tuple[str, ...]
    human_ees: tuple[str, ...]
    """Ψ's end-effectors, paired index by index (Eq. 11)."""
    creature_length: float
    human_length: float
    """Body lengths Ψ divides by [m]."""
    human_data: str | None
    """The folder of the evaluation clips (``None``: the embedded default human motion)."""
    source: str
    """Where the pairing comes from (a run folder, or the KL mapping computed here)."""
    character: list[Motion] = field(default_factory=list)
    """The creature's synthesised data set (loaded by :func:`evaluate_methods`)."""


@dataclass(frozen=True, eq=False)
class MethodResult:
    """One method's scores on the evaluation clips."""

    method: Method
    row: TableRow
    causes: dict[str, float]
    """Share of frames with each unrealistic effect (``self_collision``, ``foot_penetration``, ``foot_sliding``)."""
    shown: list[Motion]
    """Its retargeted motions of the first clips (kept for videos)."""


@dataclass(eq=False)
class Evaluation:
    """A comparison: the data set's row, each method's, and the clips."""

    reference: Reference
    clips: list[Motion]
    dataset: TableRow
    dataset_causes: dict[str, float]
    results: list[MethodResult]


def reference_for(methods: Sequence[Method], *, human_data: str | os.PathLike[str] | None = None,
                  limit: int | None = None) -> tuple[Reference, list[Motion]]:
    """The :class:`Reference` of a comparison (see the module docs) and its evaluation clips.

    The clips are the held-out split of ``human_data`` (default: the human data the first run was
    trained on), every clip of a folder that holds none of the split, or the embedded default's
    evaluation clips (:func:`morphkit.retarget.ace.data.evaluation_clips`), at the runs' frame rate.

    Args:
        methods: The methods (:func:`~morphkit.evaluation.methods.find_methods`).
        human_data: The evaluation clips' folder.
        limit: Keep the first this many clips.
    """
    ace = next((m for m in methods if m.kind == "ace"), None)
    if ace is not None:
        model = AceRetargeter(ace.run, retarget_dir=ace.stage)
        d = model.meta.get("data", {})
        data = DataConfig(character_frames=int(d.get("character_frames", DataConfig.character_frames)),
                          fps=model.fps, synth_seed=int(d.get("synth_seed", 0)),
                          human_frames=int(d.get("human_frames", DataConfig.human_frames)))
        source = os.fspath(human_data) if human_data is not None else model.meta.get("human_data")
        clips = evaluation_clips(source, data, limit=limit)
        return Reference(model.creature, data, tuple(model.mapping), tuple(model.mapping.values()),
                         float(model.meta["creature_body_length"]), float(model.meta["human_body_length"]),
                         source, os.fspath(ace.run)), clips
    nkn = NknRetargeter(methods[0].run)
    creature = nkn.creature
    assert creature is not None  # find_methods keeps cross-morphology NKN runs only
    nd = nkn.config.data
    data = DataConfig(character_frames=nd.character_frames, fps=nkn.fps, synth_seed=nd.synth_seed,
                      human_frames=nd.human_frames)
    folders = nkn.meta.get("human_data") or []
    source = os.fspath(human_data) if human_data is not None else (folders[0] if folders else None)
    clips = evaluation_clips(source, data, limit=limit)
    character = character_motions(creature, data, progress=False)
    human = clips[0].morphology
    c_len, h_len = body_length(creature, character), body_length(human, clips)
    roles = ({e.name: e.role for e in creature.end_effectors}, {e.name: e.role for e in human.end_effectors})
    mapping = map_end_effectors(ee_distributions(character, length=c_len, max_frames_per_clip=300),
                                ee_distributions(clips, length=h_len, max_frames_per_clip=300), roles=roles)
    c_ees, h_ees = mapping.feature_order()
    return Reference(creature, data, c_ees, h_ees, float(c_len), float(h_len), source,
                     "KL mapping on the evaluation clips (no ACE run given)", character), clips


def retarget(method: Method, clips: Sequence[Motion], *, device: str = "cpu") -> list[Motion]:
    """``clips`` retargeted by ``method`` (clips resampled to the run's frame rate where needed)."""
    if method.kind == "ace":
        return [r.motion for r in AceRetargeter(method.run, retarget_dir=method.stage, device=device).retarget(clips)]
    model = NknRetargeter(method.run, device=device)
    same_rate = [c if abs(c.fps - model.fps) < 1e-6 else c.resample(model.fps) for c in clips]
    return model.retarget(same_rate)


def evaluate_methods(
    methods: Sequence[Method],
    clips: Sequence[Motion],
    reference: Reference,
    *,
    keep: int = 0,
    seed: int = 0,
    device: str = "cpu",
    log: Callable[[str], None] = print,
) -> Evaluation:
    """Retarget ``clips`` with every method and score it against ``reference`` (Table-1 metrics).

    Args:
        methods: What to compare.
        clips: Held-out human clips (:func:`reference_for`).
        reference: :func:`reference_for` of the methods.
        keep: Keep the retargeted motions of the first ``keep`` clips (for videos).
        seed: Seed of DIV's random subsets (the same for every row).
        device: Torch device of the retargeters.
        log: Where progress lines go.
    """
    if not clips:
        raise ConfigError("no evaluation clips")
    ref = reference
    if not ref.character:
        ref.character = character_motions(ref.creature, ref.data, progress=False)
    frames = sum(c.frame_count for c in clips)
    log(f"evaluation: {len(clips)} clips ({frames} frames) against {sum(m.frame_count for m in ref.character)} "
        f"frames of {ref.creature.name}'s data set")
    dataset = dataset_row(ref.character, ref.creature_ees, ref.creature_length, seed=seed)
    dataset_ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in ref.character])
    results = []
    for i, method in enumerate(methods):
        motions = retarget(method, clips, device=device)
        row = evaluate_clips(method.name, list(clips), motions, ref.character, creature_ees=ref.creature_ees,
                             human_ees=ref.human_ees, creature_length=ref.creature_length,
                             human_length=ref.human_length, seed=seed)
        causes = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in motions]).cause_ratios()
        results.append(MethodResult(method, row, causes, motions[:keep]))
        log(f"[{i + 1}/{len(methods)}] {method.name} (seed {method.seed}, {method.stage}): DIV {row.div:.3f}, "
            f"FID {row.fid:.3f}, L_fea {row.feature_loss:.3f}, UFR {100 * row.ufr:.2f}%")
    return Evaluation(ref, list(clips), dataset, dataset_ufr.cause_ratios(), results)

