"""BVH (Biovision hierarchy) files: a vectorised parser, a writer, and BVH skeleton -> Morphology.

Parsing (:func:`parse_bvh`, :func:`read_bvh`) keeps the file's own units, axes and degrees and
returns a frozen :class:`BvhFile`: the joint tree (names, parents, ``OFFSET`` s, channels in
file order), the End Sites, the frame time and the whole ``MOTION`` section as one float64
array of shape [frame_count, channel_count], parsed in one vectorised pass. Every element
records the line it was declared on. Malformed hierarchies raise
:class:`~morphkit.errors.DescriptionError`, malformed motion
:class:`~morphkit.errors.MotionFormatError`, both with file and line.

BVH semantics assumed throughout (and by :func:`bvh_joint_positions`):

- A joint's rotation in its parent is the product of its rotation channels in file order,
  ``R = R_c1(a1) R_c2(a2) R_c3(a3)`` (intrinsic; angles in degrees), e.g.
  ``Zrotation Xrotation Yrotation`` gives ``R = Rz Rx Ry``.
- Position channels (on any joint) *replace* the joint's ``OFFSET`` as its translation in the
  parent frame; a joint without them sits at its ``OFFSET``. The real files agree: the Bandai
  Namco clips animate every joint and frame 0 repeats the offsets; the dog's and the elephant's
  root positions sit at their root offsets.

Skeletons (:func:`read_bvh_skeleton`, :func:`skeleton_from_bvh`) become a
:class:`~morphkit.graph.Morphology`:

- Axes: BVH files are Y-up; most face +Z (CMU, Daz, Bandai Namco) with the character's left
  at +X. :data:`BVH_TO_MORPHKIT` is the proper rotation ``v_morphkit = BVH_TO_MORPHKIT @ v_bvh``
  that maps BVH +Y (up) to morphkit +Z, BVH +Z (facing) to morphkit +X (forward) and BVH +X
  (left) to morphkit +Y (left). :func:`bvh_frame_rotation` gives the matrix for files that
  face another direction; by default (``facing="auto"``) :func:`detect_bvh_facing` finds it
  from the motion: +Z for every skeleton with hands (the humans), -X for the dog (whose rest
  pose points its head along +X, but whose root frame has the head along -X once it stands),
  +X for the elephants.
- Units: file units times a scale to metres; by default :func:`detect_bvh_scale` (1 when the
  rest skeleton's largest extent is at most 10 file units, else centimetres, 0.01). The real
  files behind this rule (largest rest extent in file units): CMU (AMASS) 1.58 (metres), CMU
  Daz 152.7 and Bandai Namco 184-194 (centimetres), dog 87 (cm), crab 1.1 and elephants 2.84
  (metres). Inches cannot be told from centimetres by size alone: pass ``scale=0.0254``.
- Rest poses: the skeleton's rest pose is the BVH's (all channels zero). CMU and Daz rest in a
  standing T-pose; the Bandai Namco and dog rigs put every bone along its local x, so their
  rest pose is not upright (their motion rotations make it so), and a rest-pose height is
  meaningless for them. Note also that the CMU (AMASS) clips are Z-up in their motion (the root
  rotation stands the Y-up skeleton up along Z), whereas Daz, Bandai Namco and the dog are Y-up.
- Static roots: a root that never rotates over the clip and has a single child with
  translation channels (Bandai Namco's ``joint_Root`` above ``Hips``) is folded away first
  (:func:`fold_static_root`): the child becomes the root. The motion reader folds the same
  root, so :func:`read_bvh_skeleton` and the motion's morphology agree.
- Links and joints: one link per BVH joint (after folding), named after it, in BVH order
  (``links[i]`` is joint ``i`` of the folded file); the root joint is the root link of a
  floating base (its ``OFFSET`` is ignored: the motion places the root). Every other joint
  is a joint of the same name: spherical when it has any rotation channel, fixed otherwise;
  its origin is its ``OFFSET`` (converted, no rotation). Position channels of non-root
  joints have no counterpart in the morphology (their rest value is the ``OFFSET``).
- Shapes: each link gets a capsule from its origin to each child joint and End Site (radius
  8% of the bone length, at least 1 cm); a link with no bone gets a sphere of its incoming
  bone's radius, so renders and self-collision queries work on any BVH skeleton.
- End-effectors, from names (see :func:`skeleton_from_bvh`): hands, feet and head found from
  keywords in joint names, one per limb, at the limb's End Site (named ``<joint>_end``) or,
  where a limb ends in several End Sites (fingers, eyes), at the limb's topmost keyword joint
  (named after that joint, zero offset). Unnamed End Sites become ``tool`` end-effectors.
  Quadrupeds' front paws named hands become feet when they are as long as the legs and move
  at the feet's height; human hands never do (their arms are 67-75% of their legs).
"""

from __future__ import annotations

import math
import os
import re
import warnings
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.errors import ConfigError, DescriptionError, MotionFormatError, SourceLocation
from morphkit.graph import (
    BaseType,
    EndEffectorRole,
    JointType,
    Morphology,
    MorphologyBuilder,
    Shape,
    ShapeType,
    Transform,
)
from morphkit.io._source import read_text
from morphkit.rotations import quat_between_vectors

__all__ = [
    "BVH_CHANNEL_NAMES",
    "BVH_TO_MORPHKIT",
    "ROLE_KEYWORDS",
    "BvhEndSite",
    "BvhFile",
    "bvh_frame_rotation",
    "bvh_joint_positions",
    "detect_bvh_facing",
    "detect_bvh_scale",
    "detect_bvh_up",
    "dump_bvh",
    "fold_static_root",
    "keyword_role",
    "parse_bvh",
    "read_bvh",
    "read_bvh_skeleton",
    "skeleton_from_bvh",
    "write_bvh",
]

BVH_CHANNEL_NAMES: tuple[str, ...] = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
"""The six channel names BVH knows (read case-insensitively, stored in this spelling)."""

_CHANNEL_CANON = {c.lower(): c for c in BVH_CHANNEL_NAMES}


def bvh_frame_rotation(facing: str = "+z") -> np.ndarray:
    """Rotation ``R`` with ``v_morphkit = R @ v_bvh`` for a Y-up BVH whose character faces ``facing``.

    Args:
        facing: The BVH axis the character faces at rest: ``"+z"`` (CMU, Daz, Bandai Namco),
            ``"-z"``, ``"+x"`` or ``"-x"``.

    Returns:
        A proper rotation, shape [3, 3], mapping BVH +Y to morphkit +Z (up) and ``facing`` to
        morphkit +X (forward).

    Raises:
        ConfigError: ``facing`` is not one of the four horizontal axes.
    """
    axes = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0)}
    key = facing.strip().lower() if isinstance(facing, str) else facing
    if key not in axes:
        raise ConfigError(f"unknown BVH facing {facing!r}; expected one of: {', '.join(axes)}")
    forward = np.array(axes[key])
    up = np.array([0.0, 1.0, 0.0])
    left = np.cross(up, forward)
    # Rows are the morphkit x, y, z axes written in BVH coordinates.
    return np.stack([forward, left, up])


BVH_TO_MORPHKIT: np.ndarray = bvh_frame_rotation("+z")
"""``v_morphkit = BVH_TO_MORPHKIT @ v_bvh`` for Y-up, +Z-facing BVH files (CMU convention):
``[[0, 0, 1], [1, 0, 0], [0, 1, 0]]`` — morphkit x (forward) = BVH z, y (left) = BVH x, z (up) = BVH y."""
BVH_TO_MORPHKIT.setflags(write=False)


# ---------------------------------------------------------------------------------------------
# Parsed file
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BvhEndSite:
    """An ``End Site``: a leaf point with an offset from its parent joint."""

    joint: str
    """Name of the parent joint."""
    parent: int
    """Index of the parent joint."""
    offset: tuple[float, float, float]
    """Offset in the parent joint's frame, file units."""
    line: int
    """Line of the ``End Site`` keyword."""


@dataclass(frozen=True, eq=False)
class BvhFile:
    """A parsed BVH file, in the file's own units, axes and degrees.

    Joints are in file order (a depth-first preorder: every parent comes before its
    children). Arrays are read-only.
    """

    joint_names: tuple[str, ...]
    """Joint names, shape [joint_count]; joint 0 is the ``ROOT``."""
    joint_parents: tuple[int, ...]
    """Parent joint index of every joint (-1 for the root), shape [joint_count]."""
    joint_offsets: np.ndarray
    """``OFFSET`` of every joint in its parent's frame, shape [joint_count, 3], file units."""
    joint_channels: tuple[tuple[str, ...], ...]
    """Channel names of every joint in file order (spellings of :data:`BVH_CHANNEL_NAMES`)."""
    end_sites: tuple[BvhEndSite, ...]
    """End Sites in file order."""
    frame_time: float
    """Seconds per frame (> 0)."""
    motion: np.ndarray
    """Channel values, shape [frame_count, channel_count], float64; file units and degrees.
    Column ``joint_channel_start[j] + k`` is channel ``joint_channels[j][k]``."""
    source: str | None = None
    """Path the file was read from, if any."""
    joint_lines: tuple[int, ...] = ()
    """Line of each joint's ``ROOT``/``JOINT`` keyword, shape [joint_count] (empty when built in code)."""
    motion_line: int | None = None
    """Line of the ``MOTION`` keyword."""
    frame_time_line: int | None = None
    """Line of ``Frame Time:``."""
    frame_lines: np.ndarray | None = None
    """Line of every frame, shape [frame_count], int64."""

    def __post_init__(self) -> None:
        for arr in (self.joint_offsets, self.motion, self.frame_lines):
            if arr is not None:
                arr.setflags(write=False)

    @property
    def joint_count(self) -> int:
        return len(self.joint_names)

    @property
    def frame_count(self) -> int:
        return int(self.motion.shape[0])

    @property
    def channel_count(self) -> int:
        return self.joint_channel_start[-1]

    @property
    def fps(self) -> float:
        """Frames per second, ``1 / frame_time``."""
        return 1.0 / self.frame_time

    @property
    def joint_channel_start(self) -> tuple[int, ...]:
        """Column of each joint's first channel in :attr:`motion`, shape [joint_count + 1]."""
        starts = [0]
        for ch in self.joint_channels:
            starts.append(starts[-1] + len(ch))
        return tuple(starts)

    def joint_index(self, name: str) -> int:
        """Index of joint ``name``.

        Raises:
            DescriptionError: no such joint (the message lists the joints).
        """
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise DescriptionError(
                f"no BVH joint {name!r} (joints: {', '.join(self.joint_names)})", location=self.location()
            ) from None

    def children(self, joint: int) -> tuple[int, ...]:
        """Indices of the child joints of joint ``joint``."""
        return tuple(i for i, p in enumerate(self.joint_parents) if p == joint)

    def location(self, line: int | None = None) -> SourceLocation:
        """A :class:`SourceLocation` in this file."""
        return SourceLocation(self.source, line)


# ---------------------------------------------------------------------------------------------
# Parser
# ---------------------------------------------------------------------------------------------
class _Tokens:
    """Whitespace tokens of a text with their 1-based line numbers, consumed front to back."""

    def __init__(self, lines: list[str]) -> None:
        self.lines = lines
        self.row = 0  # index of the line the pending tokens come from
        self.pending: list[str] = []
        self.last_line = 1

    def _fill(self) -> bool:
        while not self.pending:
            if self.row >= len(self.lines):
                return False
            self.pending = self.lines[self.row].split()
            self.pending.reverse()
            self.row += 1
        return True

    def next(self) -> tuple[str, int] | None:
        """The next token and its line, or ``None`` at the end of the text."""
        if not self._fill():
            return None
        self.last_line = self.row
        return self.pending.pop(), self.row

    def rest_of_line(self) -> list[str]:
        """The tokens left on the current line (consumed)."""
        rest = list(reversed(self.pending))
        self.pending = []
        return rest

    def push_back(self, tok: str) -> None:
        self.pending.append(tok)


@dataclass
class _Node:
    kind: str  # "joint" or "end"
    index: int
    name: str
    line: int
    offset: tuple[float, float, float] | None = None
    channels: tuple[str, ...] | None = None


def _number(tok: tuple[str, int] | None, what: str, source: str | None, eof_line: int) -> float:
    if tok is None:
        raise DescriptionError(f"unexpected end of file: expected {what}", location=SourceLocation(source, eof_line))
    text, line = tok
    try:
        value = float(text)
    except ValueError:
        raise DescriptionError(f"expected {what}, got {text!r}", location=SourceLocation(source, line)) from None
    if not math.isfinite(value):
        raise DescriptionError(f"{what} must be finite, got {text!r}", location=SourceLocation(source, line))
    return value


def parse_bvh(text: str, *, source: str | os.PathLike[str] | None = None) -> BvhFile:
    """Parse BVH text: the HIERARCHY and the whole MOTION section.

    The motion values are parsed in one vectorised pass (a 700-frame clip takes milliseconds);
    a slow per-line pass runs only to locate an error.

    Args:
        text: The file's contents.
        source: Path used in error locations and stored in :attr:`BvhFile.source`.

    Returns:
        The parsed file, in file units, axes and degrees.

    Raises:
        DescriptionError: a malformed HIERARCHY (unknown keyword or channel, bad number,
            unbalanced braces, end of file inside the hierarchy, duplicate joint name, ...).
        MotionFormatError: a malformed MOTION section (missing, bad ``Frames:`` or
            ``Frame Time:``, fewer or more frames than declared, a frame with the wrong number
            of values, a non-numeric or non-finite value).
    """
    src = os.fspath(source) if source is not None else None
    if not isinstance(text, str):
        raise DescriptionError(f"BVH text must be a string, got {type(text).__name__}", location=SourceLocation(src))
    # One line convention (CRLF, LF or old Mac CR) so that line numbers match editors.
    lines = text.removeprefix("\ufeff").replace("\r\n", "\n").replace("\r", "\n").split("\n")
    toks = _Tokens(lines)
    loc = lambda line: SourceLocation(src, line)  # noqa: E731

    first = toks.next()
    if first is None:
        raise DescriptionError("empty BVH file: expected HIERARCHY", location=loc(1))
    if first[0] != "HIERARCHY":
        raise DescriptionError(f"expected HIERARCHY, got {first[0]!r}", location=loc(first[1]))

    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, float, float]] = []
    channels: list[tuple[str, ...]] = []
    joint_lines: list[int] = []
    end_sites: list[BvhEndSite] = []
    name_line: dict[str, int] = {}
    stack: list[_Node] = []
    expect_open: _Node | None = None  # a node whose "{" must come next
    root_done = False
    motion_line: int | None = None

    def open_node(kind: str, name: str, line: int) -> _Node:
        if kind == "joint":
            if name in name_line:
                raise DescriptionError(
                    f"duplicate joint name {name!r} (first declared on line {name_line[name]})", location=loc(line)
                )
            name_line[name] = line
            parent = stack[-1].index if stack else -1
            names.append(name)
            parents.append(parent)
            offsets.append((0.0, 0.0, 0.0))
            channels.append(())
            joint_lines.append(line)
            return _Node("joint", len(names) - 1, name, line)
        return _Node("end", len(end_sites), name, line)

    while True:
        tok = toks.next()
        if tok is None:
            if expect_open is not None or stack:
                node = expect_open or stack[-1]
                what = f"joint {node.name!r}" if node.kind == "joint" else f"End Site of {node.name!r}"
                raise DescriptionError(
                    f"unexpected end of file in HIERARCHY: the block of {what} (line {node.line}) is never closed",
                    location=loc(toks.last_line),
                )
            if not root_done:
                raise DescriptionError("unexpected end of file: HIERARCHY has no ROOT", location=loc(toks.last_line))
            raise MotionFormatError("unexpected end of file: no MOTION section", location=loc(toks.last_line))
        word, line = tok
        if expect_open is not None:
            if word != "{":
                raise DescriptionError(f"expected '{{' after {expect_open.name!r}, got {word!r}", location=loc(line))
            stack.append(expect_open)
            expect_open = None
            continue
        if root_done:
            if word == "MOTION":
                motion_line = line
                break
            if word == "ROOT":
                raise DescriptionError("a second ROOT: only one skeleton per BVH file is supported", location=loc(line))
            raise DescriptionError(f"expected MOTION after the hierarchy, got {word!r}", location=loc(line))
        key = word.upper()
        if key in ("ROOT", "JOINT"):
            if key == "ROOT" and (stack or names):
                raise DescriptionError("ROOT inside the hierarchy (use JOINT)", location=loc(line))
            if key == "JOINT" and not stack:
                raise DescriptionError("JOINT outside any ROOT block", location=loc(line))
            if stack and stack[-1].kind == "end":
                raise DescriptionError("an End Site cannot have child joints", location=loc(line))
            rest = toks.rest_of_line()
            brace = False
            if rest and rest[-1] == "{":
                rest.pop()
                brace = True
            elif rest and rest[-1].endswith("{"):
                rest[-1] = rest[-1][:-1]
                brace = True
            name = " ".join(rest)
            if not name or "{" in name or "}" in name:
                raise DescriptionError(f"{word} needs a name, got {name!r}", location=loc(line))
            node = open_node("joint", name, line)
            if brace:
                stack.append(node)
            else:
                expect_open = node
        elif key == "END":
            site = toks.next()
            if site is None or site[0].lower() != "site" or site[1] != line:
                raise DescriptionError("expected 'End Site'", location=loc(line))
            if not stack or stack[-1].kind == "end":
                raise DescriptionError("End Site outside a joint block", location=loc(line))
            parent = stack[-1]
            node = open_node("end", parent.name, line)
            rest = toks.rest_of_line()
            if rest == ["{"]:
                stack.append(node)
            elif rest:
                raise DescriptionError(f"unexpected {' '.join(rest)!r} after End Site", location=loc(line))
            else:
                expect_open = node
        elif key == "OFFSET":
            if not stack:
                raise DescriptionError("OFFSET outside a joint block", location=loc(line))
            node = stack[-1]
            if node.offset is not None:
                raise DescriptionError(f"second OFFSET for {node.name!r}", location=loc(line))
            vals = tuple(_number(toks.next(), "an OFFSET number", src, toks.last_line) for _ in range(3))
            node.offset = vals  # type: ignore[assignment]
        elif key == "CHANNELS":
            if not stack:
                raise DescriptionError("CHANNELS outside a joint block", location=loc(line))
            node = stack[-1]
            if node.kind == "end":
                raise DescriptionError("an End Site cannot have CHANNELS", location=loc(line))
            if node.channels is not None:
                raise DescriptionError(f"second CHANNELS for joint {node.name!r}", location=loc(line))
            count_tok = toks.next()
            if count_tok is None:
                raise DescriptionError("unexpected end of file: expected a channel count", location=loc(line))
            if not re.fullmatch(r"[0-9]+", count_tok[0]) or int(count_tok[0]) > 6:
                raise DescriptionError(
                    f"CHANNELS count must be an integer from 0 to 6, got {count_tok[0]!r}", location=loc(count_tok[1])
                )
            chans: list[str] = []
            for _ in range(int(count_tok[0])):
                ctok = toks.next()
                if ctok is None:
                    raise DescriptionError("unexpected end of file: expected a channel name", location=loc(line))
                canon = _CHANNEL_CANON.get(ctok[0].lower())
                if canon is None:
                    raise DescriptionError(
                        f"unknown channel {ctok[0]!r}; expected one of: {', '.join(BVH_CHANNEL_NAMES)}",
                        location=loc(ctok[1]),
                    )
                if canon in chans:
                    raise DescriptionError(
                        f"channel {canon} listed twice for joint {node.name!r}", location=loc(ctok[1])
                    )
                chans.append(canon)
            node.channels = tuple(chans)
        elif word == "}":
            if not stack:
                raise DescriptionError("unbalanced '}': no block is open", location=loc(line))
            node = stack.pop()
            if node.offset is None:
                what = f"joint {node.name!r}" if node.kind == "joint" else f"End Site of {node.name!r}"
                raise DescriptionError(f"{what} (line {node.line}) has no OFFSET", location=loc(line))
            if node.kind == "joint":
                offsets[node.index] = node.offset
                channels[node.index] = node.channels or ()
            else:
                parent_index = stack[-1].index
                end_sites.append(BvhEndSite(node.name, parent_index, node.offset, node.line))
            if not stack:
                root_done = True
        elif word == "{":
            raise DescriptionError("unexpected '{'", location=loc(line))
        elif word == "MOTION" and not stack:
            raise DescriptionError("MOTION before any ROOT: the HIERARCHY is empty", location=loc(line))
        elif word == "MOTION":
            raise DescriptionError(
                f"MOTION inside the hierarchy: the block of {stack[-1].name!r} (line {stack[-1].line}) is never closed",
                location=loc(line),
            )
        else:
            raise DescriptionError(
                f"unknown keyword {word!r}; expected one of: JOINT, End Site, OFFSET, CHANNELS, {{, }}",
                location=loc(line),
            )

    # ---- MOTION --------------------------------------------------------------------------
    if toks.rest_of_line():
        raise MotionFormatError("unexpected text after MOTION", location=loc(motion_line))
    channel_count = sum(len(c) for c in channels)
    row = toks.row  # index of the first line after MOTION
    frames_decl, frames_line, row = _header_value(lines, row, r"Frames\s*:", "Frames:", src)
    if not re.fullmatch(r"[0-9]+", frames_decl):
        raise MotionFormatError(
            f"Frames: must be a non-negative integer, got {frames_decl!r}", location=loc(frames_line)
        )
    frame_count = int(frames_decl)
    ft_text, ft_line, row = _header_value(lines, row, r"Frame\s+Time\s*:", "Frame Time:", src)
    try:
        frame_time = float(ft_text)
    except ValueError:
        raise MotionFormatError(f"Frame Time: must be a number, got {ft_text!r}", location=loc(ft_line)) from None
    if not math.isfinite(frame_time) or frame_time <= 0:
        raise MotionFormatError(f"Frame Time: must be a positive number, got {ft_text!r}", location=loc(ft_line))
    motion, frame_lines = _parse_frames(lines, row, frame_count, channel_count, src)

    return BvhFile(
        joint_names=tuple(names),
        joint_parents=tuple(parents),
        joint_offsets=np.asarray(offsets, dtype=np.float64).reshape(-1, 3),
        joint_channels=tuple(channels),
        end_sites=tuple(end_sites),
        frame_time=frame_time,
        motion=motion,
        source=src,
        joint_lines=tuple(joint_lines),
        motion_line=motion_line,
        frame_time_line=ft_line,
        frame_lines=frame_lines,
    )


def _header_value(lines: list[str], row: int, pattern: str, what: str, src: str | None) -> tuple[str, int, int]:
    """Find ``<pattern> value`` on the next non-blank line; returns (value, line, next row)."""
    while row < len(lines) and not lines[row].strip():
        row += 1
    if row >= len(lines):
        last = len(lines)
        while last > 1 and not lines[last - 1].strip():
            last -= 1
        raise MotionFormatError(f"unexpected end of file: expected {what}", location=SourceLocation(src, last))
    m = re.fullmatch(rf"\s*{pattern}\s*(.*?)\s*", lines[row])
    if m is None:
        raise MotionFormatError(
            f"expected {what}, got {lines[row].strip()[:40]!r}", location=SourceLocation(src, row + 1)
        )
    if not m.group(1):
        raise MotionFormatError(f"{what} has no value", location=SourceLocation(src, row + 1))
    return m.group(1), row + 1, row + 1


def _parse_frames(
    lines: list[str], row: int, frame_count: int, channel_count: int, src: str | None
) -> tuple[np.ndarray, np.ndarray]:
    """Parse the frame lines from ``lines[row:]`` into [frame_count, channel_count] values."""
    body = lines[row:]
    # Blank lines (trailing newlines, '\r' of CRLF files) carry no frame.
    keep = [i for i, text in enumerate(body) if text.strip()]
    frame_lines = np.asarray(keep, dtype=np.int64) + row + 1
    frames = [body[i] for i in keep]
    if len(frames) < frame_count:
        # Point at the last line with content: where the file was cut.
        last_line = int(frame_lines[-1]) if frames else row
        raise MotionFormatError(
            f"truncated MOTION: Frames: says {frame_count}, the file ends after {len(frames)} frame lines",
            location=SourceLocation(src, last_line),
        )
    if len(frames) > frame_count:
        raise MotionFormatError(
            f"MOTION has more frame lines than Frames: {frame_count} (first extra frame)",
            location=SourceLocation(src, int(frame_lines[frame_count])),
        )
    counts = np.fromiter((len(f.split()) for f in frames), dtype=np.int64, count=len(frames))
    bad = np.flatnonzero(counts != channel_count)
    if bad.size:
        i = int(bad[0])
        raise MotionFormatError(
            f"frame {i} has {counts[i]} values, the hierarchy declares {channel_count} channels",
            location=SourceLocation(src, int(frame_lines[i])),
        )
    if frame_count == 0:
        return np.zeros((0, channel_count)), frame_lines
    values = _parses(" ".join(frames))
    if values is None or values.size != frame_count * channel_count:
        _locate_bad_value(frames, frame_lines, src)
        raise MotionFormatError("MOTION values could not be parsed", location=SourceLocation(src, int(frame_lines[0])))
    motion = values.reshape(frame_count, channel_count)
    finite = np.isfinite(motion)
    if not finite.all():
        i, j = np.argwhere(~finite)[0]
        raise MotionFormatError(
            f"non-finite value {frames[i].split()[j]!r} in frame {i}, column {j}",
            location=SourceLocation(src, int(frame_lines[i])),
        )
    return motion, frame_lines


def _parses(text: str) -> np.ndarray | None:
    """``text`` as whitespace-separated float64 values, or ``None`` if any token is not a number."""
    with warnings.catch_warnings():
        # NumPy warns (and will raise) when text does not parse to its end.
        warnings.simplefilter("error")
        try:
            return np.fromstring(text, dtype=np.float64, sep=" ")
        except (ValueError, DeprecationWarning):
            return None


def _locate_bad_value(frames: Sequence[str], frame_lines: np.ndarray, src: str | None) -> None:
    """Raise for the first frame line that does not parse (slow path, only after a failure)."""
    for i, text in enumerate(frames):
        tokens = text.split()
        values = _parses(text)
        if values is not None and values.size == len(tokens):
            continue
        where = SourceLocation(src, int(frame_lines[i]))
        for j, tok in enumerate(tokens):
            v = _parses(tok)
            if v is None or v.size != 1:
                raise MotionFormatError(f"non-numeric value {tok[:40]!r} in frame {i}, column {j}", location=where)
        raise MotionFormatError(f"frame {i} holds characters that are not numbers or spaces", location=where)


def read_bvh(path: str | os.PathLike[str]) -> BvhFile:
    """Read and parse a BVH file (see :func:`parse_bvh`).

    Raises:
        DescriptionError: the file is missing, unreadable, not UTF-8, or has a bad hierarchy.
        MotionFormatError: the MOTION section is malformed.
    """
    return parse_bvh(read_text(path, what="BVH"), source=os.fspath(path))


# ---------------------------------------------------------------------------------------------
# Writer
# ---------------------------------------------------------------------------------------------
def _fmt(v: float) -> str:
    # The shortest text that reads back to the same float.
    return repr(float(v))


def dump_bvh(bvh: BvhFile) -> str:
    """BVH text of ``bvh`` (tab-indented hierarchy, one line per frame, 10 significant digits).

    ``parse_bvh(dump_bvh(b))`` reproduces ``b``'s tree exactly and its numbers to about 1e-9
    relative.
    """
    out: list[str] = ["HIERARCHY"]
    children: dict[int, list[int]] = {i: [] for i in range(-1, bvh.joint_count)}
    for i, p in enumerate(bvh.joint_parents):
        children[p].append(i)
    ends: dict[int, list[BvhEndSite]] = {i: [] for i in range(bvh.joint_count)}
    for e in bvh.end_sites:
        ends[e.parent].append(e)

    # An explicit stack instead of recursion: a file may nest deeper than Python's recursion limit.
    todo: list[tuple[str, int, int]] = [("open", 0, 0)]
    while todo:
        action, j, depth = todo.pop()
        pad = "\t" * depth
        if action == "close":
            for e in ends[j]:
                out.append(f"{pad}\tEnd Site")
                out.append(f"{pad}\t{{")
                out.append(f"{pad}\t\tOFFSET {' '.join(_fmt(v) for v in e.offset)}")
                out.append(f"{pad}\t}}")
            out.append(f"{pad}}}")
            continue
        kw = "ROOT" if bvh.joint_parents[j] < 0 else "JOINT"
        out.append(f"{pad}{kw} {bvh.joint_names[j]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET {' '.join(_fmt(v) for v in bvh.joint_offsets[j])}")
        ch = bvh.joint_channels[j]
        out.append(f"{pad}\tCHANNELS {len(ch)}{''.join(' ' + c for c in ch)}")
        todo.append(("close", j, depth))
        todo.extend(("open", c, depth + 1) for c in reversed(children[j]))
    out.append("MOTION")
    out.append(f"Frames: {bvh.frame_count}")
    out.append(f"Frame Time: {_fmt(bvh.frame_time)}")
    if bvh.frame_count:
        rows = np.char.mod("%.10g", bvh.motion)
        out.extend(" ".join(r) for r in rows)
    return "\n".join(out) + "\n"


def write_bvh(bvh: BvhFile, path: str | os.PathLike[str]) -> None:
    """Write ``bvh`` to ``path`` atomically (see :func:`dump_bvh`)."""
    atomic_write_text(path, dump_bvh(bvh))


# ---------------------------------------------------------------------------------------------
# Forward kinematics in file coordinates (reference for tests and for unit/role heuristics)
# ---------------------------------------------------------------------------------------------
def _axis_rotations(axis: str, deg: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] about a principal axis by ``deg`` degrees."""
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    if axis == "X":
        m = [[o, z, z], [z, c, -s], [z, s, c]]
    elif axis == "Y":
        m = [[c, z, s], [z, o, z], [-s, z, c]]
    else:
        m = [[c, -s, z], [s, c, z], [z, z, o]]
    return np.stack([np.stack(r, axis=-1) for r in m], axis=-2)


def _joint_frames(
    bvh: BvhFile, frames: slice | Sequence[int] | np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """World positions [F, J + E, 3] of joints then End Sites, and joint rotations [F, J, 3, 3] (file axes)."""
    values = bvh.motion if bvh.frame_count else np.zeros((1, bvh.channel_count))
    if frames is not None and bvh.frame_count:
        values = values[frames]
    values = np.atleast_2d(values)
    f = values.shape[0]
    starts = bvh.joint_channel_start
    rot = np.empty((bvh.joint_count, f, 3, 3))
    pos = np.empty((bvh.joint_count + len(bvh.end_sites), f, 3))
    for j in range(bvh.joint_count):
        r = np.broadcast_to(np.eye(3), (f, 3, 3)).copy()
        t = np.broadcast_to(bvh.joint_offsets[j], (f, 3)).copy()
        for k, ch in enumerate(bvh.joint_channels[j]):
            col = values[:, starts[j] + k]
            if ch.endswith("rotation"):
                r = r @ _axis_rotations(ch[0], col)
            else:
                t[:, "XYZ".index(ch[0])] = col
        p = bvh.joint_parents[j]
        if p < 0:
            rot[j], pos[j] = r, t
        else:
            rot[j] = rot[p] @ r
            pos[j] = pos[p] + np.einsum("fij,fj->fi", rot[p], t)
    for e, site in enumerate(bvh.end_sites):
        p = site.parent
        pos[bvh.joint_count + e] = pos[p] + rot[p] @ np.asarray(site.offset)
    return np.moveaxis(pos, 0, 1), np.moveaxis(rot, 0, 1)


def bvh_joint_positions(bvh: BvhFile, frames: slice | Sequence[int] | np.ndarray | None = None) -> np.ndarray:
    """World positions of every joint and End Site, in file units and axes (vectorised over frames).

    Args:
        bvh: A parsed file.
        frames: Which frames (default all). With a file of zero frames, the rest pose is used.

    Returns:
        Positions, shape [frames, joint_count + end_site_count, 3]: joints in file order, then
        End Sites in file order.
    """
    return _joint_frames(bvh, frames)[0]


def _rest_positions(bvh: BvhFile) -> np.ndarray:
    """Rest positions of joints then End Sites relative to the root, shape [J + E, 3], file units."""
    pts = np.zeros((bvh.joint_count + len(bvh.end_sites), 3))
    for j in range(1, bvh.joint_count):
        pts[j] = pts[bvh.joint_parents[j]] + bvh.joint_offsets[j]
    for e, site in enumerate(bvh.end_sites):
        pts[bvh.joint_count + e] = pts[site.parent] + np.asarray(site.offset)
    return pts


def detect_bvh_scale(bvh: BvhFile) -> float:
    """Scale from file units to metres: 1.0 if the rest skeleton's largest extent is <= 10 units, else 0.01.

    The extent is measured on the rest pose (offsets only, the root's own ``OFFSET`` ignored),
    over joints and End Sites, along whichever axis is largest, so that skeletons whose rest pose
    is not upright (rigs with bones along local x) are judged by size, not height.
    """
    pts = _rest_positions(bvh)
    extent = float((pts.max(axis=0) - pts.min(axis=0)).max()) if len(pts) else 0.0
    return 1.0 if extent <= 10.0 else 0.01


# ---------------------------------------------------------------------------------------------
# Static roots
# ---------------------------------------------------------------------------------------------
_STILL_DEGREES = 1e-6
"""Rotation channels within this many degrees of zero in every frame count as never rotating."""


def fold_static_root(bvh: BvhFile) -> BvhFile:
    """Remove a root that never rotates when its single child carries translation channels.

    Bandai Namco's ``joint_Root`` is such a root: it never rotates and either stays put or
    carries the clip's travel, while ``Hips`` below it carries the body's own translation. With
    an identity root rotation the two translations simply add, so the child becomes the root with
    their sum (in its position channels, and in its ``OFFSET`` from the root's first frame) and
    every world position is unchanged. Repeated while the new root qualifies too.

    Both :func:`skeleton_from_bvh` and the motion reader (:func:`morphkit.motion.bvh_to_motion`)
    fold, so a file's skeleton is the same whichever reads it. Needs the ``MOTION`` section: a
    file without frames is returned unchanged, as is a root with End Sites, several children or a
    child without translation channels.

    Args:
        bvh: A parsed file.

    Returns:
        The folded file (``bvh`` itself when nothing folds). Joint indices shift down by one per
        removed root; frame lines and the motion's line numbers are kept.
    """
    while bvh.joint_count >= 2 and bvh.frame_count > 0:
        children = bvh.children(0)
        if len(children) != 1 or any(s.parent == 0 for s in bvh.end_sites):
            break
        child = children[0]
        child_pos = _position_columns(bvh, child)
        if not child_pos:
            break
        rot_cols = [c for c, ch in _channel_columns(bvh, 0) if ch.endswith("rotation")]
        if np.abs(bvh.motion[:, rot_cols]).max(initial=0.0) > _STILL_DEGREES:
            break
        root_pos = np.broadcast_to(np.asarray(bvh.joint_offsets[0], dtype=float), (bvh.frame_count, 3)).copy()
        for axis, col in _position_columns(bvh, 0).items():
            root_pos[:, axis] = bvh.motion[:, col]
        shift = bvh.joint_channel_start[1]  # the child's columns start at 0 in the new array
        motion = bvh.motion[:, shift:].copy()
        for axis, col in child_pos.items():
            motion[:, col - shift] += root_pos[:, axis]
        offsets = bvh.joint_offsets[1:].copy()
        offsets[0] += root_pos[0]
        bvh = BvhFile(
            joint_names=bvh.joint_names[1:],
            joint_parents=tuple(p - 1 for p in bvh.joint_parents[1:]),
            joint_offsets=offsets,
            joint_channels=bvh.joint_channels[1:],
            end_sites=tuple(BvhEndSite(s.joint, s.parent - 1, s.offset, s.line) for s in bvh.end_sites),
            frame_time=bvh.frame_time,
            motion=motion,
            source=bvh.source,
            joint_lines=bvh.joint_lines[1:],
            motion_line=bvh.motion_line,
            frame_time_line=bvh.frame_time_line,
            frame_lines=bvh.frame_lines,
        )
    return bvh


def _channel_columns(bvh: BvhFile, j: int) -> list[tuple[int, str]]:
    """``(column, channel)`` of joint ``j``'s channels in :attr:`BvhFile.motion`."""
    start = bvh.joint_channel_start[j]
    return [(start + k, ch) for k, ch in enumerate(bvh.joint_channels[j])]


def _position_columns(bvh: BvhFile, j: int) -> dict[int, int]:
    """``{axis: column}`` of joint ``j``'s position channels."""
    return {"XYZ".index(ch[0]): c for c, ch in _channel_columns(bvh, j) if ch.endswith("position")}


# ---------------------------------------------------------------------------------------------
# Skeleton -> Morphology
# ---------------------------------------------------------------------------------------------
ROLE_KEYWORDS = (
    (
        EndEffectorRole.HAND,
        ("hand", "wrist", "finger", "thumb", "index", "middle", "mid", "ring", "pinky", "palm", "claw"),
    ),
    (EndEffectorRole.FOOT, ("foot", "toe", "ankle", "heel", "paw", "hoof")),
    (EndEffectorRole.HEAD, ("head",)),
)
"""Keywords (matched in lower-cased joint names) that give an end-effector its role."""
_WEAK = (
    (EndEffectorRole.HAND, ("arm",)),
    (EndEffectorRole.FOOT, ("leg",)),
    (EndEffectorRole.HEAD, ("neck",)),
)
"""Fallback keywords, used only when no joint on the path to the root has a strong keyword."""

_MIN_RADIUS = 0.01
_Z = np.array([0.0, 0.0, 1.0])
_RADIUS_FRACTION = 0.08
_FRONT_PAW_FRACTION = 0.35
"""A leg-long "hand" whose median height above the feet is below this fraction of the hips' is a paw."""
_FRONT_PAW_LIMB_RATIO = 0.9
"""A "hand" can be a front paw only if its limb is at least this fraction of the legs' mean length."""


@dataclass(frozen=True)
class _PlannedEndEffector:
    """An end-effector chosen from a :class:`BvhFile`, before axes and units are applied."""

    name: str
    joint: int
    """BVH joint (link) it sits on."""
    site: int | None
    """End Site it sits at, or ``None`` for the joint's origin."""
    role: EndEffectorRole
    line: int | None
    column: int
    """Its point's index in :func:`bvh_joint_positions`' second axis."""


def keyword_role(name: str, table: tuple[tuple[EndEffectorRole, tuple[str, ...]], ...]) -> EndEffectorRole | None:
    """The role of the first row of ``table`` (e.g. :data:`ROLE_KEYWORDS`) one of whose keywords ``name`` holds."""
    low = name.lower()
    for role, words in table:
        if any(w in low for w in words):
            return role
    return None


def _bone_shapes(segments: list[np.ndarray], incoming: float | None) -> tuple[Shape, ...]:
    """Capsules along ``segments`` (vectors from the link origin, metres), or one sphere."""
    shapes: list[Shape] = []
    for seg in segments:
        length = float(np.linalg.norm(seg))
        if length < 1e-6:
            continue
        quat = tuple(float(v) for v in quat_between_vectors(_Z, seg / length))
        origin = Transform(tuple(float(v) for v in 0.5 * seg), quat)  # type: ignore[arg-type]
        radius = max(_RADIUS_FRACTION * length, _MIN_RADIUS)
        shapes.append(Shape(ShapeType.CAPSULE, origin=origin, radius=radius, length=length))
    if not shapes:
        radius = max(_RADIUS_FRACTION * incoming, _MIN_RADIUS) if incoming else _MIN_RADIUS
        shapes.append(Shape(ShapeType.SPHERE, radius=radius))
    return tuple(shapes)


def skeleton_from_bvh(
    bvh: BvhFile,
    *,
    scale: float | None = None,
    facing: str = "auto",
    name: str | None = None,
    detect_front_paws: bool = True,
    share: bool = False,
) -> Morphology:
    """Build a :class:`~morphkit.graph.Morphology` from a parsed BVH skeleton.

    A static root is folded away first (:func:`fold_static_root`), so Bandai Namco's skeletons
    are rooted at ``Hips``, as in their motions.

    End-effectors are chosen from names:

    1. Each End Site is a candidate on its parent joint's link. Its role comes from the nearest
       joint on its path to the root whose name holds a *strong* keyword (hand: hand, wrist,
       finger, thumb, index, mid, ring, pinky, palm, claw; foot: foot, toe, ankle, heel, paw,
       hoof; head: head), else a *weak* one (arm -> hand, leg -> foot, neck -> head); End Sites
       with neither are ``tool``.
    2. The candidate's *limb* is the topmost joint of the run of joints with that same role
       containing its keyword joint (e.g. ``lankle`` for CMU's ``ltoe`` End Site, ``rHand`` for
       each Daz finger). A limb with one candidate keeps it, named ``<parent joint>_end``; a
       limb with several (fingers, eyes) becomes one end-effector at the limb's topmost joint,
       zero offset, named after that joint. (A joint already named ``*_end`` lends its name
       unchanged; clashing names get a numeric suffix.) A limb with a strong keyword but no End
       Site at all (some exporters omit them) gets an end-effector at its tip joint (followed
       down while the limb does not branch), zero offset, named after that joint.
    3. With ``detect_front_paws``, a "hand" is a front foot (quadruped rigs call their front
       paws hands) when both hold:

       - its limb is as long as a leg: the bone path from the end-effector up to the joint
         where the limb branches off the body is at least 90% of the legs' mean (the same path
         for the feet). Bone lengths do not depend on the clip. Humans measure 0.67-0.75 (CMU,
         Daz, Bandai Namco), the dog 1.24, the elephants 1.18, so a human's hands stay hands
         whatever the clip (crawling, a sun salutation);
       - the motion keeps it at the feet's height: its median height above the feet over the
         clip is below 35% of the hips' (the joint where the feet's chains meet). The dog's
         paws give at most 0.21; the crab's claws, as long as its legs, are held up.

       A file without frames keeps its hands.

    Args:
        bvh: A parsed file (:func:`parse_bvh`).
        scale: File units to metres; ``None`` detects it (:func:`detect_bvh_scale`).
        facing: The BVH axis the character faces (:func:`bvh_frame_rotation`), or ``"auto"``
            to detect it from the motion (:func:`detect_bvh_facing`).
        name: Morphology name (default: the file's stem, or ``"bvh"``).
        detect_front_paws: Turn leg-long hands that move at the feet's height into feet (rule 3).
        share: Return one object for every file with the same skeleton (hierarchy and offsets,
            options, end-effectors), e.g. all clips of a subject, so that it compiles once. Its
            ``name`` and ``source`` are those of the first such file.

    Raises:
        ConfigError: ``scale`` is not a positive finite number, or ``facing`` is unknown.
        GraphError: the skeleton cannot form a valid morphology (also for absurd offsets that
            overflow to non-finite lengths).
    """
    # Absurd offsets (1e308) overflow to inf here; the builder then rejects them with a GraphError.
    with np.errstate(over="ignore", invalid="ignore"):
        return _skeleton_from_bvh(fold_static_root(bvh), scale, facing, name, detect_front_paws, share)


_shared: dict[tuple, Morphology] = {}
"""Skeletons by everything they depend on, for ``share=True`` (cleared beyond 256 entries)."""


def _check_facing(facing: str) -> str:
    """``facing`` normalised (``"auto"`` or one of :func:`bvh_frame_rotation`'s axes)."""
    if isinstance(facing, str) and facing.strip().lower() == "auto":
        return "auto"
    bvh_frame_rotation(facing)  # raises ConfigError for anything else
    return facing.strip().lower()


def _skeleton_from_bvh(
    bvh: BvhFile, scale: float | None, facing: str, name: str | None, detect_front_paws: bool, share: bool
) -> Morphology:
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) or scale <= 0:
            raise ConfigError(f"BVH scale must be a positive number, got {scale!r}")
        s = float(scale)
    else:
        s = detect_bvh_scale(bvh)
    plan = _plan_end_effectors(bvh, detect_front_paws)
    facing = _check_facing(facing)
    if facing == "auto":
        facing = detect_bvh_facing(bvh, detect_front_paws=detect_front_paws)
    key = None
    if share:
        # The root's OFFSET does not enter the skeleton (the motion places the root).
        key = (
            bvh.joint_names,
            bvh.joint_parents,
            bvh.joint_offsets[1:].tobytes(),
            bvh.joint_channels,
            tuple((e.parent, e.offset) for e in bvh.end_sites),
            s,
            facing,
            tuple((c.name, c.joint, c.site, c.role) for c in plan),
        )
        if key in _shared:
            return _shared[key]
    R = bvh_frame_rotation(facing)
    src = bvh.source
    if name is None:
        name = Path(src).stem if src else "bvh"
    J = bvh.joint_count
    offsets = (bvh.joint_offsets @ R.T) * s  # [J, 3] metres, morphkit axes
    end_offsets = [(R @ np.asarray(e.offset)) * s for e in bvh.end_sites]
    line_of = (lambda j: bvh.joint_lines[j]) if len(bvh.joint_lines) == J else (lambda j: None)

    segments: list[list[np.ndarray]] = [[] for _ in range(J)]
    for j in range(1, J):
        segments[bvh.joint_parents[j]].append(offsets[j])
    for e, site in enumerate(bvh.end_sites):
        segments[site.parent].append(end_offsets[e])

    b = MorphologyBuilder(name, source=src)
    b.set_base(BaseType.FLOATING)
    for j in range(J):
        incoming = float(np.linalg.norm(offsets[j])) if j > 0 else None
        b.add_link(bvh.joint_names[j], shapes=_bone_shapes(segments[j], incoming), location=bvh.location(line_of(j)))
    b.set_root(bvh.joint_names[0], location=bvh.location(line_of(0)))
    for j in range(1, J):
        has_rotation = any(c.endswith("rotation") for c in bvh.joint_channels[j])
        b.add_joint(
            bvh.joint_names[j],
            JointType.SPHERICAL if has_rotation else JointType.FIXED,
            bvh.joint_names[bvh.joint_parents[j]],
            bvh.joint_names[j],
            origin=Transform(tuple(float(v) for v in offsets[j])),  # type: ignore[arg-type]
            location=bvh.location(line_of(j)),
        )
    for ee in plan:
        offset = _tuple3(end_offsets[ee.site]) if ee.site is not None else (0.0, 0.0, 0.0)
        b.add_end_effector(
            ee.name, bvh.joint_names[ee.joint], offset=offset, role=ee.role, location=bvh.location(ee.line)
        )
    m = b.build()
    if key is not None:
        if len(_shared) >= 256:
            _shared.clear()
        _shared[key] = m
    return m


_analyses: weakref.WeakKeyDictionary[BvhFile, dict[tuple[str, bool], Any]] = weakref.WeakKeyDictionary()
"""Per parsed file: its end-effector plan, up axis and facing, computed once (the skeleton reader
and the motion reader both ask, and the front paws and the facing need forward kinematics)."""


def _memo(bvh: BvhFile, what: str, detect_front_paws: bool, compute: Callable[[], Any]) -> Any:
    entry = _analyses.setdefault(bvh, {})
    key = (what, bool(detect_front_paws))
    if key not in entry:
        entry[key] = compute()
    return entry[key]


def _plan_end_effectors(bvh: BvhFile, detect_front_paws: bool) -> tuple[_PlannedEndEffector, ...]:
    """End-effectors of ``bvh`` in file terms (see :func:`skeleton_from_bvh`, rules 1-3)."""
    return _memo(bvh, "plan", detect_front_paws, lambda: tuple(_plan(bvh, detect_front_paws)))


def _plan(bvh: BvhFile, detect_front_paws: bool) -> list[_PlannedEndEffector]:
    J = bvh.joint_count
    parents = bvh.joint_parents
    strong = [keyword_role(n, ROLE_KEYWORDS) for n in bvh.joint_names]
    weak = [keyword_role(n, _WEAK) for n in bvh.joint_names]

    def joint_line(j: int) -> int | None:
        return bvh.joint_lines[j] if len(bvh.joint_lines) == J else None

    # End Sites grouped by limb (role, topmost joint of the role's run); unnamed ones are tools.
    limbs: dict[tuple[EndEffectorRole, int], list[int]] = {}
    tools: list[int] = []
    for e, site in enumerate(bvh.end_sites):
        chain = [site.parent]
        while parents[chain[-1]] >= 0:
            chain.append(parents[chain[-1]])
        hit = None
        for table in (strong, weak):
            j = next((j for j in chain if table[j] is not None), None)
            if j is not None:
                hit = (table, j)
                break
        if hit is None:
            tools.append(e)
            continue
        table, top = hit
        role = table[top]
        assert role is not None
        while parents[top] >= 0 and table[parents[top]] == role:
            top = parents[top]
        limbs.setdefault((role, top), []).append(e)

    chosen: list[_PlannedEndEffector] = []

    def at_site(e: int, role: EndEffectorRole) -> _PlannedEndEffector:
        site = bvh.end_sites[e]
        return _PlannedEndEffector(_end_name(site.joint), site.parent, e, role, site.line, J + e)

    def at_joint(j: int, role: EndEffectorRole) -> _PlannedEndEffector:
        return _PlannedEndEffector(bvh.joint_names[j], j, None, role, joint_line(j), j)

    for (role, top), ends in limbs.items():
        chosen.append(at_site(ends[0], role) if len(ends) == 1 else at_joint(top, role))
    chosen.extend(at_site(e, EndEffectorRole.TOOL) for e in tools)
    # Limbs that end without any End Site (some exporters omit them): the limb's joint itself.
    ends_below = set()
    for site in bvh.end_sites:
        j = site.parent
        while j >= 0 and j not in ends_below:
            ends_below.add(j)
            j = parents[j]
    children = [[c for c in range(J) if parents[c] == j] for j in range(J)]
    for j in range(J):
        role = strong[j]
        if role is None or j in ends_below or (parents[j] >= 0 and strong[parents[j]] == role):
            continue
        # Follow the limb down while it does not branch (ankle -> toe), so the point is its tip.
        tip = j
        while len(children[tip]) == 1 and strong[children[tip][0]] == role:
            tip = children[tip][0]
        chosen.append(at_joint(tip, role))

    if detect_front_paws:
        paws = set(_front_paws(bvh, chosen))
        chosen = [replace(c, role=EndEffectorRole.FOOT) if i in paws else c for i, c in enumerate(chosen)]

    used: set[str] = set()
    out = []
    for c in chosen:
        name, k = c.name, 2
        while name in used:
            name, k = f"{c.name}{k}", k + 1
        used.add(name)
        out.append(replace(c, name=name))
    return out


def _front_paws(bvh: BvhFile, chosen: list[_PlannedEndEffector]) -> list[int]:
    """Indices into ``chosen`` of the hands that are front paws (rule 3 of :func:`skeleton_from_bvh`)."""
    hands = [i for i, c in enumerate(chosen) if c.role == EndEffectorRole.HAND]
    feet = [c for c in chosen if c.role == EndEffectorRole.FOOT]
    if not hands or not feet or bvh.frame_count == 0:
        return []
    branches = _branch_counts(bvh)
    leg = float(np.mean([_limb_length(bvh, c, branches) for c in feet]))
    # Bone lengths first: they do not depend on the clip, and they rule humans out.
    long = [i for i in hands if _limb_length(bvh, chosen[i], branches) >= _FRONT_PAW_LIMB_RATIO * leg]
    if not long:
        return []
    heights = _heights_over_hips(bvh, [chosen[i].column for i in long], [c.column for c in feet])
    return [i for i, h in zip(long, heights, strict=True) if h < _FRONT_PAW_FRACTION]


def _branch_counts(bvh: BvhFile) -> list[int]:
    """Children (joints and End Sites) of every joint, shape [joint_count]."""
    counts = [0] * bvh.joint_count
    for p in bvh.joint_parents[1:]:
        counts[p] += 1
    for site in bvh.end_sites:
        counts[site.parent] += 1
    return counts


def _limb_length(bvh: BvhFile, ee: _PlannedEndEffector, branches: list[int]) -> float:
    """Bone path length [file units] from ``ee`` up to the joint where its limb branches off the body."""
    length = float(np.linalg.norm(bvh.end_sites[ee.site].offset)) if ee.site is not None else 0.0
    j = ee.joint
    while bvh.joint_parents[j] >= 0:
        length += float(np.linalg.norm(bvh.joint_offsets[j]))
        j = bvh.joint_parents[j]
        if branches[j] >= 2:
            break
    return length


def _end_name(joint: str) -> str:
    """End-effector name for an End Site of ``joint``: ``<joint>_end`` (rigs often name leaves ``*_end`` already)."""
    return joint if joint.lower().endswith("_end") else f"{joint}_end"


def _tuple3(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _sample_frames(bvh: BvhFile, count: int) -> slice:
    """At most about ``count`` evenly spaced frames: plenty for medians and means, cheap for long clips."""
    return slice(None, None, max(1, bvh.frame_count // count))


def _heights_over_hips(bvh: BvhFile, columns: list[int], feet: list[int]) -> np.ndarray:
    """Median height of points above the feet, as a fraction of the hips' height above the feet.

    The hips are the joint where the feet's chains meet. "Up" is taken from the motion itself, as
    the file axis nearest to the median direction from the feet to the hips, so
    the test works whatever the clip's world up axis is (the CMU AMASS clips are Z-up in motion
    although their skeleton offsets are Y-up).

    Args:
        bvh: The file, with at least one frame.
        columns: Point indices into :func:`bvh_joint_positions`' second axis.
        feet: Point indices of the feet.

    Returns:
        One ratio per column, shape [len(columns)] (``inf`` where the hips are not above the feet).
    """
    pos = bvh_joint_positions(bvh, _sample_frames(bvh, 200))  # [F, J + E, 3], file units
    # The joint where the legs meet (the hips) stands above the feet; the rig's root may not.
    J = bvh.joint_count
    chains = []
    for c in feet:
        j = bvh.end_sites[c - J].parent if c >= J else c
        chain = []
        while j >= 0:
            chain.append(j)
            j = bvh.joint_parents[j]
        chains.append(chain)
    common = [j for j in chains[0] if all(j in ch for ch in chains[1:])]
    hips = common[0]
    base = pos[:, feet].mean(axis=1)  # [F, 3]
    # Motion worlds are Y-up or Z-up: snap the median feet-to-hips direction to the nearest axis
    # (legs slant, especially a quadruped's hind legs).
    rise = np.median(pos[:, hips] - base, axis=0)
    k = int(np.argmax(np.abs(rise)))
    up = np.zeros(3)
    up[k] = np.sign(rise[k])
    hip = float(abs(rise[k]))
    if hip < 1e-9:
        return np.full(len(columns), np.inf)
    rel = np.einsum("fcx,x->fc", pos[:, columns] - base[:, None], up)  # [F, C]
    return np.median(rel, axis=0) / hip


# ---------------------------------------------------------------------------------------------
# Up axis and facing of the motion
# ---------------------------------------------------------------------------------------------
_AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0)}
"""Candidate facings: the skeleton's horizontal axes (BVH skeletons are Y-up)."""
_LEVEL_TRUNK = 0.7
"""A frame's trunk is level when its horizontal part is at least this fraction of its length (within ~45 deg)."""
_LEVEL_FRAMES = 0.1
"""Posture decides the facing only when at least this fraction of the frames has a level trunk."""
_FACING_SCORE = 0.25
"""The winning axis must score at least this (a mean cosine) ..."""
_FACING_MARGIN = 2.0
"""... and this many times the score of the axes across it."""


def detect_bvh_up(bvh: BvhFile, *, detect_front_paws: bool = True) -> str:
    """The file axis the motion's world is up along: ``"+y"`` or ``"+z"``.

    With feet (:func:`skeleton_from_bvh`'s foot end-effectors), each axis scores how far the
    root stays above its *highest* foot joint along it (mean over up to 64 frames): along the
    vertical every foot is below the root, while along a horizontal axis feet lie on both sides
    of it (strides, front and hind legs). Without feet, the direction the root's rest up (+Y)
    points to on average decides. Most files are Y-up; the CMU (AMASS) clips move their Y-up
    skeleton in a Z-up world.

    Args:
        bvh: A parsed file (folded with :func:`fold_static_root` first).
        detect_front_paws: As in :func:`skeleton_from_bvh` (front paws count as feet).
    """
    return _memo(bvh, "up", detect_front_paws, lambda: _detect_up(bvh, _plan_end_effectors(bvh, detect_front_paws)))


def _detect_up(bvh: BvhFile, plan: Sequence[_PlannedEndEffector]) -> str:
    feet = [c.joint for c in plan if c.role == EndEffectorRole.FOOT]
    frames = _sample_frames(bvh, 64)
    if feet:
        pos = bvh_joint_positions(bvh, frames)[:, : bvh.joint_count]
        score = (pos[:, 0] - pos[:, feet].max(axis=1)).mean(axis=0)  # [3]
        return "+z" if score[2] > score[1] else "+y"
    up = _joint_frames(bvh, frames)[1][:, 0, :, 1].mean(axis=0)  # the root's +Y in the world, averaged
    return "+z" if up[2] > up[1] else "+y"


def detect_bvh_facing(bvh: BvhFile, *, detect_front_paws: bool = True) -> str:
    """The skeleton axis the creature faces, for ``facing="auto"``: ``"+z"``, ``"-z"``, ``"+x"`` or ``"-x"``.

    BVH has no facing convention for creatures. Humanoid exports (CMU, Daz, Bandai Namco,
    Mixamo) face +Z, but the MANN dog's root frame has its head along -X once it stands, and
    the elephants' along +X. The candidates are the skeleton's horizontal axes, taken in the
    root's frame and followed through the clip:

    1. A skeleton with hand end-effectors (arms, not front paws) follows the humanoid
       convention, ``"+z"``: human clips never change with the motion. (A human's trunk lies
       level when crawling or bowing, and Bandai Namco's root frame has its +X along the spine,
       so posture would mislead.)
    2. Posture: the *trunk* runs from the root to the joint where the head's chain branches off
       (the dog's ``Spine1``; the head end-effector itself where nothing branches). Over the
       frames where the trunk is level (its horizontal part at least 70% of its length; a
       sitting dog's is not), each axis scores the mean of ``h(R a) . h(t) / |t|`` (``R`` the
       root's rotation, ``t`` the trunk, ``h`` the horizontal part). Used when at least 10% of
       the frames are level and the best axis scores at least 0.25 and twice the axes across
       it. On the 24 dog clips: ``"-x"`` every time, with scores 0.36-0.97 against at most 0.2.
    3. Travel, when the root moves at least one body size: each axis scores
       ``sum h(R a) . v / sum |v|`` over the root's horizontal velocity ``v``, with a threshold
       of 0.5 and the same margin. Only for creatures whose posture does not tell: travel is
       not facing for a clip walking backwards or sideways.
    4. Otherwise ``"+z"`` (also for a file without frames).

    Args:
        bvh: A parsed file (folded with :func:`fold_static_root` first).
        detect_front_paws: As in :func:`skeleton_from_bvh` (front paws are not hands).
    """
    return _memo(bvh, "facing", detect_front_paws, lambda: _detect_facing(bvh, detect_front_paws))


def _detect_facing(bvh: BvhFile, detect_front_paws: bool) -> str:
    plan = _plan_end_effectors(bvh, detect_front_paws)
    roles = [c.role for c in plan]
    if EndEffectorRole.HAND in roles or bvh.frame_count < 2:
        return "+z"
    frames = _sample_frames(bvh, 200)
    pos, rot = _joint_frames(bvh, frames)  # [F, J + E, 3], [F, J, 3, 3]
    up = np.zeros(3)
    up["xyz".index(detect_bvh_up(bvh, detect_front_paws=detect_front_paws)[1])] = 1.0

    def horizontal(v: np.ndarray) -> np.ndarray:
        return v - (v @ up)[..., None] * up

    axes = {k: horizontal(rot[:, 0] @ np.asarray(a)) for k, a in _AXES.items()}  # [F, 3] each, world
    head = next((c for c in plan if c.role == EndEffectorRole.HEAD), None)
    if head is not None:
        trunk = pos[:, _trunk_end(bvh, head)] - pos[:, 0]  # [F, 3]
        level = horizontal(trunk)
        length = np.linalg.norm(trunk, axis=-1)
        keep = np.linalg.norm(level, axis=-1) >= _LEVEL_TRUNK * np.maximum(length, 1e-12)
        if keep.mean() >= _LEVEL_FRAMES:
            cosines = {k: np.einsum("fi,fi->f", a[keep], level[keep]) / length[keep] for k, a in axes.items()}
            scores = {k: float(c.mean()) for k, c in cosines.items()}
            best = _clear_winner(scores, _FACING_SCORE)
            if best is not None:
                return best
    velocity = np.diff(pos[:, 0], axis=0)  # [F - 1, 3] per sampled step
    v = horizontal(velocity)
    travel = float(np.linalg.norm(v, axis=-1).sum())
    size = float(np.ptp(_rest_positions(bvh), axis=0).max())
    if travel > 1e-12 and travel >= size:
        scores = {k: float(np.einsum("fi,fi->", a[:-1], v)) / travel for k, a in axes.items()}
        best = _clear_winner(scores, 2.0 * _FACING_SCORE)
        if best is not None:
            return best
    return "+z"


def _clear_winner(scores: dict[str, float], threshold: float) -> str | None:
    """The best-scoring axis if it reaches ``threshold`` and ``_FACING_MARGIN`` times the axes across it."""
    best = max(scores, key=scores.__getitem__)
    across = ("+z", "-z") if best[1] == "x" else ("+x", "-x")
    rival = max(abs(scores[k]) for k in across)
    if scores[best] >= threshold and scores[best] >= _FACING_MARGIN * rival:
        return best
    return None


def _trunk_end(bvh: BvhFile, head: _PlannedEndEffector) -> int:
    """Point index of the trunk's front end: where the head's chain branches off, or the head itself."""
    branches = _branch_counts(bvh)
    j = head.joint
    while bvh.joint_parents[j] > 0:
        j = bvh.joint_parents[j]
        if branches[j] >= 2:
            return j
    return head.column


def read_bvh_skeleton(
    path: str | os.PathLike[str],
    *,
    scale: float | None = None,
    facing: str = "auto",
    detect_front_paws: bool = True,
) -> Morphology:
    """Read a BVH file's skeleton as a :class:`~morphkit.graph.Morphology` (metres, z up, x forward).

    The whole file is parsed and checked, motion included; the motion folds a static root away
    and decides front paws and the facing. The skeleton equals the one
    :func:`morphkit.motion.read_bvh_motion` gives the file's motion with the same options. See
    :func:`skeleton_from_bvh`.

    Args:
        path: BVH file.
        scale: File units to metres; ``None`` detects centimetres vs metres.
        facing: The BVH axis the character faces at rest, or ``"auto"`` (:func:`detect_bvh_facing`).
        detect_front_paws: Turn leg-long hands that move at the feet's height into feet.

    Raises:
        DescriptionError: bad file or hierarchy. MotionFormatError: bad MOTION section.
        ConfigError: bad ``scale`` or ``facing``.
    """
    return skeleton_from_bvh(read_bvh(path), scale=scale, facing=facing, detect_front_paws=detect_front_paws)
