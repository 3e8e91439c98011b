"""Rollouts: commands → root path → feet, arms and other joints → IK → :class:`Motion`.

Rollouts run in batches of ``SynthConfig.batch``, stepped together frame by frame; every per-frame
operation is vectorised over rollouts and limbs, and all limbs of all rollouts go through one
batched IK call per iteration, warm-started from the previous frame extrapolated at constant
velocity (so ``ik_iterations`` = 2 suffices). Every rollout draws its randomness up front from
its own generator (``SeedSequence(seed).spawn``), so a dataset depends only on the creature,
``frames``, ``fps``, ``seed`` and the config — not on how rollouts are batched.
"""

from __future__ import annotations

import functools
import hashlib
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.body.wheels import Drive, wheel_carried_links
from morphkit.errors import ConfigError
from morphkit.graph import JointType, Morphology
from morphkit.kernels.contact import RecordedSelfCollision, SelfCollisionPairs, self_collision_pairs
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_from_rpy, quat_from_yaw, quat_rotate
from morphkit.synth._ik import LimbSolver
from morphkit.synth._util import nlerp, quat_delta_extrapolate
from morphkit.synth.actions import (
    ACTION_NAMES,
    ActionConfig,
    ActionRig,
    ActionSpan,
    arm_swing,
    calibrate_actions,
    draw_actions,
    limit_speed,
    neutral_stance,
)
from morphkit.synth.analysis import BodyPlan, analyse
from morphkit.synth.arms import ArmConfig, PosePool, calibrate_arms, draw_upper_body, other_joints
from morphkit.synth.ground import (
    GroundGuard,
    GroundPoint,
    GroundStats,
    lift_coordinates,
    lift_mask,
    upper_body_points,
)
from morphkit.synth.legged import (
    LegConfig,
    LeggedController,
    LegRig,
    calibrate_legs,
    keep_hinge_knees_bent,
    keep_knees_bent,
    limb_links,
    upright_root_height,
)
from morphkit.synth.locomotion_commands import (
    CMD_DH,
    CMD_PITCH,
    CMD_ROLL,
    CMD_VX,
    CMD_VY,
    CMD_WZ,
    COMMAND_NAMES,
    CommandConfig,
    CommandLimits,
    draw_commands,
    integrate_root,
)
from morphkit.synth.wheeled import (
    Locomotion,
    base_coordinates,
    drive_of,
    glide_height,
    lateral_allowed,
    locomotion_of,
    steer_wheels,
)

__all__ = [
    "SynthConfig",
    "SynthResult",
    "SynthRig",
    "iter_synthesize",
    "prepare",
    "rollout_count",
    "source_digest",
    "synthesize",
]


@dataclass(frozen=True)
class SynthConfig:
    """Everything :func:`synthesize` can be told (defaults follow the ACE paper where it says)."""

    rollout_seconds: float = 20.0
    """Length of one rollout, i.e. of one output motion [s] (the last one may be shorter)."""
    batch: int = 256
    """Rollouts stepped together."""
    ik_iterations: int = 2
    """DLS iterations every pose takes per frame (warm-started)."""
    ik_max_iterations: int = 8
    """Most DLS iterations per frame, for poses still off target after ``ik_iterations``."""
    ik_tolerance: float = 1e-4
    """IK residual [m] at which a pose stops iterating."""
    look_ahead_seconds: float = 3.0
    """Commanded root path planned beyond the last frame (footsteps near the end look ahead)."""
    keep_above_ground: bool = True
    """Lift arms, tails and heads that would go below the ground (:mod:`.ground`); False makes the
    motions of morphkit before the lift (an arm may then reach through the floor)."""
    commands: CommandConfig = field(default_factory=CommandConfig)
    legs: LegConfig = field(default_factory=LegConfig)
    arms: ArmConfig = field(default_factory=ArmConfig)
    actions: ActionConfig = field(default_factory=ActionConfig)


@dataclass(eq=False)
class SynthRig:
    """Everything derived once per creature, config and frame rate (see :func:`prepare`)."""

    morphology: Morphology
    plan: BodyPlan
    """Body plan used for motion (legs of a non-floating base are driven like arms)."""
    locomotion: Locomotion
    solver: LimbSolver
    legs: LegRig | None
    arms: PosePool
    """Upper-body pose pool (arms and other joints)."""
    q_stance: np.ndarray
    """Standing pose [C] (root at the origin's ground point, level, facing +x)."""
    limits: CommandLimits
    scale: float
    """Size scale of the linear command ranges."""
    fps: float
    config: SynthConfig
    actions: ActionRig | None = None
    """Key poses of the arms that do upper-body actions and swing (None: no arm does)."""
    ground: GroundGuard | None = None
    """Lifts the upper body's shapes and arm tips above the ground (None: no upper body)."""
    arm_pairs: SelfCollisionPairs | None = None
    """Shape pairs of the arms IK moves against the rest of the body but the legs, for the per-frame check of
    an arm that strayed to another branch (None: no such pair)."""
    upper_coordinates: tuple[np.ndarray, np.ndarray, np.ndarray] = field(
        default_factory=lambda: (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0)))
    """The upper body's 1-DoF coordinates (arms and the other joints, not legs and not those carrying a leg:
    indices in ``q``) and their lower and upper limits (:func:`~morphkit.synth.ground.lift_coordinates`)."""
    drive: Drive | None = None
    """What a wheeled base's wheels allow (None: no wheels named)."""
    wheel_held: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    """Coordinates of the joints that carry only a wheel (suspensions), held at rest."""

    def summary(self) -> dict[str, Any]:
        """Calibration figures for reports (JSON-friendly)."""
        out: dict[str, Any] = {
            "locomotion": self.locomotion.value,
            "legs": len(self.plan.legs),
            "arms": len(self.plan.arms),
            "size_scale": round(self.scale, 4),
            "forward_speed_range": [round(float(v), 4) for v in self.limits.forward],
            "lateral_speed_range": [round(float(v), 4) for v in self.limits.lateral],
            "yaw_rate_range": [round(v, 4) for v in self.limits.yaw],
        }
        if self.legs is not None:
            lr = self.legs
            out.update({
                "stance_height_m": round(lr.stance_height, 4),
                "stance_of_rest_height": round(lr.stance_height / max(self.plan.body_height, 1e-9), 3),
                "step_semi_axes_m": np.round(lr.semi_axes.mean(axis=0), 4).tolist(),
                "swing_height_m": round(lr.swing_height, 4),
                "cadence_hz": round(lr.cadence_hz, 4),
                "gaits": list(dict.fromkeys(g.name for b in lr.bands for g in b.gaits)),
                "max_forward_speed_m_s": round(float(self.max_speed(np.array([1.0, 0.0]))), 3),
                "max_lateral_speed_m_s": round(float(self.max_speed(np.array([0.0, 1.0]))), 3),
                "max_yaw_rate_rad_s": round(self.max_yaw_rate(), 3),
            })
            if "stance_note" in lr.stats:
                out["stance_note"] = lr.stats["stance_note"]
            if lr.fixed_axes is not None:  # a direction no leg can step is not commanded at all
                for key, rng in (("max_forward_speed_m_s", self.limits.forward),
                                 ("max_lateral_speed_m_s", self.limits.lateral),
                                 ("max_yaw_rate_rad_s", self.limits.yaw)):
                    out[key] = min(out[key], round(max(abs(rng[0]), abs(rng[1])), 3))
                out["fixed_axes"] = lr.fixed_axes.tolist()
        if not self.arms.empty:
            out["upper_body_pool"] = self.arms.stats
        if self.actions is not None:
            out["actions"] = self.actions.stats
        if self.drive is not None:
            out.update(self.drive.summary())
        return out

    def max_speed(self, direction: np.ndarray) -> float:
        """Fastest feasible speed [m/s] along a heading-frame direction [2] (no turning)."""
        if self.limits.clamp is None:
            return float("inf")
        v = np.array([[direction[0], direction[1], 0.0]]) * 1e3
        return float(np.linalg.norm(self.limits.clamp(v)[0, :2]))

    def max_yaw_rate(self) -> float:
        """Fastest feasible turn on the spot [rad/s] (either way)."""
        if self.limits.clamp is None:
            return float("inf")
        w = self.limits.clamp(np.array([[0.0, 0.0, 1e3], [0.0, 0.0, -1e3]]))[:, 2]
        return float(np.abs(w).min())


_rig_cache: list[tuple[Morphology, float, SynthConfig, SynthRig]] = []


def prepare(m: Morphology, *, fps: float = 30.0, config: SynthConfig | None = None) -> SynthRig:
    """Analyse and calibrate a creature for synthesis (cached for the last few creatures)."""
    config = config or SynthConfig()
    for mm, ff, cc, rig in _rig_cache:
        if mm is m and ff == fps and cc == config:
            return rig
    plan = analyse(m)
    loco = locomotion_of(m, plan)
    if loco != Locomotion.LEGGED and plan.legs:
        # without a floating base the legs cannot carry the body: move them like arms
        plan = BodyPlan(legs=(), arms=plan.arms + plan.legs, head=plan.head, wheeled=plan.wheeled,
                        body_height=plan.body_height, leg_reach=plan.leg_reach)
    # the upper body's lowest points (its shapes and arm tips), kept above the ground every frame
    others, carrying = other_joints(m, plan)
    # steering and caster joints follow the root path (steer_wheels), suspensions stay at rest: no walk of their own
    on_wheels = wheel_carried_links(m)
    others = [j for j in others if j + 1 not in on_wheels]
    lifting = [m.joint_index(n) for arm in plan.arms for n in arm.joints] + [j for j in others if j not in carrying]
    upper: set[str] = set()
    for ji in lifting:
        upper |= limb_links(m, (m.joints[ji].name,))
    for leg in plan.legs:
        upper -= limb_links(m, leg.joints)
    points = upper_body_points(m, upper)
    points += [GroundPoint(e.link, e.offset, 0.0) for e in (m.end_effector(a.end_effector) for a in plan.arms)]
    solver = LimbSolver(m, plan, points=[(p.link, p.offset) for p in points])
    upper_coordinates = lift_coordinates(m, lifting)
    ground = None
    if points and config.keep_above_ground:
        mask = lift_mask(m, lifting, len(solver.all_mask))
        ground = GroundGuard(solver.model, solver.point_ee, np.array([p.radius for p in points]), mask, solver.step,
                             solver.link_transforms, coordinates=upper_coordinates)
    cc = config.commands
    legs = None
    if loco == Locomotion.LEGGED:
        legs = calibrate_legs(m, plan, solver, config.legs, fps=fps, height_fraction=cc.height, pitch=cc.pitch,
                              roll=cc.roll, ground=ground)
        q_stance = legs.q_nominal.copy()
        scale = plan.leg_reach / cc.reference_leg_reach if cc.scale_by_size else 1.0
    else:
        q_stance = m.rest_q()
        if loco == Locomotion.GLIDE:
            q_stance[2] = glide_height(m)
        scale = 1.0
    actions = calibrate_actions(m, plan, q_stance, config.actions, upright=legs is not None and legs.upright,
                                nominal_xy=legs.nominal_xy if legs is not None else None)
    if actions is not None:
        q_stance = neutral_stance(actions, q_stance)
    arms = calibrate_arms(m, plan, solver, q_stance, config.arms, fixed_arms=actions.arms if actions else ())
    lat = cc.lateral_speed if lateral_allowed(m) else (0.0, 0.0)
    moving = loco != Locomotion.FIXED
    clamp: Callable[[np.ndarray], np.ndarray] | None = None
    if legs is not None:
        leg_rig, leg_cfg = legs, config.legs

        def clamp(cmd: np.ndarray) -> np.ndarray:
            return leg_rig.clamp(cmd, leg_cfg)

    forward = tuple(v * scale * moving for v in cc.forward_speed)
    lateral = tuple(v * scale * moving for v in lat)
    if legs is not None and forward[1] > 0:
        # where dynamic similarity bounds the speed below what the legs can step, every range shrinks by one
        # factor (backwards and sideways too, as size scales them): the bound is a speed scale, not a clip
        fastest = min(forward[1], legs.top_speed((1.0, 0.0), replace(config.legs, max_froude=None)))
        k = min(1.0, legs.froude_speed(config.legs) / max(fastest, 1e-9))
        forward, lateral = tuple(k * v for v in forward), tuple(k * v for v in lateral)
    yaw = tuple(v * moving for v in cc.yaw_rate)
    if legs is not None and legs.fixed_axes is not None:
        # a leg that cannot step along a direction: no walking that way, slow turns
        fixed = legs.fixed_axes.any(axis=0)
        forward = (0.0, 0.0) if fixed[0] else forward
        lateral = (0.0, 0.0) if fixed[1] else lateral
        w = config.legs.fixed_axis_yaw_rate
        yaw = (max(yaw[0], -w), min(yaw[1], w))
    if legs is not None and cc.fit_range_to_creature:
        # shrink a range the legs cannot step (straight, without turning) to what they can, so that
        # speeds stay spread over what the creature does instead of piling up at its top speed
        top = legs.top_speed
        forward = (max(forward[0], -top((-1.0, 0.0), config.legs)), min(forward[1], top((1.0, 0.0), config.legs)))
        lateral = (max(lateral[0], -top((0.0, -1.0), config.legs)), min(lateral[1], top((0.0, 1.0), config.legs)))
    drive = drive_of(m) if loco == Locomotion.WHEELED else None
    if drive is not None:
        # the paper's ranges as fractions of its top forward speed, times the wheels' top speed
        top, ref = drive.top_speed, cc.forward_speed[1]
        forward = (cc.forward_speed[0] / ref * top, top)
        lateral = tuple(v / ref * top for v in lat)
        clamp = drive.clamp
    limits = CommandLimits(
        forward=forward,  # type: ignore[arg-type]
        lateral=lateral,  # type: ignore[arg-type]
        yaw=yaw,  # type: ignore[arg-type]
        height=legs.height_range if legs is not None else (0.0, 0.0),
        pitch=legs.pitch if legs is not None else 0.0,
        roll=legs.roll if legs is not None else 0.0,
        acceleration=cc.acceleration * scale,
        yaw_acceleration=cc.yaw_acceleration,
        clamp=clamp,
    )
    held = actions.arms if actions is not None else ()
    arm_pairs = _arm_body_pairs(m, plan, solver, [a for a in range(len(plan.arms)) if a not in held],
                                config.arms.collision_rest_margin)
    rig = SynthRig(m, plan, loco, solver, legs, arms, q_stance, limits, float(scale), fps, config, actions, ground,
                   arm_pairs, upper_coordinates, drive, _wheel_held(m))
    _rig_cache.append((m, fps, config, rig))
    del _rig_cache[:-4]
    return rig


def _wheel_held(m: Morphology) -> np.ndarray:
    """Coordinates [k] of 1-DoF joints that carry only a wheel and neither steer nor roll it (suspensions)."""
    on_wheels = wheel_carried_links(m)
    qs = m.joint_q_start
    return np.array([qs[ji] for ji, j in enumerate(m.joints) if ji + 1 in on_wheels and qs[ji + 1] - qs[ji] == 1
                     and j.name not in m.wheel_steering_joints], dtype=np.int64)


def _arm_body_pairs(m: Morphology, plan: BodyPlan, solver: LimbSolver, arms: list[int],
                    rest_margin: float) -> SelfCollisionPairs | None:
    """Shape pairs of ``arms`` (indices into ``plan.arms``) against the body and the other arms, not the legs:
    the pose pool keeps arms clear of the legs, and skipping those pairs makes the per-frame check several
    times cheaper."""
    arm_links: set[str] = set()
    for a in arms:
        arm_links |= limb_links(m, plan.arms[a].joints)
    if not arm_links:
        return None
    leg_links: set[str] = set()
    for leg in plan.legs:
        leg_links |= limb_links(m, leg.joints)
    model = solver.model
    pairs = self_collision_pairs(model, rest_margin=rest_margin).touching(model.link_index(n) for n in arm_links)
    pairs = pairs.apart_from(model.link_index(n) for n in leg_links - arm_links)
    return pairs if pairs.pair_count else None


@dataclass
class SynthResult(Sequence[Motion]):
    """Synthesised motions (a sequence of :class:`Motion`, one per rollout) and what drove them."""

    motions: list[Motion]
    command: list[np.ndarray]
    """Per motion: the smoothed command [T, 6] (channels :data:`~morphkit.synth.locomotion_commands.COMMAND_NAMES`)."""
    target: list[np.ndarray]
    """Per motion: the command's current target [T, 6]."""
    settled: list[np.ndarray]
    """Per motion: [T] bool, the command has reached its target (away from transitions)."""
    contact: list[np.ndarray]
    """Per motion: [T, NL] bool, which feet are in stance (legs in body-plan order)."""
    gait: list[np.ndarray]
    """Per motion: [T] int8 index into ``gait_names`` of the gait in use (-1 without legs)."""
    gait_names: tuple[str, ...]
    clamped: list[np.ndarray]
    """Per motion: [T] bool, the segment's velocity target was scaled down to what the creature can do."""
    seconds: float
    """Wall time of the generation [s] (calibration included)."""
    rig: SynthRig = field(repr=False)
    actions: list[tuple[ActionSpan, ...]] = field(default_factory=list)
    """Per motion: its upper-body actions in order (empty without acting arms)."""
    action: list[np.ndarray] = field(default_factory=list)
    """Per motion: [T] int8 action code per frame (:data:`~morphkit.synth.actions.ACTION_NAMES`; empty
    without acting arms)."""
    ground: GroundStats = field(default_factory=GroundStats)
    """Upper-body poses lifted above the ground, and the links that could not be (:mod:`.ground`)."""

    @property
    def warnings(self) -> list[str]:
        """One line per limb that cannot be moved well: the calibration's and the ground lift's."""
        legs = list(self.rig.legs.warnings) if self.rig.legs is not None else []
        named = {w.split(":")[0] for w in legs}  # a link the calibration already named is not named twice
        return legs + [w for w in self.ground.warnings() if w.split(":")[0] not in named]

    def __len__(self) -> int:
        return len(self.motions)

    @classmethod
    def concatenate(cls, parts: Sequence[SynthResult], *, seconds: float | None = None) -> SynthResult:
        """One result of the rollouts of ``parts`` (of one creature's rig, e.g. :func:`iter_synthesize`'s), in order."""
        if not parts:
            raise ConfigError("nothing to concatenate: no synthesised rollouts")
        first = parts[0]

        def cat(name: str) -> list:
            return [x for p in parts for x in getattr(p, name)]

        ground = GroundStats()
        for p in parts:
            ground = ground.merge(p.ground)
        return cls(cat("motions"), cat("command"), cat("target"), cat("settled"), cat("contact"), cat("gait"),
                   first.gait_names, cat("clamped"), parts[-1].seconds if seconds is None else seconds, first.rig,
                   cat("actions"), cat("action"), ground)

    def __getitem__(self, i):  # type: ignore[override]
        return self.motions[i]

    def __iter__(self) -> Iterator[Motion]:
        return iter(self.motions)

    @property
    def frame_count(self) -> int:
        """Total frames over all motions."""
        return sum(m.frame_count for m in self.motions)

    @property
    def frames_per_s(self) -> float:
        """Generation speed [frames/s] (calibration included unless the creature was :func:`prepare`-d before)."""
        return self.frame_count / max(self.seconds, 1e-9)

    def extras(self, i: int) -> dict[str, np.ndarray]:
        """Arrays stored beside motion ``i`` in its NPZ file (``action`` and ``action_names`` with acting arms)."""
        out = {
            "command": self.command[i].astype(np.float32),
            "command_target": self.target[i].astype(np.float32),
            "command_settled": self.settled[i],
            "command_names": np.array(COMMAND_NAMES),
            "contact": self.contact[i],
            "gait": self.gait[i],
            "gait_names": np.array(self.gait_names if self.gait_names else ("none",)),
        }
        if self.action:
            out.update(action=self.action[i], action_names=np.array(ACTION_NAMES))
        return out

    def save(self, path: str | os.PathLike[str], **info: Any) -> list[Path]:
        """Write the motions as NPZ files (:func:`~morphkit.motion.write_npz_motion`) and return their paths.

        A path ending in ``.npz`` gets one file: every motion end to end, with ``clip_starts`` (first
        frame of each rollout) among the extra arrays — consumers that ignore it see jumps at clip
        boundaries. A path without a suffix (or an existing folder) is a folder with one
        ``<name>.npz`` per motion (the name through :func:`~morphkit.output_names.safe_stem`) and a
        ``manifest.json`` listing them (``info`` goes into it); files an
        earlier save listed there are replaced or removed (:mod:`morphkit.synth.output`). Another
        suffix is a ``ConfigError``.
        """
        from morphkit.synth.output import SynthWriter

        writer = SynthWriter(path, **info)
        writer.write(self)
        return writer.close()


def _scalar_and_quat_coords(m: Morphology) -> tuple[np.ndarray, np.ndarray]:
    scalar, quats = [], []
    for ji, j in enumerate(m.joints):
        s, e = m.joint_q_start[ji], m.joint_q_start[ji + 1]
        if e == s:
            continue
        if j.type == JointType.SPHERICAL:
            quats.append(s)
        else:
            scalar.extend(range(s, e))
    return np.array(scalar, dtype=np.int64), np.array(quats, dtype=np.int64)


class _BatchRollout:
    """``R`` rollouts stepped together, one frame per :meth:`step`, carrying the previous two poses.

    The constructor draws everything random first (for ``drawn`` frames whatever the lengths, so a rollout does
    not depend on its batch: start yaw, commands, upper-body walks, actions), integrates the root path and plans
    the footsteps; :meth:`step` then warm-starts, places the root, sets the targets and solves the IK of frame
    ``t``; :meth:`results` hands over the per-frame arrays [R, T, ...].
    """

    def __init__(self, rig: SynthRig, seeds: Sequence[np.random.SeedSequence], lengths: Sequence[int],
                 drawn: int) -> None:
        self.rig = rig
        self.m, self.cfg, self.fps = rig.morphology, rig.config, rig.fps
        self.solver = rig.solver
        self.pool = rig.arms
        self.frames = max(lengths)
        """T: frames stepped (the longest rollout's)."""
        self.active = np.asarray(lengths)
        """[R] frames each rollout keeps."""
        self.NL = len(rig.plan.legs)
        self._draw(seeds, drawn)
        self._plan_feet()
        self._choose_ik_targets()
        self._prepare_warm_start()

    def _draw(self, seeds: Sequence[np.random.SeedSequence], drawn: int) -> None:
        """Start yaws [R], commands, upper-body walks and actions (speeds limited while acting), and the root
        path they give (``path_xy`` [R, T', 2] [m], ``path_yaw`` [R, T'] [rad])."""
        rig, cfg, fps = self.rig, self.cfg, self.fps
        rngs = [np.random.default_rng(s) for s in seeds]
        self.R = len(rngs)
        yaw0 = np.array([rng.uniform(-np.pi, np.pi) for rng in rngs])
        if rig.locomotion == Locomotion.FIXED:
            yaw0[:] = 0.0  # a fixed base stays where its description put it
        pad = int(np.ceil(cfg.look_ahead_seconds * fps))
        self.cmds = cmds = draw_commands(rngs, drawn + pad, fps, cfg.commands, rig.limits)
        self.ub = draw_upper_body(rngs, self.pool, drawn, fps, cfg.arms)
        self.acts = None
        if rig.actions is not None:
            self.acts = acts = draw_actions(rngs, rig.actions, drawn, fps, cfg.actions)
            busy = acts.activity(drawn + pad, fps, cfg.actions.speed_ramp_seconds)
            vmax = cfg.actions.max_speed * rig.scale
            limit_speed(cmds.command, busy, vmax, cfg.actions.max_yaw_rate)
            limit_speed(cmds.target, busy, vmax, cfg.actions.max_yaw_rate)
            cmds.settled &= (busy == 0.0) | (busy == 1.0)
        if rig.drive is not None:
            # ramps between two allowed targets may pass through a turn the drive cannot make (an Ackermann
            # reversing): every frame's command is clipped, not only the targets
            cmds.command[..., :3] = rig.drive.clamp_path(cmds.command[..., :3])
        self.path_xy, self.path_yaw = integrate_root(cmds.command, fps, yaw0)

    def _plan_feet(self) -> None:
        """Footsteps for every frame (they depend on the root path only): ``feet`` [R, T, NL, 3] [m], ``foot_yaw``
        [R, T, NL] [rad], ``stance`` [R, T, NL] bool, ``gait_code`` [R, T]; an upright biped's root height
        ``z_upright`` [R, T] [m]; the arms' swing with the steps. All None without legs."""
        rig, cfg, fps, R, frames, NL = self.rig, self.cfg, self.fps, self.R, self.frames, self.NL
        cmds, path_xy, path_yaw, acts = self.cmds, self.path_xy, self.path_yaw, self.acts
        self.feet = self.foot_yaw = self.stance = self.gait_code = None
        self.z_upright = None
        if rig.legs is None:
            return
        legs = LeggedController(rig.legs, cfg.legs, fps, path_xy[:, 0], path_yaw[:, 0])
        self.feet = feet = np.empty((R, frames, NL, 3))
        self.foot_yaw = foot_yaw = np.empty((R, frames, NL))
        self.stance = stance = np.empty((R, frames, NL), dtype=bool)
        self.gait_code = gait_code = np.empty((R, frames), dtype=np.int8)
        for t in range(frames):
            c = cmds.command[:, t]
            legs.step(t, path_xy, path_yaw, c[:, [CMD_VX, CMD_VY]], c[:, CMD_WZ], cmds.choice[:, t])
            feet[:, t] = legs.feet()
            foot_yaw[:, t] = legs.foot_yaw
            stance[:, t] = legs.stance
            gait_code[:, t] = legs.clock.gait_code
        if rig.legs.upright:
            c = cmds.command[:, :frames]
            yaw_t = path_yaw[:, :frames]
            rot_t = quat_from_rpy(np.stack([c[..., CMD_ROLL], c[..., CMD_PITCH], yaw_t], axis=-1))
            ik_pts = feet - rig.solver.ankle_offsets(foot_yaw.reshape(R * frames, NL)).reshape(R, frames, NL, 3)
            self.z_upright = upright_root_height(rig.legs, ik_pts, path_xy[:, :frames], rot_t,
                                                 rig.legs.stance_height + c[..., CMD_DH], fps,
                                                 cfg.legs.upright_smoothing_seconds)
        if acts is not None and rig.actions is not None and rig.actions.swing:
            stride = 2.0 * cfg.legs.stroke_usage * float(rig.legs.semi_axes[:, 0].mean())
            speed = np.linalg.norm(cmds.command[:, :frames, :2], axis=-1)
            acts.swing = arm_swing(rig.actions, rig.legs.nominal_xy, stride, feet[..., :2], path_xy[:, :frames],
                                   path_yaw[:, :frames], speed, cfg.actions.swing_full_speed * rig.scale, fps,
                                   cfg.actions)

    def _choose_ik_targets(self) -> None:
        """IK end-effectors: legs and the arms that actions do not move (``ik_ee``, ``ik_mask``, ``ik_key``,
        ``free_arms``)."""
        rig, m, solver = self.rig, self.m, self.solver
        self.ik_ee, self.ik_mask, self.ik_key = solver.all_ee, solver.all_mask, "all"
        self.free_arms = np.arange(len(rig.plan.arms))
        if self.acts is not None and rig.actions is not None:
            self.free_arms = free_arms = np.array([a for a in range(len(rig.plan.arms)) if a not in rig.actions.arms],
                                                  dtype=np.int64)
            self.ik_mask = ik_mask = solver.leg_mask.copy()
            qd = m.joint_qd_start
            for a in free_arms:
                for n in rig.plan.arms[a].joints:
                    ji = m.joint_index(n)
                    if m.joints[ji].mimic is None:
                        ik_mask[qd[ji]:qd[ji + 1]] = True
            self.ik_ee = np.concatenate([solver.leg_targets_ee, solver.arm_ee[free_arms]]).astype(np.int64)
            self.ik_key = "legs+free_arms"

    def _prepare_warm_start(self) -> None:
        """Coordinate groups and knee constraints of the warm start, the output arrays and the first two poses."""
        rig, m, solver, pool, R, frames = self.rig, self.m, self.solver, self.pool, self.R, self.frames
        self.scalar, self.quats = _scalar_and_quat_coords(m)
        self.leg_balls = np.array([c[0] for c in solver.ball_constraints], dtype=np.int64)
        self.knees: list[tuple[int, int, float]] = []
        if rig.legs is not None and rig.legs.upright:
            # nearly straight legs: keep ball knees on the side they bend to at stance
            for s, ax, h in solver.ball_constraints:
                if h == -2:
                    th = 2.0 * np.arctan2(rig.q_stance[s + ax], rig.q_stance[s + 3])
                    self.knees.append((int(s), int(ax), 1.0 if th >= 0 else -1.0))
        self.hinge_knees = rig.legs.hinge_knees if rig.legs is not None else ()
        self.lower, self.upper = m.coordinate_limits
        self.lo_s, self.hi_s = self.lower[self.scalar], self.upper[self.scalar]
        self.out_q = np.empty((R, frames, m.coordinate_count))
        self.contact = np.zeros((R, frames, self.NL), dtype=bool)
        self.gait = np.full((R, frames), -1, dtype=np.int8)
        self.q_prev = np.repeat(rig.q_stance[None], R, axis=0)
        if not pool.empty:
            self.q_prev[:, pool.coords] = pool.q[self.ub.i0[:, 0]]  # the upper body starts where its walk does
        self.q_prev2 = self.q_prev.copy()
        self.glide_z = rig.q_stance[2] if rig.locomotion == Locomotion.GLIDE else 0.0
        self.arm_pairs = rig.arm_pairs if len(pool.arm_coords) else None
        self.arm_checks: dict[int, RecordedSelfCollision] = {}
        self.ground_stats = GroundStats()

    def step(self, t: int) -> None:
        """Frame ``t`` of every rollout: warm start, root, targets, IK, ground lift."""
        q = self._warm_start()
        z, rot = self._place_root(q, t)
        targets, ref = self._targets(q, t, z, rot)
        if targets:
            q = self._solve(q, t, np.concatenate(targets, axis=1), ref)
        if self.rig.ground is not None:
            q = self.rig.ground.lift(q, self.ground_stats)
        self.out_q[:, t] = q
        self.q_prev2, self.q_prev = self.q_prev, q

    def _warm_start(self) -> np.ndarray:
        """Constant-velocity extrapolation of the last two poses [R, C], clamped into the limits, ball legs leaned
        toward stance and knees kept bent."""
        cfg, solver, q_prev, q_prev2 = self.cfg, self.solver, self.q_prev, self.q_prev2
        scalar = self.scalar
        q = q_prev.copy()
        if scalar.size:
            q[:, scalar] = np.clip(2.0 * q_prev[:, scalar] - q_prev2[:, scalar], self.lo_s, self.hi_s)
        for s in self.quats:
            q[:, s:s + 4] = quat_delta_extrapolate(q_prev[:, s:s + 4], q_prev2[:, s:s + 4])
        if self.leg_balls.size:
            # ball-jointed legs have no limits to keep them on the knee-forward branch: lean toward stance
            for s in self.leg_balls:
                q[:, s:s + 4] = nlerp(q[:, s:s + 4], np.broadcast_to(self.rig.q_stance[s:s + 4], (self.R, 4)),
                                      np.full(self.R, cfg.legs.ball_posture_gain))
        if solver.redundant_coordinates:
            # a leg with more DoFs than its foot point drifts in the null space (a knee straightening, an ankle
            # folding) until a joint limit stops it short of the ground: lean toward stance, as ball legs do
            r = solver.redundant_coordinates
            q[:, r] += cfg.legs.ball_posture_gain * (self.rig.q_stance[r] - q[:, r])
        solver.constrain(q)
        if self.knees:
            keep_knees_bent(q, self.knees, cfg.legs.upright_knee_margin)
        if self.hinge_knees:
            keep_hinge_knees_bent(q, self.hinge_knees, cfg.legs.upright_knee_margin, self.lower, self.upper)
        return q

    def _place_root(self, q: np.ndarray, t: int) -> tuple[np.ndarray, np.ndarray]:
        """Set the base coordinates of ``q`` in place from the root path (and the feet's contacts); returns the
        root height [R] [m] and orientation [R, 4] (xyzw)."""
        rig, m, c = self.rig, self.m, self.cmds.command[:, t]
        xy, yaw = self.path_xy[:, t], self.path_yaw[:, t]
        nb = m.base_coordinate_count
        if rig.locomotion == Locomotion.LEGGED:
            assert self.stance is not None and rig.legs is not None and self.gait_code is not None
            z = rig.legs.stance_height + c[:, CMD_DH] if self.z_upright is None else self.z_upright[:, t]
            rot = quat_from_rpy(np.stack([c[:, CMD_ROLL], c[:, CMD_PITCH], yaw], axis=-1))
            q[:, :nb] = base_coordinates(m, xy, yaw, z, rot)
            self.contact[:, t] = self.stance[:, t]
            self.gait[:, t] = self.gait_code[:, t]
        else:
            z = np.full(self.R, self.glide_z)
            rot = quat_from_yaw(yaw)
            q[:, :nb] = base_coordinates(m, xy, yaw, z, rot)
        return z, rot

    def _targets(self, q: np.ndarray, t: int, z: np.ndarray, rot: np.ndarray
                 ) -> tuple[list[np.ndarray], np.ndarray | None]:
        """IK targets of frame ``t`` (world [R, n, 3] [m]: legs, then free arms' tips), the upper-body posture set
        into ``q`` in place (arms pulled toward it by ``posture_gain``, actions' joints set); also the arms' pooled
        posture [R, A] (None without arms)."""
        rig, solver, pool, ub, R = self.rig, self.solver, self.pool, self.ub, self.R
        targets = []
        ref = None
        if self.NL:
            assert self.feet is not None and self.foot_yaw is not None
            feet_t = self.feet[:, t]
            if solver.balls:
                feet_t = feet_t.copy()
                feet_t[..., 2] += solver.rolling_lift(q)  # at the warm start: the turn is second order
            targets.append(solver.leg_targets(feet_t, self.foot_yaw[:, t]))
        if not pool.empty:
            n_arm, gain = len(pool.arm_coords), self.cfg.arms.posture_gain
            post = ub.posture(pool, t)
            q[:, pool.coords[pool.direct]] = post[:, pool.direct]
            if n_arm:
                cur = q[:, pool.arm_coords]
                ref = post[:, :n_arm]
                new = cur + gain * (ref - cur)
                for o in pool.arm_quat_offsets:
                    new[:, o:o + 4] = nlerp(cur[:, o:o + 4], ref[:, o:o + 4], np.full(R, gain))
                q[:, pool.arm_coords] = new
                if self.free_arms.size:
                    root_pos = np.concatenate([self.path_xy[:, t], z[:, None]], axis=1)
                    tips = ub.tips(pool, t)[:, self.free_arms]
                    targets.append(root_pos[:, None, :] + quat_rotate(rot[:, None, :], tips))
        if self.acts is not None and rig.actions is not None:
            for coords, post_a in zip(rig.actions.coords, self.acts.posture(rig.actions, t), strict=True):
                q[:, coords] = post_a
        return targets, ref

    def _solve(self, q: np.ndarray, t: int, tg: np.ndarray, ref: np.ndarray | None) -> np.ndarray:
        """IK of targets ``tg`` [R, n, 3] from ``q`` [R, C]: stance feet accurately, airborne feet held level, ankles
        levelled, arms that flipped branch and collide put back to their posture ``ref``."""
        cfg, solver, NL = self.cfg, self.solver, self.NL
        ik = {"key": self.ik_key, "ee": self.ik_ee, "mask": self.ik_mask}
        weight = np.ones(tg.shape[:2])
        if NL:
            assert self.stance is not None
            # swinging feet and arms need no sub-millimetre accuracy: iterate for stance feet
            n_leg = len(solver.leg_targets_ee)
            weight[:, :n_leg] = solver.leg_weights(np.where(self.stance[:, t], 1.0, 0.02))
            weight[:, n_leg:] = 0.0
        else:
            weight[:] = 0.02
        q = solver.solve(q, tg, **ik, min_iterations=cfg.ik_iterations, max_iterations=cfg.ik_max_iterations,
                         tolerance=cfg.ik_tolerance, weight=weight)
        if NL:
            # feet in the air held level as far as their ankles allow, then placed exactly
            q = solver.place_airborne_feet(q, tg, self.stance[:, t], **ik, weight=weight,
                                           max_iterations=cfg.ik_max_iterations, tolerance=cfg.ik_tolerance)
        if self.foot_yaw is not None:
            q = solver.level_ankles(q, self.foot_yaw[:, t])
        if self.arm_pairs is not None:
            assert ref is not None
            self._restore_flipped_arms(q, ref)
        return q

    def _restore_flipped_arms(self, q: np.ndarray, ref: np.ndarray) -> None:
        """IK that strays far from the pooled posture ``ref`` [R, A] may have flipped to another branch of the arm
        (an elbow at its limit) that the validated moves never saw: such an arm, if it collides, takes the
        posture (in ``q`` [R, C], in place), whose branch the next frames' IK then keeps."""
        pool, R = self.pool, self.R
        far = np.flatnonzero(np.abs(q[:, pool.arm_coords] - ref).max(axis=1) > self.cfg.arms.branch_check)
        if far.size:
            # padded to a power of two so the recorded launches are reused
            size = min(R, 1 << int(np.ceil(np.log2(max(far.size, 8)))))
            size = max(size, far.size)
            check = self.arm_checks.get(size)
            if check is None:
                check = self.arm_checks[size] = RecordedSelfCollision(self.solver.model, self.arm_pairs, size)
            rows = np.concatenate([far, np.full(size - far.size, far[0])])
            d = check(self.solver.link_transforms(q[rows]))[:far.size]
            hit = far[(d < 0.0).any(axis=1)]
            q[np.ix_(hit, pool.arm_coords)] = ref[hit]

    def results(self) -> dict[str, np.ndarray]:
        """Per-frame arrays [R, T, ...]: ``q``, commands, contacts, gaits, actions; the ground lift's statistics."""
        cmds, acts, frames = self.cmds, self.acts, self.frames
        if self.m.wheel_steering_joints or self.rig.wheel_held.size:
            # the upper-body walk may have moved what carries a wheel: suspensions back at rest, steering set
            self.out_q[..., self.rig.wheel_held] = self.rig.q_stance[self.rig.wheel_held]
            steer_wheels(self.m, self.out_q, self.fps)
        return {
            "q": self.out_q,
            "command": cmds.command[:, :frames],
            "target": cmds.target[:, :frames],
            "settled": cmds.settled[:, :frames],
            "contact": self.contact,
            "gait": self.gait,
            "clamped": cmds.clamped[:, :frames],
            "action": acts.code[:, :frames] if acts is not None else None,
            "spans": acts.spans if acts is not None else None,
            "ground": self.ground_stats,
        }


def _run_batch(rig: SynthRig, seeds: Sequence[np.random.SeedSequence], lengths: Sequence[int], drawn: int,
               tick: Callable[[int], None]) -> dict[str, np.ndarray]:
    """Step ``len(seeds)`` rollouts together for ``max(lengths)`` frames; returns per-frame arrays [R, T, ...].

    Randomness is drawn for ``drawn`` frames whatever the lengths, so a rollout does not depend on
    its batch. ``tick`` gets the number of rollouts still running after each frame.
    """
    rollout = _BatchRollout(rig, seeds, lengths, drawn)
    for t in range(rollout.frames):
        rollout.step(t)
        tick(int((t < rollout.active).sum()))
    return rollout.results()


def synthesize(morphology: Morphology, *, frames: int, fps: float = 30.0, seed: int = 0,
               config: SynthConfig | None = None, progress: bool = True) -> SynthResult:
    """Generate ``frames`` frames of procedural motion for any creature, from its graph alone.

    Legged creatures walk, trot, gallop (or their leg count's gaits) after random smoothed
    commands with their feet planted; arms reach and wave; wheeled bases drive; other joints
    (heads, tails) look around. See :mod:`morphkit.synth` for the method. Every rollout stays in
    memory: :func:`iter_synthesize` hands them over a batch at a time.

    Args:
        morphology: The creature.
        frames: Total frames over all rollouts (>= 1).
        fps: Frame rate [1/s].
        seed: Random seed: the same arguments give the same motions.
        config: Tuning (:class:`SynthConfig`).
        progress: Show a tqdm progress bar on stderr.

    Returns:
        A :class:`SynthResult`: a sequence of motions of ``rollout_seconds`` each (the last may be
        shorter), named ``<creature>_synth_<seed>_<index>``, and the commands and contacts behind them.

    Raises:
        ConfigError: on a non-positive ``frames``, ``fps``, batch or rollout length.
    """
    start = time.perf_counter()
    parts = list(iter_synthesize(morphology, frames=frames, fps=fps, seed=seed, config=config, progress=progress))
    return SynthResult.concatenate(parts, seconds=time.perf_counter() - start)


def rollout_count(frames: int, fps: float, config: SynthConfig) -> int:
    """Rollouts (output motions) of a ``frames``-frame data set: ``rollout_seconds`` each, the last shorter."""
    return int(np.ceil(frames / max(2, round(config.rollout_seconds * fps))))


def iter_synthesize(morphology: Morphology, *, frames: int, fps: float = 30.0, seed: int = 0,
                    config: SynthConfig | None = None, progress: bool = True) -> Iterator[SynthResult]:
    """:func:`synthesize` one batch of rollouts at a time: each item is a :class:`SynthResult` of the next
    ``SynthConfig.batch`` rollouts (or fewer), in order, so memory stays flat however many frames are
    asked for. The rollouts are the ones :func:`synthesize` makes with the same arguments; an item's
    ``seconds`` is the time since the call (calibration included). The creature is calibrated (and its
    arguments checked, raising ``ConfigError``) when this is called, before the first item."""
    config = config or SynthConfig()
    if int(frames) < 1:
        raise ConfigError(f"frames must be >= 1, got {frames}")
    if not (np.isfinite(fps) and fps > 0):
        raise ConfigError(f"fps must be a positive number, got {fps}")
    if config.batch < 1 or config.rollout_seconds <= 0 or config.ik_iterations < 0:
        raise ConfigError("config: batch >= 1, rollout_seconds > 0 and ik_iterations >= 0 are required")
    start = time.perf_counter()
    rig = prepare(morphology, fps=fps, config=config)
    return _batches(rig, int(frames), seed, progress, start)


def _batches(rig: SynthRig, frames: int, seed: int, progress: bool, start: float) -> Iterator[SynthResult]:
    morphology, fps, config = rig.morphology, rig.fps, rig.config
    per = max(2, round(config.rollout_seconds * fps))
    count = int(np.ceil(frames / per))
    # one generator per rollout, spawned batch by batch (the same children as one spawn of all)
    root_seed = np.random.SeedSequence(seed)
    nbatch = int(np.ceil(count / config.batch))
    size = int(np.ceil(count / nbatch))
    gait_names = (rig.legs and tuple(dict.fromkeys(g.name for b in rig.legs.bands for g in b.gaits))) or ()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=frames, unit="frame", desc=f"synth {morphology.name}", leave=False)

    def tick(n: int) -> None:
        if bar is not None:
            bar.update(n)

    try:
        for b in range(nbatch):
            idx = list(range(b * size, min(count, (b + 1) * size)))
            lengths = [per if i < count - 1 else frames - per * (count - 1) for i in idx]
            out = _run_batch(rig, root_seed.spawn(len(idx)), lengths, per, tick)
            motions: list[Motion] = []
            res: dict[str, list[np.ndarray]] = {
                k: [] for k in ("command", "target", "settled", "contact", "gait", "clamped")}
            spans: list[tuple[ActionSpan, ...]] = []
            action: list[np.ndarray] = []
            for k, i in enumerate(idx):
                L = lengths[k]
                motions.append(Motion(morphology, fps, out["q"][k, :L], f"{morphology.name}_synth_{seed}_{i:04d}"))
                for key, values in res.items():
                    values.append(out[key][k, :L])
                if out["action"] is not None:
                    action.append(out["action"][k, :L])
                    spans.append(tuple(_clip_span(sp, L) for sp in out["spans"][k] if sp.start < L))
            yield SynthResult(motions, res["command"], res["target"], res["settled"], res["contact"], res["gait"],
                              gait_names, res["clamped"], time.perf_counter() - start, rig, spans, action,
                              out["ground"])
    finally:
        if bar is not None:
            bar.close()


def _clip_span(span: ActionSpan, frames: int) -> ActionSpan:
    return span if span.stop <= frames else ActionSpan(span.kind, span.start, frames, span.arms)


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 of :mod:`morphkit.synth`'s source files: part of every synthesis cache key, so a change to
    the synthesis code never serves motion made by the old one."""
    h = hashlib.sha256()
    for f in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()
