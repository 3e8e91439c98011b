"""The BVH writer: :func:`dump_bvh` / :func:`write_bvh` turn a :class:`~morphkit.io.bvh.file.BvhFile` back into
text that :func:`~morphkit.io.bvh.parser.parse_bvh` reads to the same file."""

from __future__ import annotations

import os

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.io.bvh.file import BvhEndSite, BvhFile

__all__ = ["dump_bvh", "write_bvh"]


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
