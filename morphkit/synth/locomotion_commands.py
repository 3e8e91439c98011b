"""Random, smoothed locomotion commands and the root path they drive.

A rollout's command is a sequence of segments. Each segment draws a target — forward and lateral
speed [m/s] and yaw rate [rad/s] in the heading frame, body height offset [m], pitch and roll [rad]
— holds it for a random time and reaches it from the previous target along a smoothstep ramp whose
length respects the acceleration limits. Everything is drawn up front from the rollout's own
random generator, so a rollout is the same whatever batch it runs in.

Default ranges follow the ACE paper (§7.1): linear −1.5 … 5 m/s and angular −1 … 1 rad/s. Linear
speeds and accelerations scale with the creature's size, ``scale = leg_reach / 0.769`` (0.769 m is
Spot's leg reach from :func:`~morphkit.synth.analysis.analyse`, the creature the paper's
ranges were tuned on); creatures without legs keep the paper's ranges (``scale = 1``), as the
paper does for Stretch, but for a wheeled base that names its wheels: its ranges are the paper's as fractions of
its top forward speed (5 m/s), times its wheels' top speed, and every frame's command is clipped into what its
drive allows (:class:`~morphkit.body.wheels.Drive`). Legged creatures cannot always step that fast (at 30 fps
Spot's legs manage about 2.6 m/s): the forward and lateral ranges are shrunk to the creature's top speeds
(``fit_range_to_creature``), and a feasibility clamp (:mod:`morphkit.synth.legged`) scales
down any drawn target that still exceeds them, e.g. fast running combined with turning. Where dynamic
similarity bounds a legged creature's speed lower than its legs could step (Froude number
``LegConfig.max_froude``), every range shrinks by one factor first.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from morphkit.synth._util import smoothstep

__all__ = [
    "CMD_DH",
    "CMD_PITCH",
    "CMD_ROLL",
    "CMD_VX",
    "CMD_VY",
    "CMD_WZ",
    "COMMAND_NAMES",
    "SPOT_LEG_REACH",
    "CommandConfig",
    "CommandLimits",
    "CommandTrack",
    "draw_commands",
    "integrate_root",
]

CMD_VX, CMD_VY, CMD_WZ, CMD_DH, CMD_PITCH, CMD_ROLL = range(6)
COMMAND_NAMES = ("forward_speed", "lateral_speed", "yaw_rate", "height_offset", "pitch", "roll")
"""Command channels: [m/s], [m/s], [rad/s], [m], [rad], [rad]."""

SPOT_LEG_REACH = 0.769
"""Spot's mean leg reach [m] (hip to foot, summed segment lengths): the size the paper's ranges refer to."""


@dataclass(frozen=True)
class CommandConfig:
    """How random commands are drawn (ranges at the reference size; see the module docstring)."""

    forward_speed: tuple[float, float] = (-1.5, 5.0)
    """Forward speed range [m/s] at the reference size."""
    lateral_speed: tuple[float, float] = (-1.5, 1.5)
    """Lateral speed range [m/s] at the reference size (bases that cannot move sideways ignore it)."""
    yaw_rate: tuple[float, float] = (-1.0, 1.0)
    """Yaw rate range [rad/s] (not scaled)."""
    reference_leg_reach: float = SPOT_LEG_REACH
    """Leg reach [m] at which the speed ranges apply as given."""
    scale_by_size: bool = True
    """Scale linear speeds and accelerations by ``leg_reach / reference_leg_reach`` (legged creatures)."""
    fit_range_to_creature: bool = True
    """Shrink forward and lateral ranges to the fastest the creature can step (legged creatures), so
    speeds spread over what it can do; False draws from the full ranges and scales each command down."""
    stand_probability: float = 0.1
    """Probability that a segment commands standing still."""
    lateral_probability: float = 0.4
    """Probability that a moving segment has a lateral component."""
    turn_probability: float = 0.6
    """Probability that a moving segment turns."""
    segment_seconds: tuple[float, float] = (1.5, 5.0)
    """Range of segment durations [s] (a segment lasts at least its ramp plus ``settle_seconds``)."""
    acceleration: float = 3.0
    """Linear acceleration limit of the ramps [m/s²] at the reference size."""
    yaw_acceleration: float = 3.0
    """Angular acceleration limit of the ramps [rad/s²]."""
    min_ramp_seconds: float = 0.3
    """Shortest ramp [s]."""
    height: tuple[float, float] = (-0.12, 0.04)
    """Body height offset range, as a fraction of the stance height."""
    pitch: float = 0.12
    """Body pitch range ±[rad]."""
    roll: float = 0.08
    """Body roll range ±[rad]."""
    pose_probability: float = 0.5
    """Probability that a segment changes the body height, pitch and roll."""
    settle_seconds: float = 0.3
    """Time after a ramp ends before the command counts as settled (for tracking statistics)."""


@dataclass(frozen=True)
class CommandLimits:
    """A creature's command ranges after scaling (what :func:`draw_commands` samples from)."""

    forward: tuple[float, float]
    lateral: tuple[float, float]
    yaw: tuple[float, float]
    height: tuple[float, float]
    """Body height offset range [m]."""
    pitch: float
    roll: float
    acceleration: float
    """[m/s²]."""
    yaw_acceleration: float
    """[rad/s²]."""
    clamp: Callable[[np.ndarray], np.ndarray] | None = None
    """Scales velocity targets ``[N, 3]`` (forward, lateral, yaw rate) into what the creature can do."""


@dataclass
class CommandTrack:
    """Commands of a batch of rollouts per frame (frames include a look-ahead tail)."""

    command: np.ndarray
    """Smoothed command [R, T, 6] (channels :data:`COMMAND_NAMES`)."""
    target: np.ndarray
    """The segment's target [R, T, 6]."""
    settled: np.ndarray
    """[R, T] bool: the ramp to the current target ended at least ``settle_seconds`` ago."""
    choice: np.ndarray
    """[R, T] uniform random number drawn per segment (picks among alternative gaits)."""
    clamped: np.ndarray
    """[R, T] bool: the segment's velocity target was scaled down by the feasibility clamp."""


def _draw_one(rng: np.random.Generator, duration: float, cfg: CommandConfig,
              lim: CommandLimits) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Segments of one rollout: starts [S], ramps [S], targets [S, 6], choices [S], clamped [S]."""
    smin = max(cfg.segment_seconds[0], 1e-3)
    S = int(np.ceil(duration / smin)) + 2
    u = rng.random((S, 10))
    tgt = np.zeros((S, 6))
    moving = u[:, 0] >= cfg.stand_probability
    tgt[:, CMD_VX] = np.where(moving, lim.forward[0] + u[:, 1] * (lim.forward[1] - lim.forward[0]), 0.0)
    lateral = moving & (u[:, 2] < cfg.lateral_probability)
    tgt[:, CMD_VY] = np.where(lateral, lim.lateral[0] + u[:, 3] * (lim.lateral[1] - lim.lateral[0]), 0.0)
    turning = moving & (u[:, 4] < cfg.turn_probability)
    tgt[:, CMD_WZ] = np.where(turning, lim.yaw[0] + u[:, 5] * (lim.yaw[1] - lim.yaw[0]), 0.0)
    raw = tgt[:, :3].copy()
    if lim.clamp is not None:
        tgt[:, :3] = lim.clamp(tgt[:, :3])
    clamped = np.any(np.abs(tgt[:, :3] - raw) > 1e-9, axis=1)
    # body pose: a new one with pose_probability, else the previous segment's
    pose = np.stack([
        lim.height[0] + u[:, 6] * (lim.height[1] - lim.height[0]),
        lim.pitch * (2.0 * u[:, 7] - 1.0),
        lim.roll * (2.0 * u[:, 8] - 1.0),
    ], axis=1)
    change = rng.random(S) < cfg.pose_probability
    change[0] = True
    last = np.maximum.accumulate(np.where(change, np.arange(S), 0))
    tgt[:, 3:] = pose[last]
    prev = np.vstack([np.zeros((1, 6)), tgt[:-1]])
    d = np.abs(tgt - prev)
    acc = max(lim.acceleration, 1e-9)
    yacc = max(lim.yaw_acceleration, 1e-9)
    # a smoothstep ramp peaks at 1.5x its mean rate
    ramp = np.maximum.reduce([
        np.full(S, cfg.min_ramp_seconds),
        1.5 * d[:, CMD_VX] / acc,
        1.5 * d[:, CMD_VY] / acc,
        1.5 * d[:, CMD_WZ] / yacc,
    ])
    lengths = cfg.segment_seconds[0] + rng.random(S) * (cfg.segment_seconds[1] - cfg.segment_seconds[0])
    lengths = np.maximum(lengths, ramp + cfg.settle_seconds + 0.2)
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    return starts, ramp, tgt, rng.random(S), clamped


def draw_commands(rngs: Sequence[np.random.Generator], frames: int, fps: float, cfg: CommandConfig,
                  limits: CommandLimits) -> CommandTrack:
    """Draw and smooth the commands of ``len(rngs)`` rollouts for ``frames`` frames each.

    Frame ``k`` is at time ``k / fps``; rollouts start from standing still (zero command).
    """
    R = len(rngs)
    t = np.arange(frames) / fps
    duration = frames / fps + 1.0
    command = np.zeros((R, frames, 6))
    target = np.zeros((R, frames, 6))
    settled = np.zeros((R, frames), dtype=bool)
    choice = np.zeros((R, frames))
    clamped = np.zeros((R, frames), dtype=bool)
    for r, rng in enumerate(rngs):
        starts, ramp, tgt, ch, cl = _draw_one(rng, duration, cfg, limits)
        seg = np.searchsorted(starts, t, side="right") - 1
        prev = np.vstack([np.zeros((1, 6)), tgt[:-1]])
        since = t - starts[seg]
        a = smoothstep(since / ramp[seg])
        command[r] = prev[seg] + (tgt[seg] - prev[seg]) * a[:, None]
        target[r] = tgt[seg]
        settled[r] = since >= ramp[seg] + cfg.settle_seconds
        choice[r] = ch[seg]
        clamped[r] = cl[seg]
    return CommandTrack(command=command, target=target, settled=settled, choice=choice, clamped=clamped)


def integrate_root(command: np.ndarray, fps: float, yaw0: np.ndarray,
                   xy0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Planar root path of heading-frame velocity commands (trapezoidal rule).

    Args:
        command: [R, T, >=3] with forward and lateral speed [m/s] and yaw rate [rad/s] first.
        fps: Frames per second.
        yaw0: Initial yaw [R] [rad].
        xy0: Initial position [R, 2] [m] (default 0).

    Returns:
        ``(xy [R, T, 2], yaw [R, T])``.
    """
    dt = 1.0 / fps
    w = command[..., CMD_WZ]
    dyaw = 0.5 * (w[:, 1:] + w[:, :-1]) * dt
    yaw = yaw0[:, None] + np.concatenate([np.zeros((w.shape[0], 1)), np.cumsum(dyaw, axis=1)], axis=1)
    c, s = np.cos(yaw), np.sin(yaw)
    vx, vy = command[..., CMD_VX], command[..., CMD_VY]
    world = np.stack([c * vx - s * vy, s * vx + c * vy], axis=-1)
    step = 0.5 * (world[:, 1:] + world[:, :-1]) * dt
    xy = np.concatenate([np.zeros((w.shape[0], 1, 2)), np.cumsum(step, axis=1)], axis=1)
    if xy0 is not None:
        xy = xy + xy0[:, None, :]
    return xy, yaw
