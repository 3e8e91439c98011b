"""Plain frozen dataclasses that make up a :class:`~morphkit.graph.Morphology`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from morphkit.conventions import quat_from_rpy, rpy_from_quat
from morphkit.errors import SourceLocation
from morphkit.graph.types import EndEffectorRole, JointType, ShapeType

__all__ = ["WHEEL_DRIVES", "EndEffector", "Joint", "Limit", "Link", "Mimic", "Shape", "Transform", "Wheels"]

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Transform:
    """A rigid transform: translation [m] then rotation (xyzw quaternion)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    """Translation [m]."""
    quat: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    """Rotation, unit quaternion xyzw."""

    @staticmethod
    def from_xyz_rpy(xyz: Vec3 = (0.0, 0.0, 0.0), rpy: Vec3 = (0.0, 0.0, 0.0)) -> Transform:
        """Build from a translation and fixed-axis roll, pitch, yaw [rad]."""
        q = quat_from_rpy(np.asarray(rpy, dtype=float))
        return Transform(tuple(float(v) for v in xyz), tuple(float(v) for v in q))  # type: ignore[arg-type]

    @property
    def rpy(self) -> Vec3:
        """Fixed-axis roll, pitch, yaw [rad]."""
        return tuple(float(v) for v in rpy_from_quat(np.asarray(self.quat)))  # type: ignore[return-value]

    def as_array(self) -> np.ndarray:
        """``[px, py, pz, qx, qy, qz, qw]``, shape [7]."""
        return np.array([*self.xyz, *self.quat], dtype=float)

    def is_identity(self, tol: float = 1e-12) -> bool:
        """Whether this is the identity transform (within ``tol``)."""
        q = np.asarray(self.quat)
        return bool(np.abs(self.xyz).max() <= tol and np.abs(np.abs(q[3]) - 1.0) <= tol)


IDENTITY = Transform()


@dataclass(frozen=True)
class Limit:
    """Joint range [rad or m]."""

    lower: float
    upper: float
    velocity: float | None = None
    """Speed limit [rad/s or m/s], informative only."""
    effort: float | None = None
    """Effort limit [N·m or N], informative only."""


@dataclass(frozen=True)
class Mimic:
    """A joint that follows another: ``q = multiplier * q[joint] + offset``."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Shape:
    """Geometry attached to a link, posed by ``origin`` in the link frame."""

    type: ShapeType
    origin: Transform = IDENTITY
    radius: float = 0.0
    """Sphere, capsule, cylinder radius [m]."""
    length: float = 0.0
    """Capsule/cylinder length along local z [m] (capsule: without the caps)."""
    size: Vec3 = (0.0, 0.0, 0.0)
    """Box full extents [m]."""
    mesh: str | None = None
    """Mesh file path (as written in the description)."""
    scale: Vec3 = (1.0, 1.0, 1.0)
    """Mesh scale per axis."""


@dataclass(frozen=True)
class Link:
    """A rigid body of the creature."""

    name: str
    shapes: tuple[Shape, ...] = ()
    location: SourceLocation | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class Joint:
    """Connects ``parent`` to ``child``; ``origin`` is the child joint frame in the parent link frame."""

    name: str
    type: JointType
    parent: str
    child: str
    origin: Transform = IDENTITY
    axis: Vec3 = (1.0, 0.0, 0.0)
    """Unit axis in the joint frame (revolute, continuous, prismatic)."""
    limit: Limit | None = None
    mimic: Mimic | None = None
    location: SourceLocation | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class EndEffector:
    """A named point on a link: feet, hands, head, tools."""

    name: str
    link: str
    offset: Vec3 = (0.0, 0.0, 0.0)
    """Position in the link frame [m]."""
    role: EndEffectorRole = EndEffectorRole.TOOL
    location: SourceLocation | None = field(default=None, compare=False, repr=False)
    reason: str = field(default="", compare=False, repr=False)
    """Why a reader guessed this point, where the description did not name it (empty: declared)."""


WHEEL_DRIVES = ("differential", "skid_steer", "ackermann", "holonomic")
"""How a wheeled base may move: differential and skid-steer go forward and turn (no sideways motion; skid-steer
slips its wheels sideways to turn), Ackermann goes forward and turns no tighter than its steering allows (no
turning in place), holonomic (powered casters, omni or mecanum wheels) also moves sideways."""


@dataclass(frozen=True)
class Wheels:
    """Wheels of a wheeled base: joints that the base's path turns, steers or swivels.

    The root frame is the drive's reference point on the ground (the driven axle's middle for differential and
    Ackermann drives, the wheels' centre otherwise); its planar path ``[x, y, yaw]`` decides every wheel angle.
    """

    joints: tuple[str, ...]
    """Continuous joints of wheels on fixed axles, turned by the base motion (no coordinates of their own)."""
    radius: float
    """Wheel radius [m]."""
    drive: str = "differential"
    """One of :data:`WHEEL_DRIVES`."""
    steering: tuple[str, ...] = ()
    """Vertical steering or caster swivel joints; their angles follow the base's path (they keep coordinates)."""
    steered: tuple[str, ...] = ()
    """Continuous joints of the wheels the steering joints carry; their angles follow the base's path too."""
    steered_radii: tuple[float, ...] = ()
    """Radius of each steered wheel [m] (empty: all :attr:`radius`)."""
    max_steer: float | None = None
    """Largest steering angle of an Ackermann drive's inner wheel [rad] (``None``: no steering limit)."""
    reason: str = field(default="", compare=False)
    """How the wheels were found (empty: declared by the description)."""

    @property
    def all_joints(self) -> tuple[str, ...]:
        """Every wheel joint: rolling on fixed axles, steering, and rolling under steering."""
        return self.joints + self.steering + self.steered
