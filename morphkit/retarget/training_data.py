"""The data every trainer reads, owned by none of them: the character's synthesised motion, the
human's motion, the documented evaluation split, and state windows over clips.

The character's data set is synthesised from its graph (:mod:`morphkit.synth`, §7.1: random
commands over its speed range) and cached by content hash (the morphology, frame count, frame
rate, seed, morphkit's version and the synthesis source), so a second run of the same creature skips synthesis. The
human's is a folder of motion files (BVH or any format morphkit reads), minus the documented
evaluation split, or the embedded default (the shipped ``human`` moved by morphkit's synthesis).

Every human clip is mapped onto the canonical human (:func:`~morphkit.motion.to_canonical`: the shipped
``human``, scaled by leg length), so the human state's dimension never depends on the data's skeleton
and one folder may mix conventions (CMU-22, CMU Daz, Bandai Namco, Mixamo, LAFAN1). A folder may hold
its own convention table, :data:`CONVENTION_FILE` (:func:`~morphkit.motion.read_skeleton_map`), tried
before the shipped ones; its ``scale``/``up``/``facing`` apply to every file of the folder.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch

from morphkit._atomic import atomic_path
from morphkit._version import __version__
from morphkit.errors import ConfigError, MotionFormatError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion import (
    MIRRORED_SUFFIX,
    Motion,
    NormStats,
    SkeletonMap,
    load_motions,
    mirror_motion,
    read_skeleton_map,
    to_canonical,
)
from morphkit.motion.datasets import default_cache_dir
from morphkit.output_names import safe_stem

__all__ = [
    "CONVENTION_FILE",
    "EMBEDDED_EVALUATION_CLIPS",
    "SYNTHESIS_OPTIONS",
    "DataConfig",
    "HumanData",
    "StateWindows",
    "as_folders",
    "character_data",
    "character_motions",
    "evaluation_clips",
    "evaluation_split",
    "human_motions",
    "read_human_folder",
    "split_evaluation_clips",
    "validation_split",
]


CONVENTION_FILE = "convention.yaml"
"""A human data folder's own convention table (optional)."""


@dataclass(frozen=True)
class DataConfig:
    """Where the training states come from: the creature's synthesised motion and the human's (every method's;
    a method's own data options extend it, as :class:`morphkit.retarget.nkn.NknDataConfig`)."""

    retired: ClassVar[dict[str, Any]] = {"forward_speed": None}
    """Deleted options and their off values: a run's config naming them is read where they are off
    (docs/experiments/bringing-back.md)."""

    character_frames: int = 200_000
    """Synthesised character frames (§7.1: 200k states per character)."""
    fps: float = 30.0
    """Frame rate of both data sets [1/s] (human clips are resampled to it)."""
    synth_seed: int = 0
    """Seed of the character's synthesis and of the embedded default human motion."""
    human_frames: int = 6_000
    """Frames of the embedded default human motion (used when no human data is given)."""
    stand_probability: float | None = None
    """Probability that a segment of the character's synthesised commands stands still (its arms, head
    and tail keep moving: in-place upper-body motion); ``None``: the synthesis' own default
    (:attr:`morphkit.synth.CommandConfig.stand_probability`, 0.1). Ours: the paper draws random
    commands only, while held-out humans mostly stand, bend and reach."""
    yaw_rate: float | None = None
    """Largest yaw rate [rad/s] of the character's synthesised commands (±); ``None``: the synthesis' own
    (:attr:`morphkit.synth.CommandConfig.yaw_rate`, ±1 rad/s, the paper's §7.1). Ours (``quick`` and ``default``: ±3):
    mocap humans turn at up to 2 rad/s at the 95th percentile of the CMU development split and spin faster, and a
    character whose data never turns faster cannot follow them (docs/experiments/turn-range.md)."""
    arm_hang_share: float | None = None
    """Share of the synthesised arm moves that go to the lowest-hanging neighbouring pose
    (:attr:`morphkit.synth.ArmConfig.hang_share`); ``None``: the synthesis' own (0, every move random). Ours."""
    full_arm_travel: bool = True
    """Synthesise the character's arms over each joint's whole travel (the synthesis' default,
    :class:`morphkit.synth.ArmConfig`: a wheeled robot's lift to its top); off:
    :meth:`~morphkit.synth.ArmConfig.partial_travel`, within 70 % of each arm joint's span about rest (heads, necks
    and tails over their whole travel either way; runs from before this option was recorded used it). Ours;
    measured with the main job on two seeds, the whole travel did better on the shipped export (see the docs)."""
    human_split: str = "all"
    """Which subjects of a human data folder the training clips come from (:func:`morphkit.motion.split.split_clips`):
    ``all`` (every clip but :func:`evaluation_split`'s), ``dev`` (the protocol's development subjects only, so
    that ``morphkit evaluate --split test`` scores subjects the run never saw) or ``test``. Ignored for the
    embedded default human."""
    human_mirror: bool = False
    """Add each human training clip's left-right mirror image (:func:`morphkit.motion.mirror_motion`), so the
    human data turn, step and reach to both sides alike. Ours (PFNN and MANN mirror their mocap the same way):
    the embedded default human of ``quick`` (10 clips) walks in left turns three times as often as in right
    ones, and G learnt to turn the quadruped with an arm left whichever way the human turned (see the docs)."""


SYNTHESIS_OPTIONS: tuple[str, ...] = ("stand_probability", "yaw_rate", "arm_hang_share", "full_arm_travel")
"""The :class:`DataConfig` fields that shape the creature's synthesised data besides its length, frame rate and
seed. Another trainer that synthesises the creature (NKN's cross-morphology mode) carries the same fields and
copies them from ACE's config (:func:`synthesis_options`) when a table compares both, so both see one data set."""


def synthesis_options(data: Any) -> dict[str, Any]:
    """``data``'s :data:`SYNTHESIS_OPTIONS` by name (any config with those fields)."""
    return {name: getattr(data, name) for name in SYNTHESIS_OPTIONS}


def evaluation_split() -> tuple[str, ...]:
    """Stems of the CMU clips kept for evaluation (``morphkit/retarget/data/cmu_eval_split.txt``)."""
    text = resources.files("morphkit.retarget").joinpath("data/cmu_eval_split.txt").read_text()
    return tuple(line.split("#", 1)[0].strip() for line in text.splitlines() if line.split("#", 1)[0].strip())


def split_evaluation_clips(motions: Sequence[Motion]) -> tuple[list[Motion], list[Motion]]:
    """``(train, evaluation)``: clips named in :func:`evaluation_split` go to the second list."""
    held = set(evaluation_split())
    train = [m for m in motions if m.name not in held]
    return train, [m for m in motions if m.name in held]


def _morphology_key(morphology: Morphology) -> str:
    # The frozen dataclass's repr lists every link, joint, shape and end-effector: a content hash.
    return hashlib.sha256(repr(morphology).encode()).hexdigest()[:16]


def _synth_key(data: DataConfig) -> str:
    key = "" if data.stand_probability is None else f"|stand={data.stand_probability!r}"
    key += "" if data.yaw_rate is None else f"|yaw={float(data.yaw_rate)!r}"
    key += "" if data.arm_hang_share is None else f"|hang={float(data.arm_hang_share)!r}"
    return key + ("|arms=full" if data.full_arm_travel else "|arms=partial")


def _synth_config(data: DataConfig) -> Any:
    from morphkit.synth import ArmConfig, CommandConfig, SynthConfig

    changed: dict[str, Any] = {}
    if data.stand_probability is not None:
        changed["stand_probability"] = data.stand_probability
    if data.yaw_rate is not None:
        changed["yaw_rate"] = (-float(data.yaw_rate), float(data.yaw_rate))
    commands = CommandConfig(**changed)
    arms = ArmConfig() if data.full_arm_travel else ArmConfig.partial_travel()
    if data.arm_hang_share is not None:
        arms = replace(arms, hang_share=float(data.arm_hang_share))
    return SynthConfig(commands=commands, arms=arms)


def character_motions(
    morphology: Morphology,
    data: DataConfig,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> list[Motion]:
    """The character's synthesised data set (``data.character_frames`` frames), cached.

    Args:
        morphology: The character.
        data: Frames, frame rate and seed.
        cache_dir: Cache folder (default ``$MORPHKIT_CACHE_DIR/motions``, see
            :func:`~morphkit.motion.datasets.default_cache_dir`).
        progress: Show the synthesis progress bar.
        log: Told whether the data came from the cache or were synthesised (one line).
    """
    return character_data(morphology, data, cache_dir=cache_dir, progress=progress, log=log)[0]


def character_data(
    morphology: Morphology,
    data: DataConfig,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> tuple[list[Motion], list[np.ndarray]]:
    """:func:`character_motions` and, per motion, the synthesis' stance flags [T, F] (1.0 / 0.0) of the
    creature's feet (:func:`~morphkit.motion.foot_names`; F = 0 without feet)."""
    from morphkit.synth import source_digest, synthesize

    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = hashlib.sha256(
        f"{_morphology_key(morphology)}|{data.character_frames}|{data.fps}|{data.synth_seed}|{__version__}|"
        f"{source_digest()}{_synth_key(data)}".encode()
    ).hexdigest()[:24]
    path = cache / f"synth_{safe_stem(morphology.name, default='creature')}_{key}.npz"
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as f:
                q, lengths, names, contact = f["q"], f["lengths"], [str(n) for n in f["names"]], f["contact"]
            starts = np.concatenate([[0], np.cumsum(lengths)])
            if log is not None:
                log(f"character data: {int(lengths.sum())} frames of {morphology.name} from the cache ({path})")
            spans = list(zip(starts[:-1], starts[1:], names, strict=True))
            return ([Motion(morphology, data.fps, q[a:b], n) for a, b, n in spans],
                    [contact[a:b].astype(float) for a, b, _ in spans])
        except (OSError, KeyError, ValueError):
            pass  # a damaged (or older, flag-less) cache entry is rebuilt
    if log is not None:
        log(f"character data: synthesising {data.character_frames} frames of {morphology.name} "
            f"(kept in {cache} for the next run)")
    result = synthesize(morphology, frames=data.character_frames, fps=data.fps, seed=data.synth_seed,
                        config=_synth_config(data), progress=progress)
    motions = list(result.motions)
    contacts = [_foot_order(morphology, getattr(result.rig.plan, "legs", ()), c, m.frame_count)
                for c, m in zip(result.contact, motions, strict=True)]
    cache.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, q=np.concatenate([m.q for m in motions]), lengths=np.array([m.frame_count for m in motions]),
                 names=np.array([m.name for m in motions]), contact=np.concatenate(contacts).astype(np.uint8))
    return motions, contacts


def _foot_order(morphology: Morphology, legs: Sequence[Any], contact: np.ndarray, frames: int) -> np.ndarray:
    """The synthesis' per-leg stance [T, NL] as flags [T, F] of :func:`~morphkit.motion.foot_names` (a foot
    no leg plans is in stance: the synthesis keeps it on the ground)."""
    from morphkit.motion import foot_names

    feet = foot_names(morphology)
    out = np.ones((frames, len(feet)))
    leg_of = {leg.end_effector: i for i, leg in enumerate(legs)}
    for j, name in enumerate(feet):
        if name in leg_of and contact.size:
            out[:, j] = contact[:, leg_of[name]]
    return out


HumanData = str | os.PathLike[str] | Sequence[str | os.PathLike[str]]
"""One human data folder or several (NKN trains on several; the first one is the evaluation's)."""


def as_folders(human_data: HumanData | None) -> list[Path]:
    """``human_data`` as a list of paths (empty for ``None``)."""
    if human_data is None:
        return []
    if isinstance(human_data, (str, os.PathLike)):
        return [Path(human_data)]
    return [Path(p) for p in human_data]


def read_human_folder(path: str | os.PathLike[str], fps: float,
                      cache_dir: str | os.PathLike[str] | bool | None) -> tuple[list[Motion], list[SkeletonMap]]:
    """Clips under ``path`` at ``fps``, read with the folder's convention table's options (:data:`CONVENTION_FILE`,
    when it has one), and that table."""
    table = Path(path) / CONVENTION_FILE
    maps = [read_skeleton_map(table)] if table.is_file() else []
    options = dict(maps[0].read_options) if maps else {}
    return load_motions(path, cache_dir=cache_dir, fps=fps, **options), maps


def _canonical(motions: Sequence[Motion], maps: Sequence[SkeletonMap]) -> list[Motion]:
    return [to_canonical(m, maps=maps) for m in motions]


def human_motions(
    path: str | os.PathLike[str] | None,
    data: DataConfig,
    *,
    exclude_evaluation: bool = True,
    cache_dir: str | os.PathLike[str] | bool | None = True,
    canonical: bool = True,
) -> list[Motion]:
    """Human training clips: every motion file under ``path`` (evaluation split removed), resampled
    to ``data.fps`` and mapped onto the canonical human; or, with ``path=None``, the embedded default
    human motion (the canonical human already). With ``data.human_mirror``, each clip's mirror image follows
    the clips (named ``<clip>`` + :data:`~morphkit.motion.MIRRORED_SUFFIX`).

    Args:
        path: A human data folder (or file), or ``None``.
        data: Frame rate, the folder's split (:attr:`DataConfig.human_split`), the default's frames and seed.
        exclude_evaluation: Leave the evaluation split out.
        cache_dir: Where read clips are cached (:func:`~morphkit.motion.load_motions`).
        canonical: Map onto the canonical human (``False``: the clips' own skeleton, as runs trained
            before the canonical human were; then every clip must be of one skeleton).

    Raises:
        MotionFormatError: a folder without motion files, a clip that is not a human (what is missing),
            clips of different skeletons (``canonical=False``), or only evaluation clips.
    """
    if path is None:
        from morphkit.synth import default_human_motion

        return _with_mirrored(list(default_human_motion(frames=data.human_frames, seed=data.synth_seed, fps=data.fps)),
                              data)
    motions, maps = read_human_folder(path, data.fps, cache_dir)
    if canonical:
        motions = _canonical(motions, maps)
    first = motions[0].morphology
    for m in motions[1:]:
        if m.morphology.link_names != first.link_names or m.morphology.end_effectors != first.end_effectors:
            raise MotionFormatError(
                f"clip {m.name!r} has another skeleton than {motions[0].name!r}: one human data folder holds one "
                "skeleton topology", location=SourceLocation(str(path)))
    if data.human_split != "all":
        from morphkit.motion.split import split_clips

        side = {e.name for e in split_clips(path, data.human_split)}
        motions = [m for m in motions if m.name in side]
    if exclude_evaluation:
        motions, held = split_evaluation_clips(motions)
        if not motions:
            raise MotionFormatError(f"every clip is in the evaluation split ({len(held)} clips)",
                                    location=SourceLocation(str(path)))
    return _with_mirrored(motions, data)


def _with_mirrored(motions: list[Motion], data: DataConfig) -> list[Motion]:
    if not data.human_mirror:
        return motions
    return motions + [mirror_motion(m) for m in motions]


EMBEDDED_EVALUATION_CLIPS = 6
"""Held-out clips of the embedded default human at least (the main job's ``--clips`` default; a quarter of
``quick``'s training frames held three)."""


def evaluation_clips(human_data: HumanData | None, data: DataConfig, *, limit: int | None = None,
                     cache_dir: str | os.PathLike[str] | bool | None = True, canonical: bool = True,
                     min_frames: int | None = None) -> list[Motion]:
    """Clips to evaluate on, never trained on, for every method: the evaluation split's clips of the (first) human
    data folder (every clip when none of them is named in the split), mapped onto the canonical human unless
    ``canonical`` is false (see :func:`human_motions`), or embedded default human clips of another seed: a quarter
    of the training frames, at least ``min_frames`` (default :data:`EMBEDDED_EVALUATION_CLIPS` clips); the first
    ``limit`` of them.
    """
    if human_data is None:
        from morphkit.synth import default_human_config, default_human_motion

        if min_frames is None:
            min_frames = round(default_human_config().rollout_seconds * data.fps) * EMBEDDED_EVALUATION_CLIPS
        frames = max(data.human_frames // 4, min_frames)
        clips = list(default_human_motion(frames=frames, seed=data.synth_seed + 1000, fps=data.fps))
    else:
        motions, maps = read_human_folder(as_folders(human_data)[0], data.fps, cache_dir)
        _, held = split_evaluation_clips(motions)
        clips = held or motions
        clips = clips[:limit] if limit is not None else clips
        if canonical:
            clips = _canonical(clips, maps)
    return clips[:limit] if limit is not None else clips


def validation_split(names: Sequence[str], share: float, seed: int) -> tuple[list[int], list[int]]:
    """Indices of the training and the validation clips: ``share`` of the source clips (at least one, fewer than
    all; none when there is only one), drawn by ``seed``; a clip's mirror image (``<clip>_mirrored``,
    ``data.human_mirror``) goes with its clip, so no mirrored twin of a validation clip is trained on.

    Raises:
        ConfigError: ``share`` outside (0, 1).
    """
    if not 0.0 < share < 1.0:
        raise ConfigError(f"retarget.validation_share must lie in (0, 1), got {share}")
    source_of = [n.removesuffix(MIRRORED_SUFFIX) for n in names]
    sources = sorted(set(source_of))
    if len(sources) < 2:
        return list(range(len(names))), []
    count = min(max(1, round(share * len(sources))), len(sources) - 1)
    held = {sources[i] for i in np.random.default_rng(seed).choice(len(sources), size=count, replace=False)}
    val = [i for i, s in enumerate(source_of) if s in held]
    train = [i for i, s in enumerate(source_of) if s not in held]
    return train, val


@dataclass(eq=False)
class StateWindows:
    """Normalised states of many clips in one tensor, and the windows that fit inside single clips.

    Attributes:
        states: [N, D] normalised states of all clips, concatenated (float32).
        starts: [W] first row of every window of ``length`` frames that lies inside one clip.
        length: Frames per window.
        stats: The normalisation statistics.
    """

    states: torch.Tensor
    starts: torch.Tensor
    length: int
    stats: NormStats

    @staticmethod
    def build(per_clip: Sequence[np.ndarray], length: int, stats: NormStats | None = None) -> StateWindows:
        """Windows of ``length`` frames over ``per_clip`` [T_i, D] states (statistics fitted unless given).

        Raises:
            ConfigError: when no clip is ``length`` frames long.
        """
        stats = stats if stats is not None else NormStats.fit(list(per_clip))
        lengths = [s.shape[0] for s in per_clip]
        offsets = np.concatenate([[0], np.cumsum(lengths)])
        starts = [np.arange(o, o + n - length + 1) for o, n in zip(offsets[:-1], lengths, strict=True) if n >= length]
        if not starts:
            raise ConfigError(f"no clip has {length} frames (longest: {max(lengths, default=0)})")
        flat = stats.normalize(np.concatenate(per_clip, axis=0))
        return StateWindows(torch.as_tensor(flat, dtype=torch.float32), torch.as_tensor(np.concatenate(starts)),
                            length, stats)

    def __len__(self) -> int:
        return int(self.starts.shape[0])

    def windows(self, index: torch.Tensor, device: torch.device | None = None) -> torch.Tensor:
        """Windows ``index`` [B] → [B, length, D] (on ``device``)."""
        rows = self.starts[index][:, None] + torch.arange(self.length)
        out = self.states[rows]
        return out if device is None else out.to(device)
