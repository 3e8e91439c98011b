"""What a creature's body offers for locomotion, read from its graph alone.

Legs are the chains from the root that end in ``foot`` end-effectors, arms those ending in
``hand`` or ``tool`` end-effectors; a limb is the part of that chain no other end-effector shares
(so a human's leg starts at the hip, not at the pelvis). Works for any count and placement of
limbs, asymmetric ones included.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from morphkit.conventions import transform_multiply
from morphkit.graph import BaseType, EndEffectorRole, Morphology

__all__ = ["BodyPlan", "Limb", "analyse"]


@dataclass(frozen=True)
class Limb:
    """One leg or arm: the joints only this end-effector's chain uses."""

    end_effector: str
    """End-effector name at the tip."""
    role: EndEffectorRole
    joints: tuple[str, ...]
    """Joint names from the limb's first joint to the tip link (driven and fixed included)."""
    coordinates: tuple[int, ...]
    """Indices in ``q`` that move this limb."""
    mount_link: str
    """Link the limb hangs from (the parent of its first joint)."""
    mount_rest: tuple[float, float, float]
    """Mount point (the first joint's origin) at rest in the root frame [m]."""
    tip_rest: tuple[float, float, float]
    """End-effector position at rest in the root frame [m]."""
    reach: float
    """Sum of segment lengths from the mount to the tip [m]."""


@dataclass(frozen=True)
class BodyPlan:
    """Legs, arms, head and wheels of a creature, with its rest geometry."""

    legs: tuple[Limb, ...]
    arms: tuple[Limb, ...]
    head: str | None
    """Head end-effector name, if any."""
    wheeled: bool
    """Whether the base drives on wheels (any planar or wheeled base)."""
    body_height: float
    """Height of the root above the lowest foot at rest [m] (0 without legs)."""
    leg_reach: float
    """Mean leg reach [m] (0 without legs)."""


def _rest_points(m: Morphology) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    poses = m.rest_link_poses()
    ee = {}
    for e in m.end_effectors:
        T = poses[m.link_index(e.link)]
        ee[e.name] = transform_multiply(T, np.array([*e.offset, 0, 0, 0, 1]))[:3]
    return poses, ee


def analyse(m: Morphology) -> BodyPlan:
    """Find legs, arms, head and wheels of ``m`` and measure its rest stance."""
    poses, ee_pos = _rest_points(m)
    chains = m.end_effector_chains
    use_count: dict[str, int] = {}
    for chain in chains.values():
        for j in set(chain):
            use_count[j] = use_count.get(j, 0) + 1
    legs: list[Limb] = []
    arms: list[Limb] = []
    for e in m.end_effectors:
        if e.role != EndEffectorRole.FOOT and not e.role.on_arm:
            continue
        chain = chains[e.name]
        own = [j for j in chain if use_count[j] == 1 and j not in m.wheel_joints]
        if not own:
            continue
        first = m.joint(own[0])
        coords = []
        for name in own:
            ji = m.joint_index(name)
            coords.extend(range(m.joint_q_start[ji], m.joint_q_start[ji + 1]))
        mount = poses[m.link_index(first.child)][:3]
        pts = [mount] + [poses[m.link_index(m.joint(n).child)][:3] for n in own[1:]] + [ee_pos[e.name]]
        reach = float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(pts)))
        limb = Limb(
            end_effector=e.name,
            role=e.role,
            joints=tuple(own),
            coordinates=tuple(coords),
            mount_link=first.parent,
            mount_rest=tuple(float(v) for v in mount),  # type: ignore[arg-type]
            tip_rest=tuple(float(v) for v in ee_pos[e.name]),  # type: ignore[arg-type]
            reach=reach,
        )
        (legs if e.role == EndEffectorRole.FOOT else arms).append(limb)
    heads = m.ee_by_role(EndEffectorRole.HEAD)
    body_height = float(-min(leg.tip_rest[2] for leg in legs)) if legs else 0.0
    return BodyPlan(
        legs=tuple(legs),
        arms=tuple(arms),
        head=heads[0].name if heads else None,
        wheeled=m.base in (BaseType.WHEELED, BaseType.PLANAR),
        body_height=body_height,
        leg_reach=float(np.mean([leg.reach for leg in legs])) if legs else 0.0,
    )
