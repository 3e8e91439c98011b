"""The BVH text parser: :func:`parse_bvh` reads the HIERARCHY token by token and the MOTION section in one
vectorised pass into a :class:`~morphkit.io.bvh.file.BvhFile`; every error names the file and line."""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NoReturn

import numpy as np

from morphkit.errors import DescriptionError, MotionFormatError, SourceLocation
from morphkit.io._source import read_text
from morphkit.io.bvh.file import BVH_CHANNEL_NAMES, BvhEndSite, BvhFile
from morphkit.io.bvh.memory import check_bvh_memory

__all__ = ["parse_bvh", "read_bvh"]

_CHANNEL_CANON = {c.lower(): c for c in BVH_CHANNEL_NAMES}


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
    hierarchy = _HierarchyReader(lines, src)
    hierarchy.read()
    frame_time, ft_line, motion, frame_lines = _read_motion(lines, hierarchy, src)
    return BvhFile(
        joint_names=tuple(hierarchy.names),
        joint_parents=tuple(hierarchy.parents),
        joint_offsets=np.asarray(hierarchy.offsets, dtype=np.float64).reshape(-1, 3),
        joint_channels=tuple(hierarchy.channels),
        end_sites=tuple(hierarchy.end_sites),
        frame_time=frame_time,
        motion=motion,
        source=src,
        joint_lines=tuple(hierarchy.joint_lines),
        motion_line=hierarchy.motion_line,
        frame_time_line=ft_line,
        frame_lines=frame_lines,
    )


class _HierarchyReader:
    """Reads the HIERARCHY section token by token, one keyword per :meth:`step`, up to the ``MOTION`` keyword.

    It carries the joints read so far (names, parents, offsets, channels, lines), the End Sites, and the stack of
    open blocks; every malformed construct raises where it is met, naming its line.
    """

    def __init__(self, lines: list[str], src: str | None) -> None:
        self.toks = _Tokens(lines)
        self.src = src
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[tuple[float, float, float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.joint_lines: list[int] = []
        self.end_sites: list[BvhEndSite] = []
        self.name_line: dict[str, int] = {}
        self.stack: list[_Node] = []
        self.expect_open: _Node | None = None  # a node whose "{" must come next
        self.root_done = False
        self.motion_line: int | None = None

    def loc(self, line: int | None) -> SourceLocation:
        return SourceLocation(self.src, line)

    def read(self) -> None:
        """Read from ``HIERARCHY`` to ``MOTION`` (:attr:`motion_line`)."""
        first = self.toks.next()
        if first is None:
            raise DescriptionError("empty BVH file: expected HIERARCHY", location=self.loc(1))
        if first[0] != "HIERARCHY":
            raise DescriptionError(f"expected HIERARCHY, got {first[0]!r}", location=self.loc(first[1]))
        while self.motion_line is None:
            self.step()

    def step(self) -> None:
        """Consume one token (and what belongs to it)."""
        tok = self.toks.next()
        if tok is None:
            self._end_of_file()
        word, line = tok
        if self.expect_open is not None:
            if word != "{":
                raise DescriptionError(f"expected '{{' after {self.expect_open.name!r}, got {word!r}",
                                       location=self.loc(line))
            self.stack.append(self.expect_open)
            self.expect_open = None
            return
        if self.root_done:
            self._after_root(word, line)
            return
        key = word.upper()
        if key in ("ROOT", "JOINT"):
            self._joint(word, key, line)
        elif key == "END":
            self._end_site(line)
        elif key == "OFFSET":
            self._offset(line)
        elif key == "CHANNELS":
            self._channels(line)
        elif word == "}":
            self._close(line)
        else:
            self._misplaced(word, line)

    def _end_of_file(self) -> NoReturn:
        if self.expect_open is not None or self.stack:
            node = self.expect_open or self.stack[-1]
            what = f"joint {node.name!r}" if node.kind == "joint" else f"End Site of {node.name!r}"
            raise DescriptionError(
                f"unexpected end of file in HIERARCHY: the block of {what} (line {node.line}) is never closed",
                location=self.loc(self.toks.last_line),
            )
        if not self.root_done:
            raise DescriptionError("unexpected end of file: HIERARCHY has no ROOT",
                                   location=self.loc(self.toks.last_line))
        raise MotionFormatError("unexpected end of file: no MOTION section", location=self.loc(self.toks.last_line))

    def _after_root(self, word: str, line: int) -> None:
        if word == "MOTION":
            self.motion_line = line
            return
        if word == "ROOT":
            raise DescriptionError("a second ROOT: only one skeleton per BVH file is supported",
                                   location=self.loc(line))
        raise DescriptionError(f"expected MOTION after the hierarchy, got {word!r}", location=self.loc(line))

    def _open(self, kind: str, name: str, line: int) -> _Node:
        if kind == "joint":
            if name in self.name_line:
                raise DescriptionError(
                    f"duplicate joint name {name!r} (first declared on line {self.name_line[name]})",
                    location=self.loc(line),
                )
            self.name_line[name] = line
            self.parents.append(self.stack[-1].index if self.stack else -1)
            self.names.append(name)
            self.offsets.append((0.0, 0.0, 0.0))
            self.channels.append(())
            self.joint_lines.append(line)
            return _Node("joint", len(self.names) - 1, name, line)
        return _Node("end", len(self.end_sites), name, line)

    def _joint(self, word: str, key: str, line: int) -> None:
        """``ROOT name`` or ``JOINT name``, its ``{`` on the same line or the next."""
        if key == "ROOT" and (self.stack or self.names):
            raise DescriptionError("ROOT inside the hierarchy (use JOINT)", location=self.loc(line))
        if key == "JOINT" and not self.stack:
            raise DescriptionError("JOINT outside any ROOT block", location=self.loc(line))
        if self.stack and self.stack[-1].kind == "end":
            raise DescriptionError("an End Site cannot have child joints", location=self.loc(line))
        rest = self.toks.rest_of_line()
        brace = False
        if rest and rest[-1] == "{":
            rest.pop()
            brace = True
        elif rest and rest[-1].endswith("{"):
            rest[-1] = rest[-1][:-1]
            brace = True
        name = " ".join(rest)
        if not name or "{" in name or "}" in name:
            raise DescriptionError(f"{word} needs a name, got {name!r}", location=self.loc(line))
        node = self._open("joint", name, line)
        if brace:
            self.stack.append(node)
        else:
            self.expect_open = node

    def _end_site(self, line: int) -> None:
        site = self.toks.next()
        if site is None or site[0].lower() != "site" or site[1] != line:
            raise DescriptionError("expected 'End Site'", location=self.loc(line))
        if not self.stack or self.stack[-1].kind == "end":
            raise DescriptionError("End Site outside a joint block", location=self.loc(line))
        node = self._open("end", self.stack[-1].name, line)
        rest = self.toks.rest_of_line()
        if rest == ["{"]:
            self.stack.append(node)
        elif rest:
            raise DescriptionError(f"unexpected {' '.join(rest)!r} after End Site", location=self.loc(line))
        else:
            self.expect_open = node

    def _offset(self, line: int) -> None:
        if not self.stack:
            raise DescriptionError("OFFSET outside a joint block", location=self.loc(line))
        node = self.stack[-1]
        if node.offset is not None:
            raise DescriptionError(f"second OFFSET for {node.name!r}", location=self.loc(line))
        toks = self.toks
        node.offset = tuple(_number(toks.next(), "an OFFSET number", self.src, toks.last_line)  # type: ignore[assignment]
                            for _ in range(3))

    def _channels(self, line: int) -> None:
        """``CHANNELS n name...``: a count from 0 to 6, then that many known, distinct channel names."""
        if not self.stack:
            raise DescriptionError("CHANNELS outside a joint block", location=self.loc(line))
        node = self.stack[-1]
        if node.kind == "end":
            raise DescriptionError("an End Site cannot have CHANNELS", location=self.loc(line))
        if node.channels is not None:
            raise DescriptionError(f"second CHANNELS for joint {node.name!r}", location=self.loc(line))
        count_tok = self.toks.next()
        if count_tok is None:
            raise DescriptionError("unexpected end of file: expected a channel count", location=self.loc(line))
        if not re.fullmatch(r"[0-9]+", count_tok[0]) or int(count_tok[0]) > 6:
            raise DescriptionError(
                f"CHANNELS count must be an integer from 0 to 6, got {count_tok[0]!r}", location=self.loc(count_tok[1])
            )
        chans: list[str] = []
        for _ in range(int(count_tok[0])):
            ctok = self.toks.next()
            if ctok is None:
                raise DescriptionError("unexpected end of file: expected a channel name", location=self.loc(line))
            canon = _CHANNEL_CANON.get(ctok[0].lower())
            if canon is None:
                raise DescriptionError(
                    f"unknown channel {ctok[0]!r}; expected one of: {', '.join(BVH_CHANNEL_NAMES)}",
                    location=self.loc(ctok[1]),
                )
            if canon in chans:
                raise DescriptionError(f"channel {canon} listed twice for joint {node.name!r}",
                                       location=self.loc(ctok[1]))
            chans.append(canon)
        node.channels = tuple(chans)

    def _close(self, line: int) -> None:
        """``}``: the block's joint or End Site is complete (it must have had an OFFSET)."""
        if not self.stack:
            raise DescriptionError("unbalanced '}': no block is open", location=self.loc(line))
        node = self.stack.pop()
        if node.offset is None:
            what = f"joint {node.name!r}" if node.kind == "joint" else f"End Site of {node.name!r}"
            raise DescriptionError(f"{what} (line {node.line}) has no OFFSET", location=self.loc(line))
        if node.kind == "joint":
            self.offsets[node.index] = node.offset
            self.channels[node.index] = node.channels or ()
        else:
            self.end_sites.append(BvhEndSite(node.name, self.stack[-1].index, node.offset, node.line))
        if not self.stack:
            self.root_done = True

    def _misplaced(self, word: str, line: int) -> None:
        """A token that is no keyword where it stands."""
        if word == "{":
            raise DescriptionError("unexpected '{'", location=self.loc(line))
        if word == "MOTION" and not self.stack:
            raise DescriptionError("MOTION before any ROOT: the HIERARCHY is empty", location=self.loc(line))
        if word == "MOTION":
            raise DescriptionError(
                f"MOTION inside the hierarchy: the block of {self.stack[-1].name!r} (line {self.stack[-1].line}) is "
                "never closed",
                location=self.loc(line),
            )
        raise DescriptionError(
            f"unknown keyword {word!r}; expected one of: JOINT, End Site, OFFSET, CHANNELS, {{, }}",
            location=self.loc(line),
        )


def _read_motion(lines: list[str], hierarchy: _HierarchyReader,
                 src: str | None) -> tuple[float, int, np.ndarray, np.ndarray]:
    """The MOTION section after ``hierarchy``: frame time, its line, values [frames, channels] and frame lines."""
    loc = hierarchy.loc
    if hierarchy.toks.rest_of_line():
        raise MotionFormatError("unexpected text after MOTION", location=loc(hierarchy.motion_line))
    channel_count = sum(len(c) for c in hierarchy.channels)
    row = hierarchy.toks.row  # index of the first line after MOTION
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
    return frame_time, ft_line, motion, frame_lines


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
        MotionFormatError: the MOTION section is malformed, or the clip would not fit in memory
            (:func:`~morphkit.io.bvh.memory.check_bvh_memory`, checked before its frames are read).
    """
    check_bvh_memory(path)
    return parse_bvh(read_text(path, what="BVH"), source=os.fspath(path))
