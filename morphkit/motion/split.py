"""The evaluation protocol's human clips: a development and a test split by subject, and a type per clip.

* **Subject.** A clip's subject is its file stem before the first ``_`` (CMU's ``05_12.bvh`` → ``05``); a
  stem without ``_`` is its own subject, so a folder of unrelated files is split file by file.
* **Split.** Subjects, never clips, are assigned: each subject's rank is the SHA-256 of its id
  (:func:`subject_rank`), no random state. Within the subjects that have a long clip (≥
  :data:`LONG_CLIP_SECONDS`) and within the rest, the first ``round(test_share × n)`` by rank go to the test
  split (at least one and at most ``n − 1`` of a group of two or more), so both splits hold long clips
  whenever two subjects have them. The split is a function of the folder's set of subjects: adding a subject
  may move others.
* **Clip type** (:data:`CLIP_TYPES`). From the folder's ``MANIFEST.csv`` (columns ``file``, ``category``,
  ``cmu_description``, ``seconds``; ``description`` is read too): the description's words, then the
  category's (:func:`clip_type_from_words`); a clip the manifest lists whose words name no type is
  ``other`` (dance, acrobatics, kicks, jumps). A clip the manifest does not list (or a folder without one)
  gets its type from the motion's root (:func:`clip_type_from_motion`: walk, turn or stand only).
"""

from __future__ import annotations

import csv
import hashlib
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morphkit.errors import ConfigError, MotionFormatError, SourceLocation
from morphkit.motion.motion import Motion
from morphkit.rotations import yaw_from_quat

__all__ = [
    "CLIP_MANIFEST",
    "CLIP_TYPES",
    "LONG_CLIP_SECONDS",
    "SPLITS",
    "TEST_SHARE",
    "ClipEntry",
    "clip_subject",
    "clip_type_from_motion",
    "clip_type_from_words",
    "folder_split",
    "read_clip_manifest",
    "split_clips",
    "subject_rank",
    "subject_sides",
]

SPLITS = ("dev", "test", "all")
"""Splits a protocol evaluation names: the development split, the test split, or both."""
TEST_SHARE = 0.3
"""Share of the subjects (in each group: with a long clip, without) in the test split."""
LONG_CLIP_SECONDS = 30.0
"""A clip at least this long [s] is long (reported apart: state drift over a long rollout)."""
CLIP_TYPES = ("walk", "turn", "stand", "gesture", "other")
"""Clip types, in the order tables list them."""
CLIP_MANIFEST = "MANIFEST.csv"
"""The file of a human clip folder that gives each clip's category, description and length."""

_KEYWORDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("turn", ("turn", "circle", "figure 8", "digital8", "digital 8", "wander", "navigate", "diagonal", "obstacle",
              "zigzag")),
    ("walk", ("walk", "run", "jog", "march", "sneak", "stroll", "stride")),
    ("gesture", ("gesture", "wave", "signal", "point", "salutation", "clean", "wash", "wipe", "sweep", "broom",
                 "vacuum", "paint", "box", "punch", "swing", "throw", "catch", "drink", "eat", "phone", "chop",
                 "lift", "pick", "scoop", "dribble", "shoot", "bunt", "sword", "putting on", "stretch", "yawn",
                 "push", "rub", "unscrew", "weight", "housework", "construction")),
    ("stand", ("stand", "wait", "balance", "pose", "mope", "idle", "still", "sit")),
)
"""``(type, words)`` in priority order: a text is of the first type one of whose words begins a word of it
(``walk`` matches "walking", not "sidewalk"; "run" not "drunk"). CamelCase is split first: CMU's
descriptions run words together (``DrunkWalk``, ``FurtherJumpTurn``)."""
_PATTERNS = tuple((kind, re.compile(r"\b(?:" + "|".join(map(re.escape, words)) + ")")) for kind, words in _KEYWORDS)

_STEP_SECONDS = 2.0
"""The root's motion is read in steps this long [s] (a walk's heading sways within a step; a turn goes on)."""
_WALK_SPEED = 0.3
"""Mean root speed [m/s] over the steps from which a clip without words is a walk."""
_TURN_RATE = 0.4
"""Mean |heading change| [rad/s] over the steps from which a clip without words is a turn (23°/s). Against the CMU
manifest's words (228 clips): 21 of 27 turns, 50 of 80 walks, 5 of 7 stands, 54 of 72 gestures (as stand) agree."""


@dataclass(frozen=True)
class ClipEntry:
    """One clip of a human data folder, with its subject, length, split side and type."""

    path: Path
    subject: str
    seconds: float
    """Frames × frame time [s] (the manifest's ``seconds`` where it has one)."""
    side: str
    """``dev`` or ``test``."""
    clip_type: str | None
    """From the manifest's words (:func:`clip_type_from_words`); ``None`` where the manifest does not list the
    clip: its type then comes from the motion (:func:`clip_type_from_motion`)."""

    @property
    def name(self) -> str:
        """The clip's name (its file stem, as motions read from it are named)."""
        return self.path.stem

    @property
    def long(self) -> bool:
        """At least :data:`LONG_CLIP_SECONDS` long."""
        return self.seconds >= LONG_CLIP_SECONDS


def clip_subject(name: str) -> str:
    """The subject of a clip named ``name`` (a file stem): the part before the first ``_``, or the whole name."""
    head, sep, _ = name.partition("_")
    return head if sep and head else name


def subject_rank(subject: str) -> int:
    """A subject's place in the split order: the SHA-256 of its id, as an integer (no random state)."""
    return int.from_bytes(hashlib.sha256(f"morphkit subject {subject}".encode()).digest()[:8], "big")


def subject_sides(long_subjects: Mapping[str, bool], *, test_share: float = TEST_SHARE) -> dict[str, str]:
    """``dev`` or ``test`` for each subject: in each group (subjects with a long clip, the others), the first
    ``round(test_share × n)`` by :func:`subject_rank` go to the test split, at least one and at most ``n − 1``
    of a group of two or more (a group of one is development).

    Args:
        long_subjects: Each subject → whether it has a long clip.
        test_share: Share of each group's subjects in the test split, in (0, 1).

    Raises:
        ConfigError: ``test_share`` outside (0, 1).
    """
    if not 0.0 < test_share < 1.0:
        raise ConfigError(f"test_share must lie in (0, 1), got {test_share}")
    sides: dict[str, str] = {}
    for group in (True, False):
        members = sorted((s for s, long in long_subjects.items() if long is group), key=lambda s: (subject_rank(s), s))
        count = min(max(1, round(test_share * len(members))), len(members) - 1) if len(members) > 1 else 0
        sides.update({s: "test" if i < count else "dev" for i, s in enumerate(members)})
    return sides


def clip_type_from_words(*texts: str) -> str | None:
    """The clip type (:data:`CLIP_TYPES`) named by the first of ``texts`` that names one: the first type, in
    priority order (turn, walk, gesture, stand), one of whose words begins a word of the text; ``None`` when
    none does."""
    for text in texts:
        words = re.sub(r"(?<=[a-z])(?=[A-Z])", " ", text).lower()
        for kind, pattern in _PATTERNS:
            if pattern.search(words):
                return kind
    return None


def clip_type_from_motion(motion: Motion) -> str:
    """``turn``, ``walk`` or ``stand`` from the root alone, over two-second steps: ``turn`` when its heading
    changes by at least 0.4 rad/s on average (23°/s), else ``walk`` when its ground position moves at least
    0.3 m/s on average, else ``stand``. A clip shorter than a step is one step."""
    pose = motion.root_pose()
    step = max(1, min(round(_STEP_SECONDS * motion.fps), motion.frame_count - 1))
    idx = np.arange(0, motion.frame_count, step)
    if idx.size < 2:
        return "stand"
    seconds = step / motion.fps
    yaw = np.unwrap(yaw_from_quat(pose[idx, 3:]))
    if np.abs(np.diff(yaw)).mean() / seconds >= _TURN_RATE:
        return "turn"
    speed = np.linalg.norm(np.diff(pose[idx, :2], axis=0), axis=1).mean() / seconds
    return "walk" if speed >= _WALK_SPEED else "stand"


def read_clip_manifest(folder: str | os.PathLike[str]) -> dict[str, dict[str, str]]:
    """The rows of ``folder``'s :data:`CLIP_MANIFEST` by clip name (file stem); empty without one.

    Raises:
        MotionFormatError: a manifest without a ``file`` column.
    """
    path = Path(folder) / CLIP_MANIFEST
    if not path.is_file():
        return {}
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if "file" not in (reader.fieldnames or []):
            raise MotionFormatError(f"{CLIP_MANIFEST} has no 'file' column", location=SourceLocation(str(path), 1))
        return {Path(row["file"]).stem: row for row in reader if row.get("file")}


def _bvh_seconds(path: Path) -> float | None:
    """Frames × frame time from a BVH file's header (``None`` when the header does not say)."""
    frames = frame_time = None
    with path.open(encoding="utf-8", errors="replace") as f:
        for line in f:
            if m := re.match(r"\s*Frames\s*:\s*(\d+)", line):
                frames = int(m.group(1))
            elif m := re.match(r"\s*Frame\s+Time\s*:\s*([0-9.eE+-]+)", line):
                try:
                    frame_time = float(m.group(1))
                except ValueError:
                    return None
                break
    return frames * frame_time if frames is not None and frame_time is not None else None


def _seconds(path: Path, row: Mapping[str, str] | None) -> float:
    if row is not None:
        try:
            return float(row["seconds"])
        except (KeyError, TypeError, ValueError):
            pass
    if path.suffix.lower() == ".bvh" and (seconds := _bvh_seconds(path)) is not None:
        return seconds
    from morphkit.motion import read_motion

    motion = read_motion(path)
    return motion.frame_count / motion.fps


def folder_split(folder: str | os.PathLike[str], *, test_share: float = TEST_SHARE) -> list[ClipEntry]:
    """Every motion file of ``folder`` (:func:`~morphkit.motion.expand_motion_paths`) with its subject, length,
    side and type (see the module docs), in file order.

    Raises:
        MotionFormatError: no motion files, a bad manifest, or a clip whose length cannot be read.
    """
    from morphkit.motion.datasets import expand_motion_paths  # loads torch: not at import time

    files = expand_motion_paths(folder)
    rows = read_clip_manifest(folder)
    seconds = {p: _seconds(p, rows.get(p.stem)) for p in files}
    subjects = {p: clip_subject(p.stem) for p in files}
    has_long: dict[str, bool] = {}
    for p in files:
        has_long[subjects[p]] = has_long.get(subjects[p], False) or seconds[p] >= LONG_CLIP_SECONDS
    sides = subject_sides(has_long, test_share=test_share)
    out = []
    for p in files:
        row = rows.get(p.stem)
        kind = None
        if row is not None:
            kind = clip_type_from_words(row.get("cmu_description") or row.get("description") or "",
                                        row.get("category") or "") or "other"
        out.append(ClipEntry(p, subjects[p], seconds[p], sides[subjects[p]], kind))
    return out


def split_clips(folder: str | os.PathLike[str], split: str, *, test_share: float = TEST_SHARE) -> list[ClipEntry]:
    """The clips of ``folder`` in ``split`` (``dev``, ``test`` or ``all``; see :func:`folder_split`).

    Raises:
        ConfigError: an unknown split, or an empty one (a folder of one subject has no test split).
        MotionFormatError: see :func:`folder_split`.
    """
    if split not in SPLITS:
        raise ConfigError(f"unknown split {split!r}; choose one of {', '.join(SPLITS)}")
    entries = folder_split(folder, test_share=test_share)
    chosen = [e for e in entries if split == "all" or e.side == split]
    if not chosen:
        subjects = len({e.subject for e in entries})
        raise ConfigError(f"the {split} split of {os.fspath(folder)} is empty ({len(entries)} clips of {subjects} "
                          "subject(s); a clip's subject is its file stem before the first '_')")
    return chosen
