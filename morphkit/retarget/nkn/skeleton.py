"""Skeletons of one topology with different bone lengths: checks, bone offsets, limb groups, variants.

NKN retargets between characters whose skeletons share one topology (links, joints, joint types
and frames) and differ in their bone offsets, the joint origin translations ``o_j`` [m] in the
parent link (§3.1: $\\bar s^n$). A *skeleton* here is a :class:`~morphkit.graph.Morphology`; two of
them are of one topology when everything but those translations (and end-effector offsets,
link shapes and names of the whole) agrees.

Limb groups are found from the end-effector roles, so no part is named: a joint used only by the
chains to feet is a leg joint, only by hands (or tools) an arm joint, only by the head a neck joint,
anything else (shared chains, and where each limb attaches) the trunk. Variants scale the offsets
of whole groups (longer arms, shorter legs, ±30 %), the unseen characters of the evaluation.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping, Sequence

import numpy as np

from morphkit.errors import MotionFormatError
from morphkit.graph import EndEffectorRole, JointType, Morphology, Transform

__all__ = [
    "EVALUATION_VARIANTS",
    "GROUPS",
    "bone_offsets",
    "check_same_topology",
    "limb_groups",
    "random_variants",
    "scale_limbs",
    "skeleton_key",
    "topology_difference",
    "twist_axes",
    "with_offsets",
]

GROUPS = ("trunk", "legs", "arms", "head")
"""Limb groups of :func:`limb_groups`."""

EVALUATION_VARIANTS: dict[str, dict[str, float]] = {
    "short_legs": {"legs": 0.7},
    "long_legs": {"legs": 1.3},
    "long_arms_short_legs": {"arms": 1.3, "legs": 0.8},
    "tall": {"trunk": 1.2, "legs": 1.2, "arms": 1.2, "head": 1.2},
}
"""The unseen characters of the evaluation: limb-group scale factors applied to a data skeleton."""

_ROLE_GROUP = {EndEffectorRole.FOOT: "legs", EndEffectorRole.HAND: "arms", EndEffectorRole.TOOL: "arms",
               EndEffectorRole.HEAD: "head"}


def bone_offsets(morphology: Morphology) -> np.ndarray:
    """Joint origin translations ("bone offsets") ``o_j`` in the parent links, shape [J, 3] [m]."""
    return np.array([j.origin.xyz for j in morphology.joints], dtype=float).reshape(-1, 3)


def skeleton_key(morphology: Morphology) -> str:
    """A short hash of the bone offsets (mm resolution): clips with equal keys share one skeleton."""
    rounded = np.round(bone_offsets(morphology) * 1000.0).astype(np.int64)
    return hashlib.sha1(rounded.tobytes()).hexdigest()[:12]


def topology_difference(a: Morphology, b: Morphology) -> str | None:
    """What makes ``b`` another topology than ``a`` (``None`` when they are of one topology)."""
    if a.base != b.base:
        return f"base {b.base.name.lower()} instead of {a.base.name.lower()}"
    if a.link_names != b.link_names:
        only_a = [n for n in a.link_names if n not in set(b.link_names)]
        only_b = [n for n in b.link_names if n not in set(a.link_names)]
        if only_a or only_b:
            return (f"links {', '.join(only_a[:4]) or '-'} missing and {', '.join(only_b[:4]) or '-'} extra "
                    f"({b.link_count} links instead of {a.link_count})")
        return "the same links in another order"
    for ja, jb in zip(a.joints, b.joints, strict=True):
        if (ja.parent, ja.child, ja.type) != (jb.parent, jb.child, jb.type):
            return f"joint {jb.name!r} is {jb.type.name.lower()} {jb.parent}->{jb.child}, not " \
                   f"{ja.type.name.lower()} {ja.parent}->{ja.child}"
        if not np.allclose(ja.origin.quat, jb.origin.quat, atol=1e-6) and not np.allclose(
                ja.origin.quat, -np.asarray(jb.origin.quat), atol=1e-6):
            return f"joint {jb.name!r} has another origin rotation"
        if ja.type != JointType.SPHERICAL and not np.allclose(ja.axis, jb.axis, atol=1e-6):
            return f"joint {jb.name!r} has another axis"
        if a.is_driven(ja) != b.is_driven(jb):
            return f"joint {jb.name!r} is driven in one skeleton only"
    if [(e.link, e.role) for e in a.end_effectors] != [(e.link, e.role) for e in b.end_effectors]:
        return "other end-effectors"
    return None


def check_same_topology(template: Morphology, other: Morphology, *, what: str = "skeleton") -> None:
    """Raise :class:`~morphkit.errors.MotionFormatError` naming both when ``other`` is of another topology."""
    diff = topology_difference(template, other)
    if diff is not None:
        raise MotionFormatError(
            f"{what} {other.name!r} is of another topology than {template.name!r}: {diff}; "
            "one NKN run retargets between skeletons of one topology (use the cross-morphology mode, "
            "with a creature, for another one)"
        )


def with_offsets(morphology: Morphology, offsets: np.ndarray, *, ee_offsets: np.ndarray | None = None,
                 name: str | None = None) -> Morphology:
    """``morphology`` with joint origin translations ``offsets`` [J, 3] (and end-effector offsets [E, 3])."""
    offsets = np.asarray(offsets, dtype=float).reshape(morphology.joint_count, 3)
    joints = tuple(dataclasses.replace(j, origin=Transform(tuple(map(float, o)), j.origin.quat))
                   for j, o in zip(morphology.joints, offsets, strict=True))
    ees = morphology.end_effectors
    if ee_offsets is not None:
        ee_offsets = np.asarray(ee_offsets, dtype=float).reshape(len(ees), 3)
        ees = tuple(dataclasses.replace(e, offset=tuple(map(float, o))) for e, o in zip(ees, ee_offsets, strict=True))
    return dataclasses.replace(morphology, joints=joints, end_effectors=ees, name=name or morphology.name,
                               declared_body_length=None)


def limb_groups(morphology: Morphology) -> tuple[dict[str, tuple[int, ...]], dict[str, tuple[int, ...]]]:
    """Joint and end-effector indices of each limb group (:data:`GROUPS`), found from end-effector roles.

    A joint used only by the chains to end-effectors of one group belongs to it, except the first such
    joint of each chain (where the limb attaches, e.g. root to hip), which stays in the trunk with
    every shared joint. Each end-effector's offset belongs to its role's group.

    Returns:
        ``(joints, end_effectors)``: group name → indices.
    """
    chains = morphology.end_effector_chains
    groups_of: dict[str, set[str]] = {}
    for ee in morphology.end_effectors:
        group = _ROLE_GROUP.get(ee.role)
        for name in chains[ee.name]:
            groups_of.setdefault(name, set()).add(group or "trunk")
    attach: set[str] = set()
    for ee in morphology.end_effectors:
        own = [n for n in chains[ee.name] if groups_of.get(n) == {_ROLE_GROUP.get(ee.role)}]
        if own and _ROLE_GROUP.get(ee.role) != "head":
            attach.add(own[0])
    joints: dict[str, list[int]] = {g: [] for g in GROUPS}
    for i, j in enumerate(morphology.joints):
        gs = groups_of.get(j.name, set())
        group = next(iter(gs)) if len(gs) == 1 and j.name not in attach else "trunk"
        joints[group].append(i)
    ees: dict[str, list[int]] = {g: [] for g in GROUPS}
    for i, e in enumerate(morphology.end_effectors):
        ees[_ROLE_GROUP.get(e.role, "trunk")].append(i)
    return {g: tuple(v) for g, v in joints.items()}, {g: tuple(v) for g, v in ees.items()}


def scale_limbs(morphology: Morphology, scales: Mapping[str, float], *, name: str | None = None) -> Morphology:
    """A bone-length variant: the offsets of each limb group multiplied by ``scales[group]`` (default 1).

    Raises:
        MotionFormatError: an unknown group or a scale that is not a positive number.
    """
    unknown = [g for g in scales if g not in GROUPS]
    if unknown:
        raise MotionFormatError(f"unknown limb group {unknown[0]!r}; expected one of: {', '.join(GROUPS)}")
    if any(not (float(s) > 0.0 and np.isfinite(float(s))) for s in scales.values()):
        raise MotionFormatError(f"limb scales must be positive, got {dict(scales)}")
    joint_groups, ee_groups = limb_groups(morphology)
    offsets = bone_offsets(morphology)
    ee_off = np.array([e.offset for e in morphology.end_effectors], dtype=float).reshape(-1, 3)
    for group, factor in scales.items():
        offsets[list(joint_groups[group])] *= float(factor)
        ee_off[list(ee_groups[group])] *= float(factor)
    label = "_".join(f"{g}{float(s):.2f}" for g, s in scales.items() if float(s) != 1.0) or "same"
    return with_offsets(morphology, offsets, ee_offsets=ee_off, name=name or f"{morphology.name}_{label}")


def random_variants(morphology: Morphology, count: int, *, spread: float = 0.3, seed: int = 0,
                    prefix: str | None = None) -> list[Morphology]:
    """``count`` variants with every limb group scaled by a factor drawn uniformly from [1 − spread, 1 + spread]."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        scales = {g: float(rng.uniform(1.0 - spread, 1.0 + spread)) for g in GROUPS}
        out.append(scale_limbs(morphology, scales, name=f"{prefix or morphology.name}_v{seed}_{i}"))
    return out


def twist_axes(morphology: Morphology) -> np.ndarray:
    """Unit bone axes ``a_j`` in each joint's frame, shape [J, 3]; zero rows for non-spherical joints.

    The bone of joint ``j`` runs from it to its child link's longest child joint offset; for a leaf
    link, to its farthest end-effector point, else along the joint's own offset (the bone that ends
    at it). The twist of ball joint ``j`` is its rotation about ``a_j`` (Eq. 15's ``euler_y``).
    """
    from morphkit.rotations import quat_rotate_inverse

    axes = np.zeros((morphology.joint_count, 3))
    for i, j in enumerate(morphology.joints):
        if j.type != JointType.SPHERICAL or morphology.is_driven(j):
            continue
        kids = [np.asarray(k.origin.xyz, float) for k in morphology.joints if k.parent == j.child]
        tips = [np.asarray(e.offset, float) for e in morphology.end_effectors if e.link == j.child]
        candidates: Sequence[np.ndarray] = kids or tips
        best = max(candidates, key=np.linalg.norm) if candidates else np.zeros(3)
        if np.linalg.norm(best) < 1e-9:
            best = quat_rotate_inverse(np.asarray(j.origin.quat, float), np.asarray(j.origin.xyz, float))
        norm = np.linalg.norm(best)
        if norm > 1e-9:
            axes[i] = best / norm
    return axes
