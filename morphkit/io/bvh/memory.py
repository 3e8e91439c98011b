"""Memory before work on a BVH file: an estimate from its header, checked before the frames are read.

A BVH file's text takes ~10 bytes a value and the arrays made from it 8 bytes a value each, so reading and
converting a clip takes many times its size (a 120 MB file once took 4.8 GB). :func:`check_bvh_memory` reads
only the header (the channel count and the ``Frames:`` line), estimates the peak, and refuses a clip that
would not fit in one line naming the estimate and the bound.
"""

from __future__ import annotations

import os
import re

from morphkit._memory import available_memory
from morphkit.errors import MotionFormatError, SourceLocation

__all__ = [
    "BYTES_PER_VALUE",
    "MAX_BVH_MEMORY",
    "TEXT_COPIES",
    "USD_BYTES_PER_VALUE",
    "available_memory",
    "bvh_header_counts",
    "check_bvh_memory",
    "estimate_bvh_memory",
]

MAX_BVH_MEMORY = 16 << 30
"""Most bytes (16 GiB) reading and converting one BVH clip may take, whatever the machine has free: about
134 million values (a 70-channel clip of 1.9 million frames, 4.4 h at 120 fps, near the most frames a motion
may be resampled to; a file of ~1.3 GB)."""
TEXT_COPIES = 4
"""Copies of the file's text alive while it is parsed (the text, its lines, the joined frame lines, the
lines' bookkeeping)."""
BYTES_PER_VALUE = 128
"""Bytes per motion value (frames × channels) at the peak of reading and converting a clip: 16 float64
copies (the values, their rotation matrices, joint positions, coordinates, Euler angles and text on writing
back; 14.1 measured reading a 12,000-frame clip and writing it back as BVH, ~9× the file's size)."""
USD_BYTES_PER_VALUE = BYTES_PER_VALUE + 256
"""As :data:`BYTES_PER_VALUE` when the clip is written as USD: pxr keeps every time sample as its own value
(~210 bytes per BVH value measured: 0.7 GB more for a 48,000-frame, 69-channel clip)."""

_HEAD_LIMIT = 16 << 20
"""Bytes read looking for the header's end; a hierarchy is kilobytes, so past this the parser reports."""


def bvh_header_counts(path: str | os.PathLike[str]) -> tuple[int, int, int] | None:
    """``(frames, channels, line of Frames:)`` from a BVH file's header, reading no frame line.

    ``None`` where the header is not plain (no ``MOTION``, no numeric ``Frames:``): the parser reports that.
    """
    header = re.compile(rb"(?:^|\s)MOTION\s+Frames\s*:\s*([0-9]+)\s")
    head, found = bytearray(), None
    with open(path, "rb") as f:
        while found is None and len(head) < _HEAD_LIMIT:
            block = f.read(1 << 16)
            if not block:
                break
            start = max(0, len(head) - 64)  # the header may straddle two blocks
            head += block
            found = header.search(head, start)
    if found is None:
        return None
    hierarchy = head[: found.start()]
    channels = sum(int(n) for n in re.findall(rb"\bCHANNELS\s+([0-9]+)", hierarchy))
    line = head[: found.start(1)].count(b"\n") + 1
    return int(found.group(1)), channels, line


def estimate_bvh_memory(
    frames: int, channels: int, file_bytes: int, *, bytes_per_value: int = BYTES_PER_VALUE
) -> int:
    """Peak bytes reading and converting a clip of ``frames`` × ``channels`` values from ``file_bytes`` of text:
    the larger of the parse (its text copies and the values) and the conversion."""
    values = frames * channels
    return max(TEXT_COPIES * file_bytes + 8 * values, bytes_per_value * values)


def check_bvh_memory(path: str | os.PathLike[str], *, bytes_per_value: int = BYTES_PER_VALUE) -> None:
    """Refuse a BVH clip whose estimated peak (:func:`estimate_bvh_memory`) exceeds :data:`MAX_BVH_MEMORY`
    or the memory available now, before its frames are read.

    Raises:
        MotionFormatError: one line at the ``Frames:`` line naming the estimate and the bound.
    """
    try:
        counts = bvh_header_counts(path)
        size = os.path.getsize(path)
    except OSError:
        return  # unreadable: the reader says so
    if counts is None:
        return
    frames, channels, line = counts
    need = estimate_bvh_memory(frames, channels, size, bytes_per_value=bytes_per_value)
    free = available_memory()
    bound, what = MAX_BVH_MEMORY, "morphkit's bound for one clip"
    if free is not None and free < bound:
        bound, what = free, "the memory available now"
    if need > bound:
        raise MotionFormatError(
            f"{frames} frames × {channels} channels would need about {_gib(need)} to read and convert, more "
            f"than {_gib(bound)} ({what}); split the clip, or convert it where more memory is free",
            location=SourceLocation(os.fspath(path), line),
        )


def _gib(n: int) -> str:
    gib = n / 2**30
    return f"{gib:,.0f} GiB" if gib >= 100 else f"{gib:.3g} GiB"
