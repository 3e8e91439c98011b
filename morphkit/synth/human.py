"""The embedded default human motion: the shipped ``human`` moved by morphkit's own synthesis.

For users without motion capture, this is the human data the ACE trainer's main job learns from
(``examples/ace_train.py`` without ``--human-data``). It is :func:`~morphkit.synth.synthesize` of
``morphologies/human`` under :func:`default_human_config`: upright walking at up to about
1.6 m/s, forward mostly (a few steps back and to the side), turning, standing; arms swinging
opposite to the legs; and upper-body actions (:data:`~morphkit.synth.actions.ACTION_NAMES`) mixed
into the clips, each while standing or walking slowly:

- ``reach``: one hand ahead of the body, at hip, chest or shoulder height, held, brought back;
- ``wave``: one hand raised above the head, the forearm rocking sideways two to four times;
- ``point``: one arm straight, forward or out to the side, held;
- ``push``: both hands before the chest, pushed straight ahead once or twice.

Every clip lasts ``rollout_seconds`` (10 s; the last may be shorter) and is named
``human_<labels>_<index>``: its locomotion labels (:data:`LOCOMOTION_LABELS`, in that order)
then its actions in the order they first happen, e.g. ``human_walk_turn_wave_push_3``.
:func:`default_human_clips` gives the same clips with their labels and per-frame action codes.

The dataset depends only on ``frames``, ``seed`` and ``fps``; it is cached as one NPZ per
argument set under ``$MORPHKIT_CACHE_DIR/synth`` (default ``~/.cache/morphkit/synth``), keyed by
those arguments, the human description, :data:`HUMAN_MOTION_VERSION` and the source of
:mod:`morphkit.synth`, so any change to the synthesis makes a new entry.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from morphkit._atomic import atomic_path
from morphkit._version import __version__
from morphkit.cache import cache_dir as cache_folder
from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.motion.motion import Motion
from morphkit.synth.actions import ActionConfig, ActionSpan
from morphkit.synth.arms import ArmConfig
from morphkit.synth.core import SynthConfig, SynthResult, source_digest, synthesize
from morphkit.synth.locomotion_commands import CMD_VX, CMD_VY, CMD_WZ, CommandConfig

__all__ = [
    "HUMAN_MOTION_VERSION",
    "LOCOMOTION_LABELS",
    "HumanClip",
    "clip_labels",
    "default_human_clips",
    "default_human_config",
    "default_human_motion",
]

HUMAN_MOTION_VERSION = 1
"""Bumped whenever the default human dataset changes on purpose (part of the cache key)."""

LOCOMOTION_LABELS = ("stand", "walk", "run", "turn", "sidestep", "backward")
"""What a clip's root does for at least a second (``run``: half a second): stands still (below
5 cm/s and 0.05 rad/s), walks (0.2 m/s or more in the walk gait), runs (the run gait), turns
(0.3 rad/s or more), steps sideways (0.15 m/s or more) or backward (0.15 m/s or more)."""


@dataclass(frozen=True)
class HumanClip:
    """One clip of the default human dataset and what is in it."""

    motion: Motion
    labels: tuple[str, ...]
    """Locomotion labels (:data:`LOCOMOTION_LABELS`, in that order)."""
    actions: tuple[ActionSpan, ...]
    """Its upper-body actions in order (kind, frames ``[start, stop)``, hands)."""
    action: np.ndarray
    """[T] int8 action code per frame (:data:`~morphkit.synth.actions.ACTION_NAMES`)."""


def default_human_config() -> SynthConfig:
    """The synthesis settings of the default human dataset (see the module docstring).

    Speeds are at the commands' reference size (Spot's leg reach) and scale with the human's legs
    (x1.2): forward -0.36 … 1.57 m/s, sideways ±0.12 m/s, turning ±0.8 rad/s (all in the walk gait).
    The spine, neck and head sway gently (ball joints up to 0.1 rad); actions are on.
    """
    return SynthConfig(
        rollout_seconds=10.0,
        commands=CommandConfig(forward_speed=(-0.3, 1.3), lateral_speed=(-0.1, 0.1), yaw_rate=(-0.8, 0.8),
                               stand_probability=0.2, lateral_probability=0.15, turn_probability=0.6,
                               segment_seconds=(2.0, 5.0), pose_probability=0.3),
        arms=replace(ArmConfig.partial_travel(), other_angle=0.1, other_range=0.2, reach_extremes=False,
                     walk_from_any_pose=False),
        actions=ActionConfig(enabled=True),
    )


def _longest_run(mask: np.ndarray) -> int:
    if not mask.any():
        return 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return int((edges[1::2] - edges[::2]).max())


def clip_labels(command: np.ndarray, gait: np.ndarray, gait_names: tuple[str, ...], fps: float) -> tuple[str, ...]:
    """Locomotion labels (:data:`LOCOMOTION_LABELS`) of one clip from its command [T, 6] and gait codes [T]."""
    v = command[:, [CMD_VX, CMD_VY]]
    speed = np.linalg.norm(v, axis=1)
    w = np.abs(command[:, CMD_WZ])
    second = max(1, round(fps))

    def gait_is(name: str) -> np.ndarray:
        return gait == gait_names.index(name) if name in gait_names else np.zeros(len(gait), dtype=bool)

    found = {
        "stand": _longest_run((speed < 0.05) & (w < 0.05)) >= second,
        "walk": _longest_run((speed >= 0.2) & gait_is("walk")) >= second,
        "run": _longest_run(gait_is("run")) >= second // 2,
        "turn": _longest_run(w >= 0.3) >= second,
        "sidestep": _longest_run(np.abs(v[:, 1]) >= 0.15) >= second,
        "backward": _longest_run(v[:, 0] <= -0.15) >= second,
    }
    return tuple(k for k in LOCOMOTION_LABELS if found[k])


def _clip_name(labels: tuple[str, ...], spans: tuple[ActionSpan, ...], index: int) -> str:
    parts = list(labels) + list(dict.fromkeys(sp.kind for sp in spans))
    return "_".join(["human", *parts, str(index)])


def _human() -> Morphology:
    from morphkit.io import read_morphology

    return read_morphology("human")


def _cache_key(frames: int, seed: int, fps: float) -> str:
    from morphkit.io.shipped import resolve_morphology

    h = hashlib.sha256()
    h.update(f"morphkit {__version__} default human v{HUMAN_MOTION_VERSION} {frames} {seed} {fps!r}\n".encode())
    h.update(resolve_morphology("human").read_bytes())
    h.update(source_digest().encode())
    return h.hexdigest()[:24]


def _resolve_cache(cache_dir: str | os.PathLike[str] | bool | None) -> Path | None:
    if cache_dir is None or cache_dir is False:
        return None
    if cache_dir is True:
        return cache_folder("synth")
    return Path(cache_dir)


def _from_result(res: SynthResult) -> list[HumanClip]:
    clips = []
    for i, mo in enumerate(res.motions):
        spans = res.actions[i] if res.actions else ()
        action = res.action[i] if res.action else np.zeros(mo.frame_count, dtype=np.int8)
        labels = clip_labels(res.command[i], res.gait[i], res.gait_names, mo.fps)
        named = Motion(mo.morphology, mo.fps, mo.q, _clip_name(labels, spans, i))
        clips.append(HumanClip(named, labels, tuple(spans), action))
    return clips


def _save(path: Path, clips: list[HumanClip]) -> None:
    meta = [{"name": c.motion.name, "labels": list(c.labels),
             "actions": [[s.kind, s.start, s.stop, list(s.arms)] for s in c.actions]} for c in clips]
    with atomic_path(path) as tmp:
        np.savez(tmp, q=np.concatenate([c.motion.q for c in clips]),
                 lengths=np.array([c.motion.frame_count for c in clips], dtype=np.int64),
                 action=np.concatenate([c.action for c in clips]), fps=np.float64(clips[0].motion.fps),
                 meta=np.array(json.dumps(meta)))


def _load(path: Path, m: Morphology) -> list[HumanClip] | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            q, lengths, action, fps = z["q"], z["lengths"], z["action"], float(z["fps"])
            meta = json.loads(str(z["meta"]))
    except (OSError, KeyError, ValueError):
        return None  # unreadable entry: rebuild it
    if q.shape[1:] != (m.coordinate_count,) or len(meta) != len(lengths):
        return None
    clips, start = [], 0
    for n, info in zip(lengths, meta, strict=True):
        sl = slice(start, start + int(n))
        spans = tuple(ActionSpan(k, int(a), int(b), tuple(arms)) for k, a, b, arms in info["actions"])
        clips.append(HumanClip(Motion(m, fps, q[sl], info["name"]), tuple(info["labels"]), spans, action[sl]))
        start += int(n)
    return clips


def default_human_clips(*, frames: int = 9000, seed: int = 0, fps: float = 30.0,
                        cache_dir: str | os.PathLike[str] | bool | None = True,
                        progress: bool = False) -> list[HumanClip]:
    """The default human dataset with what each clip holds (see the module docstring).

    Args:
        frames: Total frames over all clips (>= 1).
        seed: Random seed: the same arguments give the same clips.
        fps: Frame rate [1/s].
        cache_dir: Cache folder; True for ``$MORPHKIT_CACHE_DIR/synth``, None or False for none.
        progress: Show a progress bar while synthesising.

    Raises:
        ConfigError: on a non-positive ``frames`` or ``fps``.
    """
    if int(frames) < 1 or not (np.isfinite(fps) and fps > 0):
        raise ConfigError(f"default human motion: frames >= 1 and fps > 0 are required, got {frames} and {fps}")
    m = _human()
    cache = _resolve_cache(cache_dir)
    entry = cache / f"human_{_cache_key(int(frames), int(seed), float(fps))}.npz" if cache is not None else None
    if entry is not None and entry.is_file():
        clips = _load(entry, m)
        if clips is not None:
            return clips
    res = synthesize(m, frames=int(frames), fps=float(fps), seed=int(seed), config=default_human_config(),
                     progress=progress)
    clips = _from_result(res)
    if entry is not None:
        _save(entry, clips)
    return clips


def default_human_motion(*, frames: int = 9000, seed: int = 0, fps: float = 30.0,
                         cache_dir: str | os.PathLike[str] | bool | None = True,
                         progress: bool = False) -> list[Motion]:
    """The embedded default human motion: clips of the shipped ``human`` walking, turning and
    acting (see the module docstring; :func:`default_human_clips` adds labels per clip).

    Args:
        frames: Total frames over all clips (>= 1).
        seed: Random seed: the same arguments give the same clips.
        fps: Frame rate [1/s].
        cache_dir: Cache folder; True for ``$MORPHKIT_CACHE_DIR/synth``, None or False for none.
        progress: Show a progress bar while synthesising.
    """
    return [c.motion for c in default_human_clips(frames=frames, seed=seed, fps=fps, cache_dir=cache_dir,
                                                  progress=progress)]

