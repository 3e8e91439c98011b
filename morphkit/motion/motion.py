"""The :class:`Motion` container: a creature's coordinates over time.

A motion is one array ``q`` [T, C] in the morphology's q layout (base coordinates first, then
joint coordinates; see :class:`~morphkit.graph.Morphology`), sampled uniformly at ``fps``.
Frame ``t`` is at time ``t / fps`` seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from morphkit.errors import MotionFormatError
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.rotations import quat_from_yaw, quat_normalize, quat_slerp

__all__ = ["MAX_FRAMES", "MAX_RESAMPLE_BYTES", "Motion", "base_pose_from_q", "quaternion_slices"]

MAX_FRAMES = 2_000_000
"""Most frames a motion may be resampled to (≈ 4.6 h at 120 fps): a longer one is a frame rate that lies."""
MAX_RESAMPLE_BYTES = 2 << 30
"""Most bytes a resampled motion's coordinates may take (float64), checked before any is computed."""


def quaternion_slices(morphology: Morphology) -> tuple[int, ...]:
    """Start index in ``q`` of every xyzw quaternion block (floating base, spherical joints)."""
    starts = [3] if morphology.base == BaseType.FLOATING else []
    for j, start in zip(morphology.joints, morphology.joint_q_start[:-1], strict=True):
        if j.type == JointType.SPHERICAL and not morphology.is_driven(j):
            starts.append(start)
    return tuple(starts)


def base_pose_from_q(morphology: Morphology, q: np.ndarray) -> np.ndarray:
    """World pose of the root link ``T_world_root`` [..., 7] from coordinates ``q`` [..., C].

    Floating: ``q[:7]``; planar and wheeled: ``(x, y, 0)`` and a yaw rotation; fixed: identity.
    """
    q = np.asarray(q, dtype=float)
    out = np.zeros((*q.shape[:-1], 7))
    out[..., 6] = 1.0
    if morphology.base == BaseType.FLOATING:
        out[...] = q[..., :7]
        out[..., 3:] = quat_normalize(out[..., 3:])
    elif morphology.base in (BaseType.PLANAR, BaseType.WHEELED):
        out[..., :2] = q[..., :2]
        out[..., 3:] = quat_from_yaw(q[..., 2])
    return out


@dataclass(frozen=True, eq=False)
class Motion:
    """A creature's motion: coordinates ``q`` per frame at a fixed frame rate.

    The array is stored read-only (float64); methods return new motions.

    Args:
        morphology: The creature whose q layout ``q`` follows.
        fps: Frames per second (> 0).
        q: Coordinates [T, coordinate_count], T >= 1: base coordinates first (floating
            ``[x, y, z, qx, qy, qz, qw]``, planar/wheeled ``[x, y, yaw]``), then joint coordinates
            ([rad], [m], spherical joints as xyzw quaternions).
        name: A label (e.g. the clip's file stem).

    Raises:
        MotionFormatError: if ``q`` has the wrong shape, a non-finite value, or ``fps`` is not positive.
    """

    morphology: Morphology
    fps: float
    q: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        q = np.array(self.q, dtype=np.float64, copy=True)
        if q.ndim != 2 or q.shape[1] != self.morphology.coordinate_count or q.shape[0] < 1:
            raise MotionFormatError(
                f"motion {self.name!r}: q must have shape [frames >= 1, {self.morphology.coordinate_count}] "
                f"for {self.morphology.name!r}, got {list(q.shape)}"
            )
        if not np.isfinite(q).all():
            bad = int(np.argwhere(~np.isfinite(q))[0, 0])
            raise MotionFormatError(f"motion {self.name!r}: non-finite coordinate at frame {bad}")
        if not (isinstance(self.fps, (int, float, np.number)) and math.isfinite(self.fps) and self.fps > 0):
            raise MotionFormatError(f"motion {self.name!r}: fps must be a positive number, got {self.fps!r}")
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "fps", float(self.fps))

    # ---- sizes and views -------------------------------------------------------------------
    @property
    def frame_count(self) -> int:
        """Number of frames T."""
        return int(self.q.shape[0])

    def __len__(self) -> int:
        return self.frame_count

    @property
    def dt(self) -> float:
        """Time between frames [s]."""
        return 1.0 / self.fps

    @property
    def duration(self) -> float:
        """Time from the first to the last frame [s]: ``(T - 1) / fps``."""
        return (self.frame_count - 1) / self.fps

    @property
    def base_q(self) -> np.ndarray:
        """Base coordinates [T, base_coordinate_count] (a view)."""
        return self.q[:, : self.morphology.base_coordinate_count]

    @property
    def joint_q(self) -> np.ndarray:
        """Joint coordinates [T, coordinate_count - base_coordinate_count] (a view)."""
        return self.q[:, self.morphology.base_coordinate_count :]

    def root_pose(self) -> np.ndarray:
        """World pose of the root link ``T_world_root`` per frame, shape [T, 7]."""
        return base_pose_from_q(self.morphology, self.q)

    def replace(self, *, q: np.ndarray | None = None, fps: float | None = None, name: str | None = None) -> Motion:
        """A copy with some fields replaced (the morphology stays)."""
        return Motion(
            self.morphology,
            self.fps if fps is None else fps,
            self.q if q is None else q,
            self.name if name is None else name,
        )

    # ---- slicing, resampling, concatenation ------------------------------------------------
    def slice(self, start: int | None = None, stop: int | None = None, step: int = 1) -> Motion:
        """Frames ``start:stop:step`` (Python slice semantics); ``fps`` becomes ``fps / step``.

        Raises:
            MotionFormatError: if the slice selects no frame or ``step`` is not positive.
        """
        if step < 1:
            raise MotionFormatError(f"motion {self.name!r}: slice step must be >= 1, got {step}")
        q = self.q[start:stop:step]
        if q.shape[0] == 0:
            raise MotionFormatError(
                f"motion {self.name!r}: slice {start}:{stop}:{step} selects no frame of {self.frame_count}"
            )
        return self.replace(q=q, fps=self.fps / step)

    def __getitem__(self, index: slice) -> Motion:
        if not isinstance(index, slice):
            raise TypeError("Motion supports slicing only (motion[a:b:c]); index q for single frames")
        return self.slice(index.start, index.stop, 1 if index.step is None else index.step)

    def sample(self, times: np.ndarray) -> np.ndarray:
        """Coordinates at arbitrary times [s], shape [N, C].

        Quaternion blocks (floating base, spherical joints) are slerped; every other coordinate
        (positions, yaw, revolute and prismatic values) is interpolated linearly. Times outside
        ``[0, duration]`` are clamped.
        """
        times = np.asarray(times, dtype=float).reshape(-1)
        if self.frame_count == 1:
            return np.repeat(self.q, len(times), axis=0)
        s = np.clip(times * self.fps, 0.0, self.frame_count - 1)
        i0 = np.minimum(np.floor(s).astype(np.int64), self.frame_count - 2)
        w = s - i0
        q0, q1 = self.q[i0], self.q[i0 + 1]
        out = q0 + w[:, None] * (q1 - q0)
        for start in quaternion_slices(self.morphology):
            out[:, start : start + 4] = quat_slerp(q0[:, start : start + 4], q1[:, start : start + 4], w)
        return out

    def resample(self, fps: float) -> Motion:
        """The motion at another frame rate, over the same time span.

        The new frames are at ``k / fps`` for ``k = 0 .. floor(duration * fps)``; see :meth:`sample`
        for the interpolation. A motion moving at constant (angular) velocity stays exact.
        """
        if not (math.isfinite(fps) and fps > 0):
            raise MotionFormatError(f"motion {self.name!r}: fps must be a positive number, got {fps!r}")
        if abs(fps - self.fps) <= 1e-9 * self.fps:
            return self
        span = self.duration * fps  # may overflow to inf for a frame rate that lies
        count = math.floor(span + 1e-6) + 1 if span < MAX_FRAMES else MAX_FRAMES + 1
        size = (span + 1.0) * self.morphology.coordinate_count * 8
        if count > MAX_FRAMES or size > MAX_RESAMPLE_BYTES:
            # Refused before sampling: a frame time that lies would otherwise ask for gigabytes (or tebibytes).
            raise MotionFormatError(
                f"motion {self.name!r}: resampling {self.duration:.6g} s from {self.fps:.6g} to {fps:.6g} fps would "
                f"make {span + 1:.6g} frames ({size / 2**30:.3g} GiB); the limit is {MAX_FRAMES} frames and "
                f"{MAX_RESAMPLE_BYTES / 2**30:.3g} GiB: check the file's frame rate"
            )
        return self.replace(q=self.sample(np.arange(count) / fps), fps=fps)

    @staticmethod
    def concatenate(motions: Sequence[Motion], *, name: str | None = None) -> Motion:
        """Join motions of one morphology and frame rate end to end (frames are not blended).

        Raises:
            MotionFormatError: if the list is empty, or the morphologies or frame rates differ.
        """
        if not motions:
            raise MotionFormatError("cannot concatenate an empty list of motions")
        first = motions[0]
        for m in motions[1:]:
            if m.morphology is not first.morphology and m.morphology != first.morphology:
                raise MotionFormatError(
                    f"cannot concatenate motions of different morphologies "
                    f"({first.morphology.name!r} and {m.morphology.name!r}); retarget one first"
                )
            if abs(m.fps - first.fps) > 1e-9 * first.fps:
                raise MotionFormatError(
                    f"cannot concatenate motions at {first.fps:g} and {m.fps:g} fps; resample one first"
                )
        q = np.concatenate([m.q for m in motions], axis=0)
        return Motion(first.morphology, first.fps, q, first.name if name is None else name)

    # ---- kinematics ------------------------------------------------------------------------
    @cached_property
    def _wheel_q(self) -> np.ndarray:
        from morphkit.motion._fk import wheel_angles

        return wheel_angles(self.morphology, self.q)

    def wheel_angles(self) -> np.ndarray:
        """Angles [rad] of the drive wheels, rolling without slip along the base path, shape [T, W]
        (W = 0 unless the base is wheeled with named wheels); 0 at the first frame."""
        return self._wheel_q

    @cached_property
    def _fk(self) -> tuple[np.ndarray, np.ndarray]:
        from morphkit.motion._fk import link_poses_and_end_effectors

        wheel_q = self._wheel_q if self._wheel_q.shape[1] else None
        return link_poses_and_end_effectors(self.morphology, self.q, wheel_q)

    def link_poses(self) -> np.ndarray:
        """World poses of every link ``T_world_link`` per frame, shape [T, L, 7] (through the FK kernels;
        wheels turn with :meth:`wheel_angles`)."""
        return self._fk[0]

    def link_positions(self) -> np.ndarray:
        """World positions of every link origin per frame, shape [T, L, 3] [m]."""
        return self._fk[0][..., :3]

    def end_effector_positions(self) -> np.ndarray:
        """World end-effector positions per frame, shape [T, E, 3] [m] (``morphology.end_effectors`` order)."""
        return self._fk[1]
