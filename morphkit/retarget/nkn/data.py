"""NKN's training data: characters (skeletons of one topology) with their clips, and feature windows.

A :class:`Character` is one skeleton and the motion performed by it (none for a generated variant,
which is a retargeting target only). The characters come from

* a human data folder: its clips grouped by skeleton (equal bone offsets), the documented CMU
  evaluation split left out; every clip must be of one topology;
* the embedded default (no folder): the shipped human moved by morphkit's synthesis, plus
  ``synth_variants`` bone-length variants of it, each moved by the synthesis too (real motion);
* ``train_variants`` bone-length variants of every data skeleton (no motion).

:class:`ClipBank` turns the clips into NKN features (:mod:`~.features`) through the topology's
:class:`~.fk.SkeletonFK` and indexes the windows of ``window`` frames that lie inside single clips.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from morphkit.errors import ConfigError, MotionFormatError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion import Motion, NormStats
from morphkit.retarget.nkn.config import NknDataConfig
from morphkit.retarget.nkn.features import global_motion, local_positions
from morphkit.retarget.nkn.fk import SkeletonFK
from morphkit.retarget.nkn.skeleton import (
    bone_offsets,
    check_same_topology,
    random_variants,
    skeleton_key,
    topology_difference,
    with_offsets,
)
from morphkit.retarget.training_data import (
    DataConfig,
    HumanData,
    as_folders,
    character_motions,
    evaluation_clips,
    read_human_folder,
    split_evaluation_clips,
)

__all__ = [
    "Character",
    "ClipBank",
    "HumanData",
    "as_folders",
    "clip_features",
    "data_characters",
    "embedded_characters",
    "evaluation_pieces",
    "offset_stats",
    "test_clips",
    "training_characters",
]


@dataclass(eq=False)
class Character:
    """One skeleton and the clips it performs (``clips`` empty: a target-only variant)."""

    morphology: Morphology
    clips: list[Motion]
    origin: str
    """``"data"`` (a data folder), ``"synthesised"`` (the embedded default and its moved variants),
    ``"variant"`` (generated bone lengths, no motion) or ``"creature"`` (cross-morphology target)."""

    @property
    def name(self) -> str:
        return self.morphology.name

    @property
    def offsets(self) -> np.ndarray:
        """Bone offsets [J, 3] [m]."""
        return bone_offsets(self.morphology)


def _group(motions: Sequence[Motion], label: str, origin: str) -> list[Character]:
    groups: dict[str, list[Motion]] = {}
    for m in motions:
        groups.setdefault(skeleton_key(m.morphology), []).append(m)
    out = []
    for i, clips in enumerate(groups.values()):
        name = label if len(groups) == 1 else f"{label}_{i}"
        morph = with_offsets(clips[0].morphology, bone_offsets(clips[0].morphology), name=name)
        out.append(Character(morph, list(clips), origin))
    return out


def _check_topology(motions: Sequence[Motion], where: str | None = None) -> None:
    first = motions[0].morphology
    for m in motions[1:]:
        try:
            check_same_topology(first, m.morphology, what=f"clip {m.name!r}")
        except MotionFormatError as exc:
            raise MotionFormatError(str(exc.args[0]) if exc.args else str(exc),
                                    location=SourceLocation(where) if where else None) from None


def data_characters(human_data: HumanData, data: NknDataConfig, *, exclude_evaluation: bool = True,
                    cache_dir: str | os.PathLike[str] | bool | None = True) -> list[Character]:
    """The characters of human data folders: their clips (resampled to ``data.fps``, read with a folder's convention
    table where it has one) grouped by skeleton.

    The first folder's topology is the run's; a later folder of another convention is re-expressed on it
    through a shipped link map (:mod:`~.mapping`, e.g. the Bandai Namco skeleton onto CMU's 22 joints).

    Raises:
        MotionFormatError: no motion files, clips of several topologies in one folder, a folder of another
            topology without a link map, or only evaluation clips.
    """
    from morphkit.retarget.nkn.mapping import find_link_map, map_motion

    template: Morphology | None = None
    out: list[Character] = []
    for path in as_folders(human_data):
        motions, _ = read_human_folder(path, data.fps, cache_dir)
        _check_topology(motions, os.fspath(path))
        motions = [m for m in motions if m.name not in data.held_out]
        if exclude_evaluation:
            motions, held = split_evaluation_clips(motions)
            if not motions:
                raise MotionFormatError(f"every clip is in the evaluation split ({len(held)} clips)",
                                        location=SourceLocation(os.fspath(path)))
        label = path.name or "data"
        if template is None:
            template = motions[0].morphology
        elif topology_difference(template, motions[0].morphology) is not None:
            link_map = find_link_map(motions[0].morphology, template)
            if link_map is None:
                check_same_topology(template, motions[0].morphology, what=f"data folder {label!r}: skeleton")
            motions = [map_motion(m, template, link_map, skeleton_name=label) for m in motions]  # type: ignore[arg-type]
        out += _group(motions, label, "data")
    if not out:
        raise MotionFormatError("no human data folder given")
    return out


def _embedded_motion(frames: int, seed: int, fps: float) -> list[Motion]:
    from morphkit.synth import default_human_motion

    return list(default_human_motion(frames=frames, seed=seed, fps=fps))


def embedded_characters(data: NknDataConfig, *, progress: bool = False,
                        cache_dir: str | os.PathLike[str] | None = None) -> list[Character]:
    """The embedded default: the shipped human's synthesised motion and ``synth_variants`` moved variants."""
    base = _group(_embedded_motion(data.human_frames, data.synth_seed, data.fps), "default_human", "synthesised")
    out = list(base)
    variants = random_variants(base[0].morphology, data.synth_variants, spread=data.variant_range,
                               seed=data.variant_seed + 100, prefix="default_human_moved")
    for v in variants:
        synth = DataConfig(character_frames=data.synth_variant_frames, fps=data.fps, synth_seed=data.synth_seed)
        out.append(Character(v, character_motions(v, synth, cache_dir=cache_dir, progress=progress), "synthesised"))
    return out


def training_characters(human_data: HumanData | None, data: NknDataConfig, *,
                        progress: bool = False, log: Callable[[str], None] = print) -> list[Character]:
    """Every training character: the data's (or the embedded default's), then the target-only variants."""
    if human_data is None:
        log(f"skeleton data: embedded default human ({data.human_frames} frames) and {data.synth_variants} "
            "synthesised bone-length variants")
        chars = embedded_characters(data, progress=progress)
    else:
        chars = data_characters(human_data, data)
    out = list(chars)
    for i, c in enumerate(chars):
        out += [Character(v, [], "variant")
                for v in random_variants(c.morphology, data.train_variants, spread=data.variant_range,
                                         seed=data.variant_seed + i, prefix=f"{c.name}_target")]
    return out


def evaluation_pieces(human_data: HumanData | None, data: NknDataConfig, *, limit: int | None = None,
                      cache_dir: str | os.PathLike[str] | bool | None = True) -> list[Motion]:
    """§5's test clips: :func:`test_clips` of the evaluation clips
    (:func:`~morphkit.retarget.training_data.evaluation_clips` on the data's own skeleton; the embedded default's
    at least two test clips long), at most ``limit``."""
    clips = evaluation_clips(human_data, data, cache_dir=cache_dir, canonical=False, min_frames=2 * data.test_frames)
    return test_clips(clips, data.test_frames, limit=limit)


def test_clips(clips: Sequence[Motion], frames: int, *, limit: int | None = None) -> list[Motion]:
    """Non-overlapping ``frames``-long pieces of ``clips`` (§5: 4-second test clips), at most ``limit``."""
    out: list[Motion] = []
    for clip in clips:
        for start in range(0, clip.frame_count - frames + 1, frames):
            out.append(clip.slice(start, start + frames).replace(name=f"{clip.name}_{start}"))
            if limit is not None and len(out) >= limit:
                return out
    return out


def clip_features(clip: Motion, fk: SkeletonFK, offsets: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """NKN features of one clip: local link positions [T, L, 3] [m] and global motion [T, 4]."""
    q = torch.tensor(clip.q, dtype=torch.float64)
    off = None if offsets is None else torch.as_tensor(offsets, dtype=torch.float64)
    with torch.no_grad():
        P = fk(q, off).numpy()
    root = clip.root_pose()
    return local_positions(P, root), global_motion(root, clip.fps)


def offset_stats(characters: Sequence[Character], *, min_std: float) -> NormStats:
    """Mean and spread of the bone offsets [3J] over ``characters`` (spread at least ``min_std`` [m])."""
    flat = np.stack([c.offsets.reshape(-1) for c in characters])
    std = np.maximum(flat.std(axis=0), min_std)
    return NormStats(flat.mean(axis=0), std)


class ClipBank:
    """Features $[p, v]$ of every clip of ``characters`` in one tensor, and their windows.

    Args:
        characters: Characters of one topology (those without clips hold no windows).
        template: The topology's template skeleton.
        window: Frames per window.
        fk_backend: :class:`~.fk.SkeletonFK` backend for the features.

    Attributes:
        x: [N, 3L + 4] features of all frames (float32, not normalised).
        offsets: [K, J, 3] bone offsets of the characters (float32).
        has_clips: [K] bool, characters with at least one window.

    Raises:
        ConfigError: when no clip is ``window`` frames long.
    """

    def __init__(self, characters: Sequence[Character], template: Morphology, window: int, *,
                 fk_backend: str = "warp") -> None:
        self.characters = list(characters)
        self.window = int(window)
        fk = SkeletonFK(template, backend=fk_backend)  # type: ignore[arg-type]
        rows, starts, counts, row = [], [], [], 0
        for c in self.characters:
            check_same_topology(template, c.morphology, what="character")
            mine = []
            for clip in c.clips:
                p, v = clip_features(clip, fk, c.offsets)
                T = clip.frame_count
                rows.append(np.concatenate([p.reshape(T, -1), v], axis=1))
                if T >= window:
                    mine.append(np.arange(row, row + T - window + 1))
                row += T
            starts.append(np.concatenate(mine) if mine else np.zeros(0, dtype=np.int64))
            counts.append(len(starts[-1]))
        if not any(counts):
            longest = max((clip.frame_count for c in self.characters for clip in c.clips), default=0)
            raise ConfigError(f"no clip has {window} frames (longest: {longest}); lower clip_frames")
        self.raw = np.concatenate(rows, axis=0)
        self.x = torch.as_tensor(self.raw, dtype=torch.float32)
        self.offsets = torch.as_tensor(np.stack([c.offsets for c in self.characters]), dtype=torch.float32)
        self.has_clips = torch.as_tensor(np.array(counts) > 0)
        self._counts = torch.as_tensor(counts, dtype=torch.long)
        self._first = torch.as_tensor(np.concatenate([[0], np.cumsum(counts)[:-1]]), dtype=torch.long)
        self._starts = torch.as_tensor(np.concatenate(starts).astype(np.int64))
        self._owner = torch.repeat_interleave(torch.arange(len(counts)), self._counts)

    def stats(self, *, min_std: float = 0.0) -> NormStats:
        """Per-dimension mean and std of the features over all frames: constant dimensions get 1, the
        others at least ``min_std`` (a link that barely moves relative to the root must not blow up)."""
        fitted = NormStats.fit(self.raw)
        constant = fitted.std == 1.0
        return NormStats(fitted.mean, np.where(constant, 1.0, np.maximum(fitted.std, min_std)))

    @property
    def window_count(self) -> int:
        return int(self._starts.shape[0])

    def sample(self, count: int, generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
        """``count`` windows uniformly over all windows: features [count, window, D] and their characters [count]."""
        pick = torch.randint(self.window_count, (count,), generator=generator)
        return self._rows(self._starts[pick]), self._owner[pick]

    def sample_of(self, characters: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        """One random window of each given character [B] (characters without clips get any window)."""
        u = torch.rand(characters.shape[0], generator=generator)
        counts = self._counts[characters]
        ok = counts > 0
        local = (u * counts.clamp_min(1)).long().clamp_max(counts.clamp_min(1) - 1)
        index = torch.where(ok, self._first[characters] + local, (u * self.window_count).long())
        return self._rows(self._starts[index])

    def _rows(self, first: torch.Tensor) -> torch.Tensor:
        return self.x[first[:, None] + torch.arange(self.window)]
