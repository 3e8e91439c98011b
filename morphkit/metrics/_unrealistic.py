"""The unrealistic frame ratio (UFR) of ACE (Li et al. 2023, §7), measured with the contact kernels.

UFR is "the number of generated motion frames containing unrealistic effects divided by the
total number of motion frames", the effects being self-collision, foot penetration and foot
sliding. The paper gives no thresholds; morphkit's are in :class:`UnrealisticFrameThresholds`,
each effect is measured by a public query of :mod:`morphkit.kernels` on the motion's forward
kinematics (:meth:`~morphkit.motion.Motion.link_poses`,
:meth:`~morphkit.motion.Motion.end_effector_positions`), and the per-frame flags come back with
the ratio (:class:`UnrealisticFrames`).

Feet are the end-effectors whose role is ``foot`` (:func:`~morphkit.kernels.foot_indices`);
the ground is the plane $z = z_g$ (z up, metres).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.contact_rules import UFR
from morphkit.conventions import VELOCITY_DIFFERENCE
from morphkit.errors import ConfigError

if TYPE_CHECKING:
    from morphkit.graph import Morphology
    from morphkit.motion import Motion

__all__ = ["UnrealisticFrameThresholds", "UnrealisticFrames", "unrealistic_frame_ratio"]


@dataclass(frozen=True)
class UnrealisticFrameThresholds:
    """What counts as unrealistic in :func:`unrealistic_frame_ratio` (SI units: m, m/s).

    The ACE paper names the three effects but not their thresholds (its Spot dataset scores 0.258 %);
    these defaults are morphkit's, checked on clean motion: 1,800 synthesised frames each of Spot,
    the crab and the human (feet planted) flag 0.11 %, 0 % and 0.28 % of frames, all of it
    self-collision; CMU walking clips (05_01, 06_01, 07_03, 103_07) flag 0 % for sliding and
    penetration (at 10 cm/s, up to 4 % would slide) and up to 0.85 % for knees brushing.
    """

    contact_height: float = UFR.height
    """A foot lower than this above the ground is in contact [m] (2 cm: the default of the contact
    kernels and of ``morphkit synth --report``)."""
    sliding_speed: float = UFR.speed
    """A foot in contact moving horizontally faster than this slides [m/s] (20 cm/s: 1 cm per frame
    is 30 cm/s at 30 fps and counts from 21 fps up; stance feet of CMU walking stay below it; the
    speed below which the contact kernels call a foot planted)."""
    penetration_depth: float = 0.005
    """A foot deeper than this below the ground penetrates it [m] (5 mm: above mocap and IK noise,
    below what a render shows)."""
    self_collision_depth: float = 0.005
    """Two link shapes overlapping by more than this collide [m] (5 mm, as ``penetration_depth``;
    the shapes are simple proxies — capsules, boxes — so touching is not colliding)."""
    rest_margin: float = 0.005
    """Shape pairs closer than this at the rest pose are never checked [m] (they touch by design;
    :func:`~morphkit.kernels.self_collision_pairs`, as ``morphkit synth --report``)."""
    ground_height: float = 0.0
    """Height of the ground plane $z_g$ [m]."""

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float, np.number)) or not np.isfinite(v):
                raise ConfigError(f"UnrealisticFrameThresholds.{f.name} must be a finite number, got {v!r}")
            if f.name != "ground_height" and v < 0:
                raise ConfigError(f"UnrealisticFrameThresholds.{f.name} must be >= 0, got {v!r}")
            object.__setattr__(self, f.name, float(v))


@dataclass(frozen=True, eq=False)
class UnrealisticFrames:
    """Per-frame flags of :func:`unrealistic_frame_ratio` (T frames; boolean arrays, read-only)."""

    self_collision: np.ndarray
    """Some pair of link shapes overlaps by more than the threshold, shape [T]."""
    foot_penetration: np.ndarray
    """Some foot is deeper below the ground than the threshold, shape [T]."""
    foot_sliding: np.ndarray
    """Some foot in contact slides faster than the threshold, shape [T]."""
    foot_names: tuple[str, ...] = ()
    """The end-effectors checked as feet."""

    @property
    def unrealistic(self) -> np.ndarray:
        """Frames with at least one unrealistic effect, shape [T]."""
        return self.self_collision | self.foot_penetration | self.foot_sliding

    @property
    def frame_count(self) -> int:
        """T."""
        return int(self.self_collision.shape[0])

    @property
    def unrealistic_count(self) -> int:
        """Number of unrealistic frames."""
        return int(self.unrealistic.sum())

    @property
    def ratio(self) -> float:
        """UFR: unrealistic frames / all frames, in [0, 1] (ACE Table 1 prints it in %; 0 for no frames)."""
        return self.unrealistic_count / self.frame_count if self.frame_count else 0.0

    def cause_ratios(self) -> dict[str, float]:
        """Fraction of frames flagged for each effect (a frame may count under several)."""
        n = max(self.frame_count, 1)
        return {
            "self_collision": float(self.self_collision.sum()) / n,
            "foot_penetration": float(self.foot_penetration.sum()) / n,
            "foot_sliding": float(self.foot_sliding.sum()) / n,
        }

    @staticmethod
    def concatenate(results: Sequence[UnrealisticFrames]) -> UnrealisticFrames:
        """Several motions' flags end to end: ``.ratio`` is then the UFR over all their frames (feet: the first's)."""
        if not results:
            return UnrealisticFrames(*(_frozen(np.zeros(0, dtype=bool)) for _ in range(3)))
        return UnrealisticFrames(
            _frozen(np.concatenate([r.self_collision for r in results])),
            _frozen(np.concatenate([r.foot_penetration for r in results])),
            _frozen(np.concatenate([r.foot_sliding for r in results])),
            results[0].foot_names,
        )


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=bool)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class _Compiled:
    model: Any
    """The :class:`~morphkit.model.KinematicModel` on the CPU."""
    pairs: dict[float, Any]
    """Self-collision candidate pairs by ``rest_margin``."""

    def self_collision_pairs(self, rest_margin: float) -> Any:
        from morphkit.kernels import self_collision_pairs

        hit = self.pairs.get(rest_margin)
        if hit is None:
            hit = self.pairs[rest_margin] = self_collision_pairs(self.model, rest_margin=rest_margin,
                                                                 skip_adjacent=True)
        return hit


def _compile(morphology: Morphology) -> _Compiled:
    """The compiled CPU model of ``morphology`` (the motion layer's, shared by its clips) and its pairs."""
    from morphkit.motion import compiled_model

    model = compiled_model(morphology)
    return _Compiled(model, model.kernel_cache().setdefault("ufr_self_collision_pairs", {}))


def feet_of(motion: Motion, feet: Sequence[str] | None, who: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """Indices [F] into the motion's end-effectors of its feet (role ``foot``, or the names ``feet``),
    and their names.

    Raises:
        ConfigError: a name that is no end-effector of the motion's creature (``who`` says whose call).
    """
    from morphkit.kernels import foot_indices
    from morphkit.motion import compiled_model

    model = compiled_model(motion.morphology)
    names = tuple(model.ee_names)
    if feet is None:
        idx = foot_indices(model)
    else:
        unknown = [n for n in feet if n not in names]
        if unknown:
            raise ConfigError(
                f"{who}: no end-effector {unknown[0]!r} on {motion.morphology.name!r} "
                f"(end-effectors: {', '.join(names) or 'none'})"
            )
        idx = np.asarray([names.index(n) for n in feet], dtype=np.int32)
    return idx, tuple(names[int(i)] for i in idx)


def contact_over_difference(contact: np.ndarray) -> np.ndarray:
    """``contact`` [T, F], kept only where the foot is also in contact at every frame its velocity comes from.

    Motion velocities follow :data:`morphkit.conventions.VELOCITY_DIFFERENCE`: backward differences,
    ``v_t`` from frames t - 1 and t (frame 0 from frames 0 and 1). At a touchdown frame the
    difference reaches back into the swing, whose horizontal speed is not sliding.
    """
    out = contact.copy()
    if VELOCITY_DIFFERENCE == "backward":
        out[1:] &= contact[:-1]
        out[:1] &= contact[1:2] if len(contact) > 1 else contact[:1]
    elif VELOCITY_DIFFERENCE == "central":
        out[1:] &= contact[:-1]
        out[:-1] &= contact[1:]
    else:  # pragma: no cover - a new convention must say which frames a velocity reads
        raise NotImplementedError(f"velocity difference {VELOCITY_DIFFERENCE!r}")
    return out


def unrealistic_frame_ratio(
    motion: Motion,
    *,
    thresholds: UnrealisticFrameThresholds | None = None,
    feet: Sequence[str] | None = None,
) -> UnrealisticFrames:
    """Unrealistic frames of a motion: self-collision, foot penetration, foot sliding (ACE §7, UFR).

    Per frame $t$ (thresholds from ``thresholds``; see :class:`UnrealisticFrameThresholds`):

    - **self-collision**: some candidate pair of link shapes has signed distance
      $d < -d_\\text{self}$ (:func:`~morphkit.kernels.eval_self_collision_distance`; pairs from
      :func:`~morphkit.kernels.self_collision_pairs`, which skips shapes on one rigid body,
      parent–child neighbours across one joint, meshes, and pairs closer than ``rest_margin`` at rest);
    - **foot penetration**: some foot is deeper than $d_\\text{pen}$ below the ground,
      $\\max(0, z_g - p_z) > d_\\text{pen}$ (:func:`~morphkit.kernels.eval_penetration_depth`);
    - **foot sliding**: some foot in contact ($p_z - z_g <$ ``contact_height``) moves horizontally
      faster than ``sliding_speed``, the speed $\\lVert (v_x, v_y) \\rVert$ being
      :func:`~morphkit.kernels.eval_sliding_speed` (backward differences times fps,
      :data:`morphkit.conventions.VELOCITY_DIFFERENCE`). A foot counts as in contact for sliding
      only when it is in contact at both frames its velocity is measured from (t - 1 and t): at a
      touchdown frame the difference reaches back into the swing, which is not sliding (a morphkit
      choice; the paper does not say).

    $\\mathrm{UFR} = |\\{t : \\text{any effect}\\}| / T$. For a set of clips, pool the frames
    (:meth:`UnrealisticFrames.concatenate`), as the paper counts over all generated frames.

    Args:
        motion: The motion (e.g. a retargeted clip, exactly as exported).
        thresholds: What counts as unrealistic (default :class:`UnrealisticFrameThresholds()`).
        feet: End-effector names to check as feet (default: every end-effector whose role is
            ``foot``). A creature without feet is never flagged for penetration or sliding.

    Returns:
        The per-frame flags of each effect and their ratio (:attr:`UnrealisticFrames.ratio`).

    Raises:
        ConfigError: an unknown foot name.
    """
    from morphkit.kernels import (
        eval_foot_heights,
        eval_penetration_depth,
        eval_self_collision_distance,
        eval_sliding_speed,
    )

    thr = UnrealisticFrameThresholds() if thresholds is None else thresholds
    compiled = _compile(motion.morphology)
    model = compiled.model
    foot_idx, _ = feet_of(motion, feet, "unrealistic_frame_ratio")
    T = motion.frame_count
    penetration = np.zeros(T, dtype=bool)
    sliding = np.zeros(T, dtype=bool)
    if len(foot_idx):
        pos = motion.end_effector_positions()  # [T, E, 3], world [m]
        g = thr.ground_height
        depth = eval_penetration_depth(pos, feet=foot_idx, ground_height=g).numpy()  # [T, F] [m]
        penetration = (depth > thr.penetration_depth).any(axis=-1)
        height = eval_foot_heights(pos, feet=foot_idx, ground_height=g).numpy()  # [T, F] [m]
        speed = eval_sliding_speed(pos, motion.fps, feet=foot_idx, height_threshold=thr.contact_height,
                                   ground_height=g).numpy()  # [T, F] [m/s]
        contact = contact_over_difference(height < thr.contact_height)
        sliding = ((speed > thr.sliding_speed) & contact).any(axis=-1)
    collision = np.zeros(T, dtype=bool)
    pairs = compiled.self_collision_pairs(thr.rest_margin)
    if pairs.pair_count:
        dist = eval_self_collision_distance(model, pairs, motion.link_poses()).numpy()  # [T, P] [m]
        collision = (dist < -thr.self_collision_depth).any(axis=-1)
    return UnrealisticFrames(
        _frozen(collision),
        _frozen(penetration),
        _frozen(sliding),
        tuple(model.ee_names[int(i)] for i in foot_idx),
    )
