"""Incremental construction of a :class:`Morphology`; every reader goes through here."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Sequence

import numpy as np

from morphkit.errors import GraphError, SourceLocation
from morphkit.graph.elements import (
    IDENTITY,
    WHEEL_DRIVES,
    EndEffector,
    Joint,
    Limit,
    Link,
    Mimic,
    Shape,
    Transform,
    Wheels,
)
from morphkit.graph.morphology import Morphology
from morphkit.graph.types import BaseType, EndEffectorRole, JointType, ShapeType, parse_enum

__all__ = ["MAX_LIMIT", "MorphologyBuilder"]

MAX_LIMIT = 1e6
"""Largest magnitude [rad or m] of a revolute or prismatic joint's limit. Samplers draw joint values uniformly
between the limits (a width of 2e308 overflows) and poses at 10⁶ m or 10⁶ rad mean nothing; an unlimited turn is
a continuous joint, and a revolute joint whose limits lie beyond the bound on both sides is read as one (with a
warning)."""


def _finite(values: Iterable[float], what: str, location: SourceLocation | None) -> tuple[float, ...]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise GraphError(f"{what}: expected a number, got {v!r}", location=location)
        if not math.isfinite(float(v)):
            raise GraphError(f"{what}: non-finite number {v!r}", location=location)
        out.append(float(v))
    return tuple(out)


def _vec(values: Sequence[float], n: int, what: str, location: SourceLocation | None) -> tuple[float, ...]:
    if isinstance(values, (str, bytes)) or not isinstance(values, (Sequence, np.ndarray)) or len(values) != n:
        raise GraphError(f"{what}: expected {n} numbers, got {values!r}", location=location)
    return _finite(values, what, location)


class MorphologyBuilder:
    """Collects links, joints and end-effectors, then validates them into a :class:`Morphology`.

    Element errors (bad numbers, duplicate names, unknown enums) are raised as they are added;
    structural errors (missing links, two parents, cycles, disconnected links) by :meth:`build`.
    Every error carries the ``location`` given for the element.

    Args:
        name: Creature name.
        source: Path of the description being read, if any (used in error locations).
    """

    def __init__(self, name: str, *, source: str | None = None) -> None:
        self.name = name
        self.source = source
        self.base = BaseType.FLOATING
        self.root: str | None = None
        self._root_location: SourceLocation | None = None
        self._links: dict[str, Link] = {}
        self._joints: dict[str, Joint] = {}
        self._ees: dict[str, EndEffector] = {}
        self._wheels: Wheels | None = None
        self._wheels_location: SourceLocation | None = None
        self._body_length: float | None = None
        self._rest_pose: dict[str, float] = {}
        self._rest_location: SourceLocation | None = None
        self._excludes: list[tuple[str, str]] = []

    def _loc(self, location: SourceLocation | None) -> SourceLocation | None:
        return location if location is not None else (SourceLocation(self.source) if self.source else None)

    # ---- base and root ---------------------------------------------------------------------
    def set_base(self, base: BaseType | str, *, location: SourceLocation | None = None) -> None:
        """Set how the root moves (floating by default)."""
        self.base = parse_enum(BaseType, base, what="base type", location=self._loc(location))  # type: ignore[assignment]

    def set_root(self, link: str, *, location: SourceLocation | None = None) -> None:
        """Name the root link (by default, the one link without a parent)."""
        self.root = link
        self._root_location = self._loc(location)

    def set_body_length(self, length: float, *, location: SourceLocation | None = None) -> None:
        """Declare the body length [m] features are normalised by (overrides :attr:`Morphology.body_length`'s rule)."""
        loc = self._loc(location)
        (value,) = _finite([length], "body length", loc)
        if value <= 0:
            raise GraphError(f"body length must be > 0 [m], got {value}", location=loc)
        self._body_length = value

    # ---- links and shapes ------------------------------------------------------------------
    def add_link(self, name: str, *, shapes: Sequence[Shape] = (), location: SourceLocation | None = None) -> int:
        """Add a link; returns its insertion index."""
        loc = self._loc(location)
        if not isinstance(name, str) or not name:
            raise GraphError(f"link name must be a non-empty string, got {name!r}", location=loc)
        if name in self._links:
            raise GraphError(f"duplicate link name {name!r}", location=loc)
        for s in shapes:
            self._check_shape(s, name, loc)
        self._links[name] = Link(name, tuple(shapes), loc)
        return len(self._links) - 1

    def add_shape(self, link: str, shape: Shape, *, location: SourceLocation | None = None) -> None:
        """Attach one more shape to an existing link."""
        loc = self._loc(location)
        if link not in self._links:
            raise GraphError(f"shape on unknown link {link!r}", location=loc)
        self._check_shape(shape, link, loc)
        old = self._links[link]
        self._links[link] = Link(old.name, (*old.shapes, shape), old.location)

    def _check_shape(self, s: Shape, link: str, loc: SourceLocation | None) -> None:
        what = f"link {link!r} {s.type.name.lower()} shape"
        _vec(s.origin.xyz, 3, f"{what} origin", loc)
        _vec(s.origin.quat, 4, f"{what} origin rotation", loc)
        if s.type in (ShapeType.SPHERE, ShapeType.CAPSULE, ShapeType.CYLINDER):
            (r,) = _finite([s.radius], f"{what} radius", loc)
            if r <= 0:
                raise GraphError(f"{what}: radius must be > 0, got {r}", location=loc)
        if s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
            (length,) = _finite([s.length], f"{what} length", loc)
            if length < 0 or (s.type == ShapeType.CYLINDER and length == 0):
                raise GraphError(f"{what}: length must be > 0, got {length}", location=loc)
        if s.type == ShapeType.BOX and min(_vec(s.size, 3, f"{what} size", loc)) <= 0:
            raise GraphError(f"{what}: size must be 3 positive extents, got {list(s.size)}", location=loc)
        if s.type == ShapeType.MESH:
            if not s.mesh:
                raise GraphError(f"{what}: needs a mesh file", location=loc)
            # A negative factor mirrors the mesh (vendors ship one side's mesh for both: Talos, TIAGo Pro,
            # Centauro), as Pinocchio, pybullet and MuJoCo read it; only a zero one collapses it.
            if min(abs(v) for v in _vec(s.scale, 3, f"{what} scale", loc)) <= 0:
                raise GraphError(f"{what}: scale must be non-zero on every axis, got {list(s.scale)}", location=loc)

    # ---- joints ----------------------------------------------------------------------------
    def add_joint(
        self,
        name: str,
        type: JointType | str,
        parent: str,
        child: str,
        *,
        origin: Transform = IDENTITY,
        axis: Sequence[float] = (1.0, 0.0, 0.0),
        limit: Limit | None = None,
        mimic: Mimic | None = None,
        location: SourceLocation | None = None,
    ) -> int:
        """Add a joint of any type; returns its insertion index.

        ``axis`` is normalised; it must be non-zero for revolute, continuous and prismatic joints.
        Revolute and prismatic joints need a ``limit`` with ``lower <= upper``.
        """
        loc = self._loc(location)
        jtype = parse_enum(JointType, type, what="joint type", location=loc)
        if not isinstance(name, str) or not name:
            raise GraphError(f"joint name must be a non-empty string, got {name!r}", location=loc)
        if name in self._joints:
            raise GraphError(f"duplicate joint name {name!r}", location=loc)
        for what, v in (("parent", parent), ("child", child)):
            if not isinstance(v, str) or not v:
                raise GraphError(f"joint {name!r}: {what} must be a link name, got {v!r}", location=loc)
        if parent == child:
            raise GraphError(f"joint {name!r}: parent and child are the same link {parent!r}", location=loc)
        xyz = _vec(origin.xyz, 3, f"joint {name!r} origin xyz", loc)
        quat = np.asarray(_vec(origin.quat, 4, f"joint {name!r} origin rotation", loc))
        qn = float(np.linalg.norm(quat))
        if qn < 1e-9:
            raise GraphError(f"joint {name!r}: zero origin rotation quaternion", location=loc)
        origin = Transform(xyz, tuple(float(v) for v in quat / qn))  # type: ignore[arg-type]
        a = np.asarray(_vec(axis, 3, f"joint {name!r} axis", loc))
        norm = float(np.linalg.norm(a))
        if jtype in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            if norm < 1e-9:
                raise GraphError(f"joint {name!r}: zero axis {list(axis)}", location=loc)
            a = a / norm
        elif norm > 1e-9:
            a = a / norm
        else:
            a = np.array([1.0, 0.0, 0.0])
        if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            if limit is None:
                hint = " (use type continuous for an unlimited revolute joint)" if jtype == JointType.REVOLUTE else ""
                raise GraphError(f"joint {name!r}: {jtype.name.lower()} joint needs a limit{hint}", location=loc)
        if limit is not None:
            lo, hi = _finite([limit.lower, limit.upper], f"joint {name!r} limit", loc)
            if lo > hi:
                raise GraphError(f"joint {name!r}: limit lower {lo} > upper {hi}", location=loc)
            if jtype == JointType.REVOLUTE and lo < -MAX_LIMIT and hi > MAX_LIMIT:
                # Vendor files write an unlimited hinge so (example-robot-data's iris: ±1e16); Pinocchio and
                # MuJoCo read it as one that turns freely.
                warnings.warn(f"{loc or 'description'}: joint {name!r}: limit [{lo:g}, {hi:g}] beyond ±{MAX_LIMIT:g} "
                              "rad read as unlimited (a continuous joint)", stacklevel=3)
                jtype = JointType.CONTINUOUS
            elif jtype in (JointType.REVOLUTE, JointType.PRISMATIC) and max(-lo, hi) > MAX_LIMIT:
                hint = "; use type continuous for an unlimited revolute joint" if jtype == JointType.REVOLUTE else ""
                raise GraphError(f"joint {name!r}: limit [{lo:g}, {hi:g}] beyond ±{MAX_LIMIT:g} (rad or m){hint}",
                                 location=loc)
            extra = [v for v in (limit.velocity, limit.effort) if v is not None]
            _finite(extra, f"joint {name!r} limit", loc)
            limit = Limit(lo, hi, limit.velocity, limit.effort)
            if jtype in (JointType.FIXED, JointType.CONTINUOUS, JointType.SPHERICAL):
                limit = None
        if mimic is not None:
            _finite([mimic.multiplier, mimic.offset], f"joint {name!r} mimic", loc)
        self._joints[name] = Joint(name, jtype, parent, child, origin, tuple(a), limit, mimic, loc)  # type: ignore[arg-type]
        return len(self._joints) - 1

    def add_joint_fixed(self, name: str, parent: str, child: str, **kw: object) -> int:
        return self.add_joint(name, JointType.FIXED, parent, child, **kw)  # type: ignore[arg-type]

    def add_joint_revolute(self, name: str, parent: str, child: str, **kw: object) -> int:
        return self.add_joint(name, JointType.REVOLUTE, parent, child, **kw)  # type: ignore[arg-type]

    def add_joint_continuous(self, name: str, parent: str, child: str, **kw: object) -> int:
        return self.add_joint(name, JointType.CONTINUOUS, parent, child, **kw)  # type: ignore[arg-type]

    def add_joint_prismatic(self, name: str, parent: str, child: str, **kw: object) -> int:
        return self.add_joint(name, JointType.PRISMATIC, parent, child, **kw)  # type: ignore[arg-type]

    def add_joint_spherical(self, name: str, parent: str, child: str, **kw: object) -> int:
        return self.add_joint(name, JointType.SPHERICAL, parent, child, **kw)  # type: ignore[arg-type]

    def set_rest_pose(self, values: dict[str, float], *, location: SourceLocation | None = None) -> None:
        """Set the rest values [rad or m] of 1-DoF joints (others rest at 0): a keyframe or a found stance."""
        loc = self._loc(location)
        names = list(values)
        self._rest_pose = dict(zip(names, _finite([values[n] for n in names], "rest pose", loc), strict=True))
        self._rest_location = loc

    def exclude_collision(self, link_a: str, link_b: str) -> None:
        """Never check the pair ``link_a``–``link_b`` for self-collision (MJCF ``<contact><exclude>``)."""
        self._excludes.append((link_a, link_b))

    # ---- end-effectors and wheels ----------------------------------------------------------
    def add_end_effector(
        self,
        name: str,
        link: str,
        *,
        offset: Sequence[float] = (0.0, 0.0, 0.0),
        role: EndEffectorRole | str = EndEffectorRole.TOOL,
        location: SourceLocation | None = None,
    ) -> int:
        """Add a named point on ``link`` at ``offset`` [m] (link frame)."""
        loc = self._loc(location)
        r = parse_enum(EndEffectorRole, role, what="end-effector role", location=loc)
        if not isinstance(name, str) or not name:
            raise GraphError(f"end-effector name must be a non-empty string, got {name!r}", location=loc)
        if name in self._ees:
            raise GraphError(f"duplicate end-effector name {name!r}", location=loc)
        off = _vec(offset, 3, f"end-effector {name!r} offset", loc)
        self._ees[name] = EndEffector(name, link, off, r, loc)  # type: ignore[arg-type]
        return len(self._ees) - 1

    def set_wheels(self, joints: Sequence[str], radius: float, *, drive: str = "differential",
                   steering: Sequence[str] = (), steered: Sequence[str] = (), steered_radii: Sequence[float] = (),
                   max_steer: float | None = None, location: SourceLocation | None = None) -> None:
        """Name the wheels of a wheeled base: rolling joints on fixed axles, their radius [m], the drive (one of
        :data:`~morphkit.graph.elements.WHEEL_DRIVES`), steering or swivel joints and the rolling joints they
        carry and their radii [m], and an Ackermann drive's largest steering angle [rad]."""
        loc = self._loc(location)
        (r,) = _finite([radius], "wheel radius", loc)
        if r <= 0:
            raise GraphError(f"wheel radius must be > 0, got {r}", location=loc)
        for what, names in (("joints", joints), ("steering", steering), ("steered", steered)):
            if isinstance(names, str) or not all(isinstance(j, str) for j in names):
                raise GraphError(f"wheels: {what} must be a list of joint names, got {names!r}", location=loc)
        radii = _finite(list(steered_radii), "wheels steered_radii", loc) if len(steered_radii) else []
        if radii and (len(radii) != len(steered) or min(radii) <= 0):
            raise GraphError(f"wheels: steered_radii must give one radius > 0 per steered wheel, got {list(radii)}",
                             location=loc)
        if drive not in WHEEL_DRIVES:
            raise GraphError(f"wheels: drive must be one of {', '.join(WHEEL_DRIVES)}, got {drive!r}", location=loc)
        if max_steer is not None:
            (max_steer,) = _finite([max_steer], "wheels max_steer", loc)
            if not 0 < max_steer < math.pi / 2:
                raise GraphError(f"wheels: max_steer must be in (0, pi/2) rad, got {max_steer}", location=loc)
        self._wheels = Wheels(tuple(joints), r, drive, tuple(steering), tuple(steered),
                              tuple(float(v) for v in radii), max_steer)
        self._wheels_location = loc

    # ---- build -----------------------------------------------------------------------------
    def build(self) -> Morphology:
        """Validate the whole graph and return it in topological order.

        Raises:
            GraphError: missing root or link, two parents, cycle, disconnected link, unknown
                end-effector link, bad mimic or wheel reference.
        """
        where = SourceLocation(self.source) if self.source else None
        if not self._links:
            raise GraphError("a morphology needs at least one link", location=where)
        parent_of = self._parent_joints()
        root = self._find_root(parent_of, where)
        order = self._ordered_joints(root, parent_of)
        self._check_mimics(order)
        self._check_references(where)
        links = (self._links[root], *(self._links[j.child] for j in order))
        return Morphology(
            name=self.name,
            base=self.base,
            root=root,
            links=links,
            joints=tuple(order),
            end_effectors=tuple(self._ees.values()),
            wheels=self._wheels,
            source=self.source,
            declared_body_length=self._body_length,
            rest_pose=tuple((j.name, self._rest_pose[j.name]) for j in order if j.name in self._rest_pose),
            collision_excludes=tuple(self._excludes),
        )

    def _parent_joints(self) -> dict[str, Joint]:
        """The joint above each child link (every joint's links exist; no link has two parents)."""
        parent_of: dict[str, Joint] = {}
        for j in self._joints.values():
            for end in (j.parent, j.child):
                if end not in self._links:
                    raise GraphError(
                        f"joint {j.name!r} names missing link {end!r} (links: {', '.join(self._links)})",
                        location=j.location,
                    )
            if j.child in parent_of:
                raise GraphError(
                    f"link {j.child!r} has two parents (joints {parent_of[j.child].name!r} and {j.name!r})",
                    location=j.location,
                )
            parent_of[j.child] = j
        return parent_of

    def _find_root(self, parent_of: dict[str, Joint], where: SourceLocation | None) -> str:
        """The root link: the one named, or the one link without a parent (else a cycle or several roots)."""
        roots = [n for n in self._links if n not in parent_of]
        if self.root is None:
            if len(roots) != 1:
                if not roots:
                    # Walk up from the first link until a link repeats: that link's joint is on the cycle.
                    seen: set[str] = set()
                    cur = next(iter(self._links))
                    while cur not in seen:
                        seen.add(cur)
                        cur = parent_of[cur].parent
                    raise GraphError(
                        f"the joints form a cycle through link {cur!r}: every link has a parent",
                        location=parent_of[cur].location or where,
                    )
                # Point at the first parentless link after the first one (usually the intended root).
                stray = self._links[roots[1]].location if roots[0] == next(iter(self._links)) else None
                raise GraphError(
                    f"several links have no parent ({', '.join(roots)}); name the root or connect them",
                    location=stray or self._links[roots[0]].location or where,
                )
            return roots[0]
        root = self.root
        if root not in self._links:
            raise GraphError(
                f"root link {root!r} does not exist (links: {', '.join(self._links)})", location=self._root_location
            )
        if root in parent_of:
            # Either a cycle through the root or a root that is someone's child.
            raise GraphError(
                f"root link {root!r} has a parent (joint {parent_of[root].name!r})",
                location=parent_of[root].location,
            )
        return root

    def _ordered_joints(self, root: str, parent_of: dict[str, Joint]) -> list[Joint]:
        """The joints in depth-first preorder from ``root`` (each limb's joints contiguous), every link reached."""
        children: dict[str, list[Joint]] = {n: [] for n in self._links}
        for j in self._joints.values():
            children[j.parent].append(j)
        order: list[Joint] = []
        self._dfs(root, children, order)
        reached = {root} | {j.child for j in order}
        missing = [n for n in self._links if n not in reached]
        if missing:
            j = parent_of.get(missing[0])
            if j is not None and self._on_cycle(missing[0], parent_of):
                raise GraphError(f"the joints form a cycle through link {missing[0]!r}", location=j.location)
            link = self._links[missing[0]]
            raise GraphError(f"link {missing[0]!r} is not connected to the root {root!r}", location=link.location)
        return order

    def _check_mimics(self, order: list[Joint]) -> None:
        """Every mimic joint follows another 1-DoF joint that is not itself a mimic."""
        joint_names = set(self._joints)
        for j in order:
            if j.mimic is not None:
                if j.mimic.joint == j.name:
                    raise GraphError(f"joint {j.name!r} mimics itself; a mimic follows another joint",
                                     location=j.location)
                if j.mimic.joint not in joint_names:
                    raise GraphError(f"joint {j.name!r} mimics unknown joint {j.mimic.joint!r}", location=j.location)
                target = self._joints[j.mimic.joint]
                if (
                    target.mimic is not None
                    or target.type not in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)
                    or j.type not in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)
                ):
                    raise GraphError(
                        f"joint {j.name!r}: mimic needs two 1-DoF joints and a target that is not itself a mimic",
                        location=j.location,
                    )

    def _check_references(self, where: SourceLocation | None) -> None:
        """End-effectors, wheels, the rest pose and collision excludes name links and joints that exist and fit."""
        joint_names = set(self._joints)
        for ee in self._ees.values():
            if ee.link not in self._links:
                raise GraphError(
                    f"end-effector {ee.name!r} on unknown link {ee.link!r} (links: {', '.join(self._links)})",
                    location=ee.location,
                )
        if self._wheels is not None:
            if self.base != BaseType.WHEELED:
                raise GraphError(
                    f"wheels are only meaningful on a wheeled base (base is {self.base.name.lower()})",
                    location=self._wheels_location,
                )
            wl = self._wheels
            if len(set(wl.all_joints)) != len(wl.all_joints):
                raise GraphError("wheels: a joint is named twice among joints, steering and steered",
                                 location=self._wheels_location)
            for w in wl.joints + wl.steered:
                if w not in joint_names or self._joints[w].type != JointType.CONTINUOUS:
                    raise GraphError(f"wheel {w!r} must name a continuous joint", location=self._wheels_location)
            for w in wl.steering:
                if w not in joint_names or self._joints[w].type not in (JointType.REVOLUTE, JointType.CONTINUOUS):
                    raise GraphError(f"steering joint {w!r} must name a revolute or continuous joint",
                                     location=self._wheels_location)
            for w in wl.all_joints:
                if self._joints[w].mimic is not None:
                    raise GraphError(f"wheel {w!r} cannot also be a mimic joint", location=self._wheels_location)
        for name, value in self._rest_pose.items():
            j = self._joints.get(name)
            at = self._rest_location or where
            if j is None or j.type not in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
                raise GraphError(f"rest pose names {name!r}, which is not a 1-DoF joint", location=at)
            # a keyframe a hair outside its range is MuJoCo's rounding; further out is a mistake
            if j.limit is not None and not j.limit.lower - 1e-3 <= value <= j.limit.upper + 1e-3:
                raise GraphError(f"rest pose {name} = {value:g} is outside its limits "
                                 f"[{j.limit.lower:g}, {j.limit.upper:g}]", location=at)
        for pair in self._excludes:
            for link in pair:
                if link not in self._links:
                    raise GraphError(f"collision exclude names missing link {link!r}", location=where)

    @staticmethod
    def _dfs(root: str, children: dict[str, list[Joint]], order: list[Joint]) -> None:
        stack = list(reversed(children[root]))
        visited = {root}
        while stack:
            j = stack.pop()
            if j.child in visited:  # a cycle back into the tree; reported as disconnected/cycle later
                continue
            visited.add(j.child)
            order.append(j)
            stack.extend(reversed(children[j.child]))

    @staticmethod
    def _on_cycle(link: str, parent_of: dict[str, Joint]) -> bool:
        seen = set()
        cur = link
        while cur in parent_of:
            if cur in seen:
                return True
            seen.add(cur)
            cur = parent_of[cur].parent
        return False
