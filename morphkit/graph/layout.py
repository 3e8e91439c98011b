"""Coordinate and DoF widths per joint and base type (the q-layout; see docs/design/q-layout.md)."""

from __future__ import annotations

from morphkit.graph.types import BaseType, JointType

__all__ = ["BASE_COORD_NAMES", "BASE_COORD_WIDTH", "BASE_DOF_WIDTH", "JOINT_COORD_WIDTH", "JOINT_DOF_WIDTH"]

JOINT_COORD_WIDTH: dict[JointType, int] = {
    JointType.FIXED: 0,
    JointType.REVOLUTE: 1,
    JointType.CONTINUOUS: 1,
    JointType.PRISMATIC: 1,
    JointType.SPHERICAL: 4,
}
"""Number of entries a joint occupies in ``q`` (spherical: quaternion xyzw)."""

JOINT_DOF_WIDTH: dict[JointType, int] = {
    JointType.FIXED: 0,
    JointType.REVOLUTE: 1,
    JointType.CONTINUOUS: 1,
    JointType.PRISMATIC: 1,
    JointType.SPHERICAL: 3,
}
"""Number of independent velocity DoFs of a joint."""

BASE_COORD_WIDTH: dict[BaseType, int] = {
    BaseType.FIXED: 0,
    BaseType.FLOATING: 7,
    BaseType.PLANAR: 3,
    BaseType.WHEELED: 3,
}
"""Number of entries the base occupies at the start of ``q``."""

BASE_DOF_WIDTH: dict[BaseType, int] = {
    BaseType.FIXED: 0,
    BaseType.FLOATING: 6,
    BaseType.PLANAR: 3,
    BaseType.WHEELED: 2,
}
"""Base DoFs (wheeled: forward speed and yaw rate)."""

BASE_COORD_NAMES: dict[BaseType, tuple[str, ...]] = {
    BaseType.FIXED: (),
    BaseType.FLOATING: ("base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw"),
    BaseType.PLANAR: ("base_x", "base_y", "base_yaw"),
    BaseType.WHEELED: ("base_x", "base_y", "base_yaw"),
}
