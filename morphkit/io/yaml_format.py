"""The YAML creature format: reader (with line numbers on every error) and writer.

The format (``shared/DESIGN.md``, "YAML creature format")::

    name: spot
    base: floating                  # floating | planar | wheeled | fixed (default floating)
    root: body                      # optional: the link without a parent
    body_length: 0.55               # optional [m]: what Ψ divides lengths by (default: Morphology.body_length's rule)
    links:
      body:
        shapes: [{type: box, size: [0.85, 0.24, 0.18]}]
      fl_upper:
        shapes: [{type: capsule, radius: 0.04, length: 0.32, origin: {xyz: [0, 0, -0.16]}}]
      wheel_l: {}                   # a link without shapes
    joints:
      fl_hx:
        type: revolute              # fixed | revolute | continuous | prismatic | spherical
        parent: body
        child: fl_hip
        origin: {xyz: [0.29, 0.055, 0.0], rpy: [0, 0, 0]}   # or quat: [x, y, z, w]
        axis: [1, 0, 0]             # default [1, 0, 0]
        limit: {lower: -0.78, upper: 0.78}                 # optional velocity, effort
        mimic: {joint: other, multiplier: 1.0, offset: 0.0}
    end_effectors:
      fl_foot: {link: fl_lower, offset: [0, 0, -0.32], role: foot}   # foot | hand | head | tool
    wheels: {joints: [wheel_l, wheel_r], radius: 0.1}    # wheeled base only; optional drive (differential |
                                    # skid_steer | ackermann | holonomic), steering and steered joint lists,
                                    # steered_radii, max_steer [rad]

Shapes: ``sphere`` (radius), ``capsule`` and ``cylinder`` (radius, length along local z),
``box`` (size: full extents), ``mesh`` (file, optional scale); each with an optional
``origin: {xyz, rpy | quat}`` in the link frame. Units are metres and radians; quaternions xyzw.
Mesh files are resolved relative to the YAML file's folder (see :mod:`morphkit.io._source`).

Every error is a :class:`~morphkit.errors.MorphkitError` whose location names the file and the
line of the offending element; unknown keys and duplicate keys are errors.
"""

from __future__ import annotations

import functools
import math
import os
import re
from collections.abc import Iterable, Sequence
from enum import IntEnum
from pathlib import Path
from typing import Any

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
from morphkit.io._source import read_text, relative_mesh_path, resolve_mesh_path, warn_wheeled_without_wheels
from morphkit.yaml_loader import LineLoader, YamlList, YamlMapping, load_yaml

__all__ = ["DocumentReader", "dump_yaml", "load_document", "parse_yaml", "read_yaml", "write_yaml"]

_TOP_KEYS = ("name", "base", "root", "body_length", "links", "joints", "end_effectors", "wheels", "rest_pose")
_LINK_KEYS = ("shapes",)
_JOINT_KEYS = ("type", "parent", "child", "origin", "axis", "limit", "mimic")
_LIMIT_KEYS = ("lower", "upper", "velocity", "effort")
_MIMIC_KEYS = ("joint", "multiplier", "offset")
_EE_KEYS = ("link", "offset", "role")
_WHEEL_KEYS = ("joints", "radius")
_WHEEL_OPTIONAL = ("drive", "steering", "steered", "steered_radii", "max_steer")
_ORIGIN_KEYS = ("xyz", "rpy", "quat")
_SHAPE_KEYS: dict[ShapeType, tuple[tuple[str, ...], tuple[str, ...]]] = {
    # shape type: (required keys, optional keys), besides "type" and "origin"
    ShapeType.SPHERE: (("radius",), ()),
    ShapeType.CAPSULE: (("radius", "length"), ()),
    ShapeType.CYLINDER: (("radius", "length"), ()),
    ShapeType.BOX: (("size",), ()),
    ShapeType.MESH: (("file",), ("scale",)),
}


def load_document(text: str, source: str | None) -> Any:
    """Parse YAML text into :class:`~morphkit.yaml_loader.YamlMapping` / ``YamlList`` / scalars, turning every
    parser failure into a DescriptionError (:func:`~morphkit.yaml_loader.load_yaml`)."""
    return load_yaml(text, source, error=DescriptionError)


# ---- the reader ------------------------------------------------------------------------------
def _show(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class DocumentReader:
    """Walks the loaded document, checking every value at its own line."""

    def __init__(self, source: str | None) -> None:
        self.source = source

    def loc(self, line: int | None) -> SourceLocation:
        return SourceLocation(self.source, line)

    def error(self, message: str, line: int | None) -> DescriptionError:
        return DescriptionError(message, location=self.loc(line))

    # -- containers
    def mapping(self, value: Any, what: str, line: int | None, *, allow_none: bool = False) -> YamlMapping:
        if value is None and allow_none:
            empty = YamlMapping()
            empty.line = line or 0
            empty.key_lines = {}
            return empty
        if not isinstance(value, YamlMapping):
            raise self.error(f"{what}: expected a mapping, got {_show(value)}", line)
        return value

    def sequence(self, value: Any, what: str, line: int | None) -> YamlList:
        if not isinstance(value, YamlList):
            raise self.error(f"{what}: expected a list, got {_show(value)}", line)
        return value

    def keys(
        self, m: YamlMapping, what: str, allowed: Sequence[str], required: Sequence[str] = (), *,
        line: int | None = None,
    ) -> None:
        """Refuse unknown keys (at their line) and missing ones (at ``line``, else the mapping's line)."""
        for key in m:
            if key not in allowed:
                raise self.error(
                    f"{what}: unknown key {key!r}; valid keys: {', '.join(allowed)}", m.key_lines.get(key, m.line)
                )
        for key in required:
            if key not in m:
                raise self.error(f"{what}: missing required key {key!r}", line or m.line)

    def line_of(self, m: YamlMapping, key: str) -> int:
        return m.key_lines.get(key, m.line)

    # -- scalars
    def name(self, value: Any, what: str, line: int | None) -> str:
        if not isinstance(value, str) or not value.strip():
            hint = f" (quote it: '{value}')" if isinstance(value, (int, float)) and not isinstance(value, bool) else ""
            raise self.error(f"{what}: expected a name (a string), got {_show(value)}{hint}", line)
        return value

    def number(self, value: Any, what: str, line: int | None) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(f"{what}: expected a number, got {_show(value)}", line)
        try:
            out = float(value)
        except OverflowError:
            raise self.error(f"{what}: number too large: {value}", line) from None
        if not math.isfinite(out):
            raise self.error(f"{what}: non-finite number {value!r}", line)
        return out

    def vector(self, value: Any, n: int, what: str, line: int | None) -> tuple[float, ...]:
        if not isinstance(value, YamlList) or len(value) != n:
            got = f"{len(value)} values" if isinstance(value, YamlList) else _show(value)
            raise self.error(f"{what}: expected a list of {n} numbers, got {got}", line)
        return tuple(self.number(v, what, value.item_lines[i]) for i, v in enumerate(value))

    def enum(self, cls: type[IntEnum], value: Any, what: str, line: int | None) -> Any:
        return parse_enum(cls, value, what=what, location=self.loc(line))

    def transform(self, value: Any, what: str, line: int | None) -> Transform:
        m = self.mapping(value, what, line)
        self.keys(m, what, _ORIGIN_KEYS)
        xyz = self.vector(m["xyz"], 3, f"{what} xyz", self.line_of(m, "xyz")) if "xyz" in m else (0.0, 0.0, 0.0)
        if "rpy" in m and "quat" in m:
            raise self.error(f"{what}: give either rpy or quat, not both", self.line_of(m, "quat"))
        if "quat" in m:
            q = np.asarray(self.vector(m["quat"], 4, f"{what} quat (xyzw)", self.line_of(m, "quat")))
            norm = float(np.linalg.norm(q))
            if not math.isfinite(norm) or norm < 1e-9:
                raise self.error(f"{what}: quat must be a non-zero quaternion [x, y, z, w]", self.line_of(m, "quat"))
            return Transform(xyz, tuple(float(v) for v in q / norm))  # type: ignore[arg-type]
        if "rpy" in m:
            rpy = self.vector(m["rpy"], 3, f"{what} rpy", self.line_of(m, "rpy"))
            return Transform(xyz, tuple(float(v) for v in quat_from_rpy(np.asarray(rpy))))  # type: ignore[arg-type]
        return Transform(xyz)  # type: ignore[arg-type]

    # -- elements
    def shape(self, value: Any, what: str, line: int) -> Shape:
        m = self.mapping(value, what, line)
        if "type" not in m:
            raise self.error(f"{what}: missing required key 'type'", line)
        stype = self.enum(ShapeType, m["type"], "shape type", self.line_of(m, "type"))
        required, optional = _SHAPE_KEYS[stype]
        self.keys(m, f"{what} ({stype.name.lower()})", ("type", "origin", *required, *optional), required, line=line)
        kw: dict[str, Any] = {}
        if "origin" in m:
            kw["origin"] = self.transform(m["origin"], f"{what} origin", self.line_of(m, "origin"))
        for key in ("radius", "length"):
            if key in m:
                kw[key] = self.number(m[key], f"{what} {key}", self.line_of(m, key))
        if "size" in m:
            kw["size"] = self.vector(m["size"], 3, f"{what} size", self.line_of(m, "size"))
        if "scale" in m:
            kw["scale"] = self.vector(m["scale"], 3, f"{what} scale", self.line_of(m, "scale"))
        if "file" in m:
            raw = self.name(m["file"], f"{what} file", self.line_of(m, "file"))
            kw["mesh"] = resolve_mesh_path(raw, self.source, loc=self.loc(self.line_of(m, "file")))
        return Shape(stype, **kw)

    def read(self, doc: Any) -> Morphology:
        if doc is None:
            raise self.error("empty YAML document; expected a creature mapping with 'links'", 1)
        top = self.mapping(doc, "creature file", 1)
        self.keys(top, "creature file", _TOP_KEYS, ("links",))
        default_name = Path(self.source).stem if self.source else "creature"
        name = self.name(top["name"], "name", self.line_of(top, "name")) if "name" in top else default_name
        b = MorphologyBuilder(name, source=self.source)
        if "base" in top:
            b.set_base(self.enum(BaseType, top["base"], "base type", self.line_of(top, "base")))
        if "root" in top:
            line = self.line_of(top, "root")
            b.set_root(self.name(top["root"], "root", line), location=self.loc(line))
        if "body_length" in top:
            line = self.line_of(top, "body_length")
            length = self.number(top["body_length"], "body_length", line)
            if length <= 0:
                raise self.error(f"body_length: must be a length > 0 [m], got {top['body_length']!r}", line)
            b.set_body_length(length, location=self.loc(line))

        links = self.mapping(top["links"], "links", self.line_of(top, "links"))
        if not links:
            raise self.error("links: a creature needs at least one link", links.line)
        for link_name, value in links.items():
            line = links.key_lines[link_name]
            link_name = self.name(link_name, "link name", line)
            what = f"link {link_name!r}"
            m = self.mapping(value, what, line, allow_none=True)
            self.keys(m, what, _LINK_KEYS)
            b.add_link(link_name, location=self.loc(line))
            if "shapes" in m:
                shapes = self.sequence(m["shapes"], f"{what} shapes", self.line_of(m, "shapes"))
                for i, s in enumerate(shapes):
                    sline = shapes.item_lines[i]
                    b.add_shape(link_name, self.shape(s, f"{what} shape {i}", sline), location=self.loc(sline))

        if "joints" in top and top["joints"] is not None:
            joints = self.mapping(top["joints"], "joints", self.line_of(top, "joints"))
            for joint_name, value in joints.items():
                self.joint(b, joints, joint_name, value)

        if "end_effectors" in top and top["end_effectors"] is not None:
            ees = self.mapping(top["end_effectors"], "end_effectors", self.line_of(top, "end_effectors"))
            for ee_name, value in ees.items():
                line = ees.key_lines[ee_name]
                ee_name = self.name(ee_name, "end-effector name", line)
                what = f"end-effector {ee_name!r}"
                m = self.mapping(value, what, line)
                self.keys(m, what, _EE_KEYS, ("link",), line=line)
                kw: dict[str, Any] = {}
                if "offset" in m:
                    kw["offset"] = self.vector(m["offset"], 3, f"{what} offset", self.line_of(m, "offset"))
                if "role" in m:
                    kw["role"] = self.enum(EndEffectorRole, m["role"], "end-effector role", self.line_of(m, "role"))
                link = self.name(m["link"], f"{what} link", self.line_of(m, "link"))
                b.add_end_effector(ee_name, link, location=self.loc(line), **kw)

        if "wheels" in top:
            line = self.line_of(top, "wheels")
            m = self.mapping(top["wheels"], "wheels", line)
            self.keys(m, "wheels", _WHEEL_KEYS + _WHEEL_OPTIONAL, _WHEEL_KEYS, line=line)

            def joint_list(key: str) -> list[str]:
                if key not in m:
                    return []
                jl = self.sequence(m[key], f"wheels {key}", self.line_of(m, key))
                return [self.name(v, f"wheels {key} joint", jl.item_lines[i]) for i, v in enumerate(jl)]

            radius = self.number(m["radius"], "wheels radius", self.line_of(m, "radius"))
            kw: dict[str, Any] = {}
            if "drive" in m:
                kw["drive"] = self.name(m["drive"], "wheels drive", self.line_of(m, "drive"))
            if "steered_radii" in m:
                rl = self.sequence(m["steered_radii"], "wheels steered_radii", self.line_of(m, "steered_radii"))
                kw["steered_radii"] = [self.number(v, "wheels steered radius", rl.item_lines[i])
                                       for i, v in enumerate(rl)]
            if "max_steer" in m:
                kw["max_steer"] = self.number(m["max_steer"], "wheels max_steer", self.line_of(m, "max_steer"))
            b.set_wheels(joint_list("joints"), radius, steering=joint_list("steering"), steered=joint_list("steered"),
                         location=self.loc(line), **kw)
        if "rest_pose" in top:
            line = self.line_of(top, "rest_pose")
            rp = self.mapping(top["rest_pose"], "rest_pose", line)
            b.set_rest_pose({self.name(k, "rest_pose joint", self.line_of(rp, k)):
                             self.number(v, f"rest_pose {k}", self.line_of(rp, k)) for k, v in rp.items()},
                            location=self.loc(line))
        m = warn_wheeled_without_wheels(
            b.build(), self.loc(self.line_of(top, "base")), how="wheels: {joints: [...], radius: R}"
        )
        if "end_effectors" in top:  # the file decided, even on none (`end_effectors: {}`)
            return m
        return complete_anatomy(m, base_declared="base" in top)

    def joint(self, b: MorphologyBuilder, joints: YamlMapping, joint_name: Any, value: Any) -> None:
        line = joints.key_lines[joint_name]
        joint_name = self.name(joint_name, "joint name", line)
        what = f"joint {joint_name!r}"
        m = self.mapping(value, what, line)
        self.keys(m, what, _JOINT_KEYS, ("type", "parent", "child"), line=line)
        jtype = self.enum(JointType, m["type"], "joint type", self.line_of(m, "type"))
        parent = self.name(m["parent"], f"{what} parent", self.line_of(m, "parent"))
        child = self.name(m["child"], f"{what} child", self.line_of(m, "child"))
        kw: dict[str, Any] = {}
        if "origin" in m:
            kw["origin"] = self.transform(m["origin"], f"{what} origin", self.line_of(m, "origin"))
        if "axis" in m:
            kw["axis"] = self.vector(m["axis"], 3, f"{what} axis", self.line_of(m, "axis"))
        if "limit" in m:
            lim = self.mapping(m["limit"], f"{what} limit", self.line_of(m, "limit"))
            self.keys(lim, f"{what} limit", _LIMIT_KEYS, ("lower", "upper"), line=self.line_of(m, "limit"))
            vals = {k: self.number(lim[k], f"{what} limit {k}", self.line_of(lim, k)) for k in _LIMIT_KEYS if k in lim}
            if vals["lower"] > vals["upper"]:
                lo, hi = vals["lower"], vals["upper"]
                raise self.error(f"{what}: limit lower {lo} > upper {hi}", self.line_of(m, "limit"))
            kw["limit"] = Limit(vals["lower"], vals["upper"], vals.get("velocity"), vals.get("effort"))
        if "mimic" in m:
            mim = self.mapping(m["mimic"], f"{what} mimic", self.line_of(m, "mimic"))
            self.keys(mim, f"{what} mimic", _MIMIC_KEYS, ("joint",), line=self.line_of(m, "mimic"))
            target = self.name(mim["joint"], f"{what} mimic joint", self.line_of(mim, "joint"))
            mult = self.number(mim["multiplier"], f"{what} mimic multiplier", self.line_of(mim, "multiplier")) \
                if "multiplier" in mim else 1.0
            off = self.number(mim["offset"], f"{what} mimic offset", self.line_of(mim, "offset")) \
                if "offset" in mim else 0.0
            kw["mimic"] = Mimic(target, mult, off)
        b.add_joint(joint_name, jtype, parent, child, location=self.loc(line), **kw)


def parse_yaml(text: str, *, source: str | None = None) -> Morphology:
    """Build a :class:`Morphology` from YAML creature text.

    Args:
        text: The YAML document.
        source: Path the text came from (for error locations and relative mesh paths).

    Raises:
        DescriptionError: malformed YAML, unknown or missing keys, bad numbers or enum values.
        GraphError: structural problems (cycle, two parents, missing link, ...), located at the element.
    """
    return DocumentReader(source).read(load_document(text, source))


def read_yaml(path: str | os.PathLike[str]) -> Morphology:
    """Read a YAML creature file (see :func:`parse_yaml`)."""
    return parse_yaml(read_text(path, what="YAML"), source=str(path))


# ---- the writer ------------------------------------------------------------------------------
_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-/]*")


@functools.lru_cache(maxsize=4096)
def _str(s: str) -> str:
    """A YAML scalar for ``s``: plain where it reads back as the same string, else double-quoted."""
    if _PLAIN.fullmatch(s):
        # Plain only if no implicit resolver (bool, null, int, float) claims it.
        resolvers = LineLoader.yaml_implicit_resolvers
        if not any(rx.match(s) for _, rx in (*resolvers.get(s[0], ()), *resolvers.get(None, ()))):
            return s
    return _quote(s)


_PRINTABLE = re.compile("[\x20-\x7e\xa0-\u2027\u202a-\ud7ff\ue000-\ufefe\uff00-\ufffd\U00010000-\U0010ffff]")


def _quote(s: str) -> str:
    """Double-quoted YAML scalar; escapes everything YAML would refuse, fold or strip (line breaks, BOM)."""
    out = []
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif _PRINTABLE.fullmatch(ch):
            out.append(ch)
        else:
            o = ord(ch)
            out.append(f"\\x{o:02x}" if o <= 0xFF else f"\\u{o:04x}" if o <= 0xFFFF else f"\\U{o:08x}")
    return '"' + "".join(out) + '"'


def _num(x: float) -> str:
    """Shortest text that reads back as exactly ``x`` under YAML 1.1 and 1.2."""
    x = float(x)
    if x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    text = repr(x)
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:  # YAML 1.1 needs a dot: 1e-05 -> 1.0e-05
        text = f"{mantissa}.0e{exponent}"
    return text


def _vec(values: Iterable[float]) -> str:
    return "[" + ", ".join(_num(v) for v in values) + "]"


def _origin(t: Transform) -> str | None:
    """``{xyz, rpy}`` text of a transform, or ``None`` for the identity.

    Uses ``quat`` instead of ``rpy`` where rpy would not reproduce the rotation to 1e-12
    (close to pitch = ±90°, where roll and yaw are coupled).
    """
    q = np.asarray(t.quat, dtype=float)
    parts = []
    if any(v != 0.0 for v in t.xyz):
        parts.append(f"xyz: {_vec(t.xyz)}")
    if not (abs(q[3]) == 1.0 and not q[:3].any()):
        rpy = np.asarray(t.rpy)
        back = quat_from_rpy(rpy)
        if min(np.abs(back - q).max(), np.abs(back + q).max()) <= 1e-12:
            parts.append(f"rpy: {_vec(rpy)}")
        else:
            parts.append(f"quat: {_vec(q)}")
    return "{" + ", ".join(parts) + "}" if parts else None


def _shape(s: Shape, target: str | os.PathLike[str] | None) -> str:
    parts = [f"type: {s.type.name.lower()}"]
    if s.type in (ShapeType.SPHERE, ShapeType.CAPSULE, ShapeType.CYLINDER):
        parts.append(f"radius: {_num(s.radius)}")
    if s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        parts.append(f"length: {_num(s.length)}")
    if s.type == ShapeType.BOX:
        parts.append(f"size: {_vec(s.size)}")
    if s.type == ShapeType.MESH:
        parts.append(f"file: {_str(relative_mesh_path(s.mesh or '', target))}")
        if tuple(s.scale) != (1.0, 1.0, 1.0):
            parts.append(f"scale: {_vec(s.scale)}")
    origin = _origin(s.origin)
    if origin is not None:
        parts.append(f"origin: {origin}")
    return "{" + ", ".join(parts) + "}"


def dump_yaml(m: Morphology, *, target: str | os.PathLike[str] | None = None) -> str:
    """The YAML creature text of ``m`` (reads back with :func:`parse_yaml` exactly, to 1e-9).

    Args:
        m: The morphology.
        target: File the text will be saved as; absolute mesh paths are written relative to its folder.
    """
    out = [f"name: {_str(m.name)}", f"base: {m.base.name.lower()}", f"root: {_str(m.root)}"]
    if m.declared_body_length is not None:
        out.append(f"body_length: {_num(m.declared_body_length)}")
    out.append("links:")
    for link in m.links:
        if not link.shapes:
            out.append(f"  {_str(link.name)}: {{}}")
            continue
        out.append(f"  {_str(link.name)}:")
        out.append("    shapes:")
        out.extend(f"      - {_shape(s, target)}" for s in link.shapes)
    if m.joints:
        out.append("joints:")
    for j in m.joints:
        out.append(f"  {_str(j.name)}:")
        out.append(f"    type: {j.type.name.lower()}")
        out.append(f"    parent: {_str(j.parent)}")
        out.append(f"    child: {_str(j.child)}")
        origin = _origin(j.origin)
        if origin is not None:
            out.append(f"    origin: {origin}")
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC) or tuple(j.axis) != (1, 0, 0):
            out.append(f"    axis: {_vec(j.axis)}")
        if j.limit is not None:
            lim = [f"lower: {_num(j.limit.lower)}", f"upper: {_num(j.limit.upper)}"]
            if j.limit.velocity is not None:
                lim.append(f"velocity: {_num(j.limit.velocity)}")
            if j.limit.effort is not None:
                lim.append(f"effort: {_num(j.limit.effort)}")
            out.append(f"    limit: {{{', '.join(lim)}}}")
        if j.mimic is not None:
            mm = j.mimic
            out.append(
                f"    mimic: {{joint: {_str(mm.joint)}, multiplier: {_num(mm.multiplier)}, offset: {_num(mm.offset)}}}"
            )
    # written even when empty: `end_effectors: {}` tells the reader not to decide them from the body
    out.append("end_effectors:" if m.end_effectors else "end_effectors: {}")
    for ee in m.end_effectors:
        out.append(
            f"  {_str(ee.name)}: {{link: {_str(ee.link)}, offset: {_vec(ee.offset)}, role: {ee.role.name.lower()}}}"
        )
    if m.wheels is not None:
        names = ", ".join(_str(n) for n in m.wheels.joints)
        wl = m.wheels
        extra = "" if wl.drive == "differential" else f", drive: {wl.drive}"
        for key, joints in (("steering", wl.steering), ("steered", wl.steered)):
            if joints:
                extra += f", {key}: [{', '.join(_str(n) for n in joints)}]"
        if wl.steered_radii:
            extra += f", steered_radii: [{', '.join(_num(r) for r in wl.steered_radii)}]"
        if wl.max_steer is not None:
            extra += f", max_steer: {_num(wl.max_steer)}"
        out.append(f"wheels: {{joints: [{names}], radius: {_num(wl.radius)}{extra}}}")
    if m.rest_pose:
        out.append("rest_pose:  # 1-DoF joint values at rest [rad or m]; others rest at 0")
        out += [f"  {_str(n)}: {_num(v)}" for n, v in m.rest_pose]
    return "\n".join(out) + "\n"


def write_yaml(m: Morphology, path: str | os.PathLike[str]) -> None:
    """Write ``m`` as a YAML creature file, atomically (temporary file renamed into place)."""
    atomic_write_text(path, dump_yaml(m, target=path))
