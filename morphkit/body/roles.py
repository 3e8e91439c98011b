"""What a name says a body part is: one keyword table for descriptions and BVH skeletons alike.

Names are hints, never the rule (the body's shape decides: :mod:`morphkit.body.anatomy`,
:mod:`morphkit.io.bvh.analysis`). Each row of :data:`PART_WORDS` gives a part its *strong* words (the
name says it) and its *weak* ones (the name suggests it: ``arm`` for a hand, ``leg`` for a foot, ``neck``
for a head), in the order earlier words win. Two matchers read the one table, because the two kinds of
files name parts differently:

- :func:`name_hint` (robot and creature descriptions): strong words of every row before weak ones, the name
  split into words (``snake_case``,
  ``camelCase``, digits), a word matching a keyword or, for keywords of four letters or more, starting
  with it (``calf_link``, ``FR_thigh``, ``gripper_left``);
- :func:`keyword_role` (BVH skeletons): a keyword anywhere in the lower-cased name, since motion-capture
  rigs glue words together (``LHand``, ``RightToeBase``, ``lfemur``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from morphkit.graph import EndEffectorRole

__all__ = ["BVH_ROLE_WORDS", "BVH_WEAK_ROLE_WORDS", "PART_WORDS", "PartWords", "hint_rank", "keyword_role",
           "name_hint"]


@dataclass(frozen=True)
class PartWords:
    """A row of the keyword table: the part a name hints at and the words that hint it."""

    part: str
    """``"skip"`` (no end-effector: tails, ears, sensors), ``"tool"``, ``"hand"``, ``"foot"`` or ``"head"``."""
    words: tuple[tuple[str, bool], ...]
    """``(word, strong)`` in the order earlier words win."""

    @property
    def role(self) -> EndEffectorRole | None:
        """The end-effector role of the part (None for ``skip``)."""
        return None if self.part == "skip" else EndEffectorRole[self.part.upper()]


def _row(part: str, strong: str, weak: str = "") -> PartWords:
    return PartWords(part, tuple((w, True) for w in strong.split()) + tuple((w, False) for w in weak.split()))


PART_WORDS: tuple[PartWords, ...] = (
    _row("skip", "tail ear antenna imu camera lidar sensor laser kinect"),
    _row("tool", "grasp tcp tool gripper eef ee"),
    _row("hand", "palm hand finger thumb claw wrist", "index middle mid ring pinky arm"),
    _row("foot", "sole toe foot feet paw hoof heel ankle", "calf shank shin knee leg"),
    _row("head", "head skull jaw", "neck"),
)
"""The one keyword table, rows in the order earlier rows win (a ``finger_tip`` is a hand, a ``leg_camera`` is
skipped)."""


def _tokens(name: str) -> list[str]:
    spaced = re.sub(r"([a-z])([A-Z])", r"\1 \2", name)
    return [t for t in re.split(r"[^a-z]+", spaced.lower()) if t]


# Strong words first, then weak ones, each in the table's order: a ``middle_head`` is a head.
_DESCRIPTION_ORDER: tuple[tuple[str, tuple[str, ...]], ...] = tuple(
    (row.part, tuple(w for w, s in row.words if s == strong)) for strong in (True, False) for row in PART_WORDS)


def name_hint(name: str) -> str | None:
    """``"skip"``, ``"tool"``, ``"hand"``, ``"foot"`` or ``"head"`` from a link, joint or site name, if any: the
    first row with a strong word in the name, else the first with a weak one."""
    tokens = _tokens(name)
    for part, words in _DESCRIPTION_ORDER:
        for t in tokens:
            if t in words or any(t.startswith(w) and len(w) >= 4 for w in words):
                return part
    return None


def hint_rank(name: str) -> int:
    """Order of a hinted name among others on one part: strong words before weak ones, earlier keywords of the
    table first (``head`` before ``jaw``); names hinting nothing last."""
    words = [w for _, ws in _DESCRIPTION_ORDER for w in ws]
    tokens = _tokens(name)
    return min((k for k, w in enumerate(words) for t in tokens if t == w or t.startswith(w)), default=len(words))


def _bvh_table(strong: bool) -> tuple[tuple[EndEffectorRole, tuple[str, ...]], ...]:
    rows = [r for r in PART_WORDS if r.part in ("hand", "foot", "head")]
    return tuple((r.role, tuple(w for w, s in r.words if s == strong)) for r in rows)  # type: ignore[misc]


BVH_ROLE_WORDS = _bvh_table(True)
"""(role, strong words) of the table's hand, foot and head rows: the roles a BVH end site can take by name."""
BVH_WEAK_ROLE_WORDS = _bvh_table(False)
"""The same rows' weak words: used only when no joint on the path to the root has a strong one."""


def keyword_role(name: str, table: tuple[tuple[EndEffectorRole, tuple[str, ...]], ...] = BVH_ROLE_WORDS
                 ) -> EndEffectorRole | None:
    """The role of the first row of ``table`` one of whose keywords the lower-cased ``name`` holds."""
    low = name.lower()
    for role, words in table:
        if any(w in low for w in words):
            return role
    return None
