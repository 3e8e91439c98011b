"""Rollouts: commands → root path → feet, arms and other joints → IK → :class:`Motion`.

Rollouts run in batches of ``SynthConfig.batch``, stepped together frame by frame; every per-frame
operation is vectorised over rollouts and limbs, and all limbs of all rollouts go through one
batched IK call per iteration, warm-started from the previous frame extrapolated at constant
velocity (so ``ik_iterations`` = 2 suffices). Every rollout draws its randomness up front from
its own generator (``SeedSequence(seed).spawn``), so a dataset depends only on the creature,
``frames``, ``fps``, ``seed`` and the config — not on how rollouts are batched.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import JointType, Morphology
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_from_rpy, quat_from_yaw, quat_rotate
from morphkit.synth._ik import LimbSolver
from morphkit.synth._util import nlerp, quat_delta_extrapolate
from morphkit.synth.analysis import BodyPlan, analyse
from morphkit.synth.arms import ArmConfig, PosePool, calibrate_arms, draw_upper_body
from morphkit.synth.legged import LegConfig, LeggedController, LegRig, calibrate_legs
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
from morphkit.synth.wheeled import Locomotion, base_coordinates, glide_height, lateral_allowed, locomotion_of

__all__ = ["SynthConfig", "SynthResult", "SynthRig", "prepare", "synthesize"]


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
    commands: CommandConfig = field(default_factory=CommandConfig)
    legs: LegConfig = field(default_factory=LegConfig)
    arms: ArmConfig = field(default_factory=ArmConfig)


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

    def summary(self) -> dict[str, Any]:
        """Calibration figures for reports (JSON-friendly)."""
        out: dict[str, Any] = {
            "locomotion": self.locomotion.value,
            "legs": len(self.plan.legs),
            "arms": len(self.plan.arms),
            "size_scale": round(self.scale, 4),
            "forward_speed_range": [round(v, 4) for v in self.limits.forward],
            "lateral_speed_range": [round(v, 4) for v in self.limits.lateral],
            "yaw_rate_range": [round(v, 4) for v in self.limits.yaw],
        }
        if self.legs is not None:
            lr = self.legs
            out.update({
                "stance_height_m": round(lr.stance_height, 4),
                "step_semi_axes_m": np.round(lr.semi_axes.mean(axis=0), 4).tolist(),
                "swing_height_m": round(lr.swing_height, 4),
                "cadence_hz": round(lr.cadence_hz, 4),
                "gaits": list(dict.fromkeys(g.name for b in lr.bands for g in b.gaits)),
                "max_forward_speed_m_s": round(float(self.max_speed(np.array([1.0, 0.0]))), 3),
                "max_lateral_speed_m_s": round(float(self.max_speed(np.array([0.0, 1.0]))), 3),
            })
        if not self.arms.empty:
            out["upper_body_pool"] = self.arms.stats
        return out

    def max_speed(self, direction: np.ndarray) -> float:
        """Fastest feasible speed [m/s] along a heading-frame direction [2] (no turning)."""
        if self.limits.clamp is None:
            return float("inf")
        v = np.array([[direction[0], direction[1], 0.0]]) * 1e3
        return float(np.linalg.norm(self.limits.clamp(v)[0, :2]))


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
    solver = LimbSolver(m, plan)
    cc = config.commands
    legs = None
    if loco == Locomotion.LEGGED:
        legs = calibrate_legs(m, plan, solver, config.legs, fps=fps, height_fraction=cc.height, pitch=cc.pitch,
                              roll=cc.roll)
        q_stance = legs.q_nominal.copy()
        scale = plan.leg_reach / cc.reference_leg_reach if cc.scale_by_size else 1.0
    else:
        q_stance = m.rest_q()
        if loco == Locomotion.GLIDE:
            q_stance[2] = glide_height(m)
        scale = 1.0
    arms = calibrate_arms(m, plan, solver, q_stance, config.arms)
    lat = cc.lateral_speed if lateral_allowed(m) else (0.0, 0.0)
    moving = loco != Locomotion.FIXED
    clamp: Callable[[np.ndarray], np.ndarray] | None = None
    if legs is not None:
        leg_rig, leg_cfg = legs, config.legs

        def clamp(cmd: np.ndarray) -> np.ndarray:
            return leg_rig.clamp(cmd, leg_cfg)

    forward = tuple(v * scale * moving for v in cc.forward_speed)
    lateral = tuple(v * scale * moving for v in lat)
    if clamp is not None and cc.fit_range_to_creature:
        # shrink a range the legs cannot step (straight, without turning) to what they can, so that
        # speeds stay spread over what the creature does instead of piling up at its top speed
        def top(d: tuple[float, float]) -> float:
            v = np.array([[d[0], d[1], 0.0]]) * 1e3
            return float(np.linalg.norm(clamp(v)[0, :2]))

        forward = (max(forward[0], -top((-1.0, 0.0))), min(forward[1], top((1.0, 0.0))))
        lateral = (max(lateral[0], -top((0.0, -1.0))), min(lateral[1], top((0.0, 1.0))))
    limits = CommandLimits(
        forward=forward,  # type: ignore[arg-type]
        lateral=lateral,  # type: ignore[arg-type]
        yaw=tuple(v * moving for v in cc.yaw_rate),  # type: ignore[arg-type]
        height=legs.height_range if legs is not None else (0.0, 0.0),
        pitch=legs.pitch if legs is not None else 0.0,
        roll=legs.roll if legs is not None else 0.0,
        acceleration=cc.acceleration * scale,
        yaw_acceleration=cc.yaw_acceleration,
        clamp=clamp,
    )
    rig = SynthRig(m, plan, loco, solver, legs, arms, q_stance, limits, float(scale), fps, config)
    _rig_cache.append((m, fps, config, rig))
    del _rig_cache[:-4]
    return rig


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

    def __len__(self) -> int:
        return len(self.motions)

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
        """Arrays stored beside motion ``i`` in its NPZ file."""
        return {
            "command": self.command[i].astype(np.float32),
            "command_target": self.target[i].astype(np.float32),
            "command_settled": self.settled[i],
            "command_names": np.array(COMMAND_NAMES),
            "contact": self.contact[i],
            "gait": self.gait[i],
            "gait_names": np.array(self.gait_names if self.gait_names else ("none",)),
        }

    def save(self, path: str | os.PathLike[str]) -> list[Path]:
        """Write the motions as NPZ files (:func:`~morphkit.motion.write_npz_motion`) and return their paths.

        A path ending in ``.npz`` gets one file: every motion end to end, with ``clip_starts`` (first
        frame of each rollout) among the extra arrays — consumers that ignore it see jumps at clip
        boundaries. Any other path is a folder (created if needed) with one ``<name>.npz`` per motion.
        """
        from morphkit.motion.io_npz import write_npz_motion

        p = Path(path)
        if p.suffix.lower() == ".npz":
            if not self.motions:
                raise ConfigError("nothing to save: no motion was synthesised")
            joined = Motion.concatenate(self.motions, name=p.stem)
            starts = np.cumsum([0] + [m.frame_count for m in self.motions[:-1]]).astype(np.int64)
            ex = {k: np.concatenate([self.extras(i)[k] for i in range(len(self))], axis=0)
                  for k in ("command", "command_target", "command_settled", "contact", "gait")}
            ex.update(command_names=np.array(COMMAND_NAMES), gait_names=self.extras(0)["gait_names"],
                      clip_starts=starts)
            p.parent.mkdir(parents=True, exist_ok=True)
            write_npz_motion(joined, p, **ex)
            return [p]
        if p.exists() and not p.is_dir():
            raise ConfigError(f"--out {p}: exists and is not a folder (use a .npz name for a single file)")
        p.mkdir(parents=True, exist_ok=True)
        out = []
        for i, m in enumerate(self.motions):
            f = p / f"{m.name}.npz"
            write_npz_motion(m, f, **self.extras(i))
            out.append(f)
        return out


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


def _run_batch(rig: SynthRig, seeds: Sequence[np.random.SeedSequence], lengths: Sequence[int], drawn: int,
               tick: Callable[[int], None]) -> dict[str, np.ndarray]:
    """Step ``len(seeds)`` rollouts together for ``max(lengths)`` frames; returns per-frame arrays [R, T, ...].

    Randomness is drawn for ``drawn`` frames whatever the lengths, so a rollout does not depend on
    its batch.
    """
    frames = max(lengths)
    active = np.asarray(lengths)
    m, cfg, fps = rig.morphology, rig.config, rig.fps
    rngs = [np.random.default_rng(s) for s in seeds]
    R = len(rngs)
    yaw0 = np.array([rng.uniform(-np.pi, np.pi) for rng in rngs])
    if rig.locomotion == Locomotion.FIXED:
        yaw0[:] = 0.0  # a fixed base stays where its description put it
    pad = int(np.ceil(cfg.look_ahead_seconds * fps))
    cmds = draw_commands(rngs, drawn + pad, fps, cfg.commands, rig.limits)
    path_xy, path_yaw = integrate_root(cmds.command, fps, yaw0)
    pool = rig.arms
    ub = draw_upper_body(rngs, pool, drawn, fps, cfg.arms)
    direct = pool.coords[pool.direct]
    n_arm = len(pool.arm_coords)
    solver = rig.solver
    legs = None
    NL = len(rig.plan.legs)
    if rig.legs is not None:
        legs = LeggedController(rig.legs, cfg.legs, fps, path_xy[:, 0], path_yaw[:, 0])
    C = m.coordinate_count
    nb = m.base_coordinate_count
    scalar, quats = _scalar_and_quat_coords(m)
    leg_balls = np.array([c[0] for c in solver.ball_constraints], dtype=np.int64)
    lower, upper = m.coordinate_limits
    lo_s, hi_s = lower[scalar], upper[scalar]
    out_q = np.empty((R, frames, C))
    contact = np.zeros((R, frames, NL), dtype=bool)
    gait = np.full((R, frames), -1, dtype=np.int8)
    q_prev = np.repeat(rig.q_stance[None], R, axis=0)
    q_prev2 = q_prev.copy()
    glide_z = rig.q_stance[2] if rig.locomotion == Locomotion.GLIDE else 0.0
    gain = cfg.arms.posture_gain
    for t in range(frames):
        c = cmds.command[:, t]
        xy, yaw = path_xy[:, t], path_yaw[:, t]
        # warm start: constant-velocity extrapolation of the joints, clamped into the limits
        q = q_prev.copy()
        if scalar.size:
            q[:, scalar] = np.clip(2.0 * q_prev[:, scalar] - q_prev2[:, scalar], lo_s, hi_s)
        for s in quats:
            q[:, s:s + 4] = quat_delta_extrapolate(q_prev[:, s:s + 4], q_prev2[:, s:s + 4])
        if leg_balls.size:
            # ball-jointed legs have no limits to keep them on the knee-forward branch: lean toward stance
            for s in leg_balls:
                q[:, s:s + 4] = nlerp(q[:, s:s + 4], np.broadcast_to(rig.q_stance[s:s + 4], (R, 4)),
                                      np.full(R, cfg.legs.ball_posture_gain))
        solver.constrain(q)
        if rig.locomotion == Locomotion.LEGGED:
            assert legs is not None and rig.legs is not None
            legs.step(t, path_xy, path_yaw, c[:, [CMD_VX, CMD_VY]], c[:, CMD_WZ], cmds.choice[:, t])
            z = rig.legs.stance_height + c[:, CMD_DH]
            rot = quat_from_rpy(np.stack([c[:, CMD_ROLL], c[:, CMD_PITCH], yaw], axis=-1))
            q[:, :nb] = base_coordinates(m, xy, yaw, z, rot)
            contact[:, t] = legs.stance
            gait[:, t] = legs.clock.gait_code
        else:
            z = np.full(R, glide_z)
            rot = quat_from_yaw(yaw)
            q[:, :nb] = base_coordinates(m, xy, yaw, z, rot)
        targets = []
        if NL:
            assert legs is not None
            targets.append(legs.feet() - solver.ankle_offsets(legs.foot_yaw))
        if not pool.empty:
            post = ub.posture(pool, t)
            q[:, direct] = post[:, pool.direct]
            if n_arm:
                cur = q[:, pool.arm_coords]
                ref = post[:, :n_arm]
                new = cur + gain * (ref - cur)
                for o in pool.arm_quat_offsets:
                    new[:, o:o + 4] = nlerp(cur[:, o:o + 4], ref[:, o:o + 4], np.full(R, gain))
                q[:, pool.arm_coords] = new
                root_pos = np.concatenate([xy, z[:, None]], axis=1)
                targets.append(root_pos[:, None, :] + quat_rotate(rot[:, None, :], ub.tips(pool, t)))
        if targets:
            tg = np.concatenate(targets, axis=1)
            weight = np.ones(tg.shape[:2])
            if NL:
                assert legs is not None
                # swinging feet and arms need no sub-millimetre accuracy: iterate for stance feet
                weight[:, :NL] = np.where(legs.stance, 1.0, 0.02)
                weight[:, NL:] = 0.02
            else:
                weight[:] = 0.02
            q = solver.solve(q, tg, key="all", ee=solver.all_ee, mask=solver.all_mask,
                             min_iterations=cfg.ik_iterations, max_iterations=cfg.ik_max_iterations,
                             tolerance=cfg.ik_tolerance, weight=weight)
            if legs is not None:
                q = solver.level_ankles(q, legs.foot_yaw)
        out_q[:, t] = q
        q_prev2, q_prev = q_prev, q
        tick(int((t < active).sum()))
    return {
        "q": out_q,
        "command": cmds.command[:, :frames],
        "target": cmds.target[:, :frames],
        "settled": cmds.settled[:, :frames],
        "contact": contact,
        "gait": gait,
        "clamped": cmds.clamped[:, :frames],
    }


def synthesize(morphology: Morphology, *, frames: int, fps: float = 30.0, seed: int = 0,
               config: SynthConfig | None = None, progress: bool = True) -> SynthResult:
    """Generate ``frames`` frames of procedural motion for any creature, from its graph alone.

    Legged creatures walk, trot, gallop (or their leg count's gaits) after random smoothed
    commands with their feet planted; arms reach and wave; wheeled bases drive; other joints
    (heads, tails) look around. See :mod:`morphkit.synth` for the method.

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
    config = config or SynthConfig()
    if int(frames) < 1:
        raise ConfigError(f"frames must be >= 1, got {frames}")
    if not (np.isfinite(fps) and fps > 0):
        raise ConfigError(f"fps must be a positive number, got {fps}")
    if config.batch < 1 or config.rollout_seconds <= 0 or config.ik_iterations < 0:
        raise ConfigError("config: batch >= 1, rollout_seconds > 0 and ik_iterations >= 0 are required")
    start = time.perf_counter()
    rig = prepare(morphology, fps=fps, config=config)
    per = max(2, round(config.rollout_seconds * fps))
    count = int(np.ceil(frames / per))
    lengths = [per] * count
    lengths[-1] = frames - per * (count - 1)
    seeds = np.random.SeedSequence(seed).spawn(count)
    nbatch = int(np.ceil(count / config.batch))
    size = int(np.ceil(count / nbatch))
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=frames, unit="frame", desc=f"synth {morphology.name}", leave=False)

    def tick(n: int) -> None:
        if bar is not None:
            bar.update(n)

    motions: list[Motion] = []
    res: dict[str, list[np.ndarray]] = {k: [] for k in ("command", "target", "settled", "contact", "gait", "clamped")}
    try:
        for b in range(nbatch):
            idx = list(range(b * size, min(count, (b + 1) * size)))
            out = _run_batch(rig, [seeds[i] for i in idx], [lengths[i] for i in idx], per, tick)
            for k, i in enumerate(idx):
                L = lengths[i]
                motions.append(Motion(morphology, fps, out["q"][k, :L], f"{morphology.name}_synth_{seed}_{i:04d}"))
                for key, values in res.items():
                    values.append(out[key][k, :L])
    finally:
        if bar is not None:
            bar.close()
    gait_names = (rig.legs and tuple(dict.fromkeys(g.name for b in rig.legs.bands for g in b.gaits))) or ()
    return SynthResult(motions, res["command"], res["target"], res["settled"], res["contact"], res["gait"],
                       gait_names, res["clamped"], time.perf_counter() - start, rig)
