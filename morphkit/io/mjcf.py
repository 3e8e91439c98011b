"""MJCF (MuJoCo) reader and writer.

Reading lets MuJoCo's own compiler parse the file (``mujoco.MjModel.from_xml_path``: includes,
defaults and classes, ``frame``\\ s, angle units, ``fromto``, mesh assets), then builds the graph from
the compiled model, so morphkit sees exactly the kinematics MuJoCo simulates:

- The creature is the world's child body with the most bodies below it (dm_control's dog and
  quadruped also hold a ``ball``); other world bodies are skipped with a warning, or name one in the
  side file (``body:``). A ``free`` joint on it makes a floating base; otherwise the base is fixed
  and the world becomes the root link ``world``.
- ``hinge`` → revolute (continuous where not ``limited``), ``slide`` → prismatic (needs a range),
  ``ball`` → spherical (its cone limit is not kept), a body without joints → a fixed joint. Several
  joints in one body become a chain of shape-less links ``<body>__<joint>``, the last one being the
  body itself.
- morphkit's link frame sits at its joint, as in URDF. MuJoCo's hinge or ball may sit off its body's
  origin (``jnt_pos``: 49 of the suite dog's 73 hinges do), so the link frame of such a body is its
  body frame moved to the last joint's anchor (same orientation); shapes, end-effectors and child
  bodies are moved by the opposite amount, so every world position is MuJoCo's.
  :func:`link_offsets` gives that shift per link (zero for most).
- Coordinates are measured from the joint's ``ref`` (MuJoCo's ``qpos0``): morphkit's ``q`` is
  ``qpos - ref`` and limits are ``range - ref``. ``springref`` is a spring's rest angle (dynamics) and
  does not change kinematics. Quaternions are reordered from MuJoCo's wxyz to morphkit's xyzw.
- Geoms: those that collide (``contype`` or ``conaffinity`` non-zero), or the body's visual geoms
  where none collides (the URDF reader's collision-else-visual rule). sphere, capsule, box, cylinder
  map one to one; an ellipsoid becomes its nearest supported shape, a capsule along its longest semi-axis
  (radius: the mean of the other two) or a sphere when the semi-axes are equal within 1 %; a mesh keeps
  its file (scale and MuJoCo's re-centring undone in its origin), or its bounding box where it was given
  inline; planes and height fields (the ground) are skipped.
- End-effectors: decided from the body by :func:`morphkit.body.anatomy.complete_anatomy` (feet at the
  soles of the chains that carry it, hands and tools at the ends of the others, a head ahead of the
  body), with sites and names as hints. A side file ``<model>.morphkit.yaml`` beside the model
  replaces the guess::

      body: torso                      # which world body is the creature
      end_effectors:
        front_left: {site: palm_L, role: foot}
        nose: {link: skull, offset: [0.1, 0, 0], role: head}

- A keyframe named ``home``, ``stand``, ``standing``, ``default``, ``init`` or ``rest`` (first found in
  that order) is the rest pose; ``<contact><exclude>`` pairs, and a multi-joint body with its parent
  body (MuJoCo's parent–child filter), are never checked for self-collision.
  Mesh files that are missing (a Playground robot without its Menagerie checkout) are left out with
  one warning; primitive geoms carry the kinematics and contacts. Missing textures are drawn flat (one
  warning); a body left without mass gets MuJoCo's ``boundmass`` (kinematics do not use it).
- ``equality joint`` with a linear polynomial and a second joint becomes a mimic — of the joint that
  drives the chain where joints are tied one to the next (a telescope's stages); other equality
  constraints (tendons, welds, connects) do not act on kinematics and are skipped with a warning.

A file MuJoCo refuses becomes one :class:`~morphkit.errors.DescriptionError` naming the file and line
(MuJoCo's message gives the line where it knows it; where it does not, e.g. inside an included file
or for a missing mesh, the reader finds the element it names).

Writing (:func:`dump_mjcf`): one body per link, named like it, each joint at its body's origin, shapes
as geoms, end-effectors as sites (``<site name=... user=...>`` is not used: roles travel in a comment-free
``morphkit:role`` class name), quaternions in wxyz. Reading it back gives the same creature.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.body.anatomy import Frame, complete_anatomy
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
from morphkit.io._source import relative_mesh_path
from morphkit.io.asset_paths import asset_roots, check_mjcf_files, is_inside, outside_allowed
from morphkit.rotations import (
    quat_between_vectors,
    quat_wxyz_to_xyzw,
    quat_xyzw_to_wxyz,
    transform_inverse,
    transform_multiply,
)

__all__ = [
    "dump_mjcf",
    "link_offsets",
    "morphology_from_mjmodel",
    "mujoco_model",
    "qpos_from_q",
    "read_mjcf",
    "side_file",
    "write_mjcf",
]

# mjtJoint, mjtGeom and mjtEq values (stable across MuJoCo 2.x-4.x).
_FREE, _BALL, _SLIDE, _HINGE = 0, 1, 2, 3
_PLANE, _HFIELD, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = range(8)
_EQ_JOINT = 2
_WORLD = "world"
_ELLIPSOID_SPHERE_TOLERANCE = 0.01
_FRONT_PAW_FRACTION = 0.35
"""A hand whose rest height above the lowest foot is below this fraction of the root's is a front paw."""
_MIN_LEN = 1e-9


def side_file(path: str | os.PathLike[str]) -> Path:
    """The side file that overrides what the reader guesses for ``model.xml``: ``model.morphkit.yaml``."""
    p = Path(path)
    return p.with_name(f"{p.stem}.morphkit.yaml")


# ---------------------------------------------------------------------------------------------
# MuJoCo's compiler errors -> DescriptionError at a line
# ---------------------------------------------------------------------------------------------
def _xml_files(path: Path) -> list[Path]:
    """The model file and every file it includes (recursively, once each), for locating errors."""
    out: list[Path] = []
    todo = [path]
    base = path.resolve().parent  # MuJoCo reads includes beside the real file (read through a link too)
    while todo:
        p = todo.pop(0)
        if p in out or not p.is_file():
            continue
        out.append(p)
        try:
            text = p.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        todo += [base / f for f in re.findall(r"<include\s[^>]*file\s*=\s*[\"']([^\"']+)", text)]
    return out


def _elements(p: Path) -> list[Any]:
    from lxml import etree

    parser = etree.XMLParser(recover=True, resolve_entities=False, no_network=True, load_dtd=False)
    try:
        root = etree.parse(str(p), parser).getroot()
    except (etree.LxmlError, OSError):
        return []
    return [] if root is None else [el for el in root.iter() if isinstance(el.tag, str)]


def _is_numbers(text: str) -> bool:
    try:
        return all(math.isfinite(float(v)) for v in text.split())
    except ValueError:
        return False


def _compiler_error(exc: Exception, path: Path) -> DescriptionError:
    """MuJoCo's message, cleaned, at the file and line of the element it names."""
    raw = str(exc).strip()
    line_m = re.search(r"(?:line|Line number=)\s*(\d+)", raw)
    line = int(line_m.group(1)) if line_m else 0
    tag_m = re.search(r"Element '([\w:-]+)'", raw)
    tag = tag_m.group(1) if tag_m else None
    first = raw.splitlines()[0] if raw else "MuJoCo could not compile the model"
    message = re.sub(r"^(XML Error|Error):\s*", "", first)
    if raw.startswith("XML parse error"):
        message = "malformed XML: " + (re.search(r"Error=(\w+)", raw) or re.search(r"(.*)", raw)).group(1)
    if tag:
        message += f" (in <{tag}>)"
    files = _xml_files(path)
    where = _find(raw, files, line, tag)
    if where is None:
        where = SourceLocation(str(path), line or None)
    return DescriptionError(f"MuJoCo: {message}", location=where)


def _find(raw: str, files: list[Path], line: int, tag: str | None) -> SourceLocation | None:
    """The file and line of the element MuJoCo's message ``raw`` is about, or None."""
    if line > 0:
        # MuJoCo gives the line but not the file: the first file holding that element at that line.
        for p in files:
            if any(el.sourceline == line and (tag is None or el.tag == tag) for el in _elements(p)):
                return SourceLocation(str(p), line)
        return SourceLocation(str(files[0]) if files else None, line)
    attr_m = re.search(r"attribute '([\w:-]+)'", raw)
    tokens = re.findall(r"'([^']+)'", raw.splitlines()[0] if raw else "")
    for p in files:
        for el in _elements(p):
            if attr_m and tag and el.tag == tag:
                value = el.get(attr_m.group(1))
                if value is not None and not _is_numbers(value):
                    return SourceLocation(str(p), el.sourceline)
            elif not attr_m and any(
                v == t or v.endswith("/" + t) or t.endswith("/" + v) for v in el.attrib.values() for t in tokens
            ):
                return SourceLocation(str(p), el.sourceline)
    return None


def _compile(path: Path, shown: Path) -> Any:
    """Compile ``path`` (the real, absolute file); messages name ``shown``, the path as the user gave it."""
    import mujoco

    # Includes and asset files inside the model's folder or package (morphkit.io.asset_paths), before MuJoCo
    # reads them; meshes outside are left out as missing ones are.
    if check_mjcf_files(shown) and (model := _compile_without_missing_assets(path, shown)) is not None:
        return model
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        model = _compile_without_missing_assets(path, shown) if "Error opening file" in str(exc) else None
        if model is None:
            raise _compiler_error(exc, shown) from None
        return model


MASSLESS_BOUND = (1e-4, 1e-8)
"""Mass [kg] and inertia [kg m²] MuJoCo's compiler gives a body left without either once its missing meshes are
left out (``<compiler boundmass boundinertia>``): MuJoCo refuses a moving body without mass, and the kinematics
read here do not use masses."""


def _compile_without_missing_assets(path: Path, shown: Path) -> Any:
    """The model without what its missing asset files would give (one warning each kind), or None where none is
    missing: the geoms of missing meshes left out, missing textures drawn flat.

    Files are often shipped without their visual meshes and textures (MuJoCo Playground's robots point into a
    Menagerie checkout, a copied model folder lacks its ``assets``); their collision geoms are primitives, which is
    all kinematics needs. Bodies whose mass came from those meshes get :data:`MASSLESS_BOUND`.
    """
    import mujoco

    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError:
        return None
    base = path.resolve().parent
    folder = base / (spec.meshdir or "")
    roots = asset_roots(base)
    readable = [m for m in spec.meshes if m.file and (folder / m.file).is_file()
                and (outside_allowed() or is_inside(folder / m.file, roots))]  # outside ones left out too
    missing = [m for m in spec.meshes if m.file and m not in readable]
    texture_folder = base / (spec.texturedir or "")
    textures = []  # (texture, its first missing file)
    for t in spec.textures:
        absent = [f for f in ([t.file] if t.file else list(t.cubefiles)) if f and not (texture_folder / f).is_file()]
        if absent:
            textures.append((t, absent[0]))
    if not missing and not textures:
        return None
    if missing:
        names = {m.name for m in missing}
        geoms = [g for g in spec.worldbody.find_all(mujoco.mjtObj.mjOBJ_GEOM)
                 if g.type == mujoco.mjtGeom.mjGEOM_MESH and g.meshname in names]
        for g in geoms:
            spec.delete(g)
        for m in missing:
            spec.delete(m)
        spec.compiler.boundmass = max(spec.compiler.boundmass, MASSLESS_BOUND[0])
        spec.compiler.boundinertia = max(spec.compiler.boundinertia, MASSLESS_BOUND[1])
        warnings.warn(
            f"{shown}: {len(missing)} mesh file(s) not found (first: {missing[0].file}); reading without their "
            f"{len(geoms)} geom(s) — primitive shapes stay, so kinematics and contacts hold; renders lose those "
            "meshes", stacklevel=4)
    for t, _ in textures:  # a material keeps its texture, drawn in one colour
        t.file, t.cubefiles = "", [""] * 6
        t.builtin = mujoco.mjtBuiltin.mjBUILTIN_FLAT
        t.width, t.height = t.width or 8, t.height or 8
    if textures:
        warnings.warn(f"{shown}: {len(textures)} texture file(s) not found (first: {textures[0][1]}); drawn flat",
                      stacklevel=4)
    try:
        return spec.compile()
    except ValueError as exc:
        raise _compiler_error(exc, shown) from None


# ---------------------------------------------------------------------------------------------
# compiled model -> graph
# ---------------------------------------------------------------------------------------------
_STANCE_KEYS = ("home", "stand", "standing", "default", "init", "rest")
"""Keyframe names read as the rest pose, in order of preference (Menagerie and Playground use ``home``)."""


def _pose(pos: Any, quat_wxyz: Any) -> np.ndarray:
    return np.array([*np.asarray(pos, dtype=float), *quat_wxyz_to_xyzw(np.asarray(quat_wxyz, dtype=float))])


def _translation(v: Any) -> np.ndarray:
    return np.array([*np.asarray(v, dtype=float), 0.0, 0.0, 0.0, 1.0])


def _transform(T: np.ndarray) -> Transform:
    q = T[3:] / np.linalg.norm(T[3:])
    return Transform(tuple(float(v) for v in T[:3]), tuple(float(v) for v in q))  # type: ignore[arg-type]


def _name(model: Any, kind: Any, i: int, default: str) -> str:
    import mujoco

    return mujoco.mj_id2name(model, kind, i) or default


class _Builder:
    def __init__(self, model: Any, name: str, source: str | None, body: str | None) -> None:
        import mujoco

        self.mj = mujoco
        self.model = model
        self.source = source
        self.loc = SourceLocation(source) if source else None
        self.b = MorphologyBuilder(name, source=source)
        self.body_names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, i, f"body{i}") for i in range(model.nbody)]
        self.joint_names = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, i, "") for i in range(model.njnt)]
        self.children: dict[int, list[int]] = {i: [] for i in range(model.nbody)}
        for i in range(1, model.nbody):
            self.children[int(model.body_parentid[i])].append(i)
        self.root_body = self._pick_root(body)
        self.body_link: dict[int, str] = {}
        self.link_from_body: dict[int, np.ndarray] = {0: _translation(np.zeros(3))}
        """Per body: the pose of its body frame in its link's frame (``[p, xyzw]``)."""

    def _subtree(self, b: int) -> list[int]:
        out, todo = [], [b]
        while todo:
            i = todo.pop()
            out.append(i)
            todo += reversed(self.children[i])
        return out

    def _pick_root(self, body: str | None) -> int:
        tops = self.children[0]
        if body is not None:
            named = [i for i in tops if self.body_names[i] == body]
            if not named:
                choices = ", ".join(self.body_names[i] for i in tops) or "none"
                raise DescriptionError(f"no world body named {body!r} (world bodies: {choices})", location=self.loc)
            return named[0]
        if not tops:
            raise DescriptionError("the model has no body under <worldbody>", location=self.loc)
        root = max(tops, key=lambda i: len(self._subtree(i)))  # first of the largest
        others = [self.body_names[i] for i in tops if i != root]
        if others:
            warnings.warn(
                f"{self.loc or 'MJCF'}: reading world body {self.body_names[root]!r} as the creature; skipping "
                f"{', '.join(others)} (name another with 'body:' in {side_file(self.source or 'model.xml').name})",
                stacklevel=4,
            )
        return root

    def build(self) -> tuple[MorphologyBuilder, list[int]]:
        m = self.model
        root = self.root_body
        jnt = list(range(m.body_jntadr[root], m.body_jntadr[root] + m.body_jntnum[root]))
        free = [j for j in jnt if m.jnt_type[j] == _FREE]
        if free and len(jnt) > 1:
            raise DescriptionError(
                f"body {self.body_names[root]!r}: a free joint with other joints in one body is not supported",
                location=self.loc,
            )
        self.mimic_of = self._mimics(set(self._subtree(root)))
        at_origin = np.allclose(m.body_pos[root], 0.0) and abs(abs(float(m.body_quat[root][0])) - 1.0) < 1e-12
        if free or (not jnt and at_origin):
            self.b.set_base(BaseType.FLOATING if free else BaseType.FIXED)
            self.b.add_link(self.body_names[root], location=self.loc)
            self.body_link[root] = self.body_names[root]
            # A floating root's initial orientation (CMU humanoid: y-up turned z-up) is baked into its link,
            # so that morphkit's rest pose (identity base) stands as the file does.
            rot = np.array([0.0, 0.0, 0.0, *quat_wxyz_to_xyzw(np.asarray(m.body_quat[root], dtype=float))])
            self.link_from_body[root] = rot if free else _translation(np.zeros(3))
        else:
            self.b.set_base(BaseType.FIXED)
            self.b.add_link(_WORLD, location=self.loc)
            self.body_link[0] = _WORLD
            self._body(root)
        bodies = self._subtree(root)
        for i in bodies:
            if i != root:
                self._body(i)
        for i in bodies:
            self._shapes(i)
        self.rest_key = self._rest_from_keyframe(bodies)
        # MuJoCo never checks a body against its parent body; where a body has several joints, morphkit's
        # shape-less links between the two hide that adjacency, so it is written as an exclude.
        for i in bodies:
            parent = int(m.body_parentid[i])
            if i != self.root_body and int(m.body_jntnum[i]) > 1 and parent in self.body_link:
                self.b.exclude_collision(self.body_link[parent], self.body_link[i])
        for sig in np.asarray(m.exclude_signature, dtype=np.int64)[: m.nexclude]:
            pair = [self.body_link.get(int(b)) for b in (sig >> 16, sig & 0xFFFF)]
            if None not in pair and pair[0] != pair[1]:
                self.b.exclude_collision(*pair)  # type: ignore[arg-type]
        return self.b, bodies

    def _rest_from_keyframe(self, bodies: list[int]) -> str | None:
        """Set the rest pose from the first keyframe named like a stance; its name, or None where none is."""
        m = self.model
        keys = {_name(m, self.mj.mjtObj.mjOBJ_KEY, k, "").lower(): k for k in range(m.nkey)}
        name = next((n for n in _STANCE_KEYS if n in keys), None)
        if name is None:
            return None
        qpos = np.asarray(m.key_qpos[keys[name]], dtype=float)
        inside = set(bodies)
        rest = {}
        for j in range(m.njnt):
            if int(m.jnt_bodyid[j]) in inside and int(m.jnt_type[j]) in (_HINGE, _SLIDE) and j not in self.mimic_of:
                adr = int(m.jnt_qposadr[j])
                if abs(qpos[adr] - m.qpos0[adr]) > 1e-12:
                    rest[self._joint_name(j)] = float(qpos[adr] - m.qpos0[adr])
        self.b.set_rest_pose(rest, location=self.loc)
        return _name(m, self.mj.mjtObj.mjOBJ_KEY, keys[name], name)

    def _body(self, i: int) -> None:
        m = self.model
        name = self.body_names[i]
        parent = int(m.body_parentid[i])
        parent_link = self.body_link[parent]
        # The body frame in its parent link frame (the parent's link frame sits at its anchor).
        T = transform_multiply(self.link_from_body[parent], _pose(m.body_pos[i], m.body_quat[i]))
        joints = list(range(m.body_jntadr[i], m.body_jntadr[i] + m.body_jntnum[i]))
        if not joints:
            self.b.add_link(name, location=self.loc)
            origin = _transform(T)
            self.b.add_joint(f"{name}_fixed", JointType.FIXED, parent_link, name, origin=origin, location=self.loc)
            self.body_link[i] = name
            self.link_from_body[i] = _translation(np.zeros(3))
            return
        anchor = np.zeros(3)
        link = parent_link
        for k, j in enumerate(joints):
            jname = self._joint_name(j)
            jtype = int(m.jnt_type[j])
            if jtype == _FREE:
                raise DescriptionError(
                    f"joint {jname!r} (body {name!r}): a free joint is supported only on the creature's top body "
                    "(as its floating base)",
                    location=self.loc,
                )
            new_anchor = anchor if jtype == _SLIDE else np.asarray(m.jnt_pos[j], dtype=float)
            origin = transform_multiply(T, _translation(new_anchor)) if k == 0 else _translation(new_anchor - anchor)
            anchor = new_anchor
            child = name if k == len(joints) - 1 else f"{name}__{jname}"
            self.b.add_link(child, location=self.loc)
            kw: dict[str, Any] = {"origin": _transform(origin), "location": self.loc, "mimic": self.mimic_of.get(j)}
            if jtype == _BALL:
                self.b.add_joint(jname, JointType.SPHERICAL, link, child, **kw)
            else:
                ref = float(m.qpos0[m.jnt_qposadr[j]])
                limited = bool(m.jnt_limited[j])
                lo, hi = (float(v) - ref for v in m.jnt_range[j])
                if jtype == _SLIDE and not limited:
                    raise DescriptionError(
                        f"joint {jname!r} (body {name!r}): an unlimited slide joint has no morphkit equivalent "
                        "(prismatic joints need a range); give it limited=\"true\" range=\"lo hi\"",
                        location=self.loc,
                    )
                kind = JointType.REVOLUTE if limited else JointType.CONTINUOUS
                kind = JointType.PRISMATIC if jtype == _SLIDE else kind
                limit = Limit(lo, hi) if limited else None
                self.b.add_joint(jname, kind, link, child, axis=tuple(m.jnt_axis[j]), limit=limit, **kw)
            link = child
        self.body_link[i] = name
        self.link_from_body[i] = _translation(-anchor)

    # -- geoms
    def _shapes(self, i: int) -> None:
        m = self.model
        geoms = [g for g in range(m.body_geomadr[i], m.body_geomadr[i] + m.body_geomnum[i]) if m.body_geomadr[i] >= 0]
        geoms = [g for g in geoms if m.geom_type[g] not in (_PLANE, _HFIELD) and m.geom_type[g] <= _MESH]
        colliding = [g for g in geoms if m.geom_contype[g] or m.geom_conaffinity[g]]
        for g in colliding or geoms:
            shape = self._shape(g, self.link_from_body[i])
            if shape is not None:
                self.b.add_shape(self.body_link[i], shape, location=self.loc)

    def _shape(self, g: int, link_from_body: np.ndarray) -> Shape | None:
        m = self.model
        T = transform_multiply(link_from_body, _pose(m.geom_pos[g], m.geom_quat[g]))
        size = np.asarray(m.geom_size[g], dtype=float)
        t = int(m.geom_type[g])
        if t == _SPHERE:
            return Shape(ShapeType.SPHERE, _transform(T), radius=float(size[0]))
        if t in (_CAPSULE, _CYLINDER):
            kind = ShapeType.CAPSULE if t == _CAPSULE else ShapeType.CYLINDER
            return Shape(kind, _transform(T), radius=float(size[0]), length=2.0 * float(size[1]))
        if t == _BOX:
            return Shape(ShapeType.BOX, _transform(T), size=tuple(float(v) for v in 2.0 * size))  # type: ignore[arg-type]
        if t == _ELLIPSOID:
            return _ellipsoid(T, size)
        return self._mesh(g, T)

    def _mesh(self, g: int, T: np.ndarray) -> Shape:
        m = self.model
        mesh = int(m.geom_dataid[g])
        adr = int(m.mesh_pathadr[mesh]) if hasattr(m, "mesh_pathadr") else -1
        if adr < 0:
            # An inline mesh (vertices in the XML): morphkit's shapes need a file, so keep its bounding box.
            v = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
            lo, hi = v.min(axis=0), v.max(axis=0)
            center = transform_multiply(T, _translation(0.5 * (lo + hi)))
            size = tuple(float(max(s, 1e-6)) for s in hi - lo)
            return Shape(ShapeType.BOX, _transform(center), size=size)  # type: ignore[arg-type]
        path = self._mesh_file(m.paths[adr:].split(b"\0", 1)[0].decode())
        # MuJoCo moved the scaled file vertices into the mesh's inertial frame (mesh_pos, mesh_quat) and
        # compensated in the geom pose; undo it so that the file's own vertices land where MuJoCo draws them.
        T = transform_multiply(T, transform_inverse(_pose(m.mesh_pos[mesh], m.mesh_quat[mesh])))
        scale = tuple(float(v) for v in m.mesh_scale[mesh])
        return Shape(ShapeType.MESH, _transform(T), mesh=path, scale=scale)  # type: ignore[arg-type]

    def _mesh_file(self, stored: str) -> str:
        """The absolute path of a mesh file as MuJoCo stored it, warning when it is not there.

        MuJoCo stores a mesh's path joined to the folder of the path it compiled (``mujoco_model`` compiles the
        real absolute path, so these are absolute); a model compiled elsewhere from a relative path stores
        one relative to the working folder of that time, tried before the description's folder.
        """
        if os.path.isabs(stored):
            candidates = [stored]
        else:
            base = Path(self.source).resolve().parent if self.source else Path.cwd()
            candidates = [os.path.abspath(stored), os.fspath(base / stored)]
        found = next((c for c in candidates if os.path.isfile(c)), None)
        if found is None:
            where = f"{self.loc}: " if self.loc is not None else ""
            warnings.warn(f"{where}mesh file not found: {os.path.normpath(candidates[-1])}", stacklevel=2)
        return os.path.normpath(found or candidates[-1])

    # -- mimic joints
    def _mimics(self, bodies: set[int]) -> dict[int, Mimic]:
        """Mimic of each joint tied to another by a linear ``equality joint`` (by MuJoCo joint index)."""
        m = self.model
        tied: dict[int, tuple[int, float, float]] = {}
        for e in range(m.neq):
            eq_name = _name(m, self.mj.mjtObj.mjOBJ_EQUALITY, e, f"equality {e}")
            if int(m.eq_type[e]) != _EQ_JOINT:
                warnings.warn(
                    f"{self.loc or 'MJCF'}: skipping equality {eq_name!r}: only joint equalities act on kinematics",
                    stacklevel=4,
                )
                continue
            j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
            coef = np.asarray(m.eq_data[e][:5], dtype=float)
            if j2 < 0 or np.abs(coef[2:]).max() > 0 or int(m.jnt_bodyid[j1]) not in bodies:
                warnings.warn(
                    f"{self.loc or 'MJCF'}: skipping equality {eq_name!r}: "
                    "morphkit's mimic is linear in a second joint",
                    stacklevel=4,
                )
                continue
            # qpos1 = c0 + c1 qpos2, and morphkit's q = qpos - ref on both sides.
            ref1, ref2 = float(m.qpos0[m.jnt_qposadr[j1]]), float(m.qpos0[m.jnt_qposadr[j2]])
            tied[j1] = (j2, float(coef[1]), float(coef[0] + coef[1] * ref2 - ref1))
        out: dict[int, Mimic] = {}
        for j1, (j2, a, b) in tied.items():
            # a chain (Menagerie's Stretch ties its telescope's four stages one to the next) is followed to the joint
            # that drives it: q1 = a q2 + b with q2 = a2 q3 + b2 gives q1 = a a2 q3 + a b2 + b
            seen = {j1}
            while j2 in tied and j2 not in seen:
                seen.add(j2)
                j3, a2, b2 = tied[j2]
                j2, a, b = j3, a * a2, a * b2 + b
            out[j1] = Mimic(self._joint_name(j2), a, b)
        return out

    def _joint_name(self, j: int) -> str:
        m = self.model
        if self.joint_names[j]:
            return self.joint_names[j]
        body = int(m.jnt_bodyid[j])
        return f"{self.body_names[body]}_joint{j - int(m.body_jntadr[body])}"

    # -- end-effectors
    def link_offset(self, body: int, pos: Any) -> np.ndarray:
        """A point given in ``body``'s MuJoCo frame, in its link's frame."""
        return transform_multiply(self.link_from_body[body], _translation(pos))[:3]

    def sites(self, bodies: list[int]) -> list[Frame]:
        """The named sites on the creature's bodies, as frames on their links (hints for the end-effector guess)."""
        m = self.model
        inside = set(bodies)
        out = []
        for s in range(m.nsite):
            body = int(m.site_bodyid[s])
            name = _name(m, self.mj.mjtObj.mjOBJ_SITE, s, "")
            if body in inside and name:
                offset = tuple(float(v) for v in self.link_offset(body, m.site_pos[s]))
                out.append(Frame(name, self.body_link[body], offset))  # type: ignore[arg-type]
        return out


def _ellipsoid(T: np.ndarray, semi: np.ndarray) -> Shape:
    """An ellipsoid's nearest supported shape: a sphere (equal semi-axes) or a capsule along the longest one."""
    if semi.max() - semi.min() <= _ELLIPSOID_SPHERE_TOLERANCE * semi.max():
        return Shape(ShapeType.SPHERE, _transform(T), radius=float(semi.mean()))
    k = int(np.argmax(semi))
    radius = float(np.delete(semi, k).mean())
    axis = np.eye(3)[k]
    T = transform_multiply(T, np.array([0.0, 0.0, 0.0, *quat_between_vectors(np.array([0.0, 0.0, 1.0]), axis)]))
    return Shape(ShapeType.CAPSULE, _transform(T), radius=radius, length=max(2.0 * (float(semi[k]) - radius), 0.0))


def _side_end_effectors(bld: _Builder, path: Path, doc: Any, reader: Any) -> None:
    import mujoco

    m = bld.model
    ees = reader.mapping(doc["end_effectors"], "end_effectors", reader.line_of(doc, "end_effectors"))
    for ee_name, value in ees.items():
        line = ees.key_lines[ee_name]
        what = f"end-effector {ee_name!r}"
        item = reader.mapping(value, what, line)
        reader.keys(item, what, ("site", "link", "offset", "role"), line=line)
        role = reader.enum(EndEffectorRole, item.get("role", "tool"), "end-effector role", reader.line_of(item, "role"))
        if ("site" in item) == ("link" in item):
            raise reader.error(f"{what}: give either 'site' or 'link'", line)
        if "site" in item:
            site = reader.name(item["site"], f"{what} site", reader.line_of(item, "site"))
            s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
            if s < 0 or int(m.site_bodyid[s]) not in bld.body_link:
                raise reader.error(f"{what}: no site {site!r} on the creature", reader.line_of(item, "site"))
            body = int(m.site_bodyid[s])
            link, offset = bld.body_link[body], tuple(bld.link_offset(body, m.site_pos[s]))
        else:
            link = reader.name(item["link"], f"{what} link", reader.line_of(item, "link"))
            offset = (0.0, 0.0, 0.0)
            if "offset" in item:
                offset = reader.vector(item["offset"], 3, f"{what} offset", reader.line_of(item, "offset"))
            body = next((b for b, n in bld.body_link.items() if n == link), None)
            if body is not None:  # an offset is written in the MuJoCo body frame
                offset = tuple(bld.link_offset(body, offset))
        bld.b.add_end_effector(str(ee_name), link, offset=offset, role=role, location=SourceLocation(str(path), line))


def _read_side_file(path: Path) -> tuple[Any, Any] | None:
    if not path.is_file():
        return None
    from morphkit.io._source import read_text
    from morphkit.io.yaml_format import DocumentReader, load_document

    reader = DocumentReader(str(path))
    doc = reader.mapping(load_document(read_text(path, what="YAML"), str(path)), "MJCF side file", 1)
    reader.keys(doc, "MJCF side file", ("body", "end_effectors"))
    return doc, reader


def morphology_from_mjmodel(
    model: Any, *, name: str | None = None, source: str | None = None, side: str | os.PathLike[str] | None = None
) -> Morphology:
    """Build a :class:`Morphology` from a compiled ``mujoco.MjModel`` (see the module notes).

    Args:
        model: The compiled model (e.g. ``physics.model.ptr`` of a dm_control ``Physics``).
        name: Creature name (default: the model's name).
        source: Path of the MJCF file (error locations, mesh paths).
        side: Side file overriding the world body and the end-effectors (see :func:`side_file`).

    Raises:
        DescriptionError: a joint morphkit cannot express (free joint below the top body, unlimited slide).
        GraphError: structural problems found by :class:`~morphkit.graph.MorphologyBuilder`.
    """

    side_doc = _read_side_file(Path(side)) if side is not None else None
    body = None
    if side_doc is not None and "body" in side_doc[0]:
        doc, reader = side_doc
        body = reader.name(doc["body"], "body", reader.line_of(doc, "body"))
    model_name = name or _model_name(model) or (Path(source).stem if source else "mjcf")
    bld = _Builder(model, model_name, source, body)
    _, bodies = bld.build()
    if side_doc is not None and "end_effectors" in side_doc[0]:
        _side_end_effectors(bld, Path(side), *side_doc)  # type: ignore[arg-type]
        return bld.b.build()
    reference = f"keyframe {bld.rest_key!r}" if bld.rest_key else "q = 0"
    return complete_anatomy(bld.b.build(), frames=bld.sites(bodies), base_declared=True, reference=reference)


def _model_name(model: Any) -> str | None:
    raw = bytes(model.names[: model.names.index(b"\0")] if b"\0" in model.names else model.names)
    return raw.decode() or None


def link_offsets(model: Any, m: Morphology) -> dict[str, np.ndarray]:
    """Per link of ``m`` read from ``model``: its origin in its MuJoCo body's frame [m] (the last joint's anchor).

    A link that is a MuJoCo body sits at ``xpos + xmat @ offset``; links of intermediate joints are
    not listed.
    """
    import mujoco

    out = {}
    for link in m.links:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.name)
        if b < 0:
            continue
        joints = range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        anchor = np.zeros(3)
        for j in joints:
            if model.jnt_type[j] in (_HINGE, _BALL):
                anchor = np.asarray(model.jnt_pos[j], dtype=float)
        out[link.name] = anchor
    return out


def mujoco_model(path: str | os.PathLike[str]) -> Any:
    """The compiled ``mujoco.MjModel`` of an MJCF file, MuJoCo's errors as :class:`DescriptionError` at a line."""
    p = Path(path)
    if not p.is_file():
        raise DescriptionError(f"MJCF file not found: {path}", location=SourceLocation(str(path)))
    try:
        import mujoco  # noqa: F401
    except ImportError:
        raise DescriptionError(
            "reading MJCF needs MuJoCo: pip install 'morphkit[mujoco]'", location=SourceLocation(str(path))
        ) from None
    # MuJoCo keeps asset paths joined to the folder of the path it is given: compiled from the real, absolute
    # path, a model read by a relative path or through a symbolic link finds the same files and stores them
    # absolute (the mesh paths of its shapes), as the asset roots (resolved) and the other readers do.
    return _compile(p.resolve(), shown=p)


def read_mjcf(path: str | os.PathLike[str]) -> Morphology:
    """Read an MJCF file through MuJoCo's compiler (see the module notes).

    Raises:
        DescriptionError: MuJoCo refuses the file (naming file and line), or it holds a joint morphkit
            cannot express.
    """
    model = mujoco_model(path)
    side = side_file(path)
    return morphology_from_mjmodel(model, source=str(path), side=side if side.is_file() else None)


def qpos_from_q(m: Morphology, q: np.ndarray, model: Any) -> np.ndarray:
    """MuJoCo ``qpos`` [T, nq] of morphkit coordinates ``q`` [T, coordinate_count], for replay in ``model``.

    ``model`` is the compiled model ``m`` was read from, or the one :func:`dump_mjcf` wrote for it: joints
    are matched by name, ``ref`` is added back (``qpos = q + qpos0``), quaternions go xyzw → wxyz, the
    floating base drives the root body's free joint and mimic joints get their followed value. Joints of
    the model that ``m`` does not have (a skipped ``ball``) stay at ``qpos0``.

    Raises:
        DescriptionError: a moving joint of ``m`` is not in ``model``, or ``q`` has the wrong width.
    """
    import mujoco

    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != m.coordinate_count:
        raise DescriptionError(f"{m.name}: q must be [T, {m.coordinate_count}], got {list(q.shape)}")
    out = np.tile(np.asarray(model.qpos0, dtype=float), (len(q), 1))

    def address(name: str, kind: Any) -> int:
        i = mujoco.mj_name2id(model, kind, name)
        if i < 0:
            raise DescriptionError(f"{m.name}: the MuJoCo model has no {kind.name[6:].lower()} {name!r}")
        return i

    if m.base == BaseType.FLOATING:
        b = address(m.root, mujoco.mjtObj.mjOBJ_BODY)
        free = [j for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
                if model.jnt_type[j] == _FREE]
        if not free:
            raise DescriptionError(f"{m.name}: the MuJoCo model's body {m.root!r} has no free joint")
        a = int(model.jnt_qposadr[free[0]])
        out[:, a : a + 3] = q[:, :3]
        # The reader baked the root body's initial rotation into the root link: undo it.
        rot = np.zeros((len(q), 7))
        rot[:, 3:] = quat_wxyz_to_xyzw(np.asarray(model.body_quat[b], dtype=float))
        body_pose = transform_multiply(np.concatenate([np.zeros((len(q), 3)), q[:, 3:7]], axis=1), rot)
        out[:, a + 3 : a + 7] = quat_xyzw_to_wxyz(body_pose[:, 3:])
    starts = m.joint_q_start
    for ji, j in enumerate(m.joints):
        if j.type == JointType.FIXED:
            continue
        a = int(model.jnt_qposadr[address(j.name, mujoco.mjtObj.mjOBJ_JOINT)])
        if j.type == JointType.SPHERICAL:
            out[:, a : a + 4] = quat_xyzw_to_wxyz(q[:, starts[ji] : starts[ji] + 4])
        elif j.mimic is not None:
            target = m.joint_index(j.mimic.joint)
            out[:, a] += j.mimic.multiplier * q[:, starts[target]] + j.mimic.offset
        else:
            out[:, a] += q[:, starts[ji]]
    return out


# ---------------------------------------------------------------------------------------------
# the writer
# ---------------------------------------------------------------------------------------------
def _fmt(values: Sequence[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


def _pose_attrs(t: Transform) -> str:
    out = ""
    if any(t.xyz):
        out += f' pos="{_fmt(t.xyz)}"'
    if abs(abs(t.quat[3]) - 1.0) > 1e-15:
        out += f' quat="{_fmt(quat_xyzw_to_wxyz(np.asarray(t.quat)))}"'
    return out


_TINY_INERTIAL = '<inertial pos="0 0 0" mass="0.001" diaginertia="1e-06 1e-06 1e-06"/>'


def _geom(s: Shape, target: str | os.PathLike[str] | None, meshes: dict[str, str]) -> str:
    pose = _pose_attrs(s.origin)
    if s.type == ShapeType.SPHERE:
        return f'<geom type="sphere" size="{_fmt([s.radius])}"{pose}/>'
    if s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        kind = "capsule" if s.type == ShapeType.CAPSULE else "cylinder"
        return f'<geom type="{kind}" size="{_fmt([s.radius, s.length / 2])}"{pose}/>'
    if s.type == ShapeType.BOX:
        return f'<geom type="box" size="{_fmt(np.asarray(s.size) / 2)}"{pose}/>'
    key = f"{s.mesh}|{_fmt(s.scale)}"
    if key not in meshes:
        meshes[key] = f"mesh{len(meshes)}"
    return f'<geom type="mesh" mesh="{meshes[key]}"{pose}/>'


def dump_mjcf(m: Morphology, *, target: str | os.PathLike[str] | None = None) -> str:
    """The MJCF text of ``m``: one body per link, named like it, with its joint at the body origin.

    Fixed joints weld the child body; revolute → ``hinge`` (``limited`` with ``range``), continuous →
    unlimited ``hinge``, prismatic → ``slide``, spherical → ``ball``, mimic → ``equality joint``; a
    floating base is a ``freejoint`` on the root; a fixed base's root link named ``world`` (what the
    reader makes of a fixed model) is MuJoCo's world body. Shapes become geoms (density 1000 gives
    masses); shape-less bodies get a tiny inertial so that MuJoCo's compiler accepts them.
    End-effectors become sites named like them (roles are not kept: MJCF has none); a rest pose
    becomes the keyframe ``home``.

    Args:
        m: The creature.
        target: File the text will be saved as; absolute mesh paths are written relative to its folder.

    Raises:
        DescriptionError: a planar or wheeled base (MuJoCo would need slide/hinge root joints; not written).
    """
    if m.base not in (BaseType.FIXED, BaseType.FLOATING):
        raise DescriptionError(
            f"{m.name}: a {m.base.name.lower()} base has no MJCF writer yet (fixed and floating bases only)",
            location=SourceLocation(m.source) if m.source else None,
        )
    children: dict[str, list[Any]] = {link.name: [] for link in m.links}
    for j in m.joints:
        children[j.parent].append(j)
    ees: dict[str, list[Any]] = {}
    for ee in m.end_effectors:
        ees.setdefault(ee.link, []).append(ee)
    meshes: dict[str, str] = {}
    body_lines: list[str] = []
    rest = dict(m.rest_pose)
    qpos: list[float] = []  # the rest pose as MuJoCo's qpos, in the order the joints are written

    def body(name: str, joint: Any, depth: int) -> tuple[int, str | None]:
        """Write a body's opening lines; its children's depth less one and its closing line (``None``: none)."""
        pad = "  " * depth
        link = m.link(name)
        world = joint is None and name == _WORLD and m.base == BaseType.FIXED
        if world:  # MuJoCo's own world body: its contents go straight into <worldbody>
            pad = "  " * (depth - 1)
            depth -= 1
        else:
            pose = "" if joint is None else _pose_attrs(joint.origin)
            body_lines.append(f"{pad}<body name={quoteattr(name)}{pose}>")
        if joint is None and m.base == BaseType.FLOATING:
            body_lines.append(f'{pad}  <freejoint name="base"/>')
            qpos.extend([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        elif joint is not None and joint.type == JointType.SPHERICAL:
            body_lines.append(f"{pad}  <joint name={quoteattr(joint.name)} type=\"ball\"/>")
            qpos.extend([1.0, 0.0, 0.0, 0.0])
        elif joint is not None and joint.type != JointType.FIXED:
            qpos.append(rest.get(joint.name, 0.0))
            kind = "slide" if joint.type == JointType.PRISMATIC else "hinge"
            rng = ""
            if joint.limit is not None:
                rng = f' limited="true" range="{_fmt([joint.limit.lower, joint.limit.upper])}"'
            elif joint.type == JointType.CONTINUOUS:
                rng = ' limited="false"'
            body_lines.append(
                f'{pad}  <joint name={quoteattr(joint.name)} type="{kind}" axis="{_fmt(joint.axis)}"{rng}/>'
            )
        if not link.shapes and not world:
            body_lines.append(f"{pad}  {_TINY_INERTIAL}")
        for s in link.shapes:
            body_lines.append(f"{pad}  {_geom(s, target, meshes)}")
        for ee in ees.get(name, ()):
            body_lines.append(f'{pad}  <site name={quoteattr(ee.name)} pos="{_fmt(ee.offset)}" size="0.01"/>')
        return depth, None if world else f"{pad}</body>"

    # depth first with a stack, not recursion: a chain of a thousand links would exceed Python's recursion limit
    stack: list[tuple[str, Any, int] | str] = [(m.root, None, 2)]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            body_lines.append(item)  # a closing tag, once the body's children are written
            continue
        depth, close = body(*item)
        if close is not None:
            stack.append(close)
        stack += [(child.child, child, depth + 1) for child in reversed(children[item[0]])]
    lines = [f"<mujoco model={quoteattr(m.name)}>", '  <compiler angle="radian" autolimits="false"/>']
    if meshes:
        lines.append("  <asset>")
        for key, mesh_name in meshes.items():
            path, scale = key.split("|")
            rel = relative_mesh_path(path, target)
            lines.append(f"    <mesh name={quoteattr(mesh_name)} file={quoteattr(rel)} scale=\"{scale}\"/>")
        lines.append("  </asset>")
    lines += ["  <worldbody>", *body_lines, "  </worldbody>"]
    mimics = [j for j in m.joints if j.mimic is not None]
    if mimics:
        lines.append("  <equality>")
        for j in mimics:
            mm = j.mimic
            lines.append(
                f"    <joint joint1={quoteattr(j.name)} joint2={quoteattr(mm.joint)}"
                f' polycoef="{_fmt([mm.offset, mm.multiplier, 0, 0, 0])}"/>'
            )
        lines.append("  </equality>")
    if m.collision_excludes:
        lines.append("  <contact>")
        lines += [f"    <exclude body1={quoteattr(a)} body2={quoteattr(b)}/>" for a, b in m.collision_excludes]
        lines.append("  </contact>")
    if rest:  # the reader takes a keyframe named "home" as the rest pose
        lines += ["  <keyframe>", f'    <key name="home" qpos="{_fmt(qpos)}"/>', "  </keyframe>"]
    lines.append("</mujoco>")
    return "\n".join(lines) + "\n"


def write_mjcf(m: Morphology, path: str | os.PathLike[str]) -> None:
    """Write ``m`` as MJCF, atomically (see :func:`dump_mjcf`)."""
    atomic_write_text(path, dump_mjcf(m, target=path))
