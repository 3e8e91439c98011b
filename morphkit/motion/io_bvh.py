"""BVH motion ⇄ :class:`~morphkit.motion.Motion`, for any skeleton and any creature.

Parsing and the skeleton are :mod:`morphkit.io.bvh`'s (:func:`~morphkit.io.bvh.read_bvh`,
:func:`~morphkit.io.bvh.skeleton_from_bvh`); this module turns the channel array into ``q``
and back.

Reading (:func:`read_bvh_motion`):

- **Rotations**: each joint's rotation channels, in any Euler order, become one xyzw quaternion
  (``R = R_c1 R_c2 R_c3`` in channel order, vectorised over frames and over joints sharing an
  order), then change axes with the skeleton's frame rotation ``R_f``
  (:func:`~morphkit.io.bvh.bvh_frame_rotation`, Y-up to Z-up): ``q ↦ (R_f v, w)``.
- **Units**: positions are multiplied by ``scale`` (default: detected from the skeleton's size,
  :func:`~morphkit.io.bvh.detect_bvh_scale`).
- **Translation channels**: the root's place the root (they replace its ``OFFSET``, as BVH
  does). A non-root joint's translation channels that stay at its ``OFFSET`` (Bandai Namco
  writes them for every joint) are dropped silently; ones that move cannot be expressed by a
  rigid skeleton and are dropped with a :class:`UserWarning` naming the joints and how far they
  move. A root that never rotates, with one child that has translation channels — Bandai
  Namco's ``joint_Root`` above ``Hips`` — is removed first (the two translations add up,
  :func:`~morphkit.io.bvh.fold_static_root`), so the pelvis becomes the root, as ACE's states
  want; :func:`~morphkit.io.bvh.read_bvh_skeleton` folds it too, so the motion's morphology is
  the file's skeleton.
- **Facing**: ``facing="auto"`` (the default) detects the skeleton axis the creature faces
  (:func:`~morphkit.io.bvh.detect_bvh_facing`): ``+Z`` for skeletons with hands (humans, as
  before), the axis along the level trunk for quadrupeds (the dog's ``-X``, the elephants' ``+X``).
- **Frame rate**: ``1 / Frame Time``, snapped to the nearest integer when within 0.01 fps
  (``Frame Time: 0.033333`` is 30 fps); ``fps=`` resamples (slerp for rotations).
- **Ground**: with ``ground=True`` the root is shifted vertically so that the lowest foot
  end-effector over the clip touches z = 0 (the lowest point of the body if there is no foot).

Writing (:func:`write_bvh_motion`) works for any morphology: one BVH joint per link, named
after it, each with ``Zrotation Xrotation Yrotation`` channels holding its rotation in the
parent link (joint origin rotation times the joint's own motion); prismatic joints and the root
add ``X/Y/Zposition``. A planar or wheeled base becomes a root with translation and yaw. Axes go
back to Y up / +Z forward, units stay metres, Euler angles are unwrapped over time so Blender
interpolates smoothly. Reading the file back with ``morphology=`` recovers the original ``q``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings

import numpy as np

from morphkit.conventions import quat_conjugate, quat_from_matrix, quat_multiply, quat_rotate
from morphkit.errors import ConfigError, MotionFormatError
from morphkit.graph import BaseType, EndEffectorRole, JointType, Morphology
from morphkit.io.bvh import (
    BvhEndSite,
    BvhFile,
    bvh_frame_rotation,
    bvh_joint_positions,
    detect_bvh_facing,
    detect_bvh_scale,
    detect_bvh_up,
    fold_static_root,
    read_bvh,
    skeleton_from_bvh,
    write_bvh,
)
from morphkit.motion.motion import Motion, base_pose_from_q
from morphkit.rotations import (
    euler_from_quat,
    quat_canonical,
    quat_from_euler,
    quat_normalize,
    yaw_from_quat,
)

__all__ = [
    "FRAME_TIME_RANGE",
    "bvh_to_motion",
    "ground_motion",
    "motion_to_bvh",
    "read_bvh_motion",
    "write_bvh_motion",
]

FRAME_TIME_RANGE = (1e-4, 1.0)
"""Frame times [s] a BVH motion may declare (10 000 to 1 fps); outside it the file most likely lies (``Frame Time:
1000`` resampled to 30 fps asks for gigabytes, ``1e-300`` makes one frame of sixty): give ``source_fps``."""

EXPORT_ROTATION_ORDER = ("Zrotation", "Xrotation", "Yrotation")
"""Rotation channels written for every joint (the Daz / Bandai Namco order; Blender reads any)."""

_STATIC_TOL = 1e-3
"""Channels count as constant when they stay within this fraction of the skeleton's size."""


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------
def _is_auto(option: str) -> bool:
    return isinstance(option, str) and option.strip().lower() == "auto"


def _facing(facing: str, bvh: BvhFile) -> str:
    """``facing``, detected from the (folded) file when ``"auto"``; unknown values raise ConfigError."""
    if _is_auto(facing):
        return detect_bvh_facing(bvh)
    bvh_frame_rotation(facing)  # validates
    return facing


def _snap_fps(fps: float) -> float:
    r = round(fps)
    return float(r) if r > 0 and abs(fps - r) <= 0.01 else fps


def _skeleton_size(bvh: BvhFile) -> float:
    pts = np.zeros((bvh.joint_count, 3))
    for j in range(1, bvh.joint_count):
        pts[j] = pts[bvh.joint_parents[j]] + bvh.joint_offsets[j]
    return float(max((pts.max(axis=0) - pts.min(axis=0)).max(), 1e-9))


def _rotation_columns(bvh: BvhFile, j: int) -> tuple[list[int], str]:
    start = bvh.joint_channel_start[j]
    cols, order = [], ""
    for k, ch in enumerate(bvh.joint_channels[j]):
        if ch.endswith("rotation"):
            cols.append(start + k)
            order += ch[0].lower()
    return cols, order


def _file_rotations(bvh: BvhFile) -> np.ndarray:
    """Every joint's rotation in its parent, in file axes: xyzw quaternions [T, J, 4]."""
    T, J = bvh.frame_count, bvh.joint_count
    quats = np.zeros((T, J, 4))
    quats[..., 3] = 1.0
    groups: dict[str, list[tuple[int, list[int]]]] = {}
    for j in range(J):
        cols, order = _rotation_columns(bvh, j)
        if cols:
            groups.setdefault(order, []).append((j, cols))
    for order, members in groups.items():
        idx = [j for j, _ in members]
        cols = np.array([c for _, c in members])  # [n, k]
        angles = np.radians(bvh.motion[:, cols])  # [T, n, k]
        quats[:, idx] = quat_from_euler(angles, order)
    return quats


def _world_rotation(up: str, facing: str, bvh: BvhFile) -> np.ndarray:
    """``R_w`` with ``p_morphkit = R_w @ p_file`` for world positions."""
    key = up.strip().lower() if isinstance(up, str) else up
    if key == "auto":
        key = detect_bvh_up(bvh)
    if key == "+y":
        return bvh_frame_rotation(facing)
    if key == "+z":
        return np.eye(3)
    raise ConfigError(f"unknown BVH up axis {up!r}; expected one of: auto, +y, +z")


def _to_morphkit_rotations(file_rotations: np.ndarray, R_skel: np.ndarray, R_world: np.ndarray) -> np.ndarray:
    """Joint rotations in morphkit axes [T, J, 4]: ``R_s R R_sᵀ``, and ``R_w R R_sᵀ`` for the root."""
    out = file_rotations.copy()
    # Conjugating a rotation by the axis change R_s rotates the quaternion's vector part by R_s.
    out[..., :3] = out[..., :3] @ R_skel.T
    q_w = quat_from_matrix(R_world)
    q_s = quat_from_matrix(R_skel)
    out[:, 0] = quat_multiply(q_w, quat_multiply(file_rotations[:, 0], quat_conjugate(q_s)))
    return out


def _joint_translations(bvh: BvhFile) -> np.ndarray:
    """Every joint's translation in its parent (file units and axes), [T, J, 3]: channels replace ``OFFSET``."""
    T, J = bvh.frame_count, bvh.joint_count
    out = np.broadcast_to(bvh.joint_offsets, (T, J, 3)).copy()
    for j in range(J):
        for axis, col in bvh.position_columns(j).items():
            out[:, j, axis] = bvh.motion[:, col]
    return out


def _warn_moving_translations(bvh: BvhFile, translations: np.ndarray) -> None:
    tol = _STATIC_TOL * _skeleton_size(bvh)
    moving = []
    for j in range(1, bvh.joint_count):
        if bvh.position_columns(j):
            dev = float(np.abs(translations[:, j] - bvh.joint_offsets[j]).max())
            if dev > tol:
                moving.append(f"{bvh.joint_names[j]} (up to {dev:.4g} file units)")
    if moving:
        shown = ", ".join(moving[:5]) + (f" and {len(moving) - 5} more" if len(moving) > 5 else "")
        warnings.warn(
            f"{bvh.source or '<bvh>'}: translation channels of non-root joints move away from their OFFSET and "
            f"are ignored (a rigid skeleton keeps its bone lengths): {shown}",
            UserWarning,
            stacklevel=3,
        )


def bvh_to_motion(
    bvh: BvhFile,
    *,
    scale: float | None = None,
    facing: str = "auto",
    up: str = "auto",
    fps: float | None = None,
    ground: bool = True,
    morphology: Morphology | None = None,
    name: str | None = None,
    source_fps: float | None = None,
) -> Motion:
    """Turn a parsed BVH file into a :class:`Motion` (see the module docstring for the rules).

    Args:
        bvh: From :func:`~morphkit.io.bvh.parse_bvh` / :func:`~morphkit.io.bvh.read_bvh`.
        scale: File units to metres (``None``: detected from the skeleton's size).
        facing: The BVH axis the skeleton faces: ``"+z"`` (CMU, Daz, Bandai Namco), ``"-z"``,
            ``"+x"``, ``"-x"`` (the MANN dog clips, whose root frame's -X points to the head), or
            ``"auto"``: detected from the motion (:func:`~morphkit.io.bvh.detect_bvh_facing`;
            ``"+z"`` for every skeleton with hands, the dog's ``"-x"`` from its level trunk).
            With ``morphology=``, ``"auto"`` is ``"+z"``, :func:`write_bvh_motion`'s default.
        up: The world's up axis in the file's motion: ``"+y"``, ``"+z"`` or ``"auto"`` (the axis
            along which the root stays above every foot). The skeleton's rest pose is always
            taken as Y-up; the CMU (AMASS) clips have a Y-up skeleton moving in a Z-up world.
        fps: Resample to this frame rate (``None``: keep the file's).
        ground: Shift the root so the lowest foot touches z = 0 (ignored with ``morphology=``).
        morphology: Read into this morphology instead of the file's skeleton: BVH joints are
            matched to links by name (as :func:`write_bvh_motion` writes them), and each joint's
            coordinates are recovered from its rotation (revolute, continuous, spherical) or
            translation (prismatic).
        name: The motion's name (default: the file's stem).
        source_fps: The file's true frame rate, replacing its ``Frame Time:`` (for files that lie).

    Raises:
        MotionFormatError: the file has no frames, a ``Frame Time:`` outside :data:`FRAME_TIME_RANGE`
            (without ``source_fps``), a resample over the limits of :meth:`Motion.resample`, or (with
            ``morphology=``) misses a link.
        ConfigError: bad ``scale``, ``facing`` or ``source_fps``.
    """
    if bvh.frame_count == 0:
        raise MotionFormatError("BVH file has no frames", location=bvh.location(bvh.motion_line))
    bvh = _with_frame_time(bvh, source_fps)
    if name is None:
        name = os.path.splitext(os.path.basename(bvh.source))[0] if bvh.source else "bvh"
    if morphology is not None:
        return _bvh_into_morphology(bvh, morphology, scale=scale, facing=facing, up=up, fps=fps, name=name)
    # The skeleton reader folds the same static root, so both see the same joints.
    bvh = fold_static_root(bvh)
    if scale is not None and (isinstance(scale, bool) or not math.isfinite(scale) or scale <= 0):
        raise ConfigError(f"BVH scale must be a positive number, got {scale!r}")
    s = float(scale) if scale is not None else detect_bvh_scale(bvh)
    facing = _facing(facing, bvh)
    # Clips of one subject share one skeleton object (one compiled FK kernel).
    skeleton = skeleton_from_bvh(bvh, scale=s, facing=facing, name=name, share=True)
    R_skel = bvh_frame_rotation(facing)
    file_rotations = _file_rotations(bvh)  # [T, J, 4]
    R_world = _world_rotation(up, facing, bvh)
    rotations = _to_morphkit_rotations(file_rotations, R_skel, R_world)
    translations = _joint_translations(bvh)  # [T, J, 3]
    _warn_moving_translations(bvh, translations)

    q = np.zeros((bvh.frame_count, skeleton.coordinate_count))
    q[:, 0:3] = (translations[:, 0] @ R_world.T) * s
    q[:, 3:7] = rotations[:, 0]
    for j, joint in enumerate(skeleton.joints):
        if joint.type != JointType.SPHERICAL:
            continue
        b = bvh.joint_names.index(joint.child)
        start = skeleton.joint_q_start[j]
        q[:, start : start + 4] = rotations[:, b]
    if ground:
        q[:, 2] -= _lowest_foot(bvh, skeleton, s, R_skel, R_world)
    motion = Motion(skeleton, _snap_fps(bvh.fps), q, name)
    if fps is not None:
        motion = motion.resample(fps)
    return motion


def _with_frame_time(bvh: BvhFile, source_fps: float | None) -> BvhFile:
    """``bvh`` at ``source_fps`` when given, else checked: its frame time within :data:`FRAME_TIME_RANGE`."""
    lo, hi = FRAME_TIME_RANGE
    if source_fps is not None:
        if isinstance(source_fps, bool) or not (math.isfinite(source_fps) and 1 / hi <= source_fps <= 1 / lo):
            raise ConfigError(f"source frame rate must be from {1 / hi:g} to {1 / lo:g} fps, got {source_fps!r}")
        return dataclasses.replace(bvh, frame_time=1.0 / float(source_fps))
    if not lo <= bvh.frame_time <= hi:
        raise MotionFormatError(
            f"Frame Time: {bvh.frame_time:g} s ({bvh.fps:.6g} fps) is outside {lo:g} to {hi:g} s; "
            "if the file's frame time is wrong, give its true frame rate (--source-fps FPS; source_fps= in Python)",
            location=bvh.location(bvh.frame_time_line),
        )
    return bvh


def _lowest_foot(bvh: BvhFile, skeleton: Morphology, scale: float, R_skel: np.ndarray, R_world: np.ndarray) -> float:
    """Lowest world height [m] of the foot end-effectors over the clip (every point without feet).

    Uses the file-coordinate FK of :func:`~morphkit.io.bvh.bvh_joint_positions` (NumPy), so
    reading a BVH file never has to generate an FK kernel. Foot end-effectors are End Sites or
    joints of the skeleton (as :func:`~morphkit.io.bvh.skeleton_from_bvh` places them).
    """
    pos = bvh_joint_positions(bvh)  # [T, J + S, 3], file units and axes
    points: list[int] = []
    for ee in skeleton.end_effectors:
        if ee.role != EndEffectorRole.FOOT:
            continue
        joint = bvh.joint_names.index(ee.link)
        offset = np.asarray(ee.offset)
        if not offset.any():
            points.append(joint)
            continue
        sites = [
            bvh.joint_count + k
            for k, site in enumerate(bvh.end_sites)
            if site.parent == joint and np.allclose(R_skel @ np.asarray(site.offset) * scale, offset, atol=1e-9)
        ]
        points.extend(sites[:1] or [joint])
    heights = pos[:, points] @ R_world[2] * scale if points else pos @ R_world[2] * scale
    return float(heights.min())


def ground_motion(motion: Motion) -> Motion:
    """Shift a floating-base motion vertically so its lowest foot end-effector touches z = 0.

    Feet are the end-effectors with role ``foot``; without any, every link origin and
    end-effector counts. Other base types are returned unchanged (they move on the ground).
    """
    m = motion.morphology
    if m.base != BaseType.FLOATING:
        return motion
    feet = [i for i, e in enumerate(m.end_effectors) if e.role == EndEffectorRole.FOOT]
    ee = motion.end_effector_positions()
    if feet:
        low = float(ee[:, feet, 2].min())
    else:
        low = float(min(motion.link_positions()[..., 2].min(), ee[..., 2].min(initial=np.inf)))
    q = np.array(motion.q)
    q[:, 2] -= low
    return motion.replace(q=q)


def _bvh_into_morphology(
    bvh: BvhFile, m: Morphology, *, scale: float | None, facing: str, up: str, fps: float | None, name: str
) -> Motion:
    # write_bvh_motion faces +Z by default; "auto" means that here.
    facing = "+z" if _is_auto(facing) else facing
    R = bvh_frame_rotation(facing)
    s = 1.0 if scale is None else float(scale)
    index = {n: i for i, n in enumerate(bvh.joint_names)}
    missing = [link for link in m.link_names if link not in index]
    if missing:
        raise MotionFormatError(
            f"BVH has no joint for link(s) {', '.join(missing[:5])} of {m.name!r} "
            f"(BVH joints: {', '.join(bvh.joint_names[:10])}{', ...' if bvh.joint_count > 10 else ''})",
            location=bvh.location(),
        )
    file_rotations = _file_rotations(bvh)
    # Files written by write_bvh_motion are Y-up; "auto" means that here.
    R_world = _world_rotation("+y" if up == "auto" else up, facing, bvh)
    rotations = _to_morphkit_rotations(file_rotations, R, R_world)
    translations = (_joint_translations(bvh) @ R.T) * s
    translations[:, 0] = (_joint_translations(bvh)[:, 0] @ R_world.T) * s
    T = bvh.frame_count
    q = np.zeros((T, m.coordinate_count))
    root = index[m.root]
    if m.base == BaseType.FLOATING:
        q[:, :3] = translations[:, root]
        q[:, 3:7] = rotations[:, root]
    elif m.base in (BaseType.PLANAR, BaseType.WHEELED):
        q[:, :2] = translations[:, root, :2]
        q[:, 2] = np.unwrap(yaw_from_quat(rotations[:, root]))
    for j, joint in enumerate(m.joints):
        if m.is_driven(joint) or joint.type == JointType.FIXED:
            continue
        b = index[joint.child]
        start = m.joint_q_start[j]
        oq = np.broadcast_to(np.asarray(joint.origin.quat), (T, 4))
        if joint.type == JointType.PRISMATIC:
            d = quat_rotate(quat_conjugate(oq), translations[:, b] - np.asarray(joint.origin.xyz))
            q[:, start] = d @ np.asarray(joint.axis)
            continue
        local = quat_multiply(quat_conjugate(oq), rotations[:, b])  # the joint's own motion
        if joint.type == JointType.SPHERICAL:
            q[:, start : start + 4] = quat_canonical(local)
        else:
            # rotation about the axis by θ: vector part sin(θ/2) axis, w cos(θ/2)
            angle = 2.0 * np.arctan2(local[:, :3] @ np.asarray(joint.axis), local[:, 3])
            q[:, start] = np.unwrap(angle) if joint.type == JointType.CONTINUOUS else _wrap(angle)
    motion = Motion(m, _snap_fps(bvh.fps), q, name)
    return motion.resample(fps) if fps is not None else motion


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def read_bvh_motion(
    path: str | os.PathLike[str],
    *,
    scale: float | None = None,
    facing: str = "auto",
    up: str = "auto",
    fps: float | None = None,
    ground: bool = True,
    morphology: Morphology | None = None,
    source_fps: float | None = None,
) -> Motion:
    """Read a BVH file as a :class:`Motion` (its skeleton becomes the morphology).

    See :func:`bvh_to_motion` for the arguments.

    Raises:
        DescriptionError: a malformed hierarchy (file and line).
        MotionFormatError: a malformed or truncated MOTION section (file and line), no frames.
    """
    return bvh_to_motion(
        read_bvh(path), scale=scale, facing=facing, up=up, fps=fps, ground=ground, morphology=morphology,
        source_fps=source_fps,
    )


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------
def _local_rotations_and_translations(motion: Motion, wheel_q: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Each link's rotation [T, L, 4] and translation [T, L, 3] in its parent link (root: in the world)."""
    m = motion.morphology
    T, L = motion.frame_count, m.link_count
    rot = np.zeros((T, L, 4))
    rot[..., 3] = 1.0
    trans = np.zeros((T, L, 3))
    base = base_pose_from_q(m, motion.q)
    trans[:, 0], rot[:, 0] = base[:, :3], base[:, 3:]
    values = _joint_values(motion, wheel_q)
    for j, joint in enumerate(m.joints):
        oq = np.broadcast_to(np.asarray(joint.origin.quat), (T, 4))
        ox = np.broadcast_to(np.asarray(joint.origin.xyz), (T, 3))
        axis = np.asarray(joint.axis)
        if joint.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            half = 0.5 * values[j]
            local = np.concatenate([np.sin(half)[:, None] * axis, np.cos(half)[:, None]], axis=-1)
            rot[:, j + 1] = quat_multiply(oq, local)
            trans[:, j + 1] = ox
        elif joint.type == JointType.SPHERICAL:
            start = m.joint_q_start[j]
            rot[:, j + 1] = quat_multiply(oq, quat_normalize(motion.q[:, start : start + 4]))
            trans[:, j + 1] = ox
        elif joint.type == JointType.PRISMATIC:
            rot[:, j + 1] = oq
            trans[:, j + 1] = ox + quat_rotate(oq, values[j][:, None] * axis)
        else:
            rot[:, j + 1] = oq
            trans[:, j + 1] = ox
    return rot, trans


def _joint_values(motion: Motion, wheel_q: np.ndarray | None) -> dict[int, np.ndarray]:
    """Value [T] of every 1-DoF joint, driven ones included (mimic; wheels from ``wheel_q`` or rolling)."""
    m = motion.morphology
    T = motion.frame_count
    values: dict[int, np.ndarray] = {}
    wheels = list(m.wheels.joints) if m.wheels is not None else []
    if wheels and wheel_q is None:
        wheel_q = motion.wheel_angles()
    for j, joint in enumerate(m.joints):
        if joint.type not in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            continue
        if joint.name in wheels:
            values[j] = wheel_q[:, wheels.index(joint.name)] if wheel_q is not None else np.zeros(T)
        elif joint.mimic is None:
            values[j] = motion.q[:, m.joint_q_start[j]]
    for j, joint in enumerate(m.joints):
        if joint.mimic is not None:
            target = m.joint_index(joint.mimic.joint)
            values[j] = joint.mimic.multiplier * values[target] + joint.mimic.offset
    return values


def motion_to_bvh(motion: Motion, *, wheel_q: np.ndarray | None = None, facing: str = "+z") -> BvhFile:
    """A :class:`~morphkit.io.bvh.BvhFile` of any creature's motion (see the module docstring).

    Args:
        motion: The motion.
        wheel_q: Wheel angles [rad], shape [T, W], for a wheeled base (default:
            :meth:`Motion.wheel_angles`, rolling without slip).
        facing: The BVH axis the character should face (default ``"+z"``, Blender's convention).
    """
    m = motion.morphology
    R = bvh_frame_rotation(facing)  # morphkit <- BVH; its transpose goes back
    rot, trans = _local_rotations_and_translations(motion, wheel_q)
    rot = rot.copy()
    rot[..., :3] = rot[..., :3] @ R  # vector part into BVH axes: (R^T v) as row vectors
    trans = trans @ R
    order = "".join(c[0].lower() for c in EXPORT_ROTATION_ORDER)
    euler = np.degrees(np.unwrap(euler_from_quat(rot, order), axis=0))  # [T, L, 3]

    channels: list[tuple[str, ...]] = []
    columns: list[np.ndarray] = []
    for link in range(m.link_count):
        joint = m.joints[link - 1] if link > 0 else None
        moves = joint is None or joint.type == JointType.PRISMATIC
        if moves:
            channels.append(("Xposition", "Yposition", "Zposition", *EXPORT_ROTATION_ORDER))
            columns.append(np.concatenate([trans[:, link], euler[:, link]], axis=-1))
        else:
            channels.append(EXPORT_ROTATION_ORDER)
            columns.append(euler[:, link])
    offsets = np.array([np.zeros(3), *(np.asarray(j.origin.xyz) @ R for j in m.joints)])
    # One End Site per leaf link, at its first end-effector (or at the link origin).
    has_child = set(m.link_parent[1:])
    end_sites = []
    for link in range(m.link_count):
        if link in has_child:
            continue
        ee = next((e for e in m.end_effectors if e.link == m.link_names[link]), None)
        off = np.asarray(ee.offset) @ R if ee is not None else np.zeros(3)
        end_sites.append(BvhEndSite(m.link_names[link], link, (float(off[0]), float(off[1]), float(off[2])), 0))
    return BvhFile(
        joint_names=m.link_names,
        joint_parents=tuple(int(p) for p in m.link_parent),
        joint_offsets=offsets,
        joint_channels=tuple(channels),
        end_sites=tuple(end_sites),
        frame_time=1.0 / motion.fps,
        motion=np.concatenate(columns, axis=-1),
    )


def write_bvh_motion(
    motion: Motion, path: str | os.PathLike[str], *, wheel_q: np.ndarray | None = None, facing: str = "+z"
) -> None:
    """Write any creature's motion as a BVH file (atomically; see :func:`motion_to_bvh`)."""
    write_bvh(motion_to_bvh(motion, wheel_q=wheel_q, facing=facing), path)
