"""Bases that move without legs: wheeled and planar drives, gliding floating bases, fixed bases.

The paper (§7.1) assumes a wheeled robot "can walk with arbitrary speeds and directions using
low-level controllers": the root simply follows the commanded forward speed and yaw rate, and
sideways speed too where the base allows it (a planar base; a differential-drive wheeled base
cannot). Wheel joints have no coordinates of their own: the FK wheel-angle scan
(:func:`~morphkit.kernels.eval_wheel_angles`, used by :meth:`Motion.link_poses`) turns them so
they roll without slipping along the root path. A floating base without legs glides the same way
with its lowest rest point on the ground; a fixed base stays put and only moves its arms and other
joints.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from morphkit.graph import BaseType, Morphology
from morphkit.rotations import quat_from_yaw
from morphkit.synth.analysis import BodyPlan

__all__ = ["Locomotion", "base_coordinates", "glide_height", "locomotion_of"]


class Locomotion(Enum):
    """How a creature's root moves."""

    LEGGED = "legged"
    """Floating base carried by feet on the ground."""
    WHEELED = "wheeled"
    """Planar or wheeled base driven along the commands."""
    GLIDE = "glide"
    """Floating base without legs, sliding along the ground."""
    FIXED = "fixed"
    """Fixed base."""


def locomotion_of(m: Morphology, plan: BodyPlan) -> Locomotion:
    """The locomotion mode of a creature."""
    if m.base == BaseType.FIXED:
        return Locomotion.FIXED
    if m.base in (BaseType.PLANAR, BaseType.WHEELED):
        return Locomotion.WHEELED
    return Locomotion.LEGGED if plan.legs else Locomotion.GLIDE


def lateral_allowed(m: Morphology) -> bool:
    """Whether the base can move sideways (floating and planar; not wheeled, not fixed)."""
    return m.base in (BaseType.FLOATING, BaseType.PLANAR)


def glide_height(m: Morphology) -> float:
    """Root height [m] that puts a creature's lowest rest point (link origin or end-effector) on the ground."""
    return float(-m.rest_points()[:, 2].min())


def base_coordinates(m: Morphology, xy: np.ndarray, yaw: np.ndarray, z: np.ndarray | None = None,
                     quat: np.ndarray | None = None) -> np.ndarray:
    """Base coordinates [R, base_coordinate_count] of root poses.

    Args:
        m: The creature.
        xy: Root positions [R, 2] [m].
        yaw: Root yaw [R] [rad].
        z: Root heights [R] [m] (floating bases; default 0).
        quat: Root orientations [R, 4] xyzw (floating bases; default the yaw rotation).
    """
    R = len(yaw)
    if m.base == BaseType.FLOATING:
        out = np.empty((R, 7))
        out[:, :2] = xy
        out[:, 2] = 0.0 if z is None else z
        out[:, 3:] = quat_from_yaw(yaw) if quat is None else quat
        return out
    if m.base in (BaseType.PLANAR, BaseType.WHEELED):
        return np.stack([xy[:, 0], xy[:, 1], yaw], axis=1)
    return np.zeros((R, 0))
