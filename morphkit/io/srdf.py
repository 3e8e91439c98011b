"""SRDF (MoveIt's semantic robot description) beside a URDF: what the URDF reader takes from it.

A URDF says how a robot is built; its SRDF says how it is used. Pinocchio and MoveIt read the pair, and
collections such as example-robot-data ship them together (``x_description/urdf/x.urdf`` with
``x_description/srdf/x.srdf``). The URDF reader (:func:`morphkit.io.urdf.read_urdf`) finds the SRDF
(:func:`find_srdf`) and takes from it, as it takes an MJCF file's keyframes and excludes:

* the first ``<group_state>`` named in :data:`STATE_PREFERENCE` as the **rest pose** (joint values over
  ``q = 0``, as Pinocchio's reference configurations; the anatomy keeps it as the file's own stance);
* ``<disable_collisions link1 link2>`` pairs as self-collision **excludes**;
* ``<end_effector name parent_link>`` (and HPP's ``<gripper name><link/><position/></gripper>``) as named
  **frames**, hints of a foot, hand or tool for :func:`morphkit.body.anatomy.complete_anatomy`;
* a ``<virtual_joint type= child_link=>`` on the root as the **base** type, where the URDF declares none.

Names the URDF lacks are one warning naming the SRDF's file and line; a malformed SRDF is an error naming them.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from morphkit.body.anatomy import Frame
from morphkit.body.roles import name_hint
from morphkit.errors import DescriptionError, SourceLocation
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.io._source import parse_xml, read_text

__all__ = ["STATE_PREFERENCE", "GroupState", "Srdf", "SrdfHints", "SrdfPoint", "find_srdf", "parse_srdf",
           "read_srdf", "reference_values", "srdf_hints"]

STATE_PREFERENCE = ("standing", "half_sitting", "standing_with_arm_home", "standing_with_arm_up",
                    "straight_standing", "home", "default", "neutral")
"""The SRDF ``group_state`` taken as the reference pose (the rest pose), first found."""

_BASES = {"floating": BaseType.FLOATING, "planar": BaseType.PLANAR, "fixed": BaseType.FIXED}
_SHOWN = 5
"""Unknown names listed in a warning before ``...``."""


@dataclass(frozen=True)
class GroupState:
    """A named joint configuration (``<group_state>``): per joint, its values (one for a 1-DoF joint)."""

    name: str
    values: tuple[tuple[str, tuple[float, ...], int | None], ...]
    """``(joint, values, line)`` in file order."""
    line: int | None = None


@dataclass(frozen=True)
class SrdfPoint:
    """An ``<end_effector>`` (its ``parent_link``) or an HPP ``<gripper>`` (its link and position)."""

    name: str
    link: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    line: int | None = None


@dataclass(frozen=True)
class Srdf:
    """What morphkit reads of an SRDF file (:func:`parse_srdf`)."""

    source: str | None
    states: tuple[GroupState, ...] = ()
    points: tuple[SrdfPoint, ...] = ()
    disabled_collisions: tuple[tuple[str, str, int | None], ...] = ()
    """``(link1, link2, line)``."""
    virtual_joints: tuple[tuple[str, str, str, int | None], ...] = ()
    """``(name, type, child_link, line)``."""

    def loc(self, line: int | None = None) -> SourceLocation:
        """Where in the SRDF ``line`` is."""
        return SourceLocation(self.source, line)

    def reference_state(self) -> GroupState | None:
        """The first state named in :data:`STATE_PREFERENCE` (the first of that name), or None."""
        for name in STATE_PREFERENCE:
            for s in self.states:
                if s.name == name:
                    return s
        return None


def _attr(el: Any, name: str, source: str | None) -> str:
    value = (el.get(name) or "").strip()
    if not value:
        raise DescriptionError(f"SRDF <{el.tag}> needs a non-empty attribute {name!r}",
                               location=SourceLocation(source, el.sourceline))
    return value


def _numbers(text: str, what: str, el: Any, source: str | None, n: int | None = None) -> tuple[float, ...]:
    where = SourceLocation(source, el.sourceline)
    try:
        out = tuple(float(p) for p in text.split())
    except ValueError:
        raise DescriptionError(f"SRDF {what}: {text.strip()!r} is not a list of numbers", location=where) from None
    if not out or not all(math.isfinite(v) for v in out):
        raise DescriptionError(f"SRDF {what}: {text.strip()!r} must be finite numbers", location=where)
    if n is not None and len(out) < n:
        raise DescriptionError(f"SRDF {what}: {text.strip()!r} needs {n} numbers", location=where)
    return out


def parse_srdf(text: str, *, source: str | None = None) -> Srdf:
    """Read SRDF text: group states, end-effectors (and HPP grippers), disabled collision pairs, virtual joints.

    Raises:
        DescriptionError: malformed XML, a root other than ``<robot>``, a missing name, a value that is no number.
    """
    root = parse_xml(text, source, what="SRDF")
    if root.tag != "robot":
        raise DescriptionError(f"expected an SRDF <robot> document, found <{root.tag}>",
                               location=SourceLocation(source, root.sourceline))
    states, points, pairs, virtual = [], [], [], []
    for el in root:
        if el.tag == "group_state":
            name = _attr(el, "name", source)
            values = []
            for j in el.iter("joint"):
                jname = _attr(j, "name", source)
                values.append((jname, _numbers(_attr(j, "value", source), f"state {name!r} joint {jname!r}", j,
                                               source), j.sourceline))
            states.append(GroupState(name, tuple(values), el.sourceline))
        elif el.tag == "end_effector":
            points.append(SrdfPoint(_attr(el, "name", source), _attr(el, "parent_link", source), line=el.sourceline))
        elif el.tag == "gripper":  # HPP's extension: a grasp frame on a link
            name = _attr(el, "name", source)
            link = el.find("link")
            if link is None:
                raise DescriptionError(f"SRDF gripper {name!r} needs a <link name=...>",
                                       location=SourceLocation(source, el.sourceline))
            pos = el.find("position")
            offset = (0.0, 0.0, 0.0) if pos is None else \
                _numbers(pos.text or "", f"gripper {name!r} position", pos, source, 3)[:3]
            points.append(SrdfPoint(name, _attr(link, "name", source), offset, el.sourceline))  # type: ignore[arg-type]
        elif el.tag == "disable_collisions":
            pairs.append((_attr(el, "link1", source), _attr(el, "link2", source), el.sourceline))
        elif el.tag == "virtual_joint":
            vtype = _attr(el, "type", source)
            if vtype not in _BASES:
                raise DescriptionError(f"SRDF virtual joint type {vtype!r}; expected one of: {', '.join(_BASES)}",
                                       location=SourceLocation(source, el.sourceline))
            virtual.append((_attr(el, "name", source), vtype, _attr(el, "child_link", source), el.sourceline))
    return Srdf(source, tuple(states), tuple(points), tuple(pairs), tuple(virtual))


def read_srdf(path: str | os.PathLike[str]) -> Srdf:
    """Read an SRDF file (see :func:`parse_srdf`)."""
    return parse_srdf(read_text(path, what="SRDF"), source=str(path))


_ROBOT_NAME = re.compile(r"<robot\b[^>]*?\bname\s*=\s*(['\"])(.*?)\1", re.DOTALL)


def _robot_name(path: Path) -> str | None:
    try:
        m = _ROBOT_NAME.search(path.read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return None
    return m.group(2).strip().lower() if m else None


def find_srdf(urdf: str | os.PathLike[str], *, robot: str | None = None) -> Path | None:
    """The SRDF that goes with ``urdf`` by the layout ROS description packages use, or None.

    Looked for beside the URDF and in ``../srdf/``: the same stem (``a1.urdf`` → ``srdf/a1.srdf``); else, for the
    same robot (the ``<robot name>`` of both, any case), the longest stem the URDF's starts with
    (``hyq_no_sensors`` → ``hyq``, ``talos_reduced`` → ``talos``), else the one SRDF of ``../srdf/``
    (``baxter.urdf`` → ``srdf/baxter_manipulation.srdf``).

    Args:
        urdf: The URDF file.
        robot: Its ``<robot name>`` (read from the file when not given).
    """
    p = Path(urdf)
    folders = [p.parent, Path(os.path.normpath(p.parent / ".." / "srdf"))]  # "x.urdf": ../srdf, not ./srdf
    for folder in folders:
        if (folder / f"{p.stem}.srdf").is_file():
            return folder / f"{p.stem}.srdf"
    found = [f for folder in folders if folder.is_dir() for f in sorted(folder.glob("*.srdf")) if f.is_file()]
    if not found:
        return None
    name = robot.strip().lower() if robot is not None else _robot_name(p)
    same = [f for f in found if name and _robot_name(f) == name]
    prefixed = [f for f in same if p.stem.startswith(f.stem)]
    if prefixed:
        return max(prefixed, key=lambda f: len(f.stem))
    package = [f for f in found if f.parent == folders[1]]
    return package[0] if len(package) == 1 and package[0] in same else None


def reference_values(srdf: Srdf, joints: Collection[str]) -> dict[str, float]:
    """The reference state's one-number values by the URDF's joint names (``robot/`` prefixes dropped), quietly
    leaving out names not in ``joints``."""
    state = srdf.reference_state()
    out: dict[str, float] = {}
    for jname, values, _line in state.values if state is not None else ():
        name = jname if jname in joints else jname.partition("/")[2]
        if name in joints and len(values) == 1:
            out[name] = values[0]
    return out


@dataclass
class SrdfHints:
    """What an SRDF adds to a URDF read (:func:`srdf_hints`)."""

    rest: dict[str, float] = field(default_factory=dict)
    """Non-zero values of the reference state's 1-DoF joints (others rest at 0, as an MJCF keyframe's)."""
    reference: str | None = None
    """``"SRDF 'standing'"``: what the rest pose is, for the anatomy's notes."""
    rest_line: int | None = None
    excludes: list[tuple[str, str]] = field(default_factory=list)
    frames: list[Frame] = field(default_factory=list)
    base: BaseType | None = None
    """The base a virtual joint on the root declares (or MoveIt's fixed root where none is)."""
    base_note: str = ""
    """Why, for the morphology's notes."""


def _turned(v: float, j: Any) -> float:
    """``v`` a turn nearer 0 where that is within the joint's limits (the same pose): a revolute or continuous
    joint's SRDF value beyond ±π (anymal-kinova's arm at 3π/2 on a ±2π joint)."""
    if j.type not in (JointType.REVOLUTE, JointType.CONTINUOUS) or abs(v) <= math.pi:
        return v
    w = math.remainder(v, 2.0 * math.pi)
    return w if j.limit is None or j.limit.lower <= w <= j.limit.upper else v


def srdf_hints(srdf: Srdf, m: Morphology, *, skip_joints: Sequence[str] = ()) -> SrdfHints:
    """What ``srdf`` says about ``m`` (the URDF as read), checked against its joints and links.

    A joint or link name the URDF lacks (after HPP's ``robot/`` prefix is dropped) is left out with one warning
    for the file; fixed and mimic joints are skipped (a reduced model locks joints, a mimic follows its joint); a
    value outside the joint's limits is clamped, with one warning.

    Args:
        srdf: The SRDF read.
        m: The URDF's morphology (before the anatomy).
        skip_joints: Joints of the file morphkit does not keep as joints (the ``world`` joint that is the base).

    Raises:
        DescriptionError: a state gives a 1-DoF joint other than one value, at its line.
    """
    joints = {j.name: j for j in m.joints}
    links = {link.name for link in m.links}
    unknown: list[tuple[str, int | None]] = []

    def known(name: str, names: Mapping[str, Any] | set[str], line: int | None) -> str | None:
        if name in names:
            return name
        short = name.partition("/")[2]  # HPP prefixes names with the robot's: "baxter/left_s0"
        if short and short in names:
            return short
        unknown.append((name, line))
        return None

    out = SrdfHints()
    virtual_names = {v[0] for v in srdf.virtual_joints} | set(skip_joints)
    state = srdf.reference_state()
    clamped = []
    if state is not None:
        out.reference, out.rest_line = f"SRDF {state.name!r}", state.line
        for jname, values, line in state.values:
            if jname in virtual_names or (len(values) == 7 and jname not in joints):
                continue  # the root's 7 numbers (a free flyer's): morphkit places the base by its coordinates
            name = known(jname, joints, line)
            if name is None:
                continue
            j = joints[name]
            if j.type == JointType.FIXED or j.mimic is not None or j.type == JointType.SPHERICAL:
                continue
            if len(values) != 1:
                raise DescriptionError(f"SRDF state {state.name!r}: joint {jname!r} takes one value, got "
                                       f"{len(values)}", location=srdf.loc(line))
            v = _turned(values[0], j)
            if j.limit is not None and not j.limit.lower <= v <= j.limit.upper:
                clamped.append(f"{name} = {v:g} to [{j.limit.lower:g}, {j.limit.upper:g}]")
                v = min(max(v, j.limit.lower), j.limit.upper)
            if v != 0.0:
                out.rest[name] = v
    seen: set[tuple[str, str]] = set()
    for a, b, line in srdf.disabled_collisions:
        la, lb = known(a, links, line), known(b, links, line)
        if la is not None and lb is not None and la != lb and (la, lb) not in seen and (lb, la) not in seen:
            seen.add((la, lb))
            out.excludes.append((la, lb))
    child_of = {j.name: j.child for j in m.joints}
    for p in srdf.points:
        # A parent_link that names a joint means its child link (alex_nub_hands.srdf names the wrist joints).
        link = child_of[p.link] if p.link not in links and p.link in child_of else known(p.link, links, p.line)
        if link is not None and name_hint(p.name) not in (None, "skip"):
            # A name that hints nothing ("end_effector") would hide the link's own (panda_hand_tcp's "tcp").
            out.frames.append(Frame(p.name, link, p.offset))
    for name, vtype, child, _line in srdf.virtual_joints:
        if child == m.root:
            out.base = _BASES[vtype]
            out.base_note = f"base: {vtype} — the SRDF's virtual joint {name!r}"
    if not srdf.virtual_joints and srdf.points and not any(name_hint(p.name) == "foot" for p in srdf.points):
        # MoveIt assumes a fixed root where no virtual joint is given; Pinocchio's collections leave it out for
        # legged robots too, but those name their feet (example-robot-data loads baxter and alex fixed).
        out.base = BaseType.FIXED
        out.base_note = "base: fixed — the SRDF names end-effectors, none a foot, and no virtual joint (MoveIt's " \
                        "fixed root)"
    if unknown:
        names = list(dict.fromkeys(n for n, _ in unknown))
        shown = ", ".join(names[:_SHOWN]) + (f", ... ({len(names)} in all)" if len(names) > _SHOWN else "")
        warnings.warn(f"{srdf.loc(unknown[0][1])}: the SRDF names {len(names)} joint(s) or link(s) the URDF "
                      f"{m.source or ''} lacks, left out: {shown}".replace(" URDF  lacks", " URDF lacks"),
                      stacklevel=3)
    if clamped:
        warnings.warn(f"{srdf.loc(out.rest_line)}: SRDF state {state.name!r} "  # type: ignore[union-attr]
                      f"is outside the URDF's joint limits, clamped: {'; '.join(clamped)}", stacklevel=3)
    return out
