"""ACE's Table-1 metrics (§7.3) for retargeted clips of any method: DIV, FID, L_fea and UFR, the data
set's own row, and the table as markdown and CSV.

* Ψ of a retargeted clip is taken from the **exported** motion (:func:`~morphkit.motion.motion_features`
  of the :class:`~morphkit.motion.Motion`, end-effectors through FK), with the comparison's
  :class:`~morphkit.motion.Pairing`; the human's Ψ from its states with the paired human end-effectors.
* DIV and FID compare frames of all retargeted clips with frames of the creature's synthesised data
  set (:func:`morphkit.metrics.diversity`, :func:`morphkit.metrics.fid`).
* L_fea is Eq. 9 per frame, averaged over all frames of all clips.
* UFR pools every frame of every clip (:func:`morphkit.metrics.unrealistic_frame_ratio`).
* ``off data``: the share of clips whose Ψ lies outside the creature's data (:func:`morphkit.metrics.data_envelope`:
  a clip's mean Mahalanobis distance to the data's Ψ Gaussian above the largest the data's own 60-frame segments
  reach); the clips are named in :attr:`TableRow.off_data_clips`, and the commands warn of each.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphkit.graph import BaseType, EndEffectorRole
from morphkit.metrics import (
    UFR_SETTINGS,
    DataEnvelope,
    FootContactFigures,
    UnrealisticFrames,
    data_envelope,
    diversity,
    feature_loss,
    fid,
    floating_frames,
    follow_gain,
    follow_score,
    foot_contact_figures,
    longest_flight,
    matched_reference,
    physdiff_figures,
    skating_ratio,
    unrealistic_frame_ratio,
)
from morphkit.motion import GROUND_MOTION_FEATURES, ROOT_FEATURE_DIM, Motion, Pairing
from morphkit.retarget.tables import write_table_files

__all__ = ["EXTRA_COLUMNS", "PERCENT_FIGURES", "ReferenceData", "TableRow", "dataset_row", "evaluate_clips",
           "follow_figures", "follow_series", "format_table", "moves_over_ground", "off_data_warnings",
           "outside_clips", "pooled_skating", "reference_data", "write_table"]


@dataclass(frozen=True)
class TableRow:
    """One row of a Table-1-style comparison (``None`` where a metric does not apply or was not measured).

    ``div``/``fid`` are measured against the content-matched reference (the creature's data resampled
    to the clips' root speed and yaw rate); ``div_all``/``fid_all`` against the whole data set, as
    the paper does. Rates are fractions in [0, 1]; PhysDiff's figures are millimetres.
    """

    name: str
    div: float
    fid: float
    feature_loss: float | None
    ufr: float
    frames: int
    fid_all: float | None = None
    """FID against the creature's whole data set (the paper's)."""
    div_all: float | None = None
    """The Dataset row: DIV of the whole data set (the paper's); method rows: their DIV (the same as ``div``)."""
    ufr_medium: float | None = None
    """UFR at :data:`~morphkit.metrics.UFR_MEDIUM` (5 cm contact, 0.5 m/s sliding, 1 cm penetration)."""
    ufr_loose: float | None = None
    """UFR at :data:`~morphkit.metrics.UFR_LOOSE` (5 cm, 1 m/s, 2 cm)."""
    foot_sliding: float | None = None
    """Sliding foot-frames / all foot-frames (UFR's strict sliding test, per foot)."""
    foot_penetration: float | None = None
    """Penetrating foot-frames / all foot-frames (strict)."""
    skating: float | None = None
    """GMD's skating ratio (:func:`~morphkit.metrics.skating_ratio`), frame transitions pooled."""
    penetrate_mm: float | None = None
    float_mm: float | None = None
    skate_mm: float | None = None
    """PhysDiff's Penetrate, Float and Skate [mm] (:func:`~morphkit.metrics.physdiff_figures`), frame-weighted."""
    floating: float | None = None
    """Frames in a flight (no foot within 2 cm of the ground) longer than the data set's longest / all frames."""
    follow: float | None = None
    """Mean over clips of the Pearson correlation of paired human and creature series, averaged over
    the series: each mapped end-effector's height, the root's forward velocity and its yaw rate."""
    follow_hand: float | None = None
    """``follow`` of the heights of the creature's hand and tool end-effectors only."""
    follow_reach: float | None = None
    """Mean over clips and hand/tool end-effectors of the Pearson correlation of the end-effector's forward offset from
    the root (its heading-frame x) with the human's: a hand reaching forward, not only rising. ``follow_hand`` reads
    heights alone, and a tool that goes up when the hand goes forward scores well there."""
    follow_forward: float | None = None
    """``follow`` of the root's forward velocity only."""
    follow_yaw: float | None = None
    """``follow`` of the yaw rate only."""
    turn_gain: float | None = None
    """How far the creature turns when the human does: :func:`~morphkit.metrics.follow_gain` of the yaw rates, the
    clips' frames pooled (1: through the human's angle; 0: not at all). A correlation misses a creature that turns
    the right way at a tenth of the rate."""

    drift: float | None = None
    """Where the creature goes that the human does not: mean over clips of the distance between the two roots' mean
    heading-frame (forward, sideways) velocities [body lengths/s]. A creature that walks backwards at 0.1 body
    lengths/s while the human stands scores 0.1; a correlation does not see it (it ignores a constant)."""
    off_data: float | None = None
    """Share of clips whose motion lies outside the creature's data (:func:`outside_clips`); the Dataset row: its own
    clips' share (0 by the threshold's construction)."""
    off_data_clips: tuple[tuple[str, float], ...] = ()
    """``(clip name, distance)`` of each clip outside the data (not a column: the commands warn of each)."""
    off_data_threshold: float | None = None
    """The data's own largest per-segment distance the clips were compared with."""

    def as_dict(self) -> dict[str, object]:
        out: dict[str, object] = {"method": self.name, "DIV": self.div, "FID": self.fid, "L_fea": self.feature_loss,
                                  "UFR": self.ufr, "frames": self.frames}
        out.update({column: getattr(self, key) for key, column in EXTRA_COLUMNS})
        return out


EXTRA_COLUMNS = (
    ("off_data", "off data"), ("fid_all", "FID (all data)"), ("div_all", "DIV (all data)"), ("follow", "follow"),
    ("follow_hand", "follow hand"), ("follow_reach", "follow reach"), ("follow_forward", "follow forward"),
    ("follow_yaw", "follow yaw"), ("turn_gain", "turn gain"), ("drift", "drift"),
    ("ufr_medium", "UFR medium"), ("ufr_loose", "UFR loose"), ("foot_sliding", "sliding/foot"),
    ("foot_penetration", "penetration/foot"), ("skating", "skating"), ("penetrate_mm", "Penetrate mm"),
    ("float_mm", "Float mm"), ("skate_mm", "Skate mm"), ("floating", "floating"),
)
"""``(TableRow field, column name)`` of the figures beyond the paper's four."""


@dataclass(eq=False)
class ReferenceData:
    """What every row of one comparison is measured against, computed once (:func:`reference_data`)."""

    psi: np.ndarray
    """Ψ of every frame of the creature's data set [N, 11 + 3k]."""
    longest_flight: int
    """Longest run of frames with no foot in contact in the data set (the floating limit)."""
    roles: dict[str, str]
    """Role name of each creature end-effector (``foot``, ``hand``, ``tool``, ``head``)."""
    envelope: DataEnvelope | None = None
    """The data's Ψ Gaussian and its own clips' largest distance (:func:`~morphkit.metrics.data_envelope`)."""


def reference_data(character: Sequence[Motion], pairing: Pairing) -> ReferenceData:
    """Ψ, longest flight, end-effector roles and envelope of the creature's data set."""
    per_clip = [pairing.creature_psi(m) for m in character]
    psi = np.concatenate(per_clip, axis=0)
    flight = max((longest_flight(m) for m in character), default=0)
    m = character[0].morphology
    return ReferenceData(psi, int(flight), {e.name: e.role.name.lower() for e in m.end_effectors},
                         data_envelope(per_clip, segment=ENVELOPE_SEGMENT))


ENVELOPE_SEGMENT = 60
"""Frames per data segment the off-data threshold is measured on (ours: 2 s at the data's 30 fps, the length of a
short evaluation clip)."""


def outside_clips(retargeted: Sequence[Motion], reference: ReferenceData, pairing: Pairing) -> list[tuple[str, float]]:
    """``(name, distance)`` of each clip whose Ψ lies outside the creature's data (:meth:`DataEnvelope.outside`)."""
    env = reference.envelope
    if env is None:
        return []
    out = []
    for m in retargeted:
        d = env.distance(pairing.creature_psi(m))
        if d > env.threshold:
            out.append((m.name, d))
    return out


def off_data_warnings(row: TableRow) -> list[str]:
    """One line per clip of ``row`` outside the creature's data (empty when none is)."""
    return [f"{row.name}: clip {name!r} lies outside the creature's data: distance {d:.2f} > "
            f"{row.off_data_threshold:.2f} (the largest its own clips reach); look at it before using it"
            for name, d in row.off_data_clips]


def _matched(reference: ReferenceData, psi_h: np.ndarray, seed: int) -> np.ndarray:
    return matched_reference(reference.psi, psi_h, seed=seed)[0]


def dataset_row(character: Sequence[Motion], pairing: Pairing, *, seed: int = 0,
                humans: Sequence[Motion] | None = None, reference: ReferenceData | None = None) -> TableRow:
    """The data set's own row: DIV of the content-matched reference (of ``humans``; the whole data set
    without them), DIV of the whole data set, UFR and the contact figures (FID 0 by definition)."""
    ref = reference if reference is not None else reference_data(character, pairing)
    div_all = float(diversity(ref.psi, rng=seed))
    div = div_all
    if humans:
        psi_h = np.concatenate([pairing.human_psi(h) for h in humans], axis=0)
        div = float(diversity(_matched(ref, psi_h, seed), rng=seed))
    contact = _contact_figures(character, ref)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in character])
    outside = outside_clips(character, ref, pairing)
    return TableRow("Dataset", div, 0.0, None, float(ufr.ratio), int(ref.psi.shape[0]), fid_all=0.0, div_all=div_all,
                    off_data=len(outside) / max(len(character), 1), off_data_clips=tuple(outside),
                    off_data_threshold=None if ref.envelope is None else ref.envelope.threshold, **contact)


def _contact_figures(motions: Sequence[Motion], ref: ReferenceData) -> dict[str, float]:
    frames = np.array([m.frame_count for m in motions], dtype=float)
    w = frames / frames.sum()
    out: dict[str, float] = {}
    for key, thr in (("ufr_medium", UFR_SETTINGS["medium"]), ("ufr_loose", UFR_SETTINGS["loose"])):
        flags = [unrealistic_frame_ratio(m, thresholds=thr) for m in motions]
        out[key] = float(UnrealisticFrames.concatenate(flags).ratio)
    feet = FootContactFigures.concatenate([foot_contact_figures(m) for m in motions])
    out["foot_sliding"], out["foot_penetration"] = feet.sliding_rate, feet.penetration_rate
    out["skating"] = pooled_skating(motions)
    physdiff = [physdiff_figures(m) for m in motions]
    for key in ("penetrate_mm", "float_mm", "skate_mm"):
        out[key] = float(np.dot([getattr(f, key) for f in physdiff], w))
    floating = sum(int(floating_frames(m, ref.longest_flight).sum()) for m in motions)
    out["floating"] = floating / float(frames.sum())
    return out


def pooled_skating(motions: Sequence[Motion]) -> float:
    """GMD's skating ratio (:func:`~morphkit.metrics.skating_ratio`) of ``motions``' own feet, frame transitions
    pooled over the clips; for the source humans it is the bar a retargeted creature is held to (the same
    clips, the same test on the humans' feet)."""
    transitions = np.array([max(m.frame_count - 1, 0) for m in motions], dtype=float)
    skating = [skating_ratio(m) for m in motions]
    return float(np.dot(skating, transitions) / max(transitions.sum(), 1.0))


_HEIGHT = 0
_FORWARD, _SIDEWAYS, _YAW = GROUND_MOTION_FEATURES
"""Ψ columns: root height / body length, heading-frame forward and sideways velocity [body lengths/s], yaw rate
[rad/s] (:mod:`morphkit.motion.features`); an end-effector's block starts at ``ROOT_FEATURE_DIM + 3 i``."""


def follow_series(psi: np.ndarray, ees: Sequence[str]) -> dict[str, np.ndarray]:
    """The series a viewer compares, from Ψ [T, 11 + 3k]: each paired end-effector's height above the
    ground (root height plus its heading-frame z, in body lengths; named by the creature's
    end-effector), the root's forward velocity and its yaw rate."""
    out = {f"{name} height": psi[:, _HEIGHT] + psi[:, ROOT_FEATURE_DIM + 3 * i + 2] for i, name in enumerate(ees)}
    out["forward velocity"] = psi[:, _FORWARD]
    out["yaw rate"] = psi[:, _YAW]
    return out


def moves_over_ground(motions: Sequence[Motion]) -> bool:
    """Whether the creature of ``motions`` can go over the ground (any base but a fixed one): where it cannot (an
    arm bolted down), the root's forward velocity, yaw rate, turn gain and drift are not its to follow."""
    return not motions or motions[0].morphology.base != BaseType.FIXED


def follow_figures(humans: Sequence[Motion], retargeted: Sequence[Motion], pairing: Pairing,
                   roles: dict[str, str]) -> dict[str, float | None]:
    """``follow``, ``follow_hand``, ``follow_reach``, ``follow_forward``, ``follow_yaw``, ``turn_gain``, ``drift``
    (see :class:`TableRow`): per clip the Pearson correlations of :func:`follow_series` and of the hand/tool
    end-effectors' forward offsets (:func:`~morphkit.metrics.follow_score`; a constant series scores 0 against a
    varying one), averaged over clips with equal weight; the turn gain over the clips' yaw rates pooled; the drift
    per clip, averaged. Clips are compared over their common length; clips shorter than 3 frames are left out.
    A fixed-base creature (:func:`moves_over_ground`) has no root series: its forward, yaw, turn gain and drift
    are None and ``follow`` is the mean over its end-effectors."""
    rooted = not moves_over_ground(retargeted)
    per: dict[str, list[float]] = {}
    reach: list[float] = []
    hands = [i for i, e in enumerate(pairing.creature_ees) if e in roles and EndEffectorRole[roles[e].upper()].on_arm]
    yaw: list[tuple[np.ndarray, np.ndarray]] = []
    drift: list[float] = []
    for h, r in zip(humans, retargeted, strict=True):
        n = min(h.frame_count, r.frame_count)
        if n < 3:
            continue
        psi_h, psi_r = pairing.human_psi(h)[:n], pairing.creature_psi(r)[:n]
        hs = follow_series(psi_h, pairing.creature_ees)
        rs = follow_series(psi_r, pairing.creature_ees)
        if rooted:
            for key in ("forward velocity", "yaw rate"):
                del hs[key], rs[key]
        for key, value in follow_score(hs, rs).correlations.items():
            per.setdefault(key, []).append(value)
        if hands:
            forward = [ROOT_FEATURE_DIM + 3 * i for i in hands]  # each hand/tool's heading-frame x
            names = [str(i) for i in hands]
            reach += follow_score(dict(zip(names, psi_h[:, forward].T, strict=True)),
                                  dict(zip(names, psi_r[:, forward].T, strict=True))).correlations.values()
        if rooted:
            continue
        yaw.append((hs["yaw rate"], rs["yaw rate"]))
        ground = [_FORWARD, _SIDEWAYS]  # where the root goes; a turn on the spot is the yaw's, not drift
        drift.append(float(np.linalg.norm(psi_r[:, ground].mean(axis=0) - psi_h[:, ground].mean(axis=0))))
    if not per:
        return {"follow": None, "follow_hand": None, "follow_reach": None, "follow_forward": None, "follow_yaw": None,
                "turn_gain": None, "drift": None}
    mean = {k: float(np.mean(v)) for k, v in per.items()}
    heights = [mean[f"{pairing.creature_ees[i]} height"] for i in hands]
    gain = follow_gain(np.concatenate([h for h, _ in yaw]), np.concatenate([c for _, c in yaw])) if yaw else None
    return {"follow": float(np.mean(list(mean.values()))), "follow_hand": float(np.mean(heights)) if heights else None,
            "follow_reach": float(np.mean(reach)) if reach else None, "follow_forward": mean.get("forward velocity"),
            "follow_yaw": mean.get("yaw rate"), "turn_gain": gain, "drift": float(np.mean(drift)) if drift else None}


def evaluate_clips(
    name: str,
    humans: Sequence[Motion],
    retargeted: Sequence[Motion],
    character: Sequence[Motion] | ReferenceData,
    pairing: Pairing,
    *,
    seed: int = 0,
) -> TableRow:
    """Every figure of ``retargeted`` clips (pairwise with the ``humans`` they came from), against the
    creature's data set (its motions, or their :func:`reference_data`)."""
    ref = character if isinstance(character, ReferenceData) else reference_data(character, pairing)
    psi_r = np.concatenate([pairing.creature_psi(m) for m in retargeted], axis=0)
    psi_h = np.concatenate([pairing.human_psi(h) for h in humans], axis=0)
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in retargeted])
    div = float(diversity(psi_r, rng=seed))
    outside = outside_clips(retargeted, ref, pairing)
    return TableRow(name, div, float(fid(_matched(ref, psi_h, seed), psi_r)), float(feature_loss(psi_h, psi_r)),
                    float(ufr.ratio), int(psi_r.shape[0]), fid_all=float(fid(ref.psi, psi_r)), div_all=div,
                    off_data=len(outside) / max(len(retargeted), 1), off_data_clips=tuple(outside),
                    off_data_threshold=None if ref.envelope is None else ref.envelope.threshold,
                    **_contact_figures(retargeted, ref), **follow_figures(humans, retargeted, pairing, ref.roles))


def _cell(value: float | None, digits: int = 3, percent: bool = False) -> str:
    if value is None:
        return "N/A"
    return f"{100 * value:.{digits}f}%" if percent else f"{value:.{digits}f}"


def format_table(rows: Sequence[TableRow]) -> str:
    """Markdown: ``| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |`` (DIV: closest to the data set's),
    then the figures beyond the paper's (:data:`EXTRA_COLUMNS`) where any row has them."""
    lines = ["| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.name} | {_cell(r.div)} | {_cell(r.fid)} | {_cell(r.feature_loss)} | "
                     f"{_cell(r.ufr, percent=True)} | {r.frames} |")
    shown = [(k, c) for k, c in EXTRA_COLUMNS if any(getattr(r, k) is not None for r in rows)]
    if shown:
        lines += ["", "| method | " + " | ".join(c for _, c in shown) + " |", "|---|" + "---|" * len(shown)]
        for r in rows:
            cells = [_cell(getattr(r, k), 2 if k.endswith("_mm") else 3, percent=k in PERCENT_FIGURES)
                     for k, _ in shown]
            lines.append(f"| {r.name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


PERCENT_FIGURES = frozenset({"off_data", "ufr_medium", "ufr_loose", "foot_sliding", "foot_penetration", "skating",
                             "floating"})
"""Extra figures that are fractions (shown as percentages)."""


def write_table(rows: Sequence[TableRow], stem: str | os.PathLike[str]) -> str:
    """Write ``stem.md`` and ``stem.csv`` (atomically); returns the markdown."""
    return write_table_files(stem, format_table(rows), [r.as_dict() for r in rows])
