"""The evaluation protocol: retargeters scored on one split of a human clip folder, per clip type and length.

The clips are a subject split of the folder (:func:`morphkit.motion.split.split_clips`: ``dev``, ``test`` or
``all``), evaluated whole at the runs' frame rate. Each method's exported motions (``X+replan`` where the
method has contact-aware rows, else the method's own) are scored per group of clips — all, each clip type
(:data:`~morphkit.motion.split.CLIP_TYPES`), long (≥ :data:`~morphkit.motion.split.LONG_CLIP_SECONDS`) and
short — with the follow figures of :func:`~morphkit.evaluation.table.follow_figures` (hand, reach, forward,
yaw, their mean, the turn gain, the drift) and the strict UFR; and per clip, to see where following breaks.
Beside each group's and each clip's turn gain, the gain within the creature's reach
(:func:`~morphkit.metrics.reachable_gain` of the human's yaw rate at the fastest turn in the creature's data): what
copying the human's turns would score on a body that turns no faster than its data — the scale the turn gain is
read against.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from morphkit.errors import ConfigError
from morphkit.evaluation.evaluate import Evaluation, MethodResult, open_method
from morphkit.evaluation.methods import Method
from morphkit.evaluation.table import follow_figures, moves_over_ground
from morphkit.metrics import UnrealisticFrames, follow_gain, reachable_gain, unrealistic_frame_ratio
from morphkit.motion import GROUND_MOTION_FEATURES, Motion, Pairing, load_motions, read_skeleton_map, to_canonical
from morphkit.motion.split import CLIP_TYPES, LONG_CLIP_SECONDS, ClipEntry, clip_type_from_motion, split_clips
from morphkit.retarget.tables import write_table_files
from morphkit.retarget.training_data import CONVENTION_FILE, evaluation_split

__all__ = ["ClipFigures", "GroupRow", "ProtocolClips", "fastest_turn", "format_groups", "group_rows", "protocol_clips",
           "shipped_results", "split_for", "trained_on", "write_protocol"]

_YAW = GROUND_MOTION_FEATURES[2]
_CORRELATIONS = ("follow", "follow_hand", "follow_reach", "follow_forward", "follow_yaw")
"""The per-clip correlations of :func:`~morphkit.evaluation.table.follow_figures`, averaged over a group's clips."""


@dataclass(frozen=True)
class ProtocolClips:
    """The clips of one split, loaded, with what the protocol groups them by."""

    split: str
    folder: str
    motions: list[Motion]
    """On the canonical human, at the runs' frame rate, whole."""
    entries: list[ClipEntry]
    types: list[str]
    """Each clip's type: the manifest's (:attr:`ClipEntry.clip_type`), else from its motion."""


def protocol_clips(folder: str | os.PathLike[str], split: str, fps: float, *,
                   limit: int | None = None) -> ProtocolClips:
    """The clips of ``folder``'s ``split``, read at ``fps`` with the folder's convention table and mapped onto the
    canonical human (as training reads a folder), the first ``limit`` of them.

    Raises:
        ConfigError: an unknown or empty split.
        MotionFormatError: a clip that cannot be read or is not a human.
    """
    entries = split_clips(folder, split)[:limit]
    table = Path(folder) / CONVENTION_FILE
    maps = [read_skeleton_map(table)] if table.is_file() else []
    options = dict(maps[0].read_options) if maps else {}
    motions = [to_canonical(m, maps=maps) for m in load_motions([e.path for e in entries], fps=fps, **options)]
    types = [e.clip_type or clip_type_from_motion(m) for e, m in zip(entries, motions, strict=True)]
    return ProtocolClips(split, os.fspath(folder), motions, entries, types)


def split_for(methods: Sequence[Method], split: str, *, human_data: str | os.PathLike[str] | None = None,
              limit: int | None = None) -> tuple[ProtocolClips, list[str]]:
    """The ``split`` of ``human_data`` (default: the folder the first method was trained on) at the methods'
    frame rate, and the names of its clips the first method trained on (:func:`trained_on`).

    Raises:
        ConfigError: an unknown or empty split, or no folder (runs trained on the embedded default human).
    """
    model = open_method(methods[0])
    folder = human_data if human_data is not None else model.human_data
    if folder is None:
        raise ConfigError(f"--split {split}: the runs were trained on the embedded default human motion, which has no "
                          "subjects; give --human-data DIR (a folder of human clips)")
    clips = protocol_clips(folder, split, model.data.fps, limit=limit)
    return clips, trained_on(clips, model.human_data, model.data.human_split)


def trained_on(clips: ProtocolClips, run_human_data: str | None, run_split: str = "all") -> list[str]:
    """Names of ``clips`` a run trained on ``run_human_data`` has seen: when it is the same folder, every clip outside
    the held-out list (:func:`~morphkit.retarget.training_data.evaluation_split`) on the run's side of the subject
    split (:attr:`~morphkit.retarget.training_data.DataConfig.human_split`); none otherwise."""
    if run_human_data is None or Path(run_human_data).resolve() != Path(clips.folder).resolve():
        return []
    held = set(evaluation_split())
    return [m.name for m, e in zip(clips.motions, clips.entries, strict=True)
            if m.name not in held and run_split in ("all", e.side)]


@dataclass(frozen=True)
class ClipFigures:
    """One method's figures on one clip."""

    method: str
    seed: int
    clip: str
    clip_type: str
    seconds: float
    follow: float | None
    follow_hand: float | None
    follow_reach: float | None
    follow_forward: float | None
    follow_yaw: float | None
    turn_gain: float | None
    reachable_turn_gain: float | None
    """:func:`~morphkit.metrics.reachable_gain` of the clip's human yaw rate at the fastest turn in the creature's
    data (:attr:`GroupRow.fastest_turn`); ``None`` where the turn gain is."""
    drift: float | None
    ufr: float


@dataclass(frozen=True)
class GroupRow:
    """One method's figures on one group of clips: follow figures averaged over its clips, the turn gain over
    their frames pooled, UFR over their frames."""

    method: str
    seed: int
    group: str
    clips: int
    seconds: float
    follow: float | None
    follow_hand: float | None
    follow_reach: float | None
    follow_forward: float | None
    follow_yaw: float | None
    turn_gain: float | None
    reachable_turn_gain: float | None
    """:func:`~morphkit.metrics.reachable_gain` of the group's human yaw rates (pooled) at
    :attr:`fastest_turn`; ``None`` where the turn gain is."""
    fastest_turn: float | None
    """The fastest turn in the creature's data set [rad/s] (largest |Ψ yaw rate|; ``None`` for a fixed base)."""
    drift: float | None
    ufr: float


def shipped_results(evaluation: Evaluation) -> list[MethodResult]:
    """Each method's exported rows: ``X+replan`` where it exists, else ``X``; no ``+lock`` rows."""
    names = {r.method.name for r in evaluation.results}
    return [r for r in evaluation.results
            if not r.method.name.endswith("+lock") and f"{r.method.name}+replan" not in names]


def _reachable(human_yaw: np.ndarray | None, gain: float | None, fastest: float | None) -> float | None:
    """The turn gain within reach of a body that turns at most ``fastest``, where there is a turn gain."""
    if human_yaw is None or gain is None or fastest is None or fastest <= 0:
        return None
    return reachable_gain(human_yaw, fastest)


def _clip_figures(result: MethodResult, clips: ProtocolClips, pairing: Pairing, roles: dict[str, str],
                  fastest: float | None) -> tuple[list[ClipFigures], list[tuple[np.ndarray, np.ndarray]],
                                                  list[UnrealisticFrames]]:
    figures, yaws, flags = [], [], []
    moves = moves_over_ground(result.shown)
    for human, motion, entry, kind in zip(clips.motions, result.shown, clips.entries, clips.types, strict=True):
        f = follow_figures([human], [motion], pairing, roles)
        n = min(human.frame_count, motion.frame_count) if moves else 0  # a fixed base has no yaw to pool
        yaw = (pairing.human_psi(human)[:n, _YAW], pairing.creature_psi(motion)[:n, _YAW])
        ufr = unrealistic_frame_ratio(motion)
        figures.append(ClipFigures(result.method.name, result.method.seed, human.name, kind, entry.seconds,
                                   *(f[k] for k in _CORRELATIONS), f["turn_gain"],
                                   _reachable(yaw[0], f["turn_gain"], fastest), f["drift"], float(ufr.ratio)))
        yaws.append(yaw)
        flags.append(ufr)
    return figures, yaws, flags


def _mean(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None


def fastest_turn(character: Sequence[Motion], pairing: Pairing) -> float | None:
    """The largest |yaw rate| of Ψ over a creature's data set ``character`` [rad/s]; ``None`` where it cannot go
    over the ground (:func:`~morphkit.evaluation.table.moves_over_ground`) or has no data."""
    if not character or not moves_over_ground(character):
        return None
    return max(float(np.abs(pairing.creature_psi(m)[:, _YAW]).max()) for m in character)


def group_rows(evaluation: Evaluation, clips: ProtocolClips) -> tuple[list[GroupRow], list[ClipFigures]]:
    """Every shipped result's (:func:`shipped_results`) figures per group — ``all``, each clip type present,
    ``long`` and ``short`` — and per clip. ``evaluation`` must keep every clip's motions (``keep`` = all)."""
    ref = evaluation.reference
    fastest = fastest_turn(ref.character, ref.pairing)
    roles = {e.name: e.role.name.lower() for e in ref.creature.end_effectors}
    groups = [("all", lambda c: True)]
    groups += [(t, lambda c, t=t: c.clip_type == t) for t in CLIP_TYPES if t in clips.types]
    groups += [(f"long (≥ {LONG_CLIP_SECONDS:g} s)", lambda c: c.seconds >= LONG_CLIP_SECONDS),
               ("short", lambda c: c.seconds < LONG_CLIP_SECONDS)]
    rows: list[GroupRow] = []
    per_clip: list[ClipFigures] = []
    for result in shipped_results(evaluation):
        if len(result.shown) != len(clips.motions):
            raise ValueError("group_rows needs every clip's retargeted motion (evaluate with keep = all clips)")
        figures, yaws, flags = _clip_figures(result, clips, ref.pairing, roles, fastest)
        per_clip += figures
        for group, member in groups:
            chosen = [i for i, f in enumerate(figures) if member(f)]
            if not chosen:
                continue
            scored = [figures[i] for i in chosen if figures[i].follow is not None]
            pooled = [yaws[i] for i in chosen if yaws[i][0].size >= 3]
            human_yaw = np.concatenate([h for h, _ in pooled]) if pooled else None
            gain = follow_gain(human_yaw, np.concatenate([c for _, c in pooled])) if human_yaw is not None else None
            ufr = UnrealisticFrames.concatenate([flags[i] for i in chosen]).ratio
            rows.append(GroupRow(result.method.name, result.method.seed, group, len(chosen),
                                 sum(figures[i].seconds for i in chosen),
                                 *(_mean([getattr(f, k) for f in scored]) for k in _CORRELATIONS), gain,
                                 _reachable(human_yaw, gain, fastest), fastest, _mean([f.drift for f in scored]),
                                 float(ufr)))
    return rows, per_clip


def _cell(value: float | None, percent: bool = False) -> str:
    if value is None:
        return "–"
    return f"{100 * value:.2f} %" if percent else f"{value:.2f}"


def format_groups(rows: Sequence[GroupRow], *, split: str, folder: str, seen: int = 0) -> str:
    """Markdown: a heading per method and seed, a row per group of clips."""
    head = ("| clips | n | min | follow | hand | reach | forward | yaw | turn gain | within reach | drift | UFR |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|")
    lines = [f"## Protocol: the {split} split of {folder}", ""]
    if seen:
        lines += [f"Warning: the runs trained on {seen} of these clips (the folder they were trained on, less its "
                  "held-out list): these figures are not of unseen clips.", ""]
    current = None
    for r in rows:
        if (r.method, r.seed) != current:
            current = (r.method, r.seed)
            lines += ([""] if lines[-1] else []) + [f"{r.method} (seed {r.seed})", "", head]
        lines.append(f"| {r.group} | {r.clips} | {r.seconds / 60:.1f} | {_cell(r.follow)} | {_cell(r.follow_hand)} | "
                     f"{_cell(r.follow_reach)} | {_cell(r.follow_forward)} | {_cell(r.follow_yaw)} | "
                     f"{_cell(r.turn_gain)} | {_cell(r.reachable_turn_gain)} | {_cell(r.drift)} | "
                     f"{_cell(r.ufr, percent=True)} |")
    fastest = next((r.fastest_turn for r in rows if r.fastest_turn is not None), None)
    if fastest is not None:
        lines += ["", f"within reach: what copying the human's turns scores on a body that turns no faster than "
                      f"its data does ({fastest:.2f} rad/s at most) — the scale a turn gain is read against."]
    return "\n".join(lines).rstrip()


def write_protocol(rows: Sequence[GroupRow], per_clip: Sequence[ClipFigures], folder: str | os.PathLike[str], *,
                   split: str, source: str, seen: int = 0) -> str:
    """Write ``protocol.md/.csv`` (per group) and ``protocol_clips.csv`` (+ ``.md``, per clip) into the report
    ``folder``; returns the per-group markdown."""
    root = Path(folder)
    markdown = format_groups(rows, split=split, folder=source, seen=seen)
    write_table_files(root / "protocol", markdown, [asdict(r) for r in rows])
    head = ["| method | seed | clip | type | s | follow | hand | reach | forward | yaw | turn gain | within reach "
            "| drift | UFR |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    clip_md = "\n".join(head + [
        f"| {c.method} | {c.seed} | {c.clip} | {c.clip_type} | {c.seconds:.1f} | {_cell(c.follow)} | "
        f"{_cell(c.follow_hand)} | {_cell(c.follow_reach)} | {_cell(c.follow_forward)} | {_cell(c.follow_yaw)} | "
        f"{_cell(c.turn_gain)} | {_cell(c.reachable_turn_gain)} | {_cell(c.drift)} | {_cell(c.ufr, percent=True)} |"
        for c in per_clip])
    write_table_files(root / "protocol_clips", clip_md, [asdict(c) for c in per_clip])
    return markdown
