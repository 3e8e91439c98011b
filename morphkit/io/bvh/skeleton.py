"""A BVH skeleton as a :class:`~morphkit.graph.Morphology`: axes, units, links, joints, bone shapes and the
end-effectors :mod:`~morphkit.io.bvh.analysis` finds (see :mod:`morphkit.io.bvh` for the conventions)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import BaseType, JointType, Morphology, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.io.bvh.analysis import detect_bvh_facing, plan_end_effectors
from morphkit.io.bvh.file import BvhFile, detect_bvh_scale, fold_static_root
from morphkit.io.bvh.parser import read_bvh
from morphkit.rotations import quat_between_vectors

__all__ = ["BVH_TO_MORPHKIT", "bvh_frame_rotation", "read_bvh_skeleton", "skeleton_from_bvh"]

def bvh_frame_rotation(facing: str = "+z") -> np.ndarray:
    """Rotation ``R`` with ``v_morphkit = R @ v_bvh`` for a Y-up BVH whose character faces ``facing``.

    Args:
        facing: The BVH axis the character faces at rest: ``"+z"`` (CMU, Daz, Bandai Namco),
            ``"-z"``, ``"+x"`` or ``"-x"``.

    Returns:
        A proper rotation, shape [3, 3], mapping BVH +Y to morphkit +Z (up) and ``facing`` to
        morphkit +X (forward).

    Raises:
        ConfigError: ``facing`` is not one of the four horizontal axes.
    """
    axes = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0)}
    key = facing.strip().lower() if isinstance(facing, str) else facing
    if key not in axes:
        raise ConfigError(f"unknown BVH facing {facing!r}; expected one of: {', '.join(axes)}")
    forward = np.array(axes[key])
    up = np.array([0.0, 1.0, 0.0])
    left = np.cross(up, forward)
    # Rows are the morphkit x, y, z axes written in BVH coordinates.
    return np.stack([forward, left, up])


BVH_TO_MORPHKIT: np.ndarray = bvh_frame_rotation("+z")
"""``v_morphkit = BVH_TO_MORPHKIT @ v_bvh`` for Y-up, +Z-facing BVH files (CMU convention):
``[[0, 0, 1], [1, 0, 0], [0, 1, 0]]`` — morphkit x (forward) = BVH z, y (left) = BVH x, z (up) = BVH y."""
BVH_TO_MORPHKIT.setflags(write=False)


_MIN_RADIUS = 0.01
_Z = np.array([0.0, 0.0, 1.0])
_RADIUS_FRACTION = 0.08


def _bone_shapes(segments: list[np.ndarray], incoming: float | None) -> tuple[Shape, ...]:
    """Capsules along ``segments`` (vectors from the link origin, metres), or one sphere."""
    shapes: list[Shape] = []
    for seg in segments:
        length = float(np.linalg.norm(seg))
        if length < 1e-6:
            continue
        quat = tuple(float(v) for v in quat_between_vectors(_Z, seg / length))
        origin = Transform(tuple(float(v) for v in 0.5 * seg), quat)  # type: ignore[arg-type]
        radius = max(_RADIUS_FRACTION * length, _MIN_RADIUS)
        shapes.append(Shape(ShapeType.CAPSULE, origin=origin, radius=radius, length=length))
    if not shapes:
        radius = max(_RADIUS_FRACTION * incoming, _MIN_RADIUS) if incoming else _MIN_RADIUS
        shapes.append(Shape(ShapeType.SPHERE, radius=radius))
    return tuple(shapes)


def skeleton_from_bvh(
    bvh: BvhFile,
    *,
    scale: float | None = None,
    facing: str = "auto",
    name: str | None = None,
    detect_front_paws: bool = True,
    share: bool = False,
) -> Morphology:
    """Build a :class:`~morphkit.graph.Morphology` from a parsed BVH skeleton.

    A static root is folded away first (:func:`fold_static_root`), so Bandai Namco's skeletons
    are rooted at ``Hips``, as in their motions.

    End-effectors are chosen from names:

    1. Each End Site is a candidate on its parent joint's link. Its role comes from the nearest
       joint on its path to the root whose name holds a *strong* keyword (hand: hand, wrist,
       finger, thumb, index, mid, ring, pinky, palm, claw; foot: foot, toe, ankle, heel, paw,
       hoof; head: head), else a *weak* one (arm -> hand, leg -> foot, neck -> head); End Sites
       with neither are ``tool``.
    2. The candidate's *limb* is the topmost joint of the run of joints with that same role
       containing its keyword joint (e.g. ``lankle`` for CMU's ``ltoe`` End Site, ``rHand`` for
       each Daz finger). A limb with one candidate keeps it, named ``<parent joint>_end``; a
       limb with several (fingers, eyes) becomes one end-effector at the limb's topmost joint,
       zero offset, named after that joint. (A joint already named ``*_end`` lends its name
       unchanged; clashing names get a numeric suffix.) A limb with a strong keyword but no End
       Site at all (some exporters omit them) gets an end-effector at its tip joint (followed
       down while the limb does not branch), zero offset, named after that joint.
    3. With ``detect_front_paws``, a "hand" is a front foot (quadruped rigs call their front
       paws hands) by the front-paw rule descriptions are read by too (:mod:`morphkit.body.paws`), when both hold:

       - its limb is as long as a leg: the bone path from the end-effector up to the joint
         where the limb branches off the body is at least 90% of the legs' mean (the same path
         for the feet). Bone lengths do not depend on the clip. Humans measure 0.67-0.75 (CMU,
         Daz, Bandai Namco), the dog 1.24, the elephants 1.18, so a human's hands stay hands
         whatever the clip (crawling, a sun salutation);
       - the motion keeps it at the feet's height: its median height above the feet over the
         clip is at most 35% of the hips' (the joint where the feet's chains meet). The dog's
         paws give at most 0.21; the crab's claws, as long as its legs, are held up.

       A file without frames keeps its hands.

    Args:
        bvh: A parsed file (:func:`parse_bvh`).
        scale: File units to metres; ``None`` detects it (:func:`detect_bvh_scale`).
        facing: The BVH axis the character faces (:func:`bvh_frame_rotation`), or ``"auto"``
            to detect it from the motion (:func:`detect_bvh_facing`).
        name: Morphology name (default: the file's stem, or ``"bvh"``).
        detect_front_paws: Turn leg-long hands that move at the feet's height into feet (rule 3).
        share: Return one object for every file with the same skeleton (hierarchy and offsets,
            options, end-effectors), e.g. all clips of a subject, so that it compiles once. Its
            ``name`` and ``source`` are those of the first such file.

    Raises:
        ConfigError: ``scale`` is not a positive finite number, or ``facing`` is unknown.
        GraphError: the skeleton cannot form a valid morphology (also for absurd offsets that
            overflow to non-finite lengths).
    """
    # Absurd offsets (1e308) overflow to inf here; the builder then rejects them with a GraphError.
    with np.errstate(over="ignore", invalid="ignore"):
        return _skeleton_from_bvh(fold_static_root(bvh), scale, facing, name, detect_front_paws, share)


_shared: dict[tuple, Morphology] = {}
"""Skeletons by everything they depend on, for ``share=True`` (cleared beyond 256 entries)."""


def _check_facing(facing: str) -> str:
    """``facing`` normalised (``"auto"`` or one of :func:`bvh_frame_rotation`'s axes)."""
    if isinstance(facing, str) and facing.strip().lower() == "auto":
        return "auto"
    bvh_frame_rotation(facing)  # raises ConfigError for anything else
    return facing.strip().lower()


def _skeleton_from_bvh(
    bvh: BvhFile, scale: float | None, facing: str, name: str | None, detect_front_paws: bool, share: bool
) -> Morphology:
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not math.isfinite(scale) or scale <= 0:
            raise ConfigError(f"BVH scale must be a positive number, got {scale!r}")
        s = float(scale)
    else:
        s = detect_bvh_scale(bvh)
    plan = plan_end_effectors(bvh, detect_front_paws)
    facing = _check_facing(facing)
    if facing == "auto":
        facing = detect_bvh_facing(bvh, detect_front_paws=detect_front_paws)
    key = None
    if share:
        # The root's OFFSET does not enter the skeleton (the motion places the root).
        key = (
            bvh.joint_names,
            bvh.joint_parents,
            bvh.joint_offsets[1:].tobytes(),
            bvh.joint_channels,
            tuple((e.parent, e.offset) for e in bvh.end_sites),
            s,
            facing,
            tuple((c.name, c.joint, c.site, c.role) for c in plan),
        )
        if key in _shared:
            return _shared[key]
    R = bvh_frame_rotation(facing)
    src = bvh.source
    if name is None:
        name = Path(src).stem if src else "bvh"
    J = bvh.joint_count
    offsets = (bvh.joint_offsets @ R.T) * s  # [J, 3] metres, morphkit axes
    end_offsets = [(R @ np.asarray(e.offset)) * s for e in bvh.end_sites]
    line_of = (lambda j: bvh.joint_lines[j]) if len(bvh.joint_lines) == J else (lambda j: None)

    segments: list[list[np.ndarray]] = [[] for _ in range(J)]
    for j in range(1, J):
        segments[bvh.joint_parents[j]].append(offsets[j])
    for e, site in enumerate(bvh.end_sites):
        segments[site.parent].append(end_offsets[e])

    b = MorphologyBuilder(name, source=src)
    b.set_base(BaseType.FLOATING)
    for j in range(J):
        incoming = float(np.linalg.norm(offsets[j])) if j > 0 else None
        b.add_link(bvh.joint_names[j], shapes=_bone_shapes(segments[j], incoming), location=bvh.location(line_of(j)))
    b.set_root(bvh.joint_names[0], location=bvh.location(line_of(0)))
    for j in range(1, J):
        has_rotation = any(c.endswith("rotation") for c in bvh.joint_channels[j])
        b.add_joint(
            bvh.joint_names[j],
            JointType.SPHERICAL if has_rotation else JointType.FIXED,
            bvh.joint_names[bvh.joint_parents[j]],
            bvh.joint_names[j],
            origin=Transform(tuple(float(v) for v in offsets[j])),  # type: ignore[arg-type]
            location=bvh.location(line_of(j)),
        )
    for ee in plan:
        offset = _tuple3(end_offsets[ee.site]) if ee.site is not None else (0.0, 0.0, 0.0)
        b.add_end_effector(
            ee.name, bvh.joint_names[ee.joint], offset=offset, role=ee.role, location=bvh.location(ee.line)
        )
    m = b.build()
    if key is not None:
        if len(_shared) >= 256:
            _shared.clear()
        _shared[key] = m
    return m


def _tuple3(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def read_bvh_skeleton(
    path: str | os.PathLike[str],
    *,
    scale: float | None = None,
    facing: str = "auto",
    detect_front_paws: bool = True,
) -> Morphology:
    """Read a BVH file's skeleton as a :class:`~morphkit.graph.Morphology` (metres, z up, x forward).

    The whole file is parsed and checked, motion included; the motion folds a static root away
    and decides front paws and the facing. The skeleton equals the one
    :func:`morphkit.motion.read_bvh_motion` gives the file's motion with the same options. See
    :func:`skeleton_from_bvh`.

    Args:
        path: BVH file.
        scale: File units to metres; ``None`` detects centimetres vs metres.
        facing: The BVH axis the character faces at rest, or ``"auto"`` (:func:`detect_bvh_facing`).
        detect_front_paws: Turn leg-long hands that move at the feet's height into feet.

    Raises:
        DescriptionError: bad file or hierarchy. MotionFormatError: bad MOTION section.
        ConfigError: bad ``scale`` or ``facing``.
    """
    return skeleton_from_bvh(read_bvh(path), scale=scale, facing=facing, detect_front_paws=detect_front_paws)
