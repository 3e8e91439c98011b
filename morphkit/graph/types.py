"""Closed sets of the skeleton graph. Kernels see the explicit integer values."""

from __future__ import annotations

from enum import IntEnum

from morphkit.errors import DescriptionError, SourceLocation

__all__ = ["BaseType", "BodyLengthRule", "EndEffectorRole", "JointType", "ShapeType", "parse_enum"]


class JointType(IntEnum):
    """Joint between a parent and a child link."""

    FIXED = 0
    """Rigid attachment; 0 coordinates."""
    REVOLUTE = 1
    """Rotation about an axis within limits; 1 coordinate [rad]."""
    CONTINUOUS = 2
    """Rotation about an axis without limits (wheels); 1 coordinate [rad]."""
    PRISMATIC = 3
    """Translation along an axis within limits; 1 coordinate [m]."""
    SPHERICAL = 4
    """3-DoF ball joint; 4 coordinates (unit quaternion xyzw)."""


class BaseType(IntEnum):
    """How the root link moves in the world."""

    FIXED = 0
    """Root fixed at the world origin; 0 coordinates."""
    FLOATING = 1
    """6-DoF free root; 7 coordinates ``[x, y, z, qx, qy, qz, qw]``."""
    PLANAR = 2
    """Root moves in the ground plane; 3 coordinates ``[x, y, yaw]``."""
    WHEELED = 3
    """Differential-drive planar root; 3 coordinates ``[x, y, yaw]``, 2 DoF; wheel angles follow the motion."""


class ShapeType(IntEnum):
    """Geometry attached to a link (for contact, self-collision and rendering)."""

    SPHERE = 0
    """``radius`` [m]."""
    CAPSULE = 1
    """``radius`` and cylinder ``length`` [m] along the shape's local z."""
    BOX = 2
    """``size``: full extents [m]."""
    CYLINDER = 3
    """``radius`` and ``length`` [m] along the shape's local z."""
    MESH = 4
    """A mesh file with a per-axis ``scale``."""


class EndEffectorRole(IntEnum):
    """What an end-effector does; drives contact queries and cross-creature mapping."""

    FOOT = 0
    HAND = 1
    HEAD = 2
    TOOL = 3

    @property
    def on_arm(self) -> bool:
        """A hand or a tool: what an arm carries (synthesised as an arm, followed by a person's hands)."""
        return self in (EndEffectorRole.HAND, EndEffectorRole.TOOL)


class BodyLengthRule(IntEnum):
    """Which rule gave a creature's body length (see ``docs/concepts/body-length.md``)."""

    DECLARED = 0
    """Given by the description (YAML ``body_length:``) or by the caller."""
    STANCE = 1
    """Creatures with feet, upright at rest: the root's height above its lowest foot at rest."""
    STRAIGHT_LEGS = 2
    """Creatures with feet whose rest pose is not upright: the mean leg length, as if the legs hung straight."""
    MEASURED = 3
    """Creatures with feet, measured on their own motion: the root's standing height above its lowest foot."""
    HAND_REACH = 4
    """Creatures without feet: the highest point their hands reach, over :data:`~morphkit.graph.HUMAN_HAND_REACH`."""
    REST_EXTENT = 5
    """Neither feet nor hands: the rest pose's vertical extent."""


def parse_enum(cls: type[IntEnum], value: object, *, what: str, location: SourceLocation | None = None) -> IntEnum:
    """Read an enum member from its lower-case name (or pass a member through).

    Raises:
        DescriptionError: naming the unknown value and the valid choices.
    """
    if isinstance(value, cls):
        return value
    if isinstance(value, str):
        try:
            return cls[value.strip().upper()]
        except KeyError:
            pass
    choices = ", ".join(m.name.lower() for m in cls)
    raise DescriptionError(f"unknown {what} {value!r}; expected one of: {choices}", location=location)
