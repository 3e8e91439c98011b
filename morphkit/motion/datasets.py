"""Loading many clips, cached, and a windowed PyTorch dataset of ACE states.

:func:`load_motions` reads motion files (any format :func:`~morphkit.motion.read_motion` knows)
and keeps each converted clip as an ``.npz`` (:mod:`~morphkit.motion.io_npz`) in a cache
folder, named by a hash of the file's *content*, its *name* and the read options, so a second load
skips parsing, unit and axis conversion, grounding and resampling. Moving a file keeps its cache
entry; renaming or editing it makes a new one (a clip's name is part of what is cached, so two
byte-identical clips under different names each keep their own).

:class:`MotionDataset` cuts clips into fixed-length windows of ACE states (human x^h or
character x^r, :mod:`~morphkit.motion.states`), normalised with statistics fitted over all
frames (or given, e.g. the training set's, for a validation set). The states are cached in the
same ``.npz`` as the clip. Save the statistics beside a model with :meth:`MotionDataset.save_stats`.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from morphkit._version import __version__
from morphkit.cache import cache_dir
from morphkit.errors import ConfigError, MorphkitError, MotionFormatError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion.io_npz import read_npz_motion_with_extra, write_npz_motion
from morphkit.motion.manifest import MANIFEST_NAME, manifest_files
from morphkit.motion.motion import Motion
from morphkit.motion.states import (
    NormStats,
    StateLayout,
    character_state_from_motion,
    character_state_layout,
    human_state_from_motion,
    human_state_layout,
)

__all__ = [
    "CACHE_VERSION",
    "MotionDataset",
    "default_cache_dir",
    "expand_motion_paths",
    "joint_offsets",
    "load_motions",
]

CACHE_VERSION = 2
"""Bumped whenever the conversion or the state definitions change (part of every cache key)."""

_SUFFIXES = (".bvh", ".npz", ".usd", ".usda", ".usdc")
_KINDS = ("human", "character")


def default_cache_dir() -> Path:
    """``$MORPHKIT_CACHE_DIR/motions`` (default ``~/.cache/morphkit/motions``)."""
    return cache_dir("motions")


def _folder_motion_files(folder: Path) -> list[Path]:
    """Motion files of a folder: those its manifest lists (:mod:`~morphkit.motion.manifest`), else every
    one below it (sorted), less the files a sub-folder's manifest does not list."""
    listed = manifest_files(folder)
    if listed is not None:
        return [f for f in listed if f.suffix.lower() in _SUFFIXES]
    files = sorted(f for f in folder.rglob("*") if f.suffix.lower() in _SUFFIXES and f.is_file())
    for man in folder.rglob(MANIFEST_NAME):
        sub = manifest_files(man.parent)
        if sub is not None:
            allowed = set(sub)
            files = [f for f in files if f in allowed or not f.is_relative_to(man.parent)]
    return files


def expand_motion_paths(paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]]) -> list[Path]:
    """Files behind ``paths``: files as given, folders searched recursively for motion files (sorted);
    a folder with a manifest (``morphkit synth --out DIR``) gives only the files its manifest lists.

    Raises:
        MotionFormatError: a path that does not exist, no motion file at all, or a folder whose
            manifest says its run has not finished or lists a missing file.
    """
    items = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(_folder_motion_files(p))
        elif p.is_file():
            out.append(p)
        else:
            raise MotionFormatError(f"no such file or folder: {p}", location=SourceLocation(str(p)))
    if not out:
        raise MotionFormatError(f"no motion files ({', '.join(_SUFFIXES)}) in {', '.join(map(str, items))}")
    return out


def _cache_key(path: Path, options: dict[str, Any]) -> str:
    h = hashlib.sha1()
    h.update(f"morphkit {__version__} motion cache v{CACHE_VERSION} {path.suffix.lower()}\n".encode())
    # The name too: the cached clip carries it (its name, the outputs and reports named after it).
    h.update(f"{path.name}\n".encode())
    h.update(json.dumps(options, sort_keys=True, default=repr).encode())
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _load_one(path: Path, cache: Path | None, options: dict[str, Any], kind: str | None) -> tuple[Motion, Any]:
    """One clip (and its states of ``kind`` when asked), through the cache."""
    from morphkit.motion import read_motion

    entry = cache / f"{_cache_key(path, options)}.npz" if cache is not None else None
    if entry is not None and entry.is_file():
        try:
            motion, extra = read_npz_motion_with_extra(entry)
        except MorphkitError:
            motion, extra = None, {}  # a damaged entry is rebuilt below
        if motion is not None:
            if kind is None or f"state_{kind}" in extra:
                return motion, extra.get(f"state_{kind}") if kind else None
            states = _states(motion, kind)
            extra[f"state_{kind}"] = states
            write_npz_motion(motion, entry, **extra)
            return motion, states
    motion = read_motion(path, **options)
    states = _states(motion, kind) if kind else None
    if entry is not None:
        write_npz_motion(motion, entry, **({f"state_{kind}": states} if kind else {}))
    return motion, states


def joint_offsets(morphology: Morphology) -> np.ndarray:
    """Joint origin translations in their parent links ("bone offsets"), shape [J, 3] [m], joint order."""
    return np.array([j.origin.xyz for j in morphology.joints], dtype=float).reshape(-1, 3)


def _states(motion: Motion, kind: str) -> np.ndarray:
    return human_state_from_motion(motion) if kind == "human" else character_state_from_motion(motion)


def load_motions(
    paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
    *,
    cache_dir: str | os.PathLike[str] | bool | None = True,
    **options: Any,
) -> list[Motion]:
    """Read many motion files, through the content-hash cache.

    Args:
        paths: Files and/or folders (searched recursively for ``.bvh``, ``.npz``, ``.usd*``).
        cache_dir: Cache folder; ``True`` for :func:`default_cache_dir`, ``None``/``False`` for none.
        **options: Passed to :func:`~morphkit.motion.read_motion` (e.g. ``fps=30``, ``facing="+x"``);
            they are part of the cache key.

    Returns:
        The motions, in path order (folders sorted by file name).
    """
    cache = _resolve_cache(cache_dir)
    return [_load_one(p, cache, options, None)[0] for p in expand_motion_paths(paths)]


def _resolve_cache(cache_dir: str | os.PathLike[str] | bool | None) -> Path | None:
    if cache_dir is True:
        cache = default_cache_dir()
    elif cache_dir is None or cache_dir is False:
        return None
    else:
        cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    return cache


class MotionDataset(torch.utils.data.Dataset):
    """Fixed-length windows of normalised ACE states over many clips of one creature.

    Item ``i`` is a dict: ``state`` [window, D] (float32 by default, normalised), ``q`` [window, C]
    (the clip's coordinates), ``root_pose`` [window, 7] (``T_world_root``), ``offsets`` [J, 3] (the
    clip's joint origin translations, its bone offsets [m], which differ between subjects of one
    topology), ``clip`` (index into :attr:`motions`) and ``start`` (first frame). Windows start
    every ``stride`` frames; clips shorter than ``window`` give none.

    Args:
        motions: Clips of one creature (same end-effectors and q layout).
        window: Frames per item (>= 1); 2 gives the (x_{t-1}, x_t) transitions ACE trains on.
        stride: Frames between window starts (>= 1).
        kind: ``"human"`` (x^h, §6.1) or ``"character"`` (x^r, §6.2).
        stats: Normalisation statistics (default: fitted to these clips).
        states: Precomputed states per clip (as :func:`from_files` passes from its cache).
        dtype: Tensor dtype of ``state``.

    Raises:
        ConfigError: bad ``window``/``stride``/``kind``, no clips, clips of different layouts, or
            ``stats`` of another dimension.
    """

    def __init__(
        self,
        motions: Sequence[Motion],
        *,
        window: int,
        stride: int = 1,
        kind: str = "character",
        stats: NormStats | None = None,
        states: Sequence[np.ndarray] | None = None,
        dtype: torch.dtype = torch.float32,
    ) -> None:
        if kind not in _KINDS:
            raise ConfigError(f"unknown state kind {kind!r}; expected one of: {', '.join(_KINDS)}")
        if window < 1 or stride < 1:
            raise ConfigError(f"window and stride must be >= 1, got window={window}, stride={stride}")
        if not motions:
            raise ConfigError("a dataset needs at least one motion")
        self.motions = list(motions)
        self.kind = kind
        self.window = int(window)
        self.stride = int(stride)
        first = self.motions[0].morphology
        self.layout: StateLayout = human_state_layout(first) if kind == "human" else character_state_layout(first)
        for m in self.motions[1:]:
            other = human_state_layout(m.morphology) if kind == "human" else character_state_layout(m.morphology)
            if other != self.layout:
                raise ConfigError(
                    f"clip {m.name!r} has another state layout than {self.motions[0].name!r} "
                    "(different end-effectors or joints): one dataset holds one creature"
                )
        if states is None:
            states = [_states(m, kind) for m in self.motions]
        self.states = [np.asarray(s, dtype=np.float64) for s in states]
        for m, s in zip(self.motions, self.states, strict=True):
            if s.shape != (m.frame_count, self.layout.dim):
                raise ConfigError(f"clip {m.name!r}: states of shape {list(s.shape)}, expected "
                                  f"{[m.frame_count, self.layout.dim]}")
        self.stats = stats if stats is not None else NormStats.fit(self.states)
        if self.stats.mean.shape != (self.layout.dim,):
            raise ConfigError(f"stats have dimension {self.stats.mean.shape[0]}, the states {self.layout.dim}")
        # One conversion for all clips, then per-clip views (228 small conversions cost 4x more).
        lengths = [s.shape[0] for s in self.states]
        flat = torch.as_tensor(self.stats.normalize(np.concatenate(self.states, axis=0)), dtype=dtype)
        self._normalised = list(torch.split(flat, lengths))
        self._q = [torch.as_tensor(m.q, dtype=dtype) for m in self.motions]
        self._root_pose = [torch.as_tensor(m.root_pose(), dtype=dtype) for m in self.motions]
        self._offsets = [torch.as_tensor(joint_offsets(m.morphology), dtype=dtype) for m in self.motions]
        self.index = [
            (c, start)
            for c, s in enumerate(self.states)
            for start in range(0, s.shape[0] - self.window + 1, self.stride)
        ]

    @classmethod
    def from_files(
        cls,
        paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
        *,
        window: int,
        stride: int = 1,
        kind: str = "character",
        stats: NormStats | None = None,
        cache_dir: str | os.PathLike[str] | bool | None = True,
        dtype: torch.dtype = torch.float32,
        **options: Any,
    ) -> MotionDataset:
        """Load clips (:func:`load_motions`, states cached beside them) and build the dataset."""
        if kind not in _KINDS:
            raise ConfigError(f"unknown state kind {kind!r}; expected one of: {', '.join(_KINDS)}")
        cache = _resolve_cache(cache_dir)
        loaded = [_load_one(p, cache, options, kind) for p in expand_motion_paths(paths)]
        return cls(
            [m for m, _ in loaded],
            window=window,
            stride=stride,
            kind=kind,
            stats=stats,
            states=[s for _, s in loaded],
            dtype=dtype,
        )

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, i: int) -> dict[str, Any]:
        clip, start = self.index[i]
        w = slice(start, start + self.window)
        return {
            "state": self._normalised[clip][w],
            "q": self._q[clip][w],
            "root_pose": self._root_pose[clip][w],
            "offsets": self._offsets[clip],
            "clip": clip,
            "start": start,
        }

    @property
    def frame_count(self) -> int:
        """Frames over all clips."""
        return sum(s.shape[0] for s in self.states)

    def save_stats(self, path: str | os.PathLike[str]) -> None:
        """Write the normalisation statistics (``.npz``, see :meth:`NormStats.save`)."""
        self.stats.save(path)
