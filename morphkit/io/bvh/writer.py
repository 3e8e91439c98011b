"""The BVH writer: :func:`dump_bvh` / :func:`write_bvh` turn a :class:`~morphkit.io.bvh.file.BvhFile` back into
text that :func:`~morphkit.io.bvh.parser.parse_bvh` reads to the same file."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from morphkit._atomic import atomic_path
from morphkit.io.bvh.file import BvhEndSite, BvhFile

__all__ = ["dump_bvh", "write_bvh"]


def _fmt(v: float) -> str:
    # The shortest text that reads back to the same float.
    return repr(float(v))


FRAMES_PER_CHUNK = 1024
"""Frame lines formatted at a time: NumPy's text of a value takes ~8× its float64, so a whole clip at once
took ~16× the file's size."""


def dump_bvh(bvh: BvhFile) -> str:
    """BVH text of ``bvh`` (tab-indented hierarchy, one line per frame, 10 significant digits).

    ``parse_bvh(dump_bvh(b))`` reproduces ``b``'s tree exactly and its numbers to about 1e-9
    relative.
    """
    return "".join(_chunks(bvh))


def _chunks(bvh: BvhFile) -> Iterator[str]:
    """The text of ``bvh``: the header, then frame lines :data:`FRAMES_PER_CHUNK` at a time."""
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
    yield "\n".join(out) + "\n"
    for start in range(0, bvh.frame_count, FRAMES_PER_CHUNK):
        rows = np.char.mod("%.10g", bvh.motion[start : start + FRAMES_PER_CHUNK])
        yield "".join(" ".join(r) + "\n" for r in rows)


def write_bvh(bvh: BvhFile, path: str | os.PathLike[str]) -> None:
    """Write ``bvh`` to ``path`` atomically (see :func:`dump_bvh`), streaming the frames."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(_chunks(bvh))
