"""Retarget held-out clips with every method and score them on one footing (ACE §7.3, Table 1).

Every method of a comparison is scored against one :class:`Reference`: the creature's synthesised
data set (the frames FID and the data set's DIV are taken from) and one
:class:`~morphkit.motion.Pairing` (end-effector pairs and body lengths) for L_fea. It is the
first method's that has one (an ACE run's, as trained). A comparison of methods without a pairing
(NKN alone) pairs end-effectors as ACE does (KL within compatible roles, Eq. 11) on the creature's
data and the evaluation clips, and takes both body lengths from the same motion.

Methods are opened through the :class:`~morphkit.retarget.retargeter.Retargeter` protocol
(:func:`morphkit.retarget.load`); rows come from :func:`~morphkit.evaluation.table.dataset_row` and
:func:`~morphkit.evaluation.table.evaluate_clips` (Ψ of the exported motion, DIV and FID on Ψ
against the data set's frames, L_fea per frame, UFR over every frame), plus the share of frames of
each unrealistic effect (:meth:`morphkit.metrics.UnrealisticFrames.cause_ratios`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from morphkit.errors import ConfigError, MorphkitError, MotionFormatError
from morphkit.evaluation.methods import Method
from morphkit.evaluation.table import (
    TableRow,
    dataset_row,
    evaluate_clips,
    off_data_warnings,
    pooled_skating,
    reference_data,
)
from morphkit.graph import Morphology
from morphkit.metrics import UnrealisticFrames, unrealistic_frame_ratio
from morphkit.motion import Motion, Pairing, ee_distributions, map_end_effectors, measured_body_length
from morphkit.retarget.retargeter import RetargetedClip, Retargeter, contact_export
from morphkit.retarget.run_loader import load
from morphkit.retarget.training_data import (
    DataConfig,
    character_motions,
    evaluation_clips,
    human_motions,
)

CONTACT_ROWS = ("ACE", "NKN")
"""Methods whose motions are also scored through each contact-aware export (a row each)."""

__all__ = ["CONTACT_ROWS", "Evaluation", "MethodResult", "Reference", "evaluate_methods", "open_method",
           "reference_for", "retarget", "retarget_clips"]


@dataclass(eq=False)
class Reference:
    """What every method of one comparison is measured against."""

    creature: Morphology
    data: DataConfig
    """Frames, rate and seed of the creature's synthesised data set (and of the embedded evaluation clips)."""
    pairing: Pairing
    """Ψ's end-effector pairs and body lengths (Eq. 9–11)."""
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
    failed: dict[str, str] = field(default_factory=dict)
    """Methods that could not be scored (``"ACE (seed 0)"`` → the error, which names the clip): left out
    of the rows, listed in the report."""
    source_skating: float | None = None
    """The source humans' own skating ratio on the clips (:func:`~morphkit.evaluation.table.pooled_skating`)."""


def open_method(method: Method, *, device: str = "cpu") -> Retargeter:
    """The trained retargeter of ``method``."""
    return load(method.run, stage=method.stage if method.stage != method.run else None, device=device)


def reference_for(methods: Sequence[Method], *, human_data: str | os.PathLike[str] | None = None,
                  limit: int | None = None, clips: Sequence[Motion] | None = None) -> tuple[Reference, list[Motion]]:
    """The :class:`Reference` of a comparison (see the module docs) and its evaluation clips.

    The clips are the held-out split of ``human_data`` (default: the human data the first method was
    trained on), every clip of a folder that holds none of the split, or the embedded default's
    evaluation clips (:func:`morphkit.retarget.training_data.evaluation_clips`), at the runs' frame rate.

    Args:
        methods: The methods (:func:`~morphkit.evaluation.methods.find_methods`).
        human_data: The evaluation clips' folder.
        limit: Keep the first this many clips.
        clips: The evaluation clips, read already (a protocol split): they replace the held-out split.
    """
    models = [(m, open_method(m)) for m in methods]
    paired = next(((m, r) for m, r in models if r.pairing is not None), None)
    method, model = paired if paired is not None else models[0]
    creature = model.creature
    if creature is None:
        raise ConfigError(f"{method.run}: a retargeter between human skeletons has no creature to compare on")
    source = os.fspath(human_data) if human_data is not None else model.human_data
    clips = list(clips) if clips is not None else evaluation_clips(source, model.data, limit=limit)
    character = character_motions(creature, model.data, progress=False)
    if model.pairing is not None and model.pairing.centred and model.pairing.height_centred:
        return Reference(creature, model.data, model.pairing, source, os.fspath(method.run), character), clips
    if model.pairing is not None:
        pairing, origin = model.pairing, os.fspath(method.run)
    else:
        human = clips[0].morphology
        c_len, h_len = measured_body_length(creature, character), measured_body_length(human, clips)
        roles = ({e.name: e.role for e in creature.end_effectors}, {e.name: e.role for e in human.end_effectors})
        mapping = map_end_effectors(ee_distributions(character, length=c_len, max_frames_per_clip=300),
                                    ee_distributions(clips, length=h_len, max_frames_per_clip=300), roles=roles,
                                    active_hand=True)
        pairing = Pairing.from_mapping(mapping.mapping, c_len, h_len, mapping.active_hand)
        origin = "KL mapping on the evaluation clips"
    # A run trained before Ψ (or its root height) was centred, or a method without a pairing: the centres come from the
    # data it was trained on (the synthesis is deterministic), and the report says so.
    trained_on = human_motions(model.human_data, model.data)
    pairing = pairing.with_centres(character, trained_on)
    return Reference(creature, model.data, pairing, source, f"{origin}; Ψ centres computed from its data",
                     character), clips


def retarget_clips(method: Method, clips: Sequence[Motion], *, device: str = "cpu") -> list[RetargetedClip]:
    """``clips`` retargeted by ``method``, with what the method says of them (its stance flags, ...)."""
    return open_method(method, device=device).retarget(clips)


def retarget(method: Method, clips: Sequence[Motion], *, device: str = "cpu") -> list[Motion]:
    """``clips`` retargeted by ``method`` (clips resampled to the run's frame rate where needed)."""
    return [r.motion for r in retarget_clips(method, clips, device=device)]


def evaluate_methods(
    methods: Sequence[Method],
    clips: Sequence[Motion],
    reference: Reference,
    *,
    keep: int = 0,
    seed: int = 0,
    contacts: Sequence[str] = ("replan", "lock"),
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
        contacts: Contact-aware exports (:data:`morphkit.contact_export.CONTACT_MODES` other than ``none``) whose
            rows join ACE's and NKN's (named ``ACE+replan``, ...): the same motions through the export.
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
    try:
        ref.pairing.human_psi(clips[0])
    except ConfigError as exc:
        raise MotionFormatError(f"clip {clips[0].name!r}: its human states do not fit the runs' Ψ pairing "
                                f"(another human skeleton than they were trained on?): {exc}") from None
    data = reference_data(ref.character, ref.pairing)
    dataset = dataset_row(ref.character, ref.pairing, seed=seed, humans=clips, reference=data)
    dataset_ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in ref.character])
    results = []
    failed: dict[str, str] = {}
    for i, method in enumerate(methods):
        try:
            retargeted = retarget_clips(method, clips, device=device)
        except MorphkitError as exc:  # one method failing leaves the others' rows and the report
            failed[f"{method.name} (seed {method.seed})"] = f"{method.stage}: {exc}"
            log(f"[{i + 1}/{len(methods)}] {method.name} (seed {method.seed}): FAILED: {exc}")
            continue
        motions = [r.motion for r in retargeted]
        variants = [(method, motions)]
        if method.name in CONTACT_ROWS:  # lock holds the method's own stance flags where it has them
            # the shipped export's (WithContacts): replan's one-to-one paired feet follow the human's swings
            variants += [(dataclasses.replace(method, name=f"{method.name}+{mode}"),
                          [contact_export(r, mode, ref.pairing) for r in retargeted])
                         for mode in contacts if mode != "none"]
        for shown_as, shown in variants:
            row = evaluate_clips(shown_as.name, list(clips), shown, data, ref.pairing, seed=seed)
            causes = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in shown]).cause_ratios()
            results.append(MethodResult(shown_as, row, causes, shown[:keep]))
            log(f"[{i + 1}/{len(methods)}] {shown_as.name} (seed {method.seed}, {method.stage}): DIV {row.div:.3f}, "
                f"FID {row.fid:.3f}, L_fea {row.feature_loss:.3f}, UFR {100 * row.ufr:.2f}%, follow {row.follow:.2f}")
            for line in off_data_warnings(row):  # never silent: a clip that left the creature's motion
                log(f"warning: {line}")
    return Evaluation(ref, list(clips), dataset, dataset_ufr.cause_ratios(), results, failed,
                      source_skating=pooled_skating(clips))

