"""Motion exports read by tools that are not morphkit: BVH through bvhio, USD through pxr itself.

The other motion tests read exported files back with morphkit's own readers, so a convention
error shared by writer and reader (an Euler order, a sign, an axis swap) would pass them. Here
bvhio (a third-party BVH library with its own parser and forward kinematics) and USD's
``UsdGeom`` / ``UsdSkel`` evaluators place every joint, and the result must match
:meth:`Motion.link_poses`, which comes from morphkit's FK kernels.

Conventions used to compare: BVH files are Y up, +Z forward, so a BVH world point ``p`` is
``BVH_TO_MORPHKIT @ p`` in morphkit's axes and a BVH world rotation ``R`` is
``BVH_TO_MORPHKIT R BVH_TO_MORPHKITᵀ``. ``write_bvh_motion`` writes metres; a file read with
its own skeleton is compared up to the similarity (scale, rotation, shift) the reader applies.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from morphkit.io import read_morphology
from morphkit.io.bvh import BVH_TO_MORPHKIT
from morphkit.io.shipped import resolve_morphology
from morphkit.motion import Motion, read_bvh_motion, write_bvh_motion

bvhio = pytest.importorskip("bvhio")
glm = pytest.importorskip("glm")  # PyGLM, bvhio's vector maths

DATA = Path(os.environ["MORPHKIT_DATA"]) if os.environ.get("MORPHKIT_DATA") else None
CMU_CLIP = "02_04.bvh"  # 121 frames; the first 40 are used

POS_TOL_BVH = 1e-4  # [m]; bvhio works in float32 (PyGLM)
ROT_TOL_BVH = 1e-4  # rotation-matrix entries
POS_TOL_USD = 1e-5  # [m]
ROT_TOL_USD = 1e-5

# A small Y-up skeleton in centimetres, with a different Euler order on every joint and a
# translating root, read by morphkit as a BVH-skeleton motion (spherical joints).
SMALL_BVH_FRAMES = 12
SMALL_BVH_HEADER = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
  JOINT Spine
  {
    OFFSET 0 20 1
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0 30 3
      CHANNELS 3 Xrotation Yrotation Zrotation
      End Site
      {
        OFFSET 0 12 0
      }
    }
  }
  JOINT LeftUpLeg
  {
    OFFSET 10 -5 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT LeftLeg
    {
      OFFSET 0 -40 2
      CHANNELS 3 Yrotation Zrotation Xrotation
      JOINT LeftFoot
      {
        OFFSET 0 -40 -2
        CHANNELS 3 Xrotation Zrotation Yrotation
        End Site
        {
          OFFSET 0 -5 12
        }
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET -10 -5 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightLeg
    {
      OFFSET 0 -40 2
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT RightFoot
      {
        OFFSET 0 -40 -2
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -5 12
        }
      }
    }
  }
}
MOTION
"""


def _small_bvh_text() -> str:
    rng = np.random.default_rng(3)
    rows = []
    for t in range(SMALL_BVH_FRAMES):
        root = [4.0 * t, 92.0 + 2.0 * math.sin(t), 1.5 * t]
        angles = rng.uniform(-40.0, 40.0, size=3 + 3 * 8)
        angles[:3] = [15.0 * t, 5.0, -3.0]  # the root turns about Y and leans a little
        rows.append(" ".join(f"{v:.6f}" for v in [*root, *angles]))
    return SMALL_BVH_HEADER + f"Frames: {SMALL_BVH_FRAMES}\nFrame Time: 0.04\n" + "\n".join(rows) + "\n"


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] of xyzw unit quaternions [..., 4] (column-vector convention)."""
    x, y, z, w = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def _bvhio_world(path: Path) -> tuple[list[str], np.ndarray, np.ndarray, float, int]:
    """bvhio's world joint poses, in the file's axes and units.

    Returns:
        Joint names, positions [T, J, 3], rotation matrices [T, J, 3, 3], frame time [s], frame count.
    """
    container = bvhio.readAsBvh(str(path))
    # bvhio turns each joint's frame so that its Y axis runs along the bone (the joint's "rest
    # rotation"); undoing it gives the BVH joint frame the channels rotate.
    bone = {joint.Name: joint.getRotation() for joint, _, _ in container.Root.layout()}
    root = bvhio.readAsHierarchy(str(path))
    layout = [joint for joint, _, _ in root.layout()]
    T = container.FrameCount
    pos = np.zeros((T, len(layout), 3))
    rot = np.zeros((T, len(layout), 3, 3))
    for t in range(T):
        root.loadPose(t, recursive=True)
        for j, joint in enumerate(layout):
            pos[t, j] = np.array(joint.PositionWorld, dtype=float)
            r = joint.RotationWorld * glm.inverse(bone[joint.Name])
            rot[t, j] = _quat_matrix(np.array([r.x, r.y, r.z, r.w], dtype=float))
    return [joint.Name for joint in layout], pos, rot, float(container.FrameTime), T


def _bvh_to_morphkit(pos: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    B = np.asarray(BVH_TO_MORPHKIT)
    return pos @ B.T, B @ rot @ B.T


def _check_bvh_export(motion: Motion, path: Path) -> tuple[float, float]:
    """Export ``motion`` to ``path``, read it with bvhio and compare world link poses.

    Returns:
        Largest position error [m] and largest rotation-matrix entry error.
    """
    write_bvh_motion(motion, path)
    names, pos, rot, frame_time, T = _bvhio_world(path)
    m = motion.morphology
    assert T == motion.frame_count
    assert frame_time == pytest.approx(1.0 / motion.fps, rel=1e-5)
    assert sorted(names) == sorted(m.link_names)  # one BVH joint per link
    pos, rot = _bvh_to_morphkit(pos, rot)
    order = [names.index(n) for n in m.link_names]
    poses = motion.link_poses()
    pos_err = float(np.abs(pos[:, order] - poses[..., :3]).max())
    rot_err = float(np.abs(rot[:, order] - _quat_matrix(poses[..., 3:])).max())
    assert pos_err < POS_TOL_BVH, f"{motion.name}: bvhio link positions differ by {pos_err:.3g} m"
    assert rot_err < ROT_TOL_BVH, f"{motion.name}: bvhio link rotations differ by {rot_err:.3g}"
    return pos_err, rot_err


def _similarity_residual(src: np.ndarray, dst: np.ndarray) -> tuple[float, float]:
    """Best ``dst ≈ s R src + t`` over all points (Umeyama); the largest residual and ``s``."""
    src = src.reshape(-1, 3)
    dst = dst.reshape(-1, 3)
    mu_s, mu_d = src.mean(0), dst.mean(0)
    a, b = src - mu_s, dst - mu_d
    u, sig, vt = np.linalg.svd(b.T @ a / len(src))
    d = np.ones(3)
    d[2] = np.sign(np.linalg.det(u @ vt))
    R = u @ np.diag(d) @ vt
    s = float((sig * d).sum() / (a * a).sum(axis=1).mean())
    residual = dst - (s * a @ R.T + mu_d)
    return float(np.abs(residual).max()), s


def _check_bvh_read(path: Path, motion: Motion) -> float:
    """bvhio's joint positions of the original file match ``motion`` (read from it by morphkit) up
    to one similarity transform; returns the largest residual [m]."""
    names, pos, _, _, T = _bvhio_world(path)
    assert T >= motion.frame_count
    m = motion.morphology
    order = [names.index(n) for n in m.link_names]
    residual, _ = _similarity_residual(pos[: motion.frame_count, order], motion.link_positions())
    assert residual < POS_TOL_BVH, f"{path.name}: the read motion differs from bvhio's FK by {residual:.3g} m"
    return residual


@pytest.fixture(scope="module")
def spot_motion() -> Motion:
    from morphkit.synth import synthesize

    m = read_morphology(resolve_morphology("spot"))
    return synthesize(m, frames=60, seed=0, progress=False)[0]


def _stretch_motion() -> Motion:
    """Stretch drives an arc (root translation and yaw, so the wheels turn) while lifting,
    extending the arm, yawing the wrist and panning the head."""
    m = read_morphology(resolve_morphology("stretch"))
    T = 40
    s = np.linspace(0.0, 1.0, T)
    q = np.tile(m.rest_q(), (T, 1))
    yaw = 1.2 * s
    q[:, 0] = 0.8 * np.sin(yaw)
    q[:, 1] = 0.8 * (1.0 - np.cos(yaw))
    q[:, 2] = yaw
    lo, hi = m.coordinate_limits
    for c in range(3, m.coordinate_count):
        a, b = (lo[c], hi[c]) if np.isfinite(lo[c]) and np.isfinite(hi[c]) else (-1.0, 1.0)
        q[:, c] = a + (b - a) * (0.2 + 0.6 * (0.5 - 0.5 * np.cos(np.pi * (s + 0.1 * c))))
    return Motion(m, 30.0, q, "stretch_arc")


def _cmu_path() -> Path:
    if DATA is None:
        pytest.skip("MORPHKIT_DATA is not set")
    path = DATA / "human" / "cmu" / CMU_CLIP
    if not path.is_file():
        pytest.skip(f"no {path}")
    return path


# ---------------------------------------------------------------------------------------------
# BVH
# ---------------------------------------------------------------------------------------------
def test_bvh_export_spot_matches_bvhio(spot_motion: Motion, tmp_path: Path) -> None:
    assert np.ptp(spot_motion.root_pose()[:, :2], axis=0).max() > 0.05  # it moves
    _check_bvh_export(spot_motion, tmp_path / "spot.bvh")


def test_bvh_export_stretch_matches_bvhio(tmp_path: Path) -> None:
    motion = _stretch_motion()
    # The wheels roll through several turns, so matching rotations include their spin.
    assert np.ptp(motion.wheel_angles(), axis=0).min() > 2.0 * math.pi
    _check_bvh_export(motion, tmp_path / "stretch.bvh")


def test_bvh_skeleton_motion_matches_bvhio(tmp_path: Path) -> None:
    """A BVH file with mixed Euler orders: morphkit's reading agrees with bvhio, and so does the export."""
    src = tmp_path / "small.bvh"
    src.write_text(_small_bvh_text())
    motion = read_bvh_motion(src)
    _check_bvh_read(src, motion)
    _check_bvh_export(motion, tmp_path / "small_out.bvh")


def test_bvh_cmu_clip_matches_bvhio(tmp_path: Path) -> None:
    path = _cmu_path()
    motion = read_bvh_motion(path)[:40]
    _check_bvh_read(path, motion)
    _check_bvh_export(motion, tmp_path / "cmu_out.bvh")


# ---------------------------------------------------------------------------------------------
# USD
# ---------------------------------------------------------------------------------------------
def _gf_pose(matrix: object) -> tuple[np.ndarray, np.ndarray]:
    """Translation [3] and rotation [3, 3] (column-vector convention) of a Gf.Matrix4d, which
    stores row vectors (translation in the last row)."""
    a = np.array(matrix, dtype=float)
    return a[3, :3], a[:3, :3].T


def _check_usd_stage_timing(stage: object, motion: Motion) -> None:
    from pxr import UsdGeom

    assert stage.GetStartTimeCode() == 0.0
    assert stage.GetEndTimeCode() == motion.frame_count - 1
    assert stage.GetTimeCodesPerSecond() == pytest.approx(motion.fps)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == pytest.approx(1.0)


def _link_prims(stage: object, motion: Motion) -> list[object]:
    """Each link's prim: the default prim's child named after it (or carrying its ``morphkit:name``)."""
    by_name = {}
    for prim in stage.GetDefaultPrim().GetChildren():
        attr = prim.GetAttribute("morphkit:name")
        by_name[attr.Get() if attr and attr.HasAuthoredValue() else prim.GetName()] = prim
    return [by_name[n] for n in motion.morphology.link_names]


def _check_usd_link_transforms(path: Path, motion: Motion, times: list[int]) -> tuple[float, float]:
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    _check_usd_stage_timing(stage, motion)
    prims = _link_prims(stage, motion)
    poses = motion.link_poses()
    pos_err = rot_err = 0.0
    for t in times:
        for link, prim in enumerate(prims):
            p, r = _gf_pose(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(t)))
            pos_err = max(pos_err, float(np.abs(p - poses[t, link, :3]).max()))
            rot_err = max(rot_err, float(np.abs(r - _quat_matrix(poses[t, link, 3:])).max()))
    assert pos_err < POS_TOL_USD, f"USD link positions differ by {pos_err:.3g} m"
    assert rot_err < ROT_TOL_USD, f"USD link rotations differ by {rot_err:.3g}"
    return pos_err, rot_err


def _check_usd_skel(path: Path, motion: Motion, times: list[int]) -> tuple[float, float]:
    from pxr import Usd, UsdGeom, UsdSkel

    stage = Usd.Stage.Open(str(path))
    roots = [p for p in stage.Traverse() if p.IsA(UsdSkel.Root)]
    skeletons = [p for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton)]
    animations = [p for p in stage.Traverse() if p.IsA(UsdSkel.Animation)]
    assert len(roots) == 1 and len(skeletons) == 1 and len(animations) == 1
    skel = UsdSkel.Skeleton(skeletons[0])
    cache = UsdSkel.Cache()
    cache.Populate(UsdSkel.Root(roots[0]), Usd.TraverseInstanceProxies())
    query = cache.GetSkelQuery(skel)
    assert query and query.GetAnimQuery(), "the skeleton has no bound animation"
    assert query.GetAnimQuery().GetPrim().GetPath() == animations[0].GetPath()
    assert list(query.GetAnimQuery().GetJointTransformTimeSamples()) == list(range(motion.frame_count))
    # Joints are named by the last element of their path; map them to links by name.
    joint_names = [str(j).rsplit("/", 1)[-1] for j in query.GetJointOrder()]
    order = [joint_names.index(n) for n in motion.morphology.link_names]
    poses = motion.link_poses()
    pos_err = rot_err = 0.0
    for t in times:
        xf_cache = UsdGeom.XformCache(Usd.TimeCode(t))
        world = query.ComputeJointWorldTransforms(xf_cache, atRest=False)
        for link, j in enumerate(order):
            p, r = _gf_pose(world[j])
            pos_err = max(pos_err, float(np.abs(p - poses[t, link, :3]).max()))
            rot_err = max(rot_err, float(np.abs(r - _quat_matrix(poses[t, link, 3:])).max()))
    assert pos_err < POS_TOL_USD, f"UsdSkel joint positions differ by {pos_err:.3g} m"
    assert rot_err < ROT_TOL_USD, f"UsdSkel joint rotations differ by {rot_err:.3g}"
    return pos_err, rot_err


def test_usd_export_spot_link_transforms(spot_motion: Motion, tmp_path: Path) -> None:
    pytest.importorskip("pxr")
    from morphkit.motion import write_usd_motion

    path = tmp_path / "spot.usda"
    write_usd_motion(spot_motion, path)
    times = [0, 17, 42, spot_motion.frame_count - 1]
    _check_usd_link_transforms(path, spot_motion, times)
    _check_usd_skel(path, spot_motion, times)


def test_usd_export_bvh_skeleton_uses_skel(tmp_path: Path) -> None:
    pytest.importorskip("pxr")
    from morphkit.motion import write_usd_motion

    src = tmp_path / "small.bvh"
    src.write_text(_small_bvh_text())
    motion = read_bvh_motion(src)
    path = tmp_path / "small.usda"
    write_usd_motion(motion, path)
    times = [0, 5, motion.frame_count - 1]
    _check_usd_link_transforms(path, motion, times)
    _check_usd_skel(path, motion, times)


def test_usd_export_cmu_clip_uses_skel(tmp_path: Path) -> None:
    pytest.importorskip("pxr")
    from morphkit.motion import write_usd_motion

    motion = read_bvh_motion(_cmu_path())[:30]
    path = tmp_path / "cmu.usdc"
    write_usd_motion(motion, path)
    times = [0, 11, motion.frame_count - 1]
    _check_usd_link_transforms(path, motion, times)
    _check_usd_skel(path, motion, times)
