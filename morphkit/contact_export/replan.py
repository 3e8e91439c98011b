"""Contact-aware export by re-planning: a motion's legs stepped again by the synthesis' footstep planner.

A retargeted motion (ACE's, NKN's, any file's) keeps its root path, body height and tilt and every
non-leg joint; its legs are replaced by what :class:`~morphkit.synth.legged.LeggedController` plans
along that root path — stance feet fixed in the world until they lift, swing arcs between — solved
by the same damped-least-squares IK as the synthesis. The retargeter decides *where the body goes*
and what the arms do; the planner decides *where the feet go*, so a stance foot cannot slide.

Choices that are ours (named here and in the docs):

* the root's heading-frame velocity and yaw rate the planner is fed are the path's
  (:func:`~morphkit.motion.heading.heading_velocity`: backward differences, the conventions' rule),
  smoothed over ``smoothing_seconds``; the path beyond the last
  frame holds still (the planner looks ahead to place touchdowns);
* a leg IK warm-starts from the previous frame's solution (the first frame: the creature's stance
  pose), never from the retargeter's leg angles, which are what is being replaced;
* at least ``min_support`` (1) foot stays on the ground: a path that twists fast (a human spinning,
  ±3 rad/s) sends three or four feet to the edges of their ellipses in one frame, and lifting them all
  makes a flight longer than any in the creature's data; the foot deepest inside its ellipse waits instead
  until another touches down (the synthesis keeps its gaits' own flights);
* a leg given a ``swing_hint`` (the retarget layer gives one to a creature foot that alone is paired with a
  human foot — a biped's, not a quadruped's two left feet) lifts on the first frame of each of the hint's
  airborne runs and touches down on the frame the run ends (at least the shortest swing; later, if
  ``min_support`` held it, while half a shortest swing of the run remains); within one gait cycle of such a
  run the gait's phase lifts it no more, only its ellipse's edge does (a creature whose steps are shorter than
  the human's re-steps in between); elsewhere (a human standing still) and for runs shorter than half the
  shortest swing (a contact detector's flicker) the gait's phase steps it as without a hint;
* nothing but the legs moves: an arm or head the retargeter put through the ground stays there
  (the upper body is the retargeter's to answer for).

Creatures without legs (wheeled, planar, fixed bases, gliders) come back unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from morphkit.errors import ConfigError
from morphkit.motion.heading import heading_velocity
from morphkit.motion.motion import Motion
from morphkit.synth.core import SynthConfig, prepare
from morphkit.synth.legged import LeggedController
from morphkit.synth.wheeled import Locomotion

__all__ = ["replan_legs"]


def _smooth(x: np.ndarray, frames: int) -> np.ndarray:
    """Centred moving average over ``2 frames + 1`` samples along axis 0 (edges: shrinking window)."""
    if frames <= 0 or len(x) < 3:
        return x
    c = np.cumsum(np.concatenate([np.zeros((1, *x.shape[1:])), x]), axis=0)
    n = len(x)
    lo = np.clip(np.arange(n) - frames, 0, n)
    hi = np.clip(np.arange(n) + frames + 1, 0, n)
    return (c[hi] - c[lo]) / (hi - lo).reshape(-1, *([1] * (x.ndim - 1)))


class _SwingSchedule:
    """The swings ``swing_hint`` asks of the hinted legs (see :func:`replan_legs`), as the planner takes them.

    A hint's airborne runs shorter than half the shortest swing are dropped (a contact detector's flicker);
    a leg follows its hint within one gait cycle (at the creature's cadence) of a kept run, and is stepped
    by the gait's phase elsewhere (a human standing still, or a clip that starts before its first step).
    """

    def __init__(self, hints: dict[int, np.ndarray], T: int, NL: int, n_swing_min: int, cycle: int) -> None:
        self.min_run = max(2, -(-n_swing_min // 2))
        self.run = np.full((T, NL), -1, dtype=np.int64)  # index of the kept airborne run each frame is in
        self.end = np.zeros((T, NL), dtype=np.int64)  # the frame that run touches down (exclusive end)
        self.follow = np.zeros((T, NL), dtype=bool)
        self.used = np.full(NL, -1, dtype=np.int64)
        for leg, air in hints.items():
            edges = np.diff(np.concatenate([[0], air.astype(np.int8), [0]]))
            starts, ends = np.nonzero(edges > 0)[0], np.nonzero(edges < 0)[0]
            keep = ends - starts >= self.min_run
            for i, (a, b) in enumerate(zip(starts[keep], ends[keep], strict=True)):
                self.run[a:b, leg] = i
                self.end[a:b, leg] = b
                self.follow[max(a - cycle, 0):b + cycle, leg] = True

    def lift(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """Legs [1, NL] to lift at frame ``t`` (the first frame of a run no swing has used yet, or later while
        enough of it remains) and their swing frames [1, NL] (touching down as the run ends)."""
        run, left = self.run[t], self.end[t] - t
        lift = (run >= 0) & (run != self.used) & (left >= self.min_run)
        return lift[None], (left + 1)[None]

    def update(self, t: int, stance: np.ndarray) -> None:
        """Mark the runs of legs airborne at frame ``t`` (``stance`` [NL]) used: one swing per run."""
        air = ~stance & (self.run[t] >= 0)
        self.used[air] = self.run[t, air]


def replan_legs(motion: Motion, *, config: SynthConfig | None = None, smoothing_seconds: float = 0.1,
                min_support: int = 1, swing_hint: Mapping[str, np.ndarray] | None = None) -> Motion:
    """``motion`` with its legs re-planned along its own root path (see the module docstring).

    Args:
        motion: A motion of a legged creature (floating base).
        config: Synthesis configuration (leg parameters, IK iterations; default :class:`SynthConfig`).
        smoothing_seconds: Half-width of the moving average on the velocities fed to the planner [s].
        min_support: Feet kept on the ground whatever the gait and the path ask (``LeggedController``).
        swing_hint: ``{foot end-effector: [T] bool}``, True where that leg's foot should be in the air: its
            swings lift off and touch down with the hint's airborne runs instead of the gait's phase, as far
            as the planner allows (the shortest swing, ``min_support``, lifts at the ellipse's edge, reachable
            touchdowns). None, or legs it does not name: the gait's phase alone.

    Returns:
        A motion of the same creature, frame rate and length: base coordinates and non-leg joints
        bit-identical to ``motion``'s, leg joints re-solved.

    Raises:
        ConfigError: a hint naming no leg's foot, or not of the motion's length.
    """
    m = motion.morphology
    rig = prepare(m, fps=motion.fps, config=config)
    if rig.locomotion != Locomotion.LEGGED or rig.legs is None or motion.frame_count == 0:
        return motion
    cfg = rig.config
    hints = _leg_hints(swing_hint, tuple(leg.end_effector for leg in rig.plan.legs), motion.frame_count)
    fps = motion.fps
    T = motion.frame_count
    root = motion.root_pose()
    xy = root[:, :2]
    # velocities the planner needs: in the heading frame, smoothed
    vel = heading_velocity(root, fps)
    yaw, v, w = vel.yaw, vel.linear[:, :2], vel.yaw_rate
    k = round(smoothing_seconds * fps)
    v, w = _smooth(v, k), _smooth(w, k)
    pad = int(np.ceil(cfg.look_ahead_seconds * fps))
    path_xy = np.concatenate([xy, np.repeat(xy[-1:], pad, axis=0)])[None]
    path_yaw = np.concatenate([yaw, np.repeat(yaw[-1:], pad)])[None]
    solver = rig.solver
    legs = LeggedController(rig.legs, cfg.legs, fps, path_xy[:, 0], path_yaw[:, 0], min_support=min_support)
    schedule = None
    if hints:
        schedule = _SwingSchedule(hints, T, rig.legs.leg_count, legs.n_swing_min,
                                  max(1, round(fps / rig.legs.cadence_hz)))
    leg_mask = solver.leg_mask
    nb = m.base_coordinate_count
    leg_coords = np.zeros(m.coordinate_count, dtype=bool)
    # the IK mask is over DoFs; map it onto coordinates through the joints it touches
    qd, qs = m.joint_qd_start, m.joint_q_start
    for j in range(len(m.joints)):
        if leg_mask[qd[j]:qd[j + 1]].any():
            leg_coords[qs[j]:qs[j + 1]] = True
    leg_coords[:nb] = False
    out = np.array(motion.q, dtype=float, copy=True)
    q_legs = np.array(rig.q_stance, dtype=float)[leg_coords]
    choice = np.zeros(1)
    for t in range(T):
        if schedule is None:
            legs.step(t, path_xy, path_yaw, v[t : t + 1], w[t : t + 1], choice)
        else:
            lift, frames = schedule.lift(t)
            legs.step(t, path_xy, path_yaw, v[t : t + 1], w[t : t + 1], choice, lift=lift, swing_frames=frames,
                      hold=schedule.follow[t : t + 1])
            schedule.update(t, legs.stance[0])
        q = out[t : t + 1].copy()
        q[0, leg_coords] = q_legs
        solver.constrain(q)
        feet = legs.feet()
        if solver.balls:
            feet[..., 2] += solver.rolling_lift(q)
        targets = solver.leg_targets(feet, legs.foot_yaw)
        weight = solver.leg_weights(np.where(legs.stance, 1.0, 0.02))
        q = solver.solve(q, targets, key="replan_legs", ee=solver.leg_targets_ee, mask=leg_mask,
                         min_iterations=cfg.ik_iterations, max_iterations=cfg.ik_max_iterations,
                         tolerance=cfg.ik_tolerance, weight=weight)
        # feet in the air held level as far as their ankles allow, then placed exactly (as the synthesis)
        q = solver.place_airborne_feet(q, targets, legs.stance, key="replan_legs", ee=solver.leg_targets_ee,
                                       mask=leg_mask, weight=weight, max_iterations=cfg.ik_max_iterations,
                                       tolerance=cfg.ik_tolerance)
        q = solver.level_ankles(q, legs.foot_yaw)
        q_legs = q[0, leg_coords].copy()
        out[t, leg_coords] = q_legs
    return motion.replace(q=out)


def _leg_hints(swing_hint: Mapping[str, np.ndarray] | None, feet: tuple[str, ...], T: int) -> dict[int, np.ndarray]:
    """``swing_hint`` by leg index, each [T] bool.

    Raises:
        ConfigError: a name that is no leg's foot, or a hint not of ``T`` frames.
    """
    out: dict[int, np.ndarray] = {}
    for name, air in (swing_hint or {}).items():
        if name not in feet:
            raise ConfigError(f"replan_legs: swing_hint names {name!r}, no leg's foot (legs: {', '.join(feet)})")
        air = np.asarray(air, dtype=bool)
        if air.shape != (T,):
            raise ConfigError(f"replan_legs: swing_hint {name!r} has shape {list(air.shape)}, expected [{T}]")
        out[feet.index(name)] = air
    return out
