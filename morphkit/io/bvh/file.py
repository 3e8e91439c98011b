"""A parsed BVH file (:class:`BvhFile`) and what its numbers mean, in the file's own units and axes: forward
kinematics (:func:`bvh_joint_positions`, under the channel semantics of :mod:`morphkit.io.bvh`), the unit scale
(:func:`detect_bvh_scale`), and a static root folded away (:func:`fold_static_root`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphkit.errors import DescriptionError, SourceLocation

__all__ = [
    "BVH_CHANNEL_NAMES",
    "BvhEndSite",
    "BvhFile",
    "bvh_joint_positions",
    "detect_bvh_scale",
    "fold_static_root",
    "joint_frames",
    "rest_positions",
]

BVH_CHANNEL_NAMES: tuple[str, ...] = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
"""The six channel names BVH knows (read case-insensitively, stored in this spelling)."""


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

    def channel_columns(self, joint: int) -> list[tuple[int, str]]:
        """``(column, channel)`` of joint ``joint``'s channels in :attr:`motion`."""
        start = self.joint_channel_start[joint]
        return [(start + k, ch) for k, ch in enumerate(self.joint_channels[joint])]

    def position_columns(self, joint: int) -> dict[int, int]:
        """``{axis: column}`` of joint ``joint``'s position channels (axis 0, 1, 2 for X, Y, Z)."""
        return {"XYZ".index(ch[0]): c for c, ch in self.channel_columns(joint) if ch.endswith("position")}


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


def joint_frames(
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
    return joint_frames(bvh, frames)[0]


def rest_positions(bvh: BvhFile) -> np.ndarray:
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
    pts = rest_positions(bvh)
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
        child_pos = bvh.position_columns(child)
        if not child_pos:
            break
        rot_cols = [c for c, ch in bvh.channel_columns(0) if ch.endswith("rotation")]
        if np.abs(bvh.motion[:, rot_cols]).max(initial=0.0) > _STILL_DEGREES:
            break
        root_pos = np.broadcast_to(np.asarray(bvh.joint_offsets[0], dtype=float), (bvh.frame_count, 3)).copy()
        for axis, col in bvh.position_columns(0).items():
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
