"""What a BVH skeleton is, read from its names and its motion: end-effectors and their roles (hands, feet,
head, tools; front paws named hands), the motion's up axis and the direction the creature faces.

The rules are :func:`~morphkit.io.bvh.skeleton.skeleton_from_bvh`'s (end-effectors) and :func:`detect_bvh_facing`'s;
each analysis of a parsed file is computed once (the skeleton reader and the motion reader both ask).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from morphkit.body.paws import PAW_RULE
from morphkit.body.roles import BVH_ROLE_WORDS, BVH_WEAK_ROLE_WORDS, keyword_role
from morphkit.graph import EndEffectorRole
from morphkit.io.bvh.file import BvhFile, bvh_joint_positions, joint_frames, rest_positions

__all__ = ["ROLE_KEYWORDS", "PlannedEndEffector", "detect_bvh_facing", "detect_bvh_up", "keyword_role",
           "plan_end_effectors"]

ROLE_KEYWORDS = BVH_ROLE_WORDS
"""Keywords (matched in lower-cased joint names) that give an end-effector its role: the strong words of the one
keyword table (:data:`morphkit.body.roles.PART_WORDS`)."""
_WEAK = BVH_WEAK_ROLE_WORDS
"""Fallback keywords (the table's weak words), used only when no joint on the path to the root has a strong one."""

@dataclass(frozen=True)
class PlannedEndEffector:
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


_analyses: weakref.WeakKeyDictionary[BvhFile, dict[tuple[str, bool], Any]] = weakref.WeakKeyDictionary()
"""Per parsed file: its end-effector plan, up axis and facing, computed once (the skeleton reader
and the motion reader both ask, and the front paws and the facing need forward kinematics)."""


def _memo(bvh: BvhFile, what: str, detect_front_paws: bool, compute: Callable[[], Any]) -> Any:
    entry = _analyses.setdefault(bvh, {})
    key = (what, bool(detect_front_paws))
    if key not in entry:
        entry[key] = compute()
    return entry[key]


def plan_end_effectors(bvh: BvhFile, detect_front_paws: bool) -> tuple[PlannedEndEffector, ...]:
    """End-effectors of ``bvh`` in file terms (see :func:`skeleton_from_bvh`, rules 1-3)."""
    return _memo(bvh, "plan", detect_front_paws, lambda: tuple(_plan(bvh, detect_front_paws)))


def _plan(bvh: BvhFile, detect_front_paws: bool) -> list[PlannedEndEffector]:
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

    chosen: list[PlannedEndEffector] = []

    def at_site(e: int, role: EndEffectorRole) -> PlannedEndEffector:
        site = bvh.end_sites[e]
        return PlannedEndEffector(_end_name(site.joint), site.parent, e, role, site.line, J + e)

    def at_joint(j: int, role: EndEffectorRole) -> PlannedEndEffector:
        return PlannedEndEffector(bvh.joint_names[j], j, None, role, joint_line(j), j)

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


def _front_paws(bvh: BvhFile, chosen: list[PlannedEndEffector]) -> list[int]:
    """Indices into ``chosen`` of the hands that are front paws (rule 3 of :func:`skeleton_from_bvh`)."""
    hands = [i for i, c in enumerate(chosen) if c.role == EndEffectorRole.HAND]
    feet = [c for c in chosen if c.role == EndEffectorRole.FOOT]
    if not hands or not feet or bvh.frame_count == 0:
        return []
    branches = _branch_counts(bvh)
    leg = float(np.mean([_limb_length(bvh, c, branches) for c in feet]))
    # Bone lengths first: they do not depend on the clip, and they rule humans out.
    long = [i for i in hands if PAW_RULE.leg_long(_limb_length(bvh, chosen[i], branches), leg)]
    if not long:
        return []
    heights = _heights_over_hips(bvh, [chosen[i].column for i in long], [c.column for c in feet])
    return [i for i, h in zip(long, heights, strict=True) if PAW_RULE.rests(h, 1.0)]


def _branch_counts(bvh: BvhFile) -> list[int]:
    """Children (joints and End Sites) of every joint, shape [joint_count]."""
    counts = [0] * bvh.joint_count
    for p in bvh.joint_parents[1:]:
        counts[p] += 1
    for site in bvh.end_sites:
        counts[site.parent] += 1
    return counts


def _limb_length(bvh: BvhFile, ee: PlannedEndEffector, branches: list[int]) -> float:
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
    return _memo(bvh, "up", detect_front_paws, lambda: _detect_up(bvh, plan_end_effectors(bvh, detect_front_paws)))


def _detect_up(bvh: BvhFile, plan: Sequence[PlannedEndEffector]) -> str:
    feet = [c.joint for c in plan if c.role == EndEffectorRole.FOOT]
    frames = _sample_frames(bvh, 64)
    if feet:
        pos = bvh_joint_positions(bvh, frames)[:, : bvh.joint_count]
        score = (pos[:, 0] - pos[:, feet].max(axis=1)).mean(axis=0)  # [3]
        return "+z" if score[2] > score[1] else "+y"
    up = joint_frames(bvh, frames)[1][:, 0, :, 1].mean(axis=0)  # the root's +Y in the world, averaged
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
    plan = plan_end_effectors(bvh, detect_front_paws)
    roles = [c.role for c in plan]
    if EndEffectorRole.HAND in roles or bvh.frame_count < 2:
        return "+z"
    frames = _sample_frames(bvh, 200)
    pos, rot = joint_frames(bvh, frames)  # [F, J + E, 3], [F, J, 3, 3]
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
    size = float(np.ptp(rest_positions(bvh), axis=0).max())
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


def _trunk_end(bvh: BvhFile, head: PlannedEndEffector) -> int:
    """Point index of the trunk's front end: where the head's chain branches off, or the head itself."""
    branches = _branch_counts(bvh)
    j = head.joint
    while bvh.joint_parents[j] > 0:
        j = bvh.joint_parents[j]
        if branches[j] >= 2:
            return j
    return head.column
