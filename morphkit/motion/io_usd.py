"""Motions in USD: the articulation of :func:`morphkit.io.usd.write_usd` with time-sampled link
transforms. ``pxr`` is imported inside functions only.

Writing (:func:`write_usd_motion`): the morphology is written by
:func:`~morphkit.io.usd.write_usd` (a UsdPhysics articulation whose links are ``Xform`` children
of the default prim, each with a double-precision translate and orient op), then every link's
ops get one time sample per frame holding its world pose ``T_world_link`` (FK kernels; wheels
roll with the base). usdview and Omniverse play it as is. The stage's time codes are frame
numbers (``startTimeCode`` 0, ``endTimeCode`` T - 1, ``timeCodesPerSecond`` = fps). For an
exact read-back the default prim also carries:

- ``morphkit:motion:q`` (double[], time-sampled): the coordinates of each frame;
- ``morphkit:motion:coordinateNames`` (string[]): the q layout they follow;
- ``morphkit:motion:name`` (string): the motion's name.

With ``skeleton=True`` (the default) the file also holds a UsdSkel view of the same motion, for
tools that animate characters rather than articulations (usdview, Blender's USD importer,
Omniverse): a top-level ``SkelRoot`` ``/<name>_skel`` with a ``Skeleton`` whose joints are the
links (joint paths follow the tree: ``root/child/...``), rest and bind transforms from the rest
pose, and a ``SkelAnimation`` with time-sampled local translations and rotations of every link
(the root's in the skeleton root's frame, i.e. the world).

Reading (:func:`read_usd_motion`): the morphology comes from :func:`~morphkit.io.usd.read_usd`.
With ``morphkit:motion:q`` present (and matching the layout) the coordinates are read from it;
otherwise they are recovered from the link transforms' time samples (joint by joint: the
joint's own motion is ``X_jointᵀ T_parent⁻¹ T_child``), so animations authored by other tools on
the same prims read too. Stage units (``metersPerUnit``) and a Y-up stage are converted.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.conventions import quat_conjugate, quat_multiply, quat_rotate
from morphkit.errors import MotionFormatError, SourceLocation
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_canonical, quat_normalize, yaw_from_quat

__all__ = ["q_from_link_poses", "read_usd_motion", "usd_has_motion", "write_usd_motion"]

_SUFFIXES = (".usd", ".usda", ".usdc")


def _check_suffix(path: str) -> None:
    suffix = Path(path).suffix.lower()
    if suffix not in _SUFFIXES:
        raise MotionFormatError(
            f"not a USD file suffix {suffix or '(none)'!r}; expected one of: {', '.join(_SUFFIXES)}",
            location=SourceLocation(path),
        )


def _link_prims(stage: Any, robot: Any, m: Morphology) -> list[Any]:
    """The prim of every link, in link order (by ``morphkit:name`` or prim name)."""
    by_name: dict[str, Any] = {}
    for prim in robot.GetChildren():
        attr = prim.GetAttribute("morphkit:name")
        name = attr.Get() if attr and attr.HasAuthoredValue() else prim.GetName()
        by_name.setdefault(name, prim)
    missing = [n for n in m.link_names if n not in by_name]
    if missing:
        raise MotionFormatError(f"no prim for link(s) {', '.join(missing[:5])} under {robot.GetPath()}")
    return [by_name[n] for n in m.link_names]


def write_usd_motion(motion: Motion, path: str | os.PathLike[str], *, skeleton: bool = True) -> None:
    """Write ``motion`` as a USD articulation with time-sampled link transforms (atomically).

    Args:
        motion: The motion.
        path: ``.usd``, ``.usda`` or ``.usdc``.
        skeleton: Also write the UsdSkel view (see the module docstring).

    Raises:
        MotionFormatError: the suffix is not ``.usd``, ``.usda`` or ``.usdc``.
        DescriptionError: USD could not write the file.
    """
    from pxr import Gf, Sdf, UsdGeom, Vt

    from morphkit.io.usd import build_stage, export_stage

    target = os.fspath(path)
    _check_suffix(target)
    m = motion.morphology
    poses = motion.link_poses()  # [T, L, 7]
    # Built in memory and exported once: a failed write (a full disk) is one error and leaves no file.
    stage = build_stage(m, target)
    robot = stage.GetDefaultPrim()
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(max(motion.frame_count - 1, 0))
    stage.SetTimeCodesPerSecond(motion.fps)
    stage.SetFramesPerSecond(motion.fps)
    prims = _link_prims(stage, robot, m)
    for link, prim in enumerate(prims):
        ops = {op.GetOpType(): op for op in UsdGeom.Xformable(prim).GetOrderedXformOps()}
        translate = ops[UsdGeom.XformOp.TypeTranslate].GetAttr()
        orient = ops[UsdGeom.XformOp.TypeOrient].GetAttr()
        for t in range(motion.frame_count):
            p = poses[t, link]
            translate.Set(Gf.Vec3d(float(p[0]), float(p[1]), float(p[2])), t)
            orient.Set(Gf.Quatd(float(p[6]), float(p[3]), float(p[4]), float(p[5])), t)
    q_attr = robot.CreateAttribute("morphkit:motion:q", Sdf.ValueTypeNames.DoubleArray, custom=True)
    for t in range(motion.frame_count):
        q_attr.Set(Vt.DoubleArray([float(v) for v in motion.q[t]]), t)
    robot.CreateAttribute("morphkit:motion:coordinateNames", Sdf.ValueTypeNames.StringArray, custom=True).Set(
        list(m.coordinate_names)
    )
    robot.CreateAttribute("morphkit:motion:name", Sdf.ValueTypeNames.String, custom=True).Set(motion.name)
    if skeleton:
        _write_skel(stage, robot, motion, poses)
    export_stage(stage, target)


def _joint_paths(m: Morphology) -> list[str]:
    """UsdSkel joint paths (``root/child/grandchild``) of every link, in link order."""
    from pxr import Tf

    tokens = [Tf.MakeValidIdentifier(n) for n in m.link_names]
    paths: list[str] = []
    for i, parent in enumerate(m.link_parent):
        paths.append(tokens[i] if parent < 0 else f"{paths[parent]}/{tokens[i]}")
    return paths


def _local_poses(m: Morphology, poses: np.ndarray) -> np.ndarray:
    """Each link's pose in its parent link [..., L, 7] (the root's in the world)."""
    out = np.array(poses, dtype=float, copy=True)
    parent = np.asarray(m.link_parent[1:])
    inv = quat_conjugate(poses[..., parent, 3:])
    out[..., 1:, :3] = quat_rotate(inv, poses[..., 1:, :3] - poses[..., parent, :3])
    out[..., 1:, 3:] = quat_multiply(inv, poses[..., 1:, 3:])
    return out


def _matrix(pose: np.ndarray) -> Any:
    from pxr import Gf

    mat = Gf.Matrix4d(1.0)
    mat.SetRotateOnly(Gf.Quatd(float(pose[6]), float(pose[3]), float(pose[4]), float(pose[5])))
    mat.SetTranslateOnly(Gf.Vec3d(float(pose[0]), float(pose[1]), float(pose[2])))
    return mat


def _write_skel(stage: Any, robot: Any, motion: Motion, poses: np.ndarray) -> None:
    from pxr import Gf, Sdf, UsdSkel, Vt

    m = motion.morphology
    root_path = Sdf.Path.absoluteRootPath.AppendChild(f"{robot.GetName()}_skel")
    UsdSkel.Root.Define(stage, root_path)
    skel = UsdSkel.Skeleton.Define(stage, root_path.AppendChild("Skeleton"))
    anim = UsdSkel.Animation.Define(stage, root_path.AppendChild("Animation"))
    joints = Vt.TokenArray(_joint_paths(m))
    skel.CreateJointsAttr(joints)
    skel.CreateJointNamesAttr(Vt.TokenArray(list(m.link_names)))
    rest = m.rest_link_poses()
    skel.CreateRestTransformsAttr(Vt.Matrix4dArray([_matrix(p) for p in _local_poses(m, rest)]))
    skel.CreateBindTransformsAttr(Vt.Matrix4dArray([_matrix(p) for p in rest]))
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    anim.CreateJointsAttr(joints)
    local = _local_poses(m, poses)  # [T, L, 7]
    translations = anim.CreateTranslationsAttr()
    rotations = anim.CreateRotationsAttr()
    anim.CreateScalesAttr().Set(Vt.Vec3hArray([Gf.Vec3h(1.0, 1.0, 1.0)] * m.link_count))
    for t in range(motion.frame_count):
        translations.Set(Vt.Vec3fArray([Gf.Vec3f(*(float(v) for v in p[:3])) for p in local[t]]), t)
        rotations.Set(
            Vt.QuatfArray([Gf.Quatf(float(p[6]), float(p[3]), float(p[4]), float(p[5])) for p in local[t]]), t
        )


def read_usd_motion(path: str | os.PathLike[str], *, fps: float | None = None) -> Motion:
    """Read a motion from a USD file (see the module docstring).

    Args:
        path: ``.usd``, ``.usda`` or ``.usdc``.
        fps: Resample to this frame rate (``None``: the stage's ``timeCodesPerSecond``).

    Raises:
        DescriptionError: the file or its articulation cannot be read (from :func:`~morphkit.io.usd.read_usd`).
        MotionFormatError: no time samples, or stored coordinates that do not fit the morphology.
    """
    from pxr import Usd

    from morphkit.io.usd import read_usd

    src = os.fspath(path)
    _check_suffix(src)
    where = SourceLocation(src)
    m = read_usd(src)
    stage = Usd.Stage.Open(src)
    robot = _robot_prim(stage)
    rate = float(stage.GetTimeCodesPerSecond()) or 24.0
    name_attr = robot.GetAttribute("morphkit:motion:name")
    name = name_attr.Get() if name_attr and name_attr.HasAuthoredValue() else Path(src).stem
    q_attr = robot.GetAttribute("morphkit:motion:q")
    names_attr = robot.GetAttribute("morphkit:motion:coordinateNames")
    q = None
    if q_attr and q_attr.GetNumTimeSamples() > 0:
        stored_names = tuple(names_attr.Get()) if names_attr and names_attr.HasAuthoredValue() else None
        if stored_names == m.coordinate_names:
            times = q_attr.GetTimeSamples()
            q = np.array([np.asarray(q_attr.Get(t), dtype=float) for t in times])
            if q.ndim != 2 or q.shape[1] != m.coordinate_count:
                raise MotionFormatError(
                    f"morphkit:motion:q has {q.shape[-1] if q.ndim == 2 else '?'} values per frame, "
                    f"{m.name!r} has {m.coordinate_count} coordinates",
                    location=where,
                )
    if q is None:
        prims = _link_prims(stage, robot, m)
        times = sorted({t for prim in prims for t in _sample_times(prim)})
        if not times:
            raise MotionFormatError("no time-sampled link transforms: the file holds no motion", location=where)
        poses = _read_link_poses(stage, robot, prims, times)
        q = q_from_link_poses(m, poses)
    motion = Motion(m, rate, q, name)
    return motion.resample(fps) if fps is not None else motion


def usd_has_motion(path: str | os.PathLike[str]) -> bool:
    """Whether a USD file animates something: ``morphkit:motion:q`` samples or an authored time range."""
    from pxr import Tf, Usd

    try:
        stage = Usd.Stage.Open(os.fspath(path))
    except Tf.ErrorException:
        return False
    if stage is None:
        return False
    robot = _robot_prim(stage)
    attr = robot.GetAttribute("morphkit:motion:q") if robot else None
    if attr and attr.GetNumTimeSamples() > 0:
        return True
    return bool(stage.HasAuthoredTimeCodeRange())


def _robot_prim(stage: Any) -> Any:
    from pxr import UsdPhysics

    default = stage.GetDefaultPrim()
    if default and default.HasAPI(UsdPhysics.ArticulationRootAPI):
        return default
    for prim in stage.Traverse():
        if prim.HasAPI(UsdPhysics.ArticulationRootAPI):
            return prim
    return default


def _sample_times(prim: Any) -> list[float]:
    from pxr import UsdGeom

    return list(UsdGeom.Xformable(prim).GetTimeSamples())


def _read_link_poses(stage: Any, robot: Any, prims: list[Any], times: list[float]) -> np.ndarray:
    """World link poses [T, L, 7] (metres, Z up) relative to the articulation prim."""
    from pxr import UsdGeom

    scale = float(UsdGeom.GetStageMetersPerUnit(stage)) or 1.0
    y_up = UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    poses = np.zeros((len(times), len(prims), 7))
    for ti, t in enumerate(times):
        cache = UsdGeom.XformCache(t)
        for li, prim in enumerate(prims):
            mat, _ = cache.ComputeRelativeTransform(prim, robot)
            tr = mat.ExtractTranslation()
            rot = mat.ExtractRotationQuat().GetNormalized()
            im = rot.GetImaginary()
            poses[ti, li, :3] = [tr[0] * scale, tr[1] * scale, tr[2] * scale]
            poses[ti, li, 3:] = [im[0], im[1], im[2], rot.GetReal()]
    if y_up:
        # The same +90° about x that morphkit.io.usd applies to a Y-up stage's contents.
        s = np.sqrt(0.5)
        r = np.array([s, 0.0, 0.0, s])
        poses[..., :3] = quat_rotate(np.broadcast_to(r, poses[..., 3:].shape), poses[..., :3])
        poses[..., 3:] = quat_multiply(np.broadcast_to(r, poses[..., 3:].shape), poses[..., 3:])
    return poses


def q_from_link_poses(morphology: Morphology, poses: np.ndarray) -> np.ndarray:
    """Coordinates [T, C] whose FK gives the link poses ``T_world_link`` [T, L, 7].

    Each joint's own motion is recovered from its parent and child link poses; revolute and
    continuous angles come from the rotation about the joint axis (continuous ones unwrapped over
    time), prismatic offsets from the translation along it, spherical joints from the rotation
    (``w >= 0``). Link poses that no ``q`` can produce are projected onto the joint's freedom.
    """
    m = morphology
    poses = np.asarray(poses, dtype=float)
    T = poses.shape[0]
    q = np.tile(m.rest_q(), (T, 1))
    root = poses[:, 0]
    if m.base == BaseType.FLOATING:
        q[:, :3] = root[:, :3]
        q[:, 3:7] = quat_canonical(quat_normalize(root[:, 3:]))
    elif m.base in (BaseType.PLANAR, BaseType.WHEELED):
        q[:, :2] = root[:, :2]
        q[:, 2] = np.unwrap(yaw_from_quat(root[:, 3:]))
    for j, joint in enumerate(m.joints):
        if m.is_driven(joint) or joint.type == JointType.FIXED:
            continue
        parent = poses[:, m.link_index(joint.parent)]
        child = poses[:, j + 1]
        origin = np.broadcast_to(joint.origin.as_array(), (T, 7))
        # T_joint = T_parent X ; local motion = T_joint⁻¹ T_child
        jq = quat_multiply(parent[:, 3:], origin[:, 3:])
        jp = parent[:, :3] + quat_rotate(parent[:, 3:], origin[:, :3])
        inv = quat_conjugate(jq)
        local_p = quat_rotate(inv, child[:, :3] - jp)
        local_q = quat_multiply(inv, child[:, 3:])
        start = m.joint_q_start[j]
        axis = np.asarray(joint.axis, dtype=float)
        if joint.type == JointType.PRISMATIC:
            q[:, start] = local_p @ axis
        elif joint.type == JointType.SPHERICAL:
            q[:, start : start + 4] = quat_canonical(quat_normalize(local_q))
        else:
            angle = 2.0 * np.arctan2(local_q[:, :3] @ axis, local_q[:, 3])
            if joint.type == JointType.CONTINUOUS:
                q[:, start] = np.unwrap(angle)
            else:
                q[:, start] = (angle + np.pi) % (2.0 * np.pi) - np.pi
    return q
