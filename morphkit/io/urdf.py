"""URDF reader and writer, with morphkit's extension elements.

Reading: links with ``<collision>`` geometry (``<visual>`` where a link has no collision),
geometries ``box``, ``sphere``, ``cylinder`` (length along z, as in morphkit), ``mesh``
(``package://`` and relative paths resolved against the file's folder; missing mesh files
warn once for the file, they do not fail) and morphkit's own ``<capsule radius= length=/>``; joints
``revolute``, ``continuous``, ``prismatic``, ``fixed`` with origin, axis (default ``1 0 0``),
limit and mimic. A ``floating``, ``planar`` or ``fixed`` joint from a link named ``world``, or a
``floating`` or ``planar`` joint from the root link, sets the base type (floating, planar, fixed)
instead of becoming a joint; its child is the root.

An SRDF beside the file (:mod:`morphkit.io.srdf`; ``srdf=`` names another or ``False`` none) gives the
rest pose (its reference ``group_state``), self-collision excludes, end-effector hints and the base.

What other URDF tools accept, read the same way with one warning for the file: xacro leftovers
whose value is known (``$(arg x)`` with a ``<xacro:arg name="x" default=...>`` in the file,
``$(optenv VAR default)``, ``$(find pkg)`` as ``package://pkg``; others are an error at their line),
a mesh ``scale`` of four numbers (the first three), ``package:///pkg/...``, a ``<mimic>`` of a joint
the file lacks (a joint of its own, as Pinocchio reads it).

Extension elements under ``<robot>`` (other URDF tools ignore unknown elements)::

    <base type="floating|planar|wheeled|fixed"/>          absent: floating (or what a world joint says)
    <end_effector name="fl_foot" link="fl_lower" role="foot" xyz="0 0 -0.32"/>
    <wheels joints="wheel_l wheel_r" radius="0.05"/>   (optional: drive, steering, steered, steered_radii,
                                                       max_steer, as YAML's wheels:)

Writing produces standard URDF (every revolute/prismatic ``<limit>`` carries ``effort`` and
``velocity``, written as 0 where unknown, because urdfdom requires them) plus the extension
elements. Each shape becomes a ``<collision>`` and a ``<visual>``. URDF has no capsule, and
tools that read URDF (urdfdom, yourdfpy) reject a ``<capsule>`` geometry outright, so a capsule
is written as a cylinder of the same radius and length, marked in the collision as
``<cylinder ... morphkit_shape="capsule"/>`` (an attribute other tools ignore) so that morphkit
reads a capsule back. The reader also accepts a ``<capsule radius= length=/>`` geometry in
hand-written files. Spherical joints have no URDF equivalent: writing one raises
:class:`~morphkit.errors.DescriptionError` (use USD or YAML).

We parse with lxml directly rather than through yourdfpy/urdfpy because errors must name the
line of the offending element (``element.sourceline``) and because documents that declare
entities (XML bombs, external entities) must be refused before any parser expands them.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import warnings
from collections.abc import Sequence
from enum import IntEnum
from pathlib import Path
from typing import Any, Literal
from xml.sax.saxutils import quoteattr

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.body.anatomy import complete_anatomy
from morphkit.conventions import quat_from_rpy
from morphkit.errors import DescriptionError, SourceLocation
from morphkit.graph import (
    BaseType,
    EndEffectorRole,
    JointType,
    Limit,
    Mimic,
    Morphology,
    MorphologyBuilder,
    Shape,
    ShapeType,
    Transform,
)
from morphkit.graph.types import parse_enum
from morphkit.io._source import (
    mesh_warnings,
    parse_xml,
    read_text,
    relative_mesh_path,
    resolve_mesh_path,
    warn_wheeled_without_wheels,
)
from morphkit.io.srdf import Srdf, find_srdf, read_srdf, reference_values, srdf_hints

__all__ = ["dump_urdf", "parse_urdf", "read_urdf", "write_urdf"]

_URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
_WORLD = "world"
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
"""A URDF number (what urdfdom accepts; Python's float() also takes '1_000', 'infinity', 'nan')."""


_XACRO = re.compile(r"\$\((\w+)((?:\s+[^\s()]+)*)\s*\)")
"""A xacro substitution left in a file (``$(arg name)``, ``$(optenv VAR default)``, ``$(find pkg)``)."""


class _Reader:
    def __init__(self, source: str | None, srdf: Srdf | None = None, srdf_note: str = "") -> None:
        self.source = source
        self.srdf = srdf
        self.srdf_note = srdf_note
        """Said after an error in an SRDF the user did not name (how to leave it out)."""
        self.xacro_args: dict[str, str] = {}
        self.xacro_used: list[tuple[Any, str]] = []
        """(element, 'what became what') of each xacro leftover read, for the one warning."""
        self.scale4: Any = None
        """The first mesh whose scale had four numbers (the fourth dropped)."""
        self.state: dict[str, float] = {}
        """The SRDF's reference state (joint values) that joint limits must hold."""
        self.widened: list[tuple[Any, str]] = []

    def loc(self, el: Any) -> SourceLocation:
        line = el.sourceline if el is not None else None
        return SourceLocation(self.source, line if isinstance(line, int) else None)

    def error(self, message: str, el: Any) -> DescriptionError:
        return DescriptionError(message, location=self.loc(el))

    # -- attribute readers
    def get(self, el: Any, name: str) -> str | None:
        """Attribute ``name`` of ``el``, with xacro leftovers replaced (:meth:`xacro`)."""
        value = el.get(name)
        return value if value is None or "$(" not in value else self.xacro(value, el)

    def xacro(self, value: str, el: Any) -> str:
        """``value`` with the xacro substitutions an unexpanded (or half-expanded) file left in it taken as xacro
        would with no arguments given: ``$(arg x)`` its ``<xacro:arg name="x" default=...>``, ``$(optenv VAR d)``
        its default ``d``, ``$(find pkg)`` ``package://pkg``.

        Raises:
            DescriptionError: a substitution whose value is not known here (an ``$(arg)`` without a default,
                ``$(env VAR)``, an ``$(optenv)`` without a default, ``$(eval ...)``), at its line.
        """
        def one(match: re.Match[str]) -> str:
            verb, args = match.group(1), match.group(2).split()
            if verb == "arg" and len(args) == 1 and args[0] in self.xacro_args:
                out = self.xacro_args[args[0]]
            elif verb == "optenv" and len(args) >= 2:
                out = " ".join(args[1:])
            elif verb == "find" and len(args) == 1:
                out = f"package://{args[0]}"
            else:
                why = {"arg": "an argument without a <xacro:arg ... default=> in the file",
                       "optenv": "an environment variable without a default"}.get(verb, "not known without xacro")
                raise self.error(f"xacro leftover {match.group(0)!r}: {why}; expand the file with xacro first", el)
            self.xacro_used.append((el, f"{match.group(0)} as {out!r}"))
            return out

        return _XACRO.sub(one, value)

    def attr(self, el: Any, name: str, what: str, *, default: str | None = None) -> str:
        value = self.get(el, name)
        if value is None:
            if default is not None:
                return default
            raise self.error(f"{what}: <{el.tag}> needs attribute {name!r}", el)
        return value

    def name(self, el: Any, attr: str, what: str) -> str:
        value = self.attr(el, attr, what).strip()
        if not value:
            raise self.error(f"{what}: <{el.tag}> attribute {attr!r} is empty", el)
        return value

    def floats(self, el: Any, attr: str, n: int, what: str, *, default: Sequence[float] | None = None) -> tuple:
        text = self.get(el, attr)
        if text is None:
            if default is not None:
                return tuple(float(v) for v in default)
            raise self.error(f"{what}: <{el.tag}> needs attribute {attr!r}", el)
        parts = text.split()
        if len(parts) != n:
            raise self.error(f"{what}: {attr}={text!r} must be {n} number{'s' if n > 1 else ''}", el)
        out = []
        for p in parts:
            special = p.lower().lstrip("+-") in ("inf", "infinity", "nan")
            if not special and not _NUMBER.fullmatch(p):
                raise self.error(f"{what}: {attr}={text!r}: {p!r} is not a number", el)
            v = float(p)
            if not math.isfinite(v):
                raise self.error(f"{what}: {attr}={text!r}: non-finite number {p!r}", el)
            out.append(v)
        return tuple(out)

    def number(self, el: Any, attr: str, what: str, *, default: float | None = None) -> float:
        return self.floats(el, attr, 1, what, default=None if default is None else (default,))[0]

    def enum(self, cls: type[IntEnum], value: str, what: str, el: Any) -> Any:
        return parse_enum(cls, value, what=what, location=self.loc(el))

    def origin(self, parent: Any, what: str) -> Transform:
        els = parent.findall("origin")
        if not els:
            return Transform()
        if len(els) > 1:
            raise self.error(f"{what}: more than one <origin>", els[1])
        el = els[0]
        xyz = self.floats(el, "xyz", 3, f"{what} origin", default=(0, 0, 0))
        rpy = self.floats(el, "rpy", 3, f"{what} origin", default=(0, 0, 0))
        return Transform(xyz, tuple(float(v) for v in quat_from_rpy(np.asarray(rpy))))  # type: ignore[arg-type]

    def single(self, parent: Any, tag: str, what: str, *, required: bool = False) -> Any:
        els = parent.findall(tag)
        if len(els) > 1:
            raise self.error(f"{what}: more than one <{tag}>", els[1])
        if not els:
            if required:
                raise self.error(f"{what}: missing <{tag}>", parent)
            return None
        return els[0]

    # -- elements
    def shape(self, holder: Any, what: str) -> Shape:
        geometry = self.single(holder, "geometry", what, required=True)
        kids = [k for k in geometry if isinstance(k.tag, str)]
        if len(kids) != 1:
            raise self.error(f"{what}: <geometry> must hold exactly one shape, found {len(kids)}", geometry)
        g = kids[0]
        origin = self.origin(holder, what)
        gwhat = f"{what} {g.tag}"
        if g.tag == "box":
            return Shape(ShapeType.BOX, origin, size=self.floats(g, "size", 3, gwhat))
        if g.tag == "sphere":
            return Shape(ShapeType.SPHERE, origin, radius=self.number(g, "radius", gwhat))
        if g.tag in ("cylinder", "capsule"):
            capsule = g.tag == "capsule" or g.get("morphkit_shape", "").strip() == "capsule"
            stype = ShapeType.CAPSULE if capsule else ShapeType.CYLINDER
            return Shape(stype, origin, radius=self.number(g, "radius", gwhat), length=self.number(g, "length", gwhat))
        if g.tag == "mesh":
            raw = self.name(g, "filename", gwhat)
            mesh = resolve_mesh_path(raw, self.source, loc=self.loc(g))
            if len((self.get(g, "scale") or "").split()) == 4:
                # Some exporters write a homogeneous fourth number; urdfdom and Pinocchio read the first three.
                scale = self.floats(g, "scale", 4, gwhat)[:3]
                self.scale4 = self.scale4 if self.scale4 is not None else g
            else:
                scale = self.floats(g, "scale", 3, gwhat, default=(1, 1, 1))
            return Shape(ShapeType.MESH, origin, mesh=mesh, scale=scale)
        raise self.error(
            f"{what}: unknown geometry <{g.tag}>; expected one of: box, sphere, cylinder, capsule, mesh", g
        )

    def read(self, root: Any) -> Morphology:
        if root.tag != "robot":
            raise self.error(f"expected a <robot> document, found <{root.tag}>", root)
        default_name = Path(self.source).stem if self.source else "robot"
        name = root.get("name", "").strip() or default_name
        b = MorphologyBuilder(name, source=self.source)
        links = [el for el in root if el.tag == "link"]
        joints = [el for el in root if el.tag == "joint"]
        link_names = [self.name(el, "name", "link") for el in links]
        joint_els = [(self.name(el, "name", "joint"), el) for el in joints]

        if not links:
            raise self.error("the <robot> holds no <link>: nothing to read (a xacro file's unexpanded output?)", root)
        for el in root.iter():
            # <xacro:arg name= default=> left in the file: the value $(arg name) takes (xacro's, with no arguments)
            if isinstance(el.tag, str) and el.tag.endswith("}arg") and "xacro" in el.tag and el.get("name") \
                    and el.get("default") is not None:
                self.xacro_args.setdefault(el.get("name"), el.get("default"))
        anchor, world_base, world_joint = self.anchor(link_names, joint_els)
        for link_name, el in zip(link_names, links, strict=True):
            if link_name == anchor:
                if link_name != _WORLD and (el.findall("collision") or el.findall("visual")):
                    warnings.warn(f"{self.loc(el)}: link {link_name!r} is read as the world (its joint is the base): "
                                  "its shapes are left out", stacklevel=3)
                continue
            what = f"link {link_name!r}"
            b.add_link(link_name, location=self.loc(el))
            holders = el.findall("collision") or el.findall("visual")
            for h in holders:
                b.add_shape(link_name, self.shape(h, what), location=self.loc(h))

        if self.srdf is not None:
            self.state = reference_values(self.srdf, [n for n, _ in joint_els])
        mimics = {jname: self.mimic(el, f"joint {jname!r}") for jname, el in joint_els if el is not world_joint}
        for jname, el in joint_els:
            mimic = mimics.get(jname)
            if mimic is not None and mimic.joint not in mimics:
                # Pinocchio reads such a file (it reads no mimic); a joint that follows nothing moves on its own.
                warnings.warn(f"{self.loc(el)}: joint {jname!r} mimics unknown joint {mimic.joint!r}: read as a joint "
                              "of its own", stacklevel=3)
                mimics[jname] = None
        for jname, el in joint_els:
            if el is world_joint:
                continue
            self.joint(b, jname, el, _driven_by(jname, mimics, self.loc(el)))

        base_el = self.single(root, "base", "robot")
        if base_el is not None:
            b.set_base(self.enum(BaseType, self.attr(base_el, "type", "base").strip(), "base type", base_el))
        elif world_base is not None:
            b.set_base(world_base)
        for el in root.findall("end_effector"):
            ee_name = self.name(el, "name", "end_effector")
            what = f"end-effector {ee_name!r}"
            role = self.enum(EndEffectorRole, self.attr(el, "role", what, default="tool"), "end-effector role", el)
            offset = self.floats(el, "xyz", 3, what, default=(0, 0, 0))
            b.add_end_effector(ee_name, self.name(el, "link", what), offset=offset, role=role, location=self.loc(el))
        wheels = self.single(root, "wheels", "robot")
        if wheels is not None:
            names = self.attr(wheels, "joints", "wheels").split()
            kw: dict[str, Any] = {k: wheels.get(k, "").split() for k in ("steering", "steered")}
            if wheels.get("drive") is not None:
                kw["drive"] = wheels.get("drive")
            if wheels.get("steered_radii") is not None:
                kw["steered_radii"] = self.floats(wheels, "steered_radii", len(kw["steered"]), "wheels")
            if wheels.get("max_steer") is not None:
                kw["max_steer"] = self.number(wheels, "max_steer", "wheels")
            b.set_wheels(names, self.number(wheels, "radius", "wheels"), location=self.loc(wheels), **kw)
        rest = root.findall("rest_pose")
        if rest:
            b.set_rest_pose({self.name(el, "joint", "rest_pose"): self.number(el, "value", "rest_pose") for el in rest},
                            location=self.loc(rest[0]))
        declared = base_el is not None or world_base is not None
        reference, frames, base_note, srdf_base = "q = 0", [], "", None
        if self.srdf is not None:
            skip = [self.name(world_joint, "name", "joint")] if world_joint is not None else []
            try:
                hints = srdf_hints(self.srdf, b.build(), skip_joints=skip)
            except DescriptionError as exc:
                raise DescriptionError(exc.message + self.srdf_note, location=exc.location) from exc
            if not rest and hints.reference is not None:
                b.set_rest_pose(hints.rest, location=self.srdf.loc(hints.rest_line))
                reference = hints.reference
            for pair in hints.excludes:
                b.exclude_collision(*pair)
            frames = hints.frames
            if not declared and hints.base is not None:
                b.set_base(hints.base)
                declared, base_note, srdf_base = True, hints.base_note, hints.base
        m = warn_wheeled_without_wheels(
            b.build(), self.loc(base_el) if base_el is not None else None, how='<wheels joints="..." radius="R"/>'
        )
        self.warn_leftovers()
        m = complete_anatomy(m, frames=frames, base_declared=declared, reference=reference)
        # said where the base stays the SRDF's (a planar base with wheels found becomes wheeled: the anatomy says so)
        return dataclasses.replace(m, notes=(base_note, *m.notes)) if base_note and m.base == srdf_base else m

    def warn_leftovers(self) -> None:
        """One warning each for the file's xacro leftovers and four-number mesh scales."""
        if self.xacro_used:
            el, first = self.xacro_used[0]
            more = f" ({len(self.xacro_used)} substitutions in all)" if len(self.xacro_used) > 1 else ""
            warnings.warn(f"{self.loc(el)}: xacro leftover read as xacro would with no arguments: {first}{more}; "
                          "expand the file with xacro to choose other values", stacklevel=4)
        if self.widened:
            state = self.srdf.reference_state() if self.srdf is not None else None
            warnings.warn(f"{self.loc(self.widened[0][0])}: the limits of {len(self.widened)} joint(s) are widened to "
                          f"hold SRDF state {state.name if state else ''!r}: "
                          f"{'; '.join(w for _, w in self.widened)}", stacklevel=4)
        if self.scale4 is not None:
            warnings.warn(f"{self.loc(self.scale4)}: mesh scale {self.scale4.get('scale')!r} has four numbers: read as "
                          "its first three (as urdfdom does)", stacklevel=4)

    def anchor(self, link_names: list[str], joint_els: list[tuple[str, Any]]) -> tuple[str | None, BaseType | None,
                                                                                         Any]:
        """The link that stands for the world, the base its joint gives and that joint; Nones where there is none.

        A ``world`` link whose one joint (fixed, floating or planar) carries the root; or a root link (no parent)
        whose one joint is floating or planar (Pinocchio reads that joint as the free flyer): its child is the
        root, the base floats (or moves in the plane).
        """
        base_of = {"fixed": BaseType.FIXED, "floating": BaseType.FLOATING, "planar": BaseType.PLANAR}
        children = {self._end(el, "child", n) for n, el in joint_els}
        roots = [n for n in link_names if n not in children]
        candidates = [_WORLD] if _WORLD in link_names else []
        if len(roots) == 1 and roots[0] != _WORLD:
            candidates.append(roots[0])
        for candidate in candidates:
            from_it = [(n, el) for n, el in joint_els if self._end(el, "parent", n) == candidate]
            if len(from_it) != 1 or candidate in children:
                continue
            jname, jel = from_it[0]
            jtype = self.attr(jel, "type", f"joint {jname!r}").strip()
            if jtype not in base_of or (candidate != _WORLD and jtype == "fixed"):
                continue
            origin = self.origin(jel, f"joint {jname!r}")
            if not origin.is_identity(1e-12):
                kind = "world" if candidate == _WORLD else jtype
                warnings.warn(f"{self.loc(jel)}: origin of {kind} joint {jname!r} is ignored (morphkit places the "
                              "base by its coordinates)", stacklevel=4)
            return candidate, base_of[jtype], jel
        return None, None, None

    def _end(self, el: Any, tag: str, jname: str) -> str | None:
        sub = el.find(tag)
        return sub.get("link") if sub is not None else None

    def mimic(self, el: Any, what: str) -> Mimic | None:
        """The joint's ``<mimic>`` as written (the joint it follows, multiplier, offset), if any."""
        mimic = self.single(el, "mimic", what)
        if mimic is None:
            return None
        mw = f"{what} mimic"
        return Mimic(self.name(mimic, "joint", mw), self.number(mimic, "multiplier", mw, default=1.0),
                     self.number(mimic, "offset", mw, default=0.0))

    def joint(self, b: MorphologyBuilder, jname: str, el: Any, mimic: Mimic | None = None) -> None:
        what = f"joint {jname!r}"
        jtype_text = self.attr(el, "type", what).strip()
        if jtype_text in ("floating", "planar"):
            raise self.error(
                f"{what}: a {jtype_text} joint is only supported from the '{_WORLD}' link or the root link (as the "
                "base); "
                "morphkit joints are fixed, revolute, continuous, prismatic or spherical",
                el,
            )
        if jtype_text not in _URDF_JOINT_TYPES:
            raise self.error(f"unknown joint type {jtype_text!r}; expected one of: {', '.join(_URDF_JOINT_TYPES)}", el)
        jtype = JointType[jtype_text.upper()]
        parent = self.name(self.single(el, "parent", what, required=True), "link", f"{what} parent")
        child = self.name(self.single(el, "child", what, required=True), "link", f"{what} child")
        kw: dict[str, Any] = {"origin": self.origin(el, what)}
        axis = self.single(el, "axis", what)
        if axis is not None:
            kw["axis"] = self.floats(axis, "xyz", 3, f"{what} axis", default=(1, 0, 0))
        lim = self.single(el, "limit", what)
        if lim is not None:
            lw = f"{what} limit"
            velocity = self.number(lim, "velocity", lw) if lim.get("velocity") is not None else None
            effort = self.number(lim, "effort", lw) if lim.get("effort") is not None else None
            if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
                if lim.get("lower") is None and lim.get("upper") is None:
                    warnings.warn(f"{self.loc(lim)}: {what} limit has no lower/upper: URDF reads both as 0 "
                                  "(a locked joint)", stacklevel=3)
                lower = self.number(lim, "lower", lw, default=0.0)
                upper = self.number(lim, "upper", lw, default=0.0)
                if lower > upper:
                    raise self.error(f"{what}: limit lower {lower} > upper {upper}", lim)
                v = self.state.get(jname)
                if v is not None and mimic is None and not any(lower <= v + k * math.tau <= upper for k in (-1, 0, 1)):
                    # Pinocchio takes an SRDF state as it is written, limits or not (simple_humanoid's half_sitting
                    # bends the left knee past its URDF limit); the rest pose must lie within the limits.
                    self.widened.append((lim, f"{jname} [{lower:g}, {upper:g}] to hold {v:g}"))
                    lower, upper = min(lower, v), max(upper, v)
                kw["limit"] = Limit(lower, upper, velocity, effort)
        elif jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            hint = " (use type continuous for an unlimited revolute joint)" if jtype == JointType.REVOLUTE else ""
            raise self.error(f"{what}: a {jtype_text} joint needs a <limit>{hint}", el)
        if mimic is not None and jtype == JointType.FIXED:
            # Reduced models lock joints by making them fixed and keep their <mimic> (example-robot-data's
            # talos_reduced grippers): a fixed joint does not move, as Pinocchio reads it.
            warnings.warn(f"{self.loc(el)}: {what} is fixed: its <mimic> of {mimic.joint!r} is ignored", stacklevel=3)
        elif mimic is not None:
            kw["mimic"] = mimic
        b.add_joint(jname, jtype, parent, child, location=self.loc(el), **kw)


def _driven_by(jname: str, mimics: dict[str, Mimic | None], loc: SourceLocation) -> Mimic | None:
    """``jname``'s mimic followed to the joint that drives it.

    A mimic of a mimic (PAL's Talos grippers chain their finger joints so) is what MuJoCo's URDF import makes of
    it, equalities solved together: q1 = a q2 + b with q2 = a2 q3 + b2 gives q1 = a a2 q3 + a b2 + b. The graph
    keeps one level (a mimic's target drives itself), so the chain is composed here, with a warning: written
    back, the file names the driving joint. A cycle is left as written (the builder refuses it).
    """
    mimic = mimics.get(jname)
    if mimic is None or mimics.get(mimic.joint) is None:
        return mimic
    target, a, b = mimic.joint, mimic.multiplier, mimic.offset
    seen = {jname}
    while (nxt := mimics.get(target)) is not None and target not in seen:
        seen.add(target)
        target, a, b = nxt.joint, a * nxt.multiplier, a * nxt.offset + b
    if target in seen:
        return mimic
    warnings.warn(f"{loc}: joint {jname!r} mimics {mimic.joint!r}, itself a mimic: read as a mimic of {target!r} "
                  f"(multiplier {a:g}, offset {b:g}), as the chain moves it", stacklevel=3)
    return Mimic(target, a, b)


def parse_urdf(text: str, *, source: str | None = None,
               srdf: str | os.PathLike[str] | Literal[False] | None = None) -> Morphology:
    """Build a :class:`Morphology` from URDF text (with morphkit's extension elements).

    Args:
        text: The URDF document.
        source: Path the text came from (for error locations and mesh paths).
        srdf: The SRDF to read with it (:mod:`morphkit.io.srdf`: rest pose, collision excludes, end-effector
            hints, base): ``None`` finds it beside ``source`` (:func:`~morphkit.io.srdf.find_srdf`), a path names
            it, ``False`` reads none.

    Raises:
        DescriptionError: malformed XML, declared entities, missing/bad attributes, unsupported joints.
        GraphError: structural problems (cycle, two parents, missing link, ...), located at the element.
    """
    root = parse_xml(text, source)
    note = f" (the SRDF found beside {source}; read it with srdf=False to leave it out)" if srdf is None else ""
    with mesh_warnings(source):
        return _Reader(source, _srdf_for(source, srdf, root.get("name"), note), note).read(root)


def read_urdf(path: str | os.PathLike[str], *, srdf: str | os.PathLike[str] | Literal[False] | None = None
              ) -> Morphology:
    """Read a URDF file, with its SRDF where one is beside it (see :func:`parse_urdf`)."""
    return parse_urdf(read_text(path, what="URDF"), source=str(path), srdf=srdf)


def _srdf_for(source: str | None, srdf: str | os.PathLike[str] | Literal[False] | None, robot: str | None,
              note: str) -> Srdf | None:
    """The SRDF read with the URDF ``source`` (see :func:`parse_urdf`)."""
    if srdf is False:
        return None
    if srdf is not None:
        return read_srdf(srdf)
    found = find_srdf(source, robot=robot or "") if source else None
    if found is None:
        return None
    try:
        return read_srdf(found)
    except DescriptionError as exc:
        raise DescriptionError(exc.message + note, location=exc.location) from exc


# ---- the writer ------------------------------------------------------------------------------
def _num(x: float) -> str:
    x = float(x)
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def _nums(values: Sequence[float]) -> str:
    return " ".join(_num(v) for v in values)


def _origin(t: Transform) -> str:
    return f"<origin xyz={quoteattr(_nums(t.xyz))} rpy={quoteattr(_nums(t.rpy))}/>"


def _geometry(s: Shape, *, visual: bool, target: str | os.PathLike[str] | None) -> str:
    if s.type == ShapeType.BOX:
        return f"<box size={quoteattr(_nums(s.size))}/>"
    if s.type == ShapeType.SPHERE:
        return f"<sphere radius={quoteattr(_num(s.radius))}/>"
    if s.type in (ShapeType.CYLINDER, ShapeType.CAPSULE):
        marker = ' morphkit_shape="capsule"' if s.type == ShapeType.CAPSULE and not visual else ""
        return f"<cylinder radius={quoteattr(_num(s.radius))} length={quoteattr(_num(s.length))}{marker}/>"
    mesh = relative_mesh_path(s.mesh or "", target)
    return f"<mesh filename={quoteattr(mesh)} scale={quoteattr(_nums(s.scale))}/>"


def dump_urdf(m: Morphology, *, target: str | os.PathLike[str] | None = None) -> str:
    """The URDF text of ``m`` (standard URDF plus morphkit's extension elements).

    Args:
        m: The morphology.
        target: File the text will be saved as; absolute mesh paths are written relative to its folder.

    Raises:
        DescriptionError: ``m`` has a spherical joint (URDF cannot express one).
    """
    for j in m.joints:
        if j.type == JointType.SPHERICAL:
            raise DescriptionError(
                f"joint {j.name!r} is spherical, which URDF cannot express; write USD or YAML instead",
                location=j.location,
            )
    out = ['<?xml version="1.0"?>', f"<robot name={quoteattr(m.name)}>"]
    out.append("  <!-- morphkit extensions: base, end_effector, wheels, rest_pose (other URDF tools ignore them) -->")
    out.append(f'  <base type="{m.base.name.lower()}"/>')
    for link in m.links:
        if not link.shapes:
            out.append(f"  <link name={quoteattr(link.name)}/>")
            continue
        out.append(f"  <link name={quoteattr(link.name)}>")
        for s in link.shapes:
            for tag in ("visual", "collision"):
                geometry = _geometry(s, visual=tag == "visual", target=target)
                out.append(f"    <{tag}>{_origin(s.origin)}<geometry>{geometry}</geometry></{tag}>")
        out.append("  </link>")
    for j in m.joints:
        out.append(f"  <joint name={quoteattr(j.name)} type={quoteattr(j.type.name.lower())}>")
        out.append(f"    <parent link={quoteattr(j.parent)}/>")
        out.append(f"    <child link={quoteattr(j.child)}/>")
        out.append(f"    {_origin(j.origin)}")
        if j.type != JointType.FIXED or tuple(j.axis) != (1.0, 0.0, 0.0):
            out.append(f"    <axis xyz={quoteattr(_nums(j.axis))}/>")
        if j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            lim = j.limit
            out.append(
                f"    <limit lower={quoteattr(_num(lim.lower))} upper={quoteattr(_num(lim.upper))}"
                f" effort={quoteattr(_num(lim.effort or 0.0))} velocity={quoteattr(_num(lim.velocity or 0.0))}/>"
            )
        if j.mimic is not None:
            mm = j.mimic
            out.append(
                f"    <mimic joint={quoteattr(mm.joint)} multiplier={quoteattr(_num(mm.multiplier))}"
                f" offset={quoteattr(_num(mm.offset))}/>"
            )
        out.append("  </joint>")
    for ee in m.end_effectors:
        out.append(
            f"  <end_effector name={quoteattr(ee.name)} link={quoteattr(ee.link)}"
            f" role={quoteattr(ee.role.name.lower())} xyz={quoteattr(_nums(ee.offset))}/>"
        )
    if m.wheels is not None:
        w = m.wheels
        extra = f" drive={quoteattr(w.drive)}" if w.drive != "differential" else ""
        for key, names in (("steering", w.steering), ("steered", w.steered)):
            extra += f" {key}={quoteattr(' '.join(names))}" if names else ""
        if w.steered_radii:
            extra += f" steered_radii={quoteattr(' '.join(_num(r) for r in w.steered_radii))}"
        if w.max_steer is not None:
            extra += f" max_steer={quoteattr(_num(w.max_steer))}"
        out.append(f"  <wheels joints={quoteattr(' '.join(w.joints))} radius={quoteattr(_num(w.radius))}{extra}/>")
    for n, v in m.rest_pose:
        out.append(f"  <rest_pose joint={quoteattr(n)} value={quoteattr(_num(v))}/>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


def write_urdf(m: Morphology, path: str | os.PathLike[str]) -> None:
    """Write ``m`` as URDF, atomically (see :func:`dump_urdf`)."""
    atomic_write_text(path, dump_urdf(m, target=path))
