"""The skeleton graph every description becomes."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from morphkit.conventions import quat_from_axis_angle, transform_multiply
from morphkit.errors import GraphError
from morphkit.graph.elements import EndEffector, Joint, Link, Wheels
from morphkit.graph.layout import (
    BASE_COORD_NAMES,
    BASE_COORD_WIDTH,
    BASE_DOF_WIDTH,
    JOINT_COORD_WIDTH,
    JOINT_DOF_WIDTH,
)
from morphkit.graph.types import BaseType, EndEffectorRole, JointType

__all__ = ["Morphology"]


@dataclass(frozen=True)
class Morphology:
    """A creature's kinematic tree, built and validated by :class:`~morphkit.graph.MorphologyBuilder`.

    Invariants (established by the builder): ``links[0]`` is the root; ``joints`` are in
    depth-first topological order and ``links[j + 1]`` is the child of ``joints[j]``.

    The coordinate vector ``q`` of a pose is ``[base coordinates, joint coordinates]``: the
    base's coordinates first (floating 7, planar 3, wheeled 3, fixed 0), then each
    independent joint's coordinates in joint order (revolute, continuous, prismatic 1;
    spherical 4 as xyzw; fixed 0). Mimic joints and wheel joints have no coordinates of their
    own: their values follow other coordinates.
    """

    name: str
    base: BaseType
    root: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    end_effectors: tuple[EndEffector, ...] = ()
    wheels: Wheels | None = None
    source: str | None = None
    """Path of the description this was read from, if any."""

    # ---- lookups ---------------------------------------------------------------------------
    @property
    def link_count(self) -> int:
        return len(self.links)

    @property
    def joint_count(self) -> int:
        return len(self.joints)

    @cached_property
    def link_names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @cached_property
    def _link_index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.link_names)}

    @cached_property
    def _joint_index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.joint_names)}

    def link_index(self, name: str) -> int:
        """Index of link ``name`` in :attr:`links`."""
        try:
            return self._link_index[name]
        except KeyError:
            raise GraphError(f"no link {name!r} (links: {', '.join(self.link_names)})") from None

    def joint_index(self, name: str) -> int:
        """Index of joint ``name`` in :attr:`joints`."""
        try:
            return self._joint_index[name]
        except KeyError:
            raise GraphError(f"no joint {name!r} (joints: {', '.join(self.joint_names)})") from None

    def link(self, name: str) -> Link:
        return self.links[self.link_index(name)]

    def joint(self, name: str) -> Joint:
        return self.joints[self.joint_index(name)]

    def end_effector(self, name: str) -> EndEffector:
        for ee in self.end_effectors:
            if ee.name == name:
                return ee
        names = ", ".join(e.name for e in self.end_effectors)
        raise GraphError(f"no end-effector {name!r} (end-effectors: {names})")

    def parent_joint(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (``None`` for the root)."""
        i = self.link_index(link)
        return None if i == 0 else self.joints[i - 1]

    @cached_property
    def link_parent(self) -> tuple[int, ...]:
        """Parent link index of every link (-1 for the root), shape [link_count]."""
        return (-1, *(self.link_index(j.parent) for j in self.joints))

    def children(self, link: str) -> tuple[str, ...]:
        """Child links of ``link``, in joint order."""
        return tuple(j.child for j in self.joints if j.parent == link)

    def ee_by_role(self, role: EndEffectorRole) -> tuple[EndEffector, ...]:
        return tuple(e for e in self.end_effectors if e.role == role)

    # ---- coordinate and DoF layout ---------------------------------------------------------
    @cached_property
    def wheel_joints(self) -> frozenset[str]:
        return frozenset(self.wheels.joints) if self.wheels is not None else frozenset()

    def is_driven(self, joint: Joint) -> bool:
        """Whether a joint's value follows others (mimic joints and wheels)."""
        return joint.mimic is not None or joint.name in self.wheel_joints

    @cached_property
    def base_coordinate_count(self) -> int:
        return BASE_COORD_WIDTH[self.base]

    @cached_property
    def base_dof(self) -> int:
        return BASE_DOF_WIDTH[self.base]

    @cached_property
    def joint_q_start(self) -> tuple[int, ...]:
        """Start of each joint's coordinates in ``q``, shape [joint_count + 1] (last = coordinate_count)."""
        starts = [self.base_coordinate_count]
        for j in self.joints:
            starts.append(starts[-1] + (0 if self.is_driven(j) else JOINT_COORD_WIDTH[j.type]))
        return tuple(starts)

    @cached_property
    def joint_qd_start(self) -> tuple[int, ...]:
        """Start of each joint's DoFs in ``qd``, shape [joint_count + 1] (last = base_dof + dof)."""
        starts = [self.base_dof]
        for j in self.joints:
            starts.append(starts[-1] + (0 if self.is_driven(j) else JOINT_DOF_WIDTH[j.type]))
        return tuple(starts)

    @property
    def coordinate_count(self) -> int:
        """Length of ``q``, base coordinates included."""
        return self.joint_q_start[-1]

    @property
    def dof(self) -> int:
        """Independent joint DoFs, without the base and without driven joints (mimic, wheels)."""
        return self.joint_qd_start[-1] - self.base_dof

    @cached_property
    def coordinate_names(self) -> tuple[str, ...]:
        """Name of every entry of ``q``, shape [coordinate_count]."""
        names = list(BASE_COORD_NAMES[self.base])
        for j in self.joints:
            if self.is_driven(j):
                continue
            if j.type == JointType.SPHERICAL:
                names += [f"{j.name}.{c}" for c in ("qx", "qy", "qz", "qw")]
            elif JOINT_COORD_WIDTH[j.type] == 1:
                names.append(j.name)
        return tuple(names)

    @cached_property
    def coordinate_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bound of every entry of ``q`` (±inf where unbounded), each shape [coordinate_count]."""
        lower = np.full(self.coordinate_count, -np.inf)
        upper = np.full(self.coordinate_count, np.inf)
        for j, start in zip(self.joints, self.joint_q_start[:-1], strict=True):
            if self.is_driven(j):
                continue
            if j.type == JointType.SPHERICAL:
                lower[start : start + 4] = -1.0
                upper[start : start + 4] = 1.0
            elif j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
                lower[start], upper[start] = j.limit.lower, j.limit.upper
        return lower, upper

    def rest_q(self) -> np.ndarray:
        """The rest pose: base at the origin, identity rotations, joints at 0 clamped into their limits."""
        q = np.zeros(self.coordinate_count)
        if self.base == BaseType.FLOATING:
            q[6] = 1.0
        for j, start in zip(self.joints, self.joint_q_start[:-1], strict=True):
            if j.type == JointType.SPHERICAL and not self.is_driven(j):
                q[start + 3] = 1.0
        lower, upper = self.coordinate_limits
        return np.clip(q, lower, upper)

    # ---- chains and geometry ---------------------------------------------------------------
    def chain(self, link: str) -> tuple[str, ...]:
        """Joint names from the root down to ``link``."""
        names: list[str] = []
        i = self.link_index(link)
        while i > 0:
            names.append(self.joints[i - 1].name)
            i = self.link_parent[i]
        return tuple(reversed(names))

    @cached_property
    def end_effector_chains(self) -> dict[str, tuple[str, ...]]:
        """Joint names from the root to each end-effector's link."""
        return {ee.name: self.chain(ee.link) for ee in self.end_effectors}

    def rest_link_poses(self) -> np.ndarray:
        """Link poses ``T_world_link`` at :meth:`rest_q`, shape [link_count, 7] (NumPy, for queries only)."""
        q = self.rest_q()
        value = np.zeros(self.joint_count)  # 1-DoF joint values; mimic joints follow their target
        for ji, j in enumerate(self.joints):
            if not self.is_driven(j) and j.type in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
                value[ji] = q[self.joint_q_start[ji]]
        for ji, j in enumerate(self.joints):
            if j.mimic is not None:
                value[ji] = j.mimic.multiplier * value[self.joint_index(j.mimic.joint)] + j.mimic.offset
        poses = np.zeros((self.link_count, 7))
        poses[0, 6] = 1.0
        for ji, j in enumerate(self.joints):
            local = j.origin.as_array()
            if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
                motion = np.array([0, 0, 0, *quat_from_axis_angle(np.asarray(j.axis), value[ji])])
                local = transform_multiply(local, motion)
            elif j.type == JointType.PRISMATIC:
                local = transform_multiply(local, np.array([*(value[ji] * np.asarray(j.axis)), 0, 0, 0, 1]))
            poses[ji + 1] = transform_multiply(poses[self.link_parent[ji + 1]], local)
        return poses

    def rest_points(self) -> np.ndarray:
        """Link origins and end-effector points at rest, shape [link_count + ee_count, 3] [m]."""
        poses = self.rest_link_poses()
        pts = [poses[:, :3]]
        for ee in self.end_effectors:
            T = poses[self.link_index(ee.link)]
            pts.append(transform_multiply(T, np.array([*ee.offset, 0, 0, 0, 1]))[None, :3])
        return np.concatenate(pts, axis=0)

    @cached_property
    def characteristic_length(self) -> float:
        """A body length [m] for normalising features: the rest pose's height.

        Height is the vertical extent of the link origins and end-effector points at rest; where
        that is degenerate (a creature lying flat) the largest extent along any axis is used, and
        1.0 for a single point.
        """
        pts = self.rest_points()
        extent = pts.max(axis=0) - pts.min(axis=0)
        if extent[2] > 1e-6:
            return float(extent[2])
        if extent.max() > 1e-6:
            return float(extent.max())
        return 1.0
