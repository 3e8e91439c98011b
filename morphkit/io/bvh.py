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
  face another direction (the dog clips face +X).
- Units: file units times a scale to metres; by default :func:`detect_bvh_scale` (1 when the
  rest skeleton's largest extent is at most 10 file units, else centimetres, 0.01). The real
  files behind this rule (largest rest extent in file units): CMU (AMASS) 1.58 (metres), CMU
  Daz 152.7 and Bandai Namco 184-457 (centimetres), dog 87 (cm), crab 1.1 and elephants 2.84
  (metres). Inches cannot be told from centimetres by size alone: pass ``scale=0.0254``.
- Rest poses: the skeleton's rest pose is the BVH's (all channels zero). CMU and Daz rest in a
  standing T-pose; the Bandai Namco and dog rigs put every bone along its local x, so their
  rest pose is not upright (their motion rotations make it so), and a rest-pose height is
  meaningless for them. Note also that the CMU (AMASS) clips are Z-up in their motion (the root
  rotation stands the Y-up skeleton up along Z), whereas Daz, Bandai Namco and the dog are Y-up.
- Links and joints: one link per BVH joint, named after it, in BVH order (``links[i]`` is BVH
  joint ``i``); the root joint is the root link of a floating base (its ``OFFSET`` is ignored:
  the motion places the root). Every other joint is a joint of the same name: spherical when
  it has any rotation channel, fixed otherwise; its origin is its ``OFFSET`` (converted, no
  rotation). Position channels of non-root joints have no counterpart in the morphology
  (their rest value is the ``OFFSET``).
- Shapes: each link gets a capsule from its origin to each child joint and End Site (radius
  8% of the bone length, at least 1 cm); a link with no bone gets a sphere of its incoming
  bone's radius, so renders and self-collision queries work on any BVH skeleton.
- End-effectors, from names (see :func:`skeleton_from_bvh`): hands, feet and head found from
  keywords in joint names, one per limb, at the limb's End Site (named ``<joint>_end``) or,
  where a limb ends in several End Sites (fingers, eyes), at the limb's topmost keyword joint
  (named after that joint, zero offset). Unnamed End Sites become ``tool`` end-effectors.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

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

__all__ = [
    "BVH_CHANNEL_NAMES",
    "BVH_TO_MORPHKIT",
    "BvhEndSite",
    "BvhFile",
    "bvh_frame_rotation",
    "bvh_joint_positions",
    "detect_bvh_scale",
    "dump_bvh",
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


def bvh_joint_positions(bvh: BvhFile, frames: slice | Sequence[int] | np.ndarray | None = None) -> np.ndarray:
    """World positions of every joint and End Site, in file units and axes (vectorised over frames).

    Args:
        bvh: A parsed file.
        frames: Which frames (default all). With a file of zero frames, the rest pose is used.

    Returns:
        Positions, shape [frames, joint_count + end_site_count, 3]: joints in file order, then
        End Sites in file order.
    """
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
    return np.moveaxis(pos, 0, 1)


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
# Skeleton -> Morphology
# ---------------------------------------------------------------------------------------------
_STRONG = (
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
_RADIUS_FRACTION = 0.08
_FRONT_PAW_FRACTION = 0.35


def _keyword_role(name: str, table: tuple[tuple[EndEffectorRole, tuple[str, ...]], ...]) -> EndEffectorRole | None:
    low = name.lower()
    for role, words in table:
        if any(w in low for w in words):
            return role
    return None


def _quat_z_to(direction: np.ndarray) -> tuple[float, float, float, float]:
    """xyzw quaternion rotating +z onto unit ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, direction))
    if c < -1.0 + 1e-12:
        return (1.0, 0.0, 0.0, 0.0)
    axis = np.cross(z, direction)
    q = np.array([*axis, 1.0 + c])
    q = q / np.linalg.norm(q)
    return tuple(float(v) for v in q)  # type: ignore[return-value]


def _bone_shapes(segments: list[np.ndarray], incoming: float | None) -> tuple[Shape, ...]:
    """Capsules along ``segments`` (vectors from the link origin, metres), or one sphere."""
    shapes: list[Shape] = []
    for seg in segments:
        length = float(np.linalg.norm(seg))
        if length < 1e-6:
            continue
        origin = Transform(tuple(float(v) for v in 0.5 * seg), _quat_z_to(seg / length))  # type: ignore[arg-type]
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
    facing: str = "+z",
    name: str | None = None,
    detect_front_paws: bool = True,
) -> Morphology:
    """Build a :class:`~morphkit.graph.Morphology` from a parsed BVH skeleton.

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
    3. With ``detect_front_paws``, a "hand" that moves at the feet's height is a front foot
       (quadruped rigs call their front paws hands) and becomes a foot: its median height above
       the feet over the clip is below 35% of the hips' (the joint where the feet's chains
       meet). On the real data the dog's paws give at most 0.21 and humans at least 0.46,
       except CMU 111_03 (crawling, 0.05) and 144_32 (sun salutation, 0.2), whose hands become
       feet too; pass ``detect_front_paws=False`` where a dataset needs the same roles for
       every clip.

    Args:
        bvh: A parsed file (:func:`parse_bvh`).
        scale: File units to metres; ``None`` detects it (:func:`detect_bvh_scale`).
        facing: The BVH axis the character faces (:func:`bvh_frame_rotation`).
        name: Morphology name (default: the file's stem, or ``"bvh"``).
        detect_front_paws: Turn hands that move at the feet's height into feet (rule 3).

    Raises:
        ConfigError: ``scale`` is not a positive finite number, or ``facing`` is unknown.
        GraphError: the skeleton cannot form a valid morphology (also for absurd offsets that
            overflow to non-finite lengths).
    """
    # Absurd offsets (1e308) overflow to inf here; the builder then rejects them with a GraphError.
    with np.errstate(over="ignore", invalid="ignore"):
        return _skeleton_from_bvh(bvh, scale, facing, name, detect_front_paws)


def _skeleton_from_bvh(
    bvh: BvhFile, scale: float | None, facing: str, name: str | None, detect_front_paws: bool
) -> Morphology:
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) or scale <= 0:
            raise ConfigError(f"BVH scale must be a positive number, got {scale!r}")
        s = float(scale)
    else:
        s = detect_bvh_scale(bvh)
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
    for ee_name, joint, offset, role, line in _choose_end_effectors(bvh, end_offsets, detect_front_paws):
        b.add_end_effector(ee_name, bvh.joint_names[joint], offset=offset, role=role, location=bvh.location(line))
    return b.build()


def _choose_end_effectors(
    bvh: BvhFile, end_offsets: list[np.ndarray], detect_front_paws: bool
) -> list[tuple[str, int, tuple[float, float, float], EndEffectorRole, int | None]]:
    """End-effectors as (name, joint index, offset [m], role, line); see :func:`skeleton_from_bvh`."""
    J = bvh.joint_count
    parents = bvh.joint_parents
    strong = [_keyword_role(n, _STRONG) for n in bvh.joint_names]
    weak = [_keyword_role(n, _WEAK) for n in bvh.joint_names]

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

    # (name, joint, offset, role, line, column in bvh_joint_positions)
    chosen: list[tuple[str, int, tuple[float, float, float], EndEffectorRole, int | None, int]] = []
    for (role, top), ends in limbs.items():
        if len(ends) == 1:
            e = ends[0]
            site = bvh.end_sites[e]
            chosen.append((_end_name(site.joint), site.parent, _tuple3(end_offsets[e]), role, site.line, J + e))
        else:
            chosen.append((bvh.joint_names[top], top, (0.0, 0.0, 0.0), role, joint_line(top), top))
    for e in tools:
        site = bvh.end_sites[e]
        chosen.append(
            (_end_name(site.joint), site.parent, _tuple3(end_offsets[e]), EndEffectorRole.TOOL, site.line, J + e)
        )
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
        chosen.append((bvh.joint_names[tip], tip, (0.0, 0.0, 0.0), role, joint_line(tip), tip))

    # Quadruped rigs name their front paws "hands": a hand that moves at the feet's height is a foot.
    hands = [i for i, c in enumerate(chosen) if c[3] == EndEffectorRole.HAND]
    feet = [c[5] for c in chosen if c[3] == EndEffectorRole.FOOT]
    if detect_front_paws and hands and feet and bvh.frame_count:
        heights = _heights_over_hips(bvh, [chosen[i][5] for i in hands], feet)
        for i, h in zip(hands, heights, strict=True):
            if h < _FRONT_PAW_FRACTION:
                n, j, off, _, line, col = chosen[i]
                chosen[i] = (n, j, off, EndEffectorRole.FOOT, line, col)

    used: set[str] = set()
    out = []
    for n, j, off, role, line, _ in chosen:
        name, k = n, 2
        while name in used:
            name, k = f"{n}{k}", k + 1
        used.add(name)
        out.append((name, j, off, role, line))
    return out


def _end_name(joint: str) -> str:
    """End-effector name for an End Site of ``joint``: ``<joint>_end`` (rigs often name leaves ``*_end`` already)."""
    return joint if joint.lower().endswith("_end") else f"{joint}_end"


def _tuple3(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


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
    # At most ~200 evenly spaced frames: plenty for a median, cheap for long clips.
    step = max(1, bvh.frame_count // 200)
    pos = bvh_joint_positions(bvh, slice(None, None, step))  # [F, J + E, 3], file units
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


def read_bvh_skeleton(
    path: str | os.PathLike[str],
    *,
    scale: float | None = None,
    facing: str = "+z",
    detect_front_paws: bool = True,
) -> Morphology:
    """Read a BVH file's skeleton as a :class:`~morphkit.graph.Morphology` (metres, z up, x forward).

    The whole file is parsed and checked, motion included. See :func:`skeleton_from_bvh`.

    Args:
        path: BVH file.
        scale: File units to metres; ``None`` detects centimetres vs metres.
        facing: The BVH axis the character faces at rest (default ``"+z"``).
        detect_front_paws: Turn hands that move at the feet's height into feet.

    Raises:
        DescriptionError: bad file or hierarchy. MotionFormatError: bad MOTION section.
        ConfigError: bad ``scale`` or ``facing``.
    """
    return skeleton_from_bvh(read_bvh(path), scale=scale, facing=facing, detect_front_paws=detect_front_paws)
