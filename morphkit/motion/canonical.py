"""The canonical human: one skeleton every human clip is mapped onto before a trainer sees it.

**The canonical human** (:data:`CANONICAL_HUMAN`) is the shipped ``human`` (``morphologies/human``):
22 ball-jointed links in the topology of the CMU 22-joint skeleton the real data uses, with Mixamo's
link names (Hips, Spine, Spine1, Spine2, Neck, Head; Left/Right Shoulder, Arm, ForeArm, Hand; UpLeg,
Leg, Foot, ToeBase), an adult of 1.75 m whose link frames are parallel to the world in its T-pose
rest. Ours: it is the skeleton of the embedded default human motion, so those clips (and every ACE run
trained on them) pass through unchanged, and CMU-22 maps onto it joint for joint.

**Convention tables** (:class:`SkeletonMap`, one YAML file each) say which link, or point, of a source
skeleton each canonical link is: a link name (a BVH joint), an end-effector name (a BVH End Site,
``<joint>_end``), or ``[a, b, w]``, the point ``w`` of the way from link ``a`` to link ``b``, turning
with ``a`` (for a joint the source lacks). Shipped (``morphkit/motion/data/conventions/``): ``cmu22``,
``cmu_daz43``, ``bandai_namco``, ``mixamo`` (also the canonical human's own names) and ``lafan1``. A
table a user writes (:func:`read_skeleton_map`) joins them and may add BVH reading options (``scale``,
``up``, ``facing``). A table applies when every source name it uses is a link or end-effector of the
clip; a ``namespace:`` prefix (``mixamorig:Hips``) is ignored. Without one, the correspondences are
guessed from the skeleton's shape (:func:`guess_skeleton_map`) with a warning that lists them; a clip
without two legs, two arms and a head by name or by shape is refused with one error naming what is
missing.

**Mapping**, in two steps:

1. *Re-expression on the canonical topology* (:func:`plan_skeleton_map`, :func:`map_skeleton_motion`;
   NKN's data uses it to put Bandai Namco clips on CMU's 22 joints). For template link $l$ with source
   world rotation $R_l(t)$, source rest rotation $R_l^0$ and a constant $A_l$ fitted (Kabsch) to carry
   the template's rest bone directions from $l$ to its children onto the source's rest bones, the
   mapped link turns as $W_l(t) = R_l(t)\\,(R_l^0)^{-1} A_l$: the world-space orientation of the mapped
   bone, aware of both rest poses (a Bandai rig whose bones lie along local x at rest maps like a
   T-posed CMU one), never a copy of local Euler angles. With the source's bone lengths as offsets
   ($A_p^{-1} b^0$, $b^0$ the source's rest bone vectors) every mapped link lies exactly where the
   source's does.
2. *Canonical proportions* (:func:`to_canonical`). Each canonical link takes $W_l(t)$ with the canonical
   human's own bone lengths. The root is placed so that the midpoint of the two hip joints is the
   source's, scaled by $s = L_c / L_s$, where $L$ is the leg length thigh + shank (hip to knee to
   ankle joints, mean of both sides; :func:`thigh_shank_length`). Ours: ACE normalises lengths by body length;
   we scale by the legs because they set a clip's root height and stride, so a child and a tall adult
   drive a creature alike, and because every convention places its hip, knee and ankle joints alike
   (roots, spines, heads and toes differ). Then the clip is grounded: its lowest foot end-effector
   over the clip touches z = 0.

Units, up axis and facing come from the reader (metres, z up, x forward; detected per BVH file, or a
user table's ``scale``/``up``/``facing``). The frame rate is kept: trainers resample to their own.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.errors import ConfigError, MotionFormatError, SourceLocation
from morphkit.graph import BaseType, EndEffectorRole, JointType, Morphology, ShapeType, Transform
from morphkit.graph.kinematics import link_poses
from morphkit.motion.motion import Motion
from morphkit.rotations import (
    matrix_from_quat,
    quat_between_vectors,
    quat_conjugate,
    quat_from_matrix,
    quat_multiply,
    quat_rotate,
)
from morphkit.yaml_loader import YamlMapping, load_yaml_file, plain_data

__all__ = [
    "CANONICAL_HUMAN",
    "TPOSE_TOLERANCE",
    "MapPlan",
    "SkeletonMap",
    "canonical_human",
    "canonical_record",
    "find_skeleton_map",
    "guess_skeleton_map",
    "is_canonical",
    "map_skeleton_motion",
    "mapped_poses",
    "plan_skeleton_map",
    "read_canonical_motion",
    "read_skeleton_map",
    "skeleton_maps",
    "thigh_shank_length",
    "to_canonical",
]

CANONICAL_HUMAN = "human"
"""The shipped morphology every human clip is mapped onto (see the module docstring)."""

TPOSE_TOLERANCE = float(np.radians(30.0))
"""A source rest bone within this angle [rad] of the canonical T-pose's is taken to be in that T-pose."""

Source = str | tuple[str, str, float]
"""Where a template link comes from: a source link or end-effector name, or ``(a, b, w)``."""

_READ_OPTIONS = ("scale", "up", "facing")
_LEFT_RIGHT = ("Left", "Right")


# ---------------------------------------------------------------------------------------------
# convention tables
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SkeletonMap:
    """A convention table: template link → where it comes from in a source skeleton."""

    name: str
    links: Mapping[str, Source]
    """Template link → a source link or end-effector name, or ``(a, b, w)``: the point ``w`` of the way
    from source link ``a`` to ``b``, turning with ``a``."""
    description: str = ""
    path: str | None = None
    """The YAML file it was read from (``None``: built in code)."""
    read_options: Mapping[str, Any] = field(default_factory=dict)
    """BVH reading options the convention implies (``scale``, ``up``, ``facing``; empty: detected)."""

    def source_names(self) -> tuple[str, ...]:
        """Every source name the table uses, in table order, once each."""
        names = [n for v in self.links.values() for n in ((v,) if isinstance(v, str) else v[:2])]
        return tuple(dict.fromkeys(names))

    def resolve(self, source: Morphology) -> dict[str, Source] | None:
        """The table with its names spelled as ``source`` spells them (``None`` when one is missing).

        A name matches a link or end-effector of that name, or one whose name after a ``namespace:``
        prefix is that name.
        """
        known = {*source.link_names, *(e.name for e in source.end_effectors)}
        stripped: dict[str, str | None] = {}
        for n in known:
            short = n.rsplit(":", 1)[-1]
            stripped[short] = None if short in stripped and stripped[short] != n else n

        def spell(name: str) -> str | None:
            return name if name in known else stripped.get(name)

        out: dict[str, Source] = {}
        for link, spec in self.links.items():
            if isinstance(spec, str):
                s = spell(spec)
                if s is None:
                    return None
                out[link] = s
            else:
                a, b = spell(spec[0]), spell(spec[1])
                if a is None or b is None:
                    return None
                out[link] = (a, b, spec[2])
        return out

    def applies(self, source: Morphology, template: Morphology) -> bool:
        """Whether this table takes ``source``'s links onto ``template``'s."""
        return set(self.links) == set(template.link_names) and self.resolve(source) is not None

    def describe(self) -> str:
        """``template=source`` pairs, for messages."""
        return ", ".join(f"{k}={v if isinstance(v, str) else f'{v[0]}..{v[1]}@{v[2]:g}'}"
                         for k, v in self.links.items())


def _key_lines(data: Any) -> dict[str, int]:
    """1-based line of every key of a loaded table and under its ``links``."""
    lines: dict[str, int] = {}
    if isinstance(data, YamlMapping):
        for k, v in data.items():
            lines[str(k)] = data.key_lines[k]
            if k == "links" and isinstance(v, YamlMapping):
                for kk in v:
                    lines[f"links.{kk}"] = v.key_lines[kk]
    return lines


def read_skeleton_map(path: str | os.PathLike[str]) -> SkeletonMap:
    """Read a convention table (YAML: ``name``, ``links``; optional ``description``, ``scale``, ``up``,
    ``facing``; see the module docstring).

    Raises:
        ConfigError: an unreadable file, or a malformed table (file and line, the offending value).
    """
    where = SourceLocation(os.fspath(path))
    data = load_yaml_file(path, what="convention table", malformed="not YAML")
    lines = _key_lines(data)
    if not isinstance(data, dict) or not isinstance(data.get("links"), dict) or not data["links"]:
        raise ConfigError("a convention table needs a 'links' mapping: template link -> source name or [a, b, w]",
                          location=where.at_line(lines.get("links")))
    links: dict[str, Source] = {}
    for k, v in data["links"].items():
        at = where.at_line(lines.get(f"links.{k}"))
        if isinstance(v, str) and v:
            links[str(k)] = v
        elif (isinstance(v, list) and len(v) == 3 and all(isinstance(x, str) for x in v[:2])
              and isinstance(v[2], (int, float)) and not isinstance(v[2], bool) and 0.0 <= float(v[2]) <= 1.0):
            links[str(k)] = (v[0], v[1], float(v[2]))
        else:
            raise ConfigError(f"link {k!r}: expected a source name or [a, b, w] with 0 <= w <= 1, got {v!r}",
                              location=at)
    options = {k: plain_data(data[k]) for k in _READ_OPTIONS if data.get(k) is not None}
    unknown = sorted(set(data) - {"name", "description", "links", *_READ_OPTIONS})
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join(map(repr, unknown))}; expected: name, description, links, "
                          f"{', '.join(_READ_OPTIONS)}", location=where.at_line(lines.get(unknown[0])))
    return SkeletonMap(str(data.get("name") or Path(path).stem), links, str(data.get("description") or ""),
                       os.fspath(path), options)


@functools.lru_cache(maxsize=1)
def _shipped_maps() -> tuple[SkeletonMap, ...]:
    root = resources.files("morphkit.motion").joinpath("data/conventions")
    with resources.as_file(root) as base:
        return tuple(read_skeleton_map(p) for p in sorted(Path(base).glob("*.yaml")))


def skeleton_maps(folder: str | os.PathLike[str] | None = None) -> list[SkeletonMap]:
    """The convention tables in ``folder`` (default: the shipped ones, read once), by file name."""
    if folder is None:
        return list(_shipped_maps())
    return [read_skeleton_map(p) for p in sorted(Path(folder).glob("*.yaml"))]


def find_skeleton_map(source: Morphology, template: Morphology,
                      maps: Iterable[SkeletonMap] | None = None) -> SkeletonMap | None:
    """The first table in ``maps`` (default: the shipped ones) that takes ``source`` onto ``template``."""
    return next((m for m in (skeleton_maps() if maps is None else maps) if m.applies(source, template)), None)


# ---------------------------------------------------------------------------------------------
# forward kinematics (NumPy; BVH skeletons need no FK kernel)
# ---------------------------------------------------------------------------------------------
def _link_poses(m: Morphology, q: np.ndarray) -> np.ndarray:
    """World link poses ``T_world_link`` [T, L, 7] of coordinates ``q`` [T, C].

    The NumPy reference FK (:func:`~morphkit.graph.kinematics.link_poses`) for a floating base with ball and
    fixed joints (every BVH skeleton); other morphologies go through the FK kernels.
    """
    if m.base != BaseType.FLOATING or any(j.type not in (JointType.SPHERICAL, JointType.FIXED) for j in m.joints):
        from morphkit.motion._fk import link_poses_and_end_effectors

        return link_poses_and_end_effectors(m, q)[0]
    return link_poses(m, q)


def _ee_positions(m: Morphology, poses: np.ndarray, role: EndEffectorRole | None = None) -> np.ndarray:
    """End-effector positions [T, E, 3] (of ``role`` only, when given) from link poses [T, L, 7]."""
    ees = [e for e in m.end_effectors if role is None or e.role == role]
    if not ees:
        return np.zeros((poses.shape[0], 0, 3))
    idx = [m.link_index(e.link) for e in ees]
    off = np.array([e.offset for e in ees], dtype=float)
    return poses[:, idx, :3] + quat_rotate(poses[:, idx, 3:], np.broadcast_to(off, (poses.shape[0], *off.shape)))


def _source_point(poses: np.ndarray, source: Morphology, spec: Source) -> tuple[np.ndarray, np.ndarray]:
    """Position [..., 3] and rotation [..., 4] of a mapped link from source link poses [..., Ls, 7]."""
    if isinstance(spec, str):
        if spec in source.link_names:
            T = poses[..., source.link_index(spec), :]
            return T[..., :3], T[..., 3:]
        ee = source.end_effector(spec)
        T = poses[..., source.link_index(ee.link), :]
        offset = np.broadcast_to(np.asarray(ee.offset, dtype=float), T[..., :3].shape)
        return T[..., :3] + quat_rotate(T[..., 3:], offset), T[..., 3:]
    a, b, w = spec
    Ta, Tb = poses[..., source.link_index(a), :], poses[..., source.link_index(b), :]
    return (1.0 - w) * Ta[..., :3] + w * Tb[..., :3], Ta[..., 3:]


# ---------------------------------------------------------------------------------------------
# step 1: re-expression on the template's topology
# ---------------------------------------------------------------------------------------------
def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrix R minimising Σ |R a_i − b_i|² (rows of a, b: [N, 3])."""
    H = a.T @ b
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    return Vt.T @ np.diag([1.0, 1.0, d]) @ U.T


def _with_offsets(template: Morphology, offsets: np.ndarray, name: str) -> Morphology:
    joints = tuple(dataclasses.replace(j, origin=Transform(tuple(map(float, o)), j.origin.quat))  # type: ignore[arg-type]
                   for j, o in zip(template.joints, offsets, strict=True))
    return dataclasses.replace(template, joints=joints, name=name, declared_body_length=None)


@dataclass(frozen=True, eq=False)
class MapPlan:
    """How one source skeleton maps onto a template's topology (:func:`plan_skeleton_map`)."""

    source: Morphology
    skeleton: Morphology
    """The template's topology with the source's bone lengths (its rest: the template's directions)."""
    sources: tuple[Source, ...]
    """Where each template link comes from, in template link order, spelled as the source spells it."""
    align: np.ndarray
    """$A_l$ per template link, shape [L, 4] (xyzw)."""
    rest_rotation: np.ndarray
    """$R_l^0$: the source's rest world rotation at each template link, shape [L, 4] (xyzw)."""


def plan_skeleton_map(source: Morphology, template: Morphology, link_map: SkeletonMap, *, name: str,
                      rest_tolerance: float = 0.0) -> MapPlan:
    """The mapped skeleton and the rest alignments of ``source`` onto ``template`` (module docstring, step 1).

    Args:
        source: The clip's skeleton.
        template: The topology to map onto (ball joints, unrotated origins).
        link_map: The convention table.
        name: The mapped skeleton's name.
        rest_tolerance: $A_l$ is the identity where it would turn a bone by at most this angle [rad]: such
            a source rest bone is taken to be in the template's rest pose (a T-pose), so its rotations
            from rest carry over as they are; 0 aligns every bone (NKN's maps).

    Raises:
        ConfigError: a template that is not all ball joints with unrotated origins.
        MotionFormatError: the table does not fit ``source``.
    """
    if any(not np.allclose(j.origin.quat, (0, 0, 0, 1), atol=1e-9) for j in template.joints) or any(
            j.type != JointType.SPHERICAL for j in template.joints):
        raise ConfigError(f"skeleton maps need a template of ball joints with unrotated origins; {template.name!r} "
                          "is not one")
    resolved = link_map.resolve(source)
    if resolved is None or set(resolved) != set(template.link_names):
        raise MotionFormatError(f"convention table {link_map.name!r} does not fit skeleton {source.name!r}")
    specs = tuple(resolved[n] for n in template.link_names)
    rest = source.rest_link_poses()
    pos, rot = zip(*(_source_point(rest, source, s) for s in specs), strict=True)
    pos, rot = np.array(pos), np.array(rot)
    L = template.link_count
    parent = [-1] + [template.link_index(j.parent) for j in template.joints]
    children: dict[int, list[int]] = {i: [] for i in range(L)}
    for c in range(1, L):
        children[parent[c]].append(c)
    template_off = np.array([[0.0, 0.0, 0.0], *[j.origin.xyz for j in template.joints]])  # by child link
    align = np.zeros((L, 4))
    for lnk in range(L):
        kids = children[lnk]
        if kids:
            a = template_off[kids]
            b = pos[kids] - pos[lnk]
            if len(kids) == 1:
                q = quat_between_vectors(a[0] / np.linalg.norm(a[0]), b[0] / max(np.linalg.norm(b[0]), 1e-12))
            else:
                q = quat_from_matrix(_kabsch(a, b))
        else:  # a leaf: align its own incoming bone
            a, b = template_off[lnk], pos[lnk] - pos[parent[lnk]]
            q = quat_between_vectors(a / np.linalg.norm(a), b / max(np.linalg.norm(b), 1e-12))
        if 2.0 * np.arccos(min(abs(float(q[3])), 1.0)) <= rest_tolerance:
            q = np.array([0.0, 0.0, 0.0, 1.0])
        align[lnk] = q
    offsets = np.zeros((template.joint_count, 3))
    for j in range(template.joint_count):
        c, p = j + 1, parent[j + 1]
        offsets[j] = matrix_from_quat(align[p]).T @ (pos[c] - pos[p])
    return MapPlan(source, _with_offsets(template, offsets, name), specs, align, rot)


def mapped_poses(motion: Motion, plan: MapPlan) -> tuple[np.ndarray, np.ndarray]:
    """Positions [T, L, 3] [m] and world orientations $W_l(t)$ [T, L, 4] of the template's links over
    ``motion`` (a clip of ``plan.source``)."""
    poses = _link_poses(motion.morphology, motion.q)
    pos, rot = zip(*(_source_point(poses, plan.source, s) for s in plan.sources), strict=True)
    pos, rot = np.stack(pos, axis=1), np.stack(rot, axis=1)
    inv_rest = quat_conjugate(plan.rest_rotation)
    W = quat_multiply(quat_multiply(rot, np.broadcast_to(inv_rest, rot.shape)), np.broadcast_to(plan.align, rot.shape))
    return pos, W


def _fit_twists(plan: MapPlan, template: Morphology, pos: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``W`` [T, L, 4] with a constant twist about the bone fitted for every aligned link with one child.

    $A_l$ turns a bone onto the source's with the shortest arc, which leaves the turn about the bone
    (its twist) to the source's rest frame: arbitrary where that rest is not a T-pose (a Bandai foot
    would roll sideways). Where the bone and the direction back to the parent joint are far from
    parallel (a foot: toe vs knee), the twist $\theta_l$ is the one that puts the template's rest
    direction to the parent, $e_l$, closest (circular mean over the clip) to the source's, in the plane
    normal to the bone $d_l$; children's positions do not change. Links within the T-pose tolerance
    keep the source's own twist.
    """
    W = np.array(W)
    ident = np.abs(plan.align[:, 3]) >= 1.0 - 1e-12
    for ji, j in enumerate(template.joints):
        lnk = ji + 1
        kids = template.children(j.child)
        if ident[lnk] or len(kids) != 1:
            continue
        d = np.asarray(template.joint(kids[0]).origin.xyz, dtype=float)
        e = -np.asarray(j.origin.xyz, dtype=float)
        d, e = d / np.linalg.norm(d), e / np.linalg.norm(e)
        if np.linalg.norm(np.cross(d, e)) < 0.5:
            continue  # nearly parallel: the parent says nothing about the twist
        p = template.link_index(j.parent)
        k = quat_rotate(quat_conjugate(W[:, lnk]), pos[:, p] - pos[:, lnk])  # to the parent, in the link frame
        k_perp = k - (k @ d)[:, None] * d
        e_perp = e - (e @ d) * d
        angle = np.arctan2(np.cross(e_perp, k_perp) @ d, k_perp @ e_perp)
        theta = float(np.angle(np.sum(np.linalg.norm(k_perp, axis=1) * np.exp(1j * angle))))
        twist = np.array([*(np.sin(0.5 * theta) * d), np.cos(0.5 * theta)])
        W[:, lnk] = quat_multiply(W[:, lnk], np.broadcast_to(twist, W[:, lnk].shape))
    return W


def _q_from_world(m: Morphology, root: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Coordinates [T, C] of an all-ball-joint ``m`` from its root position [T, 3] and link rotations [T, L, 4]."""
    q = np.zeros((W.shape[0], m.coordinate_count))
    q[:, :3] = root
    q[:, 3:7] = W[:, 0]
    for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
        c, p = m.link_index(j.child), m.link_index(j.parent)
        q[:, start : start + 4] = quat_multiply(quat_conjugate(W[:, p]), W[:, c])
    return q


def map_skeleton_motion(motion: Motion, template: Morphology, link_map: SkeletonMap, *, skeleton_name: str,
                        plan: MapPlan | None = None) -> Motion:
    """``motion`` re-expressed on the mapped skeleton of ``template``'s topology (every link where the
    source's is; module docstring, step 1).

    Raises:
        MotionFormatError: the table does not fit the clip's skeleton.
    """
    if not link_map.applies(motion.morphology, template):
        raise MotionFormatError(f"skeleton map {link_map.name!r} does not fit clip {motion.name!r}")
    plan = plan or plan_skeleton_map(motion.morphology, template, link_map, name=skeleton_name)
    pos, W = mapped_poses(motion, plan)
    return Motion(plan.skeleton, motion.fps, _q_from_world(plan.skeleton, pos[:, 0], W), motion.name)


# ---------------------------------------------------------------------------------------------
# the canonical human
# ---------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def canonical_human() -> Morphology:
    """The canonical human's morphology (the shipped ``human``; one object per process)."""
    from morphkit.io import read_morphology

    return read_morphology(CANONICAL_HUMAN)


def thigh_shank_length(skeleton: Morphology) -> float:
    """Thigh + shank [m] of a skeleton of the canonical topology: hip → knee → ankle joints, mean of
    both sides; the foot is left out (the length clips are scaled by). Not
    :attr:`~morphkit.graph.Morphology.leg_length`, which runs on to the foot point."""
    sides = []
    for side in _LEFT_RIGHT:
        knee, ankle = skeleton.joint(f"{side}Leg"), skeleton.joint(f"{side}Foot")
        sides.append(float(np.linalg.norm(knee.origin.xyz) + np.linalg.norm(ankle.origin.xyz)))
    return float(np.mean(sides))


def _rest_height(m: Morphology) -> float:
    """Vertical extent [m] of the rest pose's shapes (sole to crown)."""
    poses = m.rest_link_poses()
    lo, hi = np.inf, -np.inf
    for i, link in enumerate(m.links):
        for s in link.shapes:
            centre = poses[i, :3] + quat_rotate(poses[i, 3:], np.asarray(s.origin.xyz, dtype=float))
            frame = quat_multiply(poses[i, 3:], np.asarray(s.origin.quat, dtype=float))
            axis = quat_rotate(frame, np.array([0.0, 0.0, 1.0]))
            half = 0.5 * (s.length or 0.0) if s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER) else 0.0
            r = s.radius or 0.0
            for end in (centre + half * axis, centre - half * axis):
                lo, hi = min(lo, end[2] - r), max(hi, end[2] + r)
    return float(hi - lo)


def canonical_record() -> dict[str, Any]:
    """What a run records of the canonical human it was trained on: ``skeleton`` (its name), ``height``
    (sole to crown at rest [m]) and ``leg_length`` (:func:`thigh_shank_length` [m]; the key keeps its name, runs
    store it)."""
    m = canonical_human()
    return {"skeleton": CANONICAL_HUMAN, "height": round(_rest_height(m), 4),
            "leg_length": round(thigh_shank_length(m), 4)}


def is_canonical(morphology: Morphology) -> bool:
    """Whether ``morphology`` is the canonical human's skeleton (links, bone offsets and end-effectors)."""
    c = canonical_human()
    if morphology is c:
        return True
    if (morphology.link_names != c.link_names or morphology.base != c.base
            or tuple((e.name, e.link, e.role) for e in morphology.end_effectors)
            != tuple((e.name, e.link, e.role) for e in c.end_effectors)):
        return False
    offsets = np.array([j.origin.xyz for j in morphology.joints])
    mine = np.array([j.origin.xyz for j in c.joints])
    ee = np.array([e.offset for e in morphology.end_effectors])
    return bool(np.allclose(offsets, mine, atol=1e-9)
                and np.allclose(ee, np.array([e.offset for e in c.end_effectors]), atol=1e-9))


def _table_for(motion: Motion, maps: Sequence[SkeletonMap] | None) -> SkeletonMap:
    canon = canonical_human()
    table = find_skeleton_map(motion.morphology, canon, [*(maps or ()), *skeleton_maps()])
    if table is not None:
        return table
    guessed = guess_skeleton_map(motion)
    some = ", ".join(motion.morphology.link_names[:6])
    warnings.warn(f"clip {motion.name!r}: no convention table matches its joint names ({some}, ...); guessed from "
                  f"the skeleton's shape: {guessed.describe()}", UserWarning, stacklevel=3)
    return guessed


def to_canonical(motion: Motion, *, maps: Sequence[SkeletonMap] | None = None, scale: bool = True) -> Motion:
    """``motion`` on the canonical human (module docstring, step 2); a clip of it comes back unchanged.

    Args:
        motion: A human clip of any known convention (or one whose shape is a human's).
        maps: Convention tables tried before the shipped ones (e.g. a user's, :func:`read_skeleton_map`).
        scale: Scale the root's path by the leg-length ratio (``False``: keep the source's metres).

    Returns:
        A motion of :func:`canonical_human` at the clip's frame rate, grounded, with the clip's name.

    Raises:
        MotionFormatError: a clip without two legs, two arms and a head by name or by shape (naming the
            clip and what is missing; :func:`read_canonical_motion` adds the file).
    """
    canon = canonical_human()
    if is_canonical(motion.morphology):
        return motion
    table = _table_for(motion, maps)
    plan = plan_skeleton_map(motion.morphology, canon, table, name=f"{motion.morphology.name}_mapped",
                             rest_tolerance=TPOSE_TOLERANCE)
    pos, W = mapped_poses(motion, plan)
    W = _fit_twists(plan, canon, pos, W)
    s = thigh_shank_length(canon) / max(thigh_shank_length(plan.skeleton), 1e-9) if scale else 1.0
    hips = [canon.link_index(f"{side}UpLeg") for side in _LEFT_RIGHT]
    hip_mid = pos[:, hips].mean(axis=1)
    hip_off = np.mean([canon.joint(f"{side}UpLeg").origin.xyz for side in _LEFT_RIGHT], axis=0)
    root = s * hip_mid - quat_rotate(W[:, 0], np.broadcast_to(hip_off, hip_mid.shape))
    q = _q_from_world(canon, root, W)
    feet = _ee_positions(canon, _link_poses(canon, q), EndEffectorRole.FOOT)
    q[:, 2] -= float(feet[..., 2].min())
    return Motion(canon, motion.fps, q, motion.name)


def read_canonical_motion(path: str | os.PathLike[str], *, maps: Sequence[SkeletonMap] | None = None,
                          fps: float | None = None, scale: bool = True) -> Motion:
    """Read a human clip (any format :func:`~morphkit.motion.read_motion` knows) onto the canonical human.

    A BVH file whose joint names a table of ``maps`` fits is read with that table's ``scale``/``up``/
    ``facing``; otherwise they are detected. See :func:`to_canonical` for ``maps`` and ``scale``.

    Raises:
        MotionFormatError: unreadable, or not a human (see :func:`to_canonical`).
    """
    from morphkit.motion import read_motion

    options: dict[str, Any] = {}
    if maps and Path(path).suffix.lower() == ".bvh":
        from morphkit.io.bvh import read_bvh

        names = set(read_bvh(path).joint_names)
        names |= {n.rsplit(":", 1)[-1] for n in names}
        for m in maps:
            # End Sites become end-effectors "<joint>_end" only once the file is read as a motion.
            if m.read_options and all(n in names or (n.endswith("_end") and n[:-4] in names)
                                      for n in m.source_names()):
                options = dict(m.read_options)
                break
    motion = read_motion(path, **options)
    try:
        motion = to_canonical(motion, maps=maps, scale=scale)
    except MotionFormatError as exc:
        # Clips of one subject share one skeleton (``read_motion``), whose ``source`` is the first such
        # file's: only the path read here names this clip's file.
        raise MotionFormatError(exc.message, location=SourceLocation(os.fspath(path))) from None
    return motion.resample(fps) if fps is not None else motion


# ---------------------------------------------------------------------------------------------
# shape-based detection
# ---------------------------------------------------------------------------------------------
def _not_humanoid(motion: Motion, problems: list[str]) -> MotionFormatError:
    m = motion.morphology
    roles = {r: [e.name for e in m.end_effectors if e.role == r] for r in
             (EndEffectorRole.FOOT, EndEffectorRole.HAND, EndEffectorRole.HEAD)}
    plural = {EndEffectorRole.FOOT: "feet", EndEffectorRole.HAND: "hands", EndEffectorRole.HEAD: "heads"}
    by_name = "; ".join(f"{len(v)} {plural[r] if len(v) != 1 else r.name.lower()}"
                        f"{' (' + ', '.join(v[:4]) + ')' if v else ''}" for r, v in roles.items())
    return MotionFormatError(
        f"clip {motion.name!r} cannot be mapped onto the canonical human: no convention table matches its joint "
        f"names and its shape is not a human's: {'; '.join(problems)} (end-effectors by name: {by_name})")


def _main_path(m: Morphology, start: int, kids: dict[int, list[int]], size: list[int]) -> list[int]:
    """``start`` and its descendants down the child with the largest subtree, to a leaf or a link where
    the chain branches into several equal children (a hand's fingers)."""
    path = [start]
    while kids[path[-1]]:
        ks = sorted(kids[path[-1]], key=lambda k: -size[k])
        if len(ks) > 1 and size[ks[0]] == size[ks[1]] and size[ks[0]] > 1:
            break  # fingers or toes: the limb ends here
        path.append(ks[0])
    return path


def _bone(m: Morphology, link: int) -> float:
    return float(np.linalg.norm(m.joints[link - 1].origin.xyz)) if link > 0 else 0.0


def _long_pair(m: Morphology, path: list[int]) -> int | None:
    """Index in ``path`` of the joint between the two longest consecutive bones (knee, elbow)."""
    best, at = -1.0, None
    for i in range(1, len(path) - 1):
        v = _bone(m, path[i]) + _bone(m, path[i + 1])
        if v > best:
            best, at = v, i
    return at


def _tip(m: Morphology, link: int) -> str | None:
    """An end-effector on ``link`` with a nonzero offset (a BVH End Site past a joint), if any."""
    ee = next((e for e in m.end_effectors if e.link == m.link_names[link] and np.linalg.norm(e.offset) > 1e-6), None)
    return ee.name if ee is not None else None


def guess_skeleton_map(motion: Motion) -> SkeletonMap:
    """Correspondences onto the canonical human from the skeleton's shape alone (no names).

    The pelvis is the first link from the root with three or more children; the spine is its child
    whose subtree holds the chest (the first link below with three or more children); the legs are the
    pelvis's two other chains whose tips are lowest over the clip; the neck is the chest's chain of the
    shortest bones, the arms its two longest others. Along a limb the knee (elbow) is the joint
    between its two longest consecutive bones. Left is the side of ``up × forward`` (up: pelvis → chest,
    forward: ankle → toe), measured over the clip. The body must be upright (pelvis → chest within 60° of
    up in most frames) with arms shorter than legs.

    Raises:
        MotionFormatError: naming what is missing (no pelvis, chest, two legs, two arms, a neck; not upright).
    """
    m = motion.morphology
    frames = np.linspace(0, motion.frame_count - 1, min(motion.frame_count, 60)).round().astype(int)
    poses = _link_poses(m, motion.q[frames])  # [F, L, 7], frames spread over the clip
    body = _find_body(motion, poses[..., :3])
    limbs = _limb_parts(motion, body)
    up = _check_standing(motion, poses[..., :3], body, limbs)
    links: dict[str, Source] = {"Hips": m.link_names[body.pelvis]}
    links.update(_sided_links(motion, poses, body, limbs, up))
    links.update(_trunk_links(m, body))
    order = canonical_human().link_names
    return SkeletonMap("guessed from shape", {n: links[n] for n in order}, "shape-based detection")


@dataclass(frozen=True)
class _Body:
    """A human-like skeleton's trunk and limb chains, as link indices (:func:`guess_skeleton_map`)."""

    pelvis: int
    chest: int
    spine: list[int]
    """From the pelvis's child to the chest."""
    legs: list[list[int]]
    """The two chains of the pelvis whose tips are lowest over the clip."""
    arms: list[list[int]]
    """The chest's two chains of the longest bones besides the neck."""
    neck: list[int]
    """The chest's chain of the shortest bones."""


def _find_body(motion: Motion, pos: np.ndarray) -> _Body:
    """The pelvis, chest, spine, legs, arms and neck of ``motion``'s skeleton; link positions ``pos`` [F, L, 3].

    Raises:
        MotionFormatError: no pelvis, no chest, no two legs, or no two arms and a neck at the chest.
    """
    m = motion.morphology
    L = m.link_count
    kids: dict[int, list[int]] = {i: [] for i in range(L)}
    for c in range(1, L):
        kids[m.link_parent[c]].append(c)
    size = [1] * L
    for c in range(L - 1, 0, -1):
        size[m.link_parent[c]] += size[c]
    pelvis = 0
    while len(kids[pelvis]) == 1:
        pelvis = kids[pelvis][0]
    if len(kids[pelvis]) < 3:
        raise _not_humanoid(motion, ["no pelvis (no link where two legs and a spine branch)", "no two legs",
                                     "no two arms"])
    chest_of = {}
    for c in kids[pelvis]:
        stack = [c]
        while stack:
            n = stack.pop()
            if len(kids[n]) >= 3 and c not in chest_of:
                chest_of[c] = n
            stack.extend(kids[n])
    spine_child = max(chest_of, key=lambda c: size[c], default=None)
    if spine_child is None:
        raise _not_humanoid(motion, ["no chest (no link above the pelvis where two arms and a neck branch)",
                                     "no two arms"])
    chest = chest_of[spine_child]
    legs = [c for c in kids[pelvis] if c != spine_child]
    leg_paths = [_main_path(m, c, kids, size) for c in legs]
    leg_paths = sorted(leg_paths, key=lambda p: float(np.median(pos[:, p[-1], 2])))[:2]
    arm_like = [_main_path(m, c, kids, size) for c in kids[chest]]
    chain_len = [sum(_bone(m, n) for n in p[1:]) for p in arm_like]
    problems = []
    if len(leg_paths) < 2:
        problems.append("no two legs")
    if len(arm_like) < 3:
        problems.append("no two arms and a neck at the chest")
    if problems:
        raise _not_humanoid(motion, problems)
    neck_i = int(np.argmin(chain_len))
    arm_paths = [p for i, p in enumerate(arm_like) if i != neck_i]
    arm_paths = sorted(arm_paths, key=lambda p: -sum(_bone(m, n) for n in p[1:]))[:2]
    spine_path = [chest]
    while spine_path[-1] != spine_child:
        spine_path.append(m.link_parent[spine_path[-1]])
    spine_path.reverse()
    return _Body(pelvis, chest, spine_path, leg_paths, arm_paths, arm_like[neck_i])


def _limb_parts(motion: Motion, body: _Body) -> dict[str, dict[str, Source]]:
    """Per limb (by its first link's name): the canonical parts (``UpLeg``, ``Leg``, ``Foot``, ``ToeBase``; or
    ``Shoulder``, ``Arm``, ``ForeArm``, ``Hand``) around its knee or elbow.

    Raises:
        MotionFormatError: a leg without hip, knee, ankle and foot, or an arm without shoulder, elbow and wrist.
    """
    m = motion.morphology
    limb: dict[str, dict[str, Source]] = {}
    bad_legs, bad_arms = [], []
    for path in body.legs:
        k = _long_pair(m, path)
        if k is None or k + 1 >= len(path):
            bad_legs.append(f"{m.link_names[path[0]]!r} has no hip, knee and ankle")
            continue
        toe: Source | None = m.link_names[path[k + 2]] if k + 2 < len(path) else _tip(m, path[k + 1])
        if toe is None:
            bad_legs.append(f"{m.link_names[path[0]]!r} has no foot (a toe or End Site past the ankle)")
            continue
        limb[m.link_names[path[0]]] = {"UpLeg": m.link_names[path[k - 1]], "Leg": m.link_names[path[k]],
                                       "Foot": m.link_names[path[k + 1]], "ToeBase": toe}
    for path in body.arms:
        e = _long_pair(m, path)
        if e is None or e + 1 >= len(path):
            bad_arms.append(f"{m.link_names[path[0]]!r} has no shoulder, elbow and wrist")
            continue
        clav: Source = (m.link_names[path[e - 2]] if e >= 2
                        else (m.link_names[body.chest], m.link_names[path[e - 1]], 0.5))
        limb[m.link_names[path[0]]] = {"Shoulder": clav, "Arm": m.link_names[path[e - 1]],
                                       "ForeArm": m.link_names[path[e]], "Hand": m.link_names[path[e + 1]]}
    problems = []
    if bad_legs:
        problems.append(f"no two legs (the pelvis's chain {'; '.join(bad_legs)})")
    if bad_arms:
        problems.append(f"no two arms (the chest's chain {'; '.join(bad_arms)})")
    if problems:
        raise _not_humanoid(motion, problems)
    return limb


def _check_standing(motion: Motion, pos: np.ndarray, body: _Body, limb: dict[str, dict[str, Source]]) -> np.ndarray:
    """The trunk's up direction per frame [F, 3] (pelvis → chest, unit length), once the body stands upright on legs
    longer than its arms.

    Raises:
        MotionFormatError: the trunk is not upright in most frames, or the arms are as long as the legs.
    """
    m = motion.morphology
    up = pos[:, body.chest] - pos[:, body.pelvis]
    up /= np.maximum(np.linalg.norm(up, axis=-1, keepdims=True), 1e-12)
    upright = float(np.mean(up[:, 2] > 0.5))
    leg_len = np.mean([_bone(m, m.link_index(str(v["Leg"]))) + _bone(m, m.link_index(str(v["Foot"])))
                       for v in limb.values() if "Leg" in v])
    arm_len = np.mean([_bone(m, m.link_index(str(v["ForeArm"]))) + _bone(m, m.link_index(str(v["Hand"])))
                       for v in limb.values() if "Hand" in v])
    problems = []
    if upright < 0.5:
        problems.append(f"the trunk is not upright (pelvis to chest within 60 degrees of up in {100 * upright:.0f}% "
                        "of frames): no two legs to stand on")
    if arm_len >= 0.9 * leg_len:
        problems.append(f"no two arms: the chest's limbs are as long as the legs ({arm_len:.2f} m vs {leg_len:.2f} m)")
    if problems:
        raise _not_humanoid(motion, problems)
    return up


def _sided_links(motion: Motion, poses: np.ndarray, body: _Body, limb: dict[str, dict[str, Source]],
                 up: np.ndarray) -> dict[str, Source]:
    """``Left*`` and ``Right*`` links of the legs and arms: left is the side of ``up × forward`` over the clip
    (forward: ankle → toe).

    Raises:
        MotionFormatError: both legs (or both arms) on one side.
    """
    m = motion.morphology
    pos = poses[..., :3]
    fwd = []
    for v in (limb[m.link_names[p[0]]] for p in body.legs):
        tip, _ = _source_point(poses, m, v["ToeBase"])
        fwd.append(tip - pos[:, m.link_index(str(v["Foot"]))])
    forward = np.mean(fwd, axis=0)
    left = np.cross(up, forward)
    left /= np.maximum(np.linalg.norm(left, axis=-1, keepdims=True), 1e-12)

    def side(path: list[int], kind: str) -> str:
        base = body.pelvis if kind == "leg" else body.chest
        return "Left" if float(np.median(((pos[:, path[0]] - pos[:, base]) * left).sum(-1))) > 0 else "Right"

    links: dict[str, Source] = {}
    for kind, paths in (("leg", body.legs), ("arm", body.arms)):
        sides = [side(p, kind) for p in paths]
        if sides[0] == sides[1]:
            raise _not_humanoid(motion, [f"cannot tell the left {kind} from the right (both on the "
                                         f"{sides[0].lower()})"])
        for p, sd in zip(paths, sides, strict=True):
            for part, src in limb[m.link_names[p[0]]].items():
                links[f"{sd}{part}"] = src
    return links


def _trunk_links(m: Morphology, body: _Body) -> dict[str, Source]:
    """``Spine``, ``Spine1`` (between the pelvis and the chest), ``Spine2`` (the chest), ``Neck`` and ``Head``: links
    of the body, or points between two where it has fewer."""
    links: dict[str, Source] = {}
    sp = [m.link_names[i] for i in body.spine]
    pel, ch = m.link_names[body.pelvis], m.link_names[body.chest]
    if len(sp) >= 3:
        links.update(Spine=sp[0], Spine1=sp[len(sp) // 2], Spine2=ch)
    elif len(sp) == 2:
        links.update(Spine=sp[0], Spine1=(sp[0], ch, 0.5), Spine2=ch)
    else:
        links.update(Spine=(pel, ch, 1 / 3), Spine1=(pel, ch, 2 / 3), Spine2=ch)
    nk = [m.link_names[i] for i in body.neck]
    if len(nk) >= 2:
        links.update(Neck=nk[0], Head=nk[1])
    else:
        links.update(Neck=(ch, nk[0], 0.5), Head=nk[0])
    return links
