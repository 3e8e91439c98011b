"""Legged locomotion: stance calibration from the graph, footstep planning and swing arcs.

**Calibration** (:func:`calibrate_legs`, once per creature) turns the body plan into a stance:

1. *Stance height*: feet stay where they are at rest in x and y (root frame); the body is lowered
   (never raised) until no leg is stretched beyond ``stance_extension`` of its reach, so knees keep
   room to bend both ways: by default the rest pose's own extension (the described stance, at most
   ``stance_extension_max``) where the step region found in 3. stays at least ``stance_step_test`` of
   the reach, else the first of ``stance_extension_steps`` that does, else ``stance_extension_fallback``
   (0.8; bipeds ``biped_stance_extension_fallback``, 0.88). Legs that are straight
   at rest are pre-bent first (knee forward for upright legs), because a straight chain is singular and
   DLS cannot bend it. The body's dip, pitch and roll are then bounded so that the upper body's joints
   can keep every link above the ground (:meth:`~morphkit.synth.ground.GroundGuard.root_floor`).
2. *Nominal posture*: DLS IK (:mod:`morphkit.synth._ik`) puts the feet there.
3. *Step region*: each foot may move within an axis-aligned ellipse about its nominal point, of
   semi-axes $(a\\rho_l, b\\rho_l)$ fore-aft and sideways ($\\rho_l$ the leg's reach). $a$ then $b$
   are found by bisection: the largest values for which IK reaches every foot on the ellipse
   (within 2 mm, at every corner of the commanded body height, pitch and roll) and random feet
   inside the ellipses make no self-collision. Crossing legs (a crab's, a biped's) therefore get
   short strides in the direction they would collide.
4. *Swing height*: ``swing_height`` of the reach, lowered until the raised foot is reachable.

**Upright bipeds** (two legs hanging straight down at rest, :func:`is_upright_biped`): a body held
at one height must leave every foot of the step region reachable, so a fixed-height biped walks
with bent knees (at the 0.88 extension above, about 1.1 rad for a human). Instead the step region
is calibrated at that lower height, but the biped stands at ``upright_extension`` of its legs'
chain lengths (knees about 0.18 rad) and its root rides over the stance legs: each frame it is as
high as commanded where no leg would be stretched beyond ``upright_max_extension``, lower where a
foot far ahead or behind needs it (:func:`upright_root_height`) — the vertical bob of a walking
person, lowest in double support. Commanded body pitch and roll are scaled by
``upright_pose_scale``, height offsets by ``upright_height_scale``.

**Legs that turn in one plane** (hip, knee and ankle all pitching; :func:`ground_mobility` finds them
from the leg Jacobian at stance): the step region is searched only along the directions the foot can
move (the other semi-axis is ``fixed_axis_semi_axis`` of the reach, room for a turn's drift); the body
does not roll (or pitch) across a direction a leg cannot follow, walks only along the other, and turns
at most ``fixed_axis_yaw_rate``. The calibration says so per leg (:attr:`LegRig.warnings`), and also
when a step region or swing height came out small. Upright bipeds with revolute knees keep them bent
by ``upright_knee_margin`` (:func:`keep_hinge_knees_bent`), as ball knees are; so do legs whose IK holds a
level sole with every ankle hinge (:func:`_level_foot_knees`), upright or not: the warm start's extrapolation at
touchdown would otherwise straighten such a knee, where its DLS steps are singular. Such a leg counts as straight at
rest where its knee is (:func:`_straight_knees`), not by its summed segments (a sole point ahead of the ankle and hip
offsets make the G1's straight leg look bent), and is pre-bent at the knee alone.

**Stepping** (:class:`LeggedController`, vectorised over rollouts and legs): the gait clock
(:mod:`morphkit.synth.gait`) says when a stance foot may lift; the cycle frequency is the
creature's cadence $f_0 = c\\sqrt{g/h}/2\\pi$ or faster, so that each stance uses at most
``stroke_usage`` of the ellipse, and at most $(1-\\beta)/T_{sw,min}$. A foot that nears the edge of
its ellipse lifts regardless. While it swings, its touchdown point is re-planned each frame
(Raibert's neutral point with velocity feed-forward, computed exactly): where its hip will be at
the middle of the coming stance along the commanded root path — the path ramps from the current
velocity to the target, so the plan uses both — clipped into the ellipse at touchdown. The swing
moves vertically first and last (the foot is off the ground before it moves horizontally, so a
lift-off never shows up as sliding), horizontally along a smoothstep, on a parabolic arc in
height. A stance foot is a fixed world target until it lifts: zero sliding up to the IK residual.

**Speed fraction**: a command needs foot $l$ to move relative to the body at
$v_l = -(v + \\omega \\hat z \\times p_l)$, i.e. $|v_l| / 2r_l(\\hat v_l)$ strokes per second ($r_l$
the ellipse's half-chord along $\\hat v_l$). Per stride a foot moves relative to the body during its
stance and during its first and last airborne frames (vertical only, while the body moves on):
$T_{span} = T_{st} + 2\\Delta t$. At the fastest gait (duty $\\beta_{min}$) and shortest swing
$T_{st} = \\beta_{min} T_{sw,min} / (1 - \\beta_{min})$, so the speed fraction
$s = \\max_l (|v_l| / 2 r_l) T_{span,min} / u_{max}$ is 1 when the fastest gait uses ``max_stroke_usage``
of the ellipse. Commands are scaled to $s \\le$ ``speed_fraction_limit``; the cadence and the touchdown
and emergency limits leave room for the two airborne frames, so a foot never leaves its ellipse. The body
speed is then bounded by dynamic similarity, $|v| \\le \\sqrt{F g h}$ (``max_froude``), whatever the stroke allows.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from morphkit.graph import JointType, Morphology
from morphkit.kernels import eval_fk
from morphkit.kernels.contact import eval_self_collision_distance, self_collision_pairs
from morphkit.kernels.ik import eval_ee_jacobian
from morphkit.rotations import quat_from_rpy, quat_from_yaw, quat_multiply, quat_rotate, wrap_angle, yaw_from_quat
from morphkit.synth._ik import LimbSolver
from morphkit.synth._util import rotate2, smoothstep
from morphkit.synth.analysis import BodyPlan
from morphkit.synth.gait import GaitBand, GaitClock, gait_bands
from morphkit.synth.ground import GroundGuard

__all__ = ["LegConfig", "LegRig", "LeggedController", "calibrate_legs", "ground_mobility", "is_upright_biped",
           "keep_hinge_knees_bent", "keep_knees_bent", "upright_root_height"]

GRAVITY = 9.81


@dataclass(frozen=True)
class LegConfig:
    """Stance, stepping and calibration parameters (see the module docstring)."""

    stance_extension: float | None = None
    """Hip-to-foot distance at stance as a fraction of reach. None: as at rest (the described stance) where the
    legs can still step from there (``stance_step_test``), else the first of ``stance_extension_steps`` below it
    that can, else ``stance_extension_fallback`` (bipeds ``biped_stance_extension_fallback``). Upright bipeds
    (see ``upright``) calibrate their step region at this height and stand taller."""
    stance_extension_fallback: float = 0.8
    """Stance extension (fraction of each leg's effective reach) of creatures of more than two legs where
    ``stance_extension`` is None and the rest pose is no straighter or cannot step: knees well bent. The same
    quantity as the anatomy's searched stance, :attr:`morphkit.body.AnatomyConfig.stance_extension` (there a
    fraction of the shortest leg's reach, 0.72 on point feet as the makers stand them), kept apart: synthesis and
    reading tune their own."""
    biped_stance_extension_fallback: float = 0.88
    """The same for one or two legs (upright bipeds calibrate their step region there and stand taller). The
    anatomy stands two legs straighter, at :attr:`morphkit.body.AnatomyConfig.biped_stance_extension` (0.92,
    which ``stance_extension_max`` equals)."""
    stance_extension_max: float = 0.92
    """Straighter legs than this stand at it (a straight chain is singular: DLS cannot bend it). Equal to the
    anatomy's two-legged stance, :attr:`morphkit.body.AnatomyConfig.biped_stance_extension`, so a biped read at
    that stance is tried at it first."""
    stance_extension_steps: tuple[float, ...] = (0.88, 0.84)
    """Extensions tried, in order, where the rest pose's cannot step."""
    stance_step_test: tuple[float, float] = (0.15, 0.08)
    """A stance can step when its step region's semi-axes (fore-aft, sideways; fractions of the leg's reach)
    come out at least this long."""
    rest_extension_tolerance: float = 1e-3
    """The rest pose's extension is tried (``stance_extension_max``, ``stance_extension_steps``) only where it
    exceeds the fallback by more than this (fraction of reach)."""
    stance_note_tolerance: float = 0.01
    """A stance lower than the rest pose's extension by more than this (fraction of reach) is noted in the stats."""
    stance_height_min: float = 0.3
    """A stance's root stands at least this fraction of its rest height."""
    stance_residual: float = 5e-4
    """IK residual [m] up to which a stance has every foot on its nominal point (else the root is raised, see
    ``settle_tries``, and finally the rest pose is kept)."""
    stance_iterations: int = 150
    """IK iterations of a stance solve (the nominal posture, and the stretch measuring the effective reach)."""
    settle_tries: int = 4
    """Where IK misses the nominal feet, the root is raised ``settle_step`` of the way to its rest height, at most
    this many times."""
    settle_step: float = 0.5
    """See ``settle_tries``."""
    reach_stretch: float = 1.5
    """The effective reach: each leg's IK point is stretched toward a target this many reaches from its mount,
    along its rest direction (joint limits may stop it well short of the summed segment lengths)."""
    reach_stretch_error: float = 0.05
    """... by IK steps working on at most this fraction of the mean reach."""
    step_region_min: float = 0.02
    """Smallest step-region semi-axis factor (fraction of reach) a stance must allow; the commanded body poses
    are halved (at most ``body_pose_halvings`` times) until it does, and bisection starts from it."""
    step_region_max: float = 0.6
    """Largest step-region semi-axis factor (fraction of reach) the bisection tries."""
    step_region_bisections: int = 6
    """Bisection steps per semi-axis factor."""
    step_region_margin: float = 0.95
    """The bisected semi-axis factors are scaled by this: a margin inside the largest feasible ellipse."""
    body_pose_halvings: int = 4
    """See ``step_region_min``."""
    upright: bool | None = None
    """Stand tall and let the root ride over straight stance legs (see "Upright bipeds" in the module
    docstring); None decides from the graph (:func:`is_upright_biped`)."""
    upright_extension: float = 0.996
    """Upright bipeds: hip-to-ankle distance at stance as a fraction of the leg's chain length (knee
    flexion $2\\arccos e$ for equal segments: 0.18 rad)."""
    upright_max_extension: float = 0.998
    """Upright bipeds: the most a leg is stretched when the root dips over a long stride (0.13 rad)."""
    upright_pose_scale: float = 0.25
    """Upright bipeds: commanded body pitch and roll are scaled by this (a person does not walk tilted)."""
    upright_height_scale: float = 0.0
    """Upright bipeds: commanded body height offsets are scaled by this (a person does not walk
    crouched; near straight, 3 cm lower bends a human's knees from 0.18 to 0.58 rad)."""
    upright_smoothing_seconds: float = 0.067
    """Upright bipeds: half-width of the root height's minimum filter and of the average after it [s]
    (two frames at 30 fps: wider is smoother but lower, and every centimetre lower bends the knees)."""
    upright_knee_margin: float = 0.1
    """Upright bipeds: a ball-jointed knee's warm start is kept bent at least this much [rad] the way
    it bends at stance, so that IK of a nearly straight leg never flips it backward."""
    swing_height: float = 0.12
    """Swing apex as a fraction of the mean leg reach (lowered if unreachable)."""
    min_swing_seconds: float = 0.1
    """Shortest swing [s] (also at least ``min_swing_frames``)."""
    min_swing_frames: int = 4
    """Shortest swing in frames (>= 3: lift frame, move, touchdown frame)."""
    stroke_usage: float = 0.6
    """Fraction of the step ellipse a stance uses at the preferred cadence."""
    max_stroke_usage: float = 0.85
    """Fraction of the step ellipse a stance may use at the highest step frequency."""
    cadence: float = 1.7
    """Preferred cycle frequency in units of $\\sqrt{g/h}/2\\pi$ (h: stance height)."""
    speed_fraction_limit: float = 0.95
    """Commands are scaled down to at most this speed fraction."""
    max_froude: float | None = 1.0
    """Largest Froude number $v^2 / g h$ of the commanded body speed (h: stance height); faster commands are
    scaled down (their yaw rate kept), and where this bound is below the fastest the legs can step, every speed
    range shrinks by their ratio (backwards and sideways too). None: only the legs' stroke bounds the speed.
    Ours: $\\sqrt{g h}$ is the fastest an inverted-pendulum walk goes (Alexander 1989), and the ACE paper's range
    (−1.5 … 5 m/s at Spot's size) is about Froude 5 at Spot's stance: legs that stand bent (MuJoCo Menagerie's
    Spot, keyframe ``home``) reach that far and were synthesised galloping at 5 m/s in 0.58 m steps, while the
    shipped Spot's stroke stops it at Froude 0.7 (docs/experiments/froude-cap.md)."""
    lift_clearance: float = 0.03
    """A swinging foot rises at least this high [m] (or to the swing height if lower) on its first
    and last airborne frames, above the usual 2 cm contact threshold."""
    touchdown_limit: float = 0.9
    """Touchdown points are clipped to this fraction of the ellipse."""
    emergency_limit: float = 0.97
    """A stance foot this far out in its ellipse lifts off whatever its phase."""
    ball_posture_gain: float = 0.1
    """Per-frame pull toward the stance posture, before IK, of leg ball joints (which have no limits) and of the
    hinges of legs with more DoFs in the IK than their foot point has (which drift in the null space)."""
    fixed_axis_semi_axis: float = 0.02
    """Step-ellipse semi-axis, as a fraction of reach, along a direction in which a leg cannot move its
    foot on the ground (sideways for a leg whose joints all pitch): what turning may drift a stance
    foot off its leg's plane before it lifts."""
    fixed_axis_yaw_rate: float = 0.15
    """Largest yaw rate [rad/s] of a creature with a leg that cannot step sideways or fore-aft: a turn
    drags such a leg's stance foot across its plane at the yaw rate times the foot's distance from the
    root, so turns are kept slow."""
    calibration_random_poses: int = 64
    """Random foot placements tested per candidate ellipse."""
    calibration_iterations: int = 30
    """IK iterations per calibration solve."""
    reach_tolerance: float = 0.002
    """IK residual [m] below which a calibration target counts as reached."""
    collision_tolerance: float = 0.001
    """Overlap [m] beyond which two shapes count as colliding."""
    collision_rest_margin: float = 0.005
    """Shape pairs closer than this at rest [m] touch by design (like neighbours across a joint) and
    are not checked."""


@dataclass(frozen=True, eq=False)
class LegRig:
    """A creature's calibrated stance and step geometry (from :func:`calibrate_legs`)."""

    nominal_xy: np.ndarray
    """Nominal foot positions in the root's heading frame [NL, 2] [m]."""
    stance_height: float
    """Root height above the ground at stance [m]."""
    semi_axes: np.ndarray
    """Step ellipse semi-axes (fore-aft, sideways) per leg [NL, 2] [m]."""
    swing_height: float
    """Swing apex [m]."""
    q_nominal: np.ndarray
    """Coordinates at stance [C] (root at (0, 0, stance_height), level)."""
    cadence_hz: float
    """Preferred cycle frequency $f_0$ [Hz]."""
    bands: tuple[GaitBand, ...]
    height_range: tuple[float, float]
    """Body height offsets the stance allows [m]."""
    pitch: float
    """Body pitch the stance allows ±[rad]."""
    roll: float
    """Body roll the stance allows ±[rad]."""
    extension: float
    """Stance extension used."""
    t_swing_min: float
    """Shortest swing [s]."""
    dt: float
    """Frame time [s] the rig was calibrated for."""
    stats: dict = field(default_factory=dict)
    """Calibration figures (ellipse factors, residuals) for reports."""
    upright: bool = False
    """The root rides over straight stance legs (:func:`upright_root_height`); ``stance_height`` is the
    tall standing height."""
    mount_xyz: np.ndarray | None = None
    """Leg mount points in the root frame [NL, 3] [m] (upright bipeds)."""
    leg_length: np.ndarray | None = None
    """Mount-to-IK-point chain length per leg [NL] [m] (upright bipeds)."""
    max_extension: float = 1.0
    """Upright bipeds: the largest mount-to-IK-point distance as a fraction of ``leg_length``."""
    ankle_xyz: np.ndarray | None = None
    """Upright bipeds: the vector from each leg's IK point to the point its ``leg_length`` ends at, level foot
    heading +x [NL, 3] [m]: the ankle of a leg that holds its sole level (:func:`_ankle_points`), else zero."""
    fixed_axes: np.ndarray | None = None
    """[NL, 2] bool: directions (fore-aft, sideways) along which a leg's joints cannot move its foot on the
    ground (:func:`ground_mobility`); None when every leg moves both ways."""
    hinge_knees: tuple[tuple[int, float, float], ...] = ()
    """Upright bipeds: revolute knees as ``(q index, straight angle, sign)``; their warm start is kept bent
    at least ``upright_knee_margin`` the way they bend at stance (see :func:`keep_hinge_knees_bent`)."""
    warnings: tuple[str, ...] = ()
    """One line per leg that cannot be moved well: which leg and why."""

    @property
    def leg_count(self) -> int:
        """NL."""
        return len(self.nominal_xy)

    @property
    def duty_min(self) -> float:
        """Smallest duty factor of the creature's gaits."""
        return min(g.duty for b in self.bands for g in b.gaits)

    def stroke_rate(self, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Strokes per second each foot needs, ``|v_l| / 2 r_l`` [N, NL], for heading-frame velocity ``v``
        [N, 2] [m/s] and yaw rate ``w`` [N] [rad/s]."""
        p = self.nominal_xy
        rel = -(v[:, None, :] + w[:, None, None] * np.stack([-p[:, 1], p[:, 0]], axis=-1)[None])
        ax = self.semi_axes
        # |v_l| / r(u) = sqrt((vx/rx)^2 + (vy/ry)^2)
        return 0.5 * np.sqrt((rel[..., 0] / ax[:, 0]) ** 2 + (rel[..., 1] / ax[:, 1]) ** 2)

    def stance_span(self, duty: float | np.ndarray) -> float | np.ndarray:
        """Time [s] a foot spends moving relative to the body per stride at the shortest swing:
        the stance, plus the first and last airborne frames (vertical only, while the body moves on)."""
        return duty / (1.0 - duty) * self.t_swing_min + 2.0 * self.dt

    def speed_fraction(self, v: np.ndarray, w: np.ndarray, max_usage: float) -> np.ndarray:
        """Speed fraction [N] of commands (see the module docstring)."""
        return self.stroke_rate(v, w).max(axis=1) * self.stance_span(self.duty_min) / max_usage

    def clamp(self, cmd: np.ndarray, cfg: LegConfig) -> np.ndarray:
        """Scale velocity commands [N, 3] (forward, lateral, yaw rate) to a speed fraction <= the limit and a body
        speed <= ``max_froude``'s."""
        s = self.speed_fraction(cmd[:, :2], cmd[:, 2], cfg.max_stroke_usage)
        k = np.where(s > cfg.speed_fraction_limit, cfg.speed_fraction_limit / np.maximum(s, 1e-12), 1.0)
        out = cmd * k[:, None]
        speed = np.linalg.norm(out[:, :2], axis=1)
        out[:, :2] *= np.minimum(1.0, self.froude_speed(cfg) / np.maximum(speed, 1e-12))[:, None]
        return out

    def froude_speed(self, cfg: LegConfig) -> float:
        """The body speed [m/s] at ``cfg.max_froude``, $\\sqrt{F g h}$ (inf without one)."""
        return np.inf if cfg.max_froude is None else float(np.sqrt(cfg.max_froude * GRAVITY * self.stance_height))

    def top_speed(self, direction: Sequence[float], cfg: LegConfig) -> float:
        """The fastest command along ``direction`` [2] (heading frame) without turning that :meth:`clamp` lets
        through [m/s]."""
        v = np.array([[*(1e3 * np.asarray(direction, dtype=float)), 0.0]])
        return float(np.linalg.norm(self.clamp(v, cfg)[0, :2]))


# ---------------------------------------------------------------------------------------------
# calibration
# ---------------------------------------------------------------------------------------------
def _descendants(m: Morphology, links: set[str]) -> set[str]:
    out = set(links)
    for j in m.joints:  # topological order: parents first
        if j.parent in out:
            out.add(j.child)
    return out


def limb_links(m: Morphology, joints: tuple[str, ...]) -> set[str]:
    """Links moved by a limb's joints (their children and everything below)."""
    return _descendants(m, {m.joint(n).child for n in joints})


class _Calibrator:
    def __init__(self, m: Morphology, plan: BodyPlan, solver: LimbSolver, cfg: LegConfig) -> None:
        self.m = m
        self.plan = plan
        self.solver = solver
        self.cfg = cfg
        self.model = solver.model
        self.NL = len(plan.legs)
        self.reach = np.array([leg.reach for leg in plan.legs])
        links = set()
        for leg in plan.legs:
            links |= limb_links(m, leg.joints)
        idx = {self.model.link_index(n) for n in links}
        self.all_pairs = self_collision_pairs(self.model, rest_margin=cfg.collision_rest_margin)
        self.pairs = self.all_pairs.touching(idx)

    def root_q(self, q: np.ndarray, z: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
        q = q.copy()
        q[:, 0:2] = 0.0
        q[:, 2] = z
        q[:, 3:7] = quat_from_rpy(np.stack([roll, pitch, np.zeros_like(z)], axis=-1))
        return q

    def solve(self, q: np.ndarray, feet: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
        """IK of the leg targets (foot points, world, level feet with yaw 0; a foot above the ground need not
        be level); returns q and final errors [B, NL]."""
        B = q.shape[0]
        yaw = np.zeros((B, self.NL))
        ik_pts = self.solver.leg_targets(feet, yaw)
        ee = self.solver.leg_targets_ee
        planted = feet[..., 2] <= 1e-9
        # whether a lifted foot can be placed at all: its orientation is left free
        w = self.solver.leg_step_weights(planted)
        q = self.solver.constrain(q.copy())
        q, _ = self.solver.step(q, ik_pts, ee=ee, mask=self.solver.leg_mask, iterations=iterations, ee_weight=w)
        q = self.solver.level_ankles(q, yaw)
        _, res = self.solver.step(q, ik_pts, ee=ee, mask=self.solver.leg_mask, iterations=1, ee_weight=w)
        # a foot's error: its point's, or, planted and held level, the farthest of its points
        err = np.linalg.norm(res, axis=-1)
        out = err[:, :self.NL].copy()
        tilt = np.where(planted[:, self.solver.tilt_leg], err[:, self.NL:], 0.0)
        np.maximum.at(out, (slice(None), self.solver.tilt_leg), tilt)
        return q, out

    def collisions(self, q: np.ndarray) -> np.ndarray:
        """[B] bool: any leg shape pair overlapping by more than the tolerance."""
        if self.pairs.pair_count == 0:
            return np.zeros(q.shape[0], dtype=bool)
        X = eval_fk(self.model, q, device="cpu")
        d = eval_self_collision_distance(self.model, self.pairs, X).numpy()
        return (d < -self.cfg.collision_tolerance).any(axis=1)


def _prebend(m: Morphology, solver: LimbSolver, q: np.ndarray, plan: BodyPlan) -> np.ndarray:
    """Bend the knees of legs that are straight at rest (a straight chain is singular for DLS)."""
    model = solver.model
    q = q.copy()
    for li, leg in enumerate(plan.legs):
        ee = int(solver.leg_ee[li])
        mov = [m.joint_index(n) for n in leg.joints
               if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None]
        if solver.ankles[li] is not None:
            mov = mov[:-1]
        if len(mov) < 2:
            continue
        X = eval_fk(model, q[None], device="cpu").numpy()[0]
        mount = np.asarray(leg.mount_rest)
        tip = _ee_point(model, X, ee)
        pts = [mount] + [X[j + 1, :3] for j in mov[1:]] + [tip]
        chain = sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(pts))
        bend = mov[1:]
        if np.linalg.norm(tip - mount) < 0.97 * chain:
            if li not in solver.tilt_leg:
                continue
            # a foot held level (ankle hinges in the solve): a sole point ahead of the ankle (the G1's toe) and hip
            # offsets make a straight leg look bent by its chain, so ask its joints, and bend only the knee
            bend = _straight_knees(model, m, q, mov, mount)
        v = tip - mount
        upright = np.hypot(v[0], v[1]) < abs(v[2])
        for ji in bend:
            if ji in solver.held_joints:  # out of the IK: it stays at rest
                continue
            j = m.joints[ji]
            s = m.joint_q_start[ji]
            cands = []
            for sign in (1.0, -1.0):
                qc = q.copy()
                if j.type == JointType.SPHERICAL:
                    d0 = m.joint_qd_start[ji]
                    axes = [a for a in range(3) if solver.leg_mask[d0 + a]]
                    if not axes:
                        continue
                    e = np.zeros(3)
                    e[axes[0]] = 1.0
                    half = 0.25 * sign
                    rot = np.array([*(e * np.sin(half)), np.cos(half)])
                    qc[s:s + 4] = quat_multiply(q[s:s + 4], rot)
                else:
                    lo, hi = model.coordinate_lower[s], model.coordinate_upper[s]
                    qc[s] = np.clip(q[s] + 0.5 * sign, lo, hi)
                    if abs(qc[s] - q[s]) < 1e-6:
                        continue
                Xc = eval_fk(model, qc[None], device="cpu").numpy()[0]
                moved = _ee_point(model, Xc, ee) - tip
                score = -moved[0] if upright else -moved[2]
                cands.append((score, qc))
            if cands:
                q = max(cands, key=lambda c: c[0])[1]
    return q


def _straight_knees(model, m: Morphology, q: np.ndarray, mov: list[int], mount: np.ndarray) -> list[int]:
    """The joints of a leg of 1-DoF joints ``mov`` at which it is straight at ``q`` [C]: knees that sit where
    turning them either way shortens the mount-to-ankle distance (``mount`` [3] in the root frame, the ankle the
    last joint's child) — to second order only, the singular pose DLS cannot bend out of."""
    ankle = model.link_index(m.joints[mov[-1]].child)

    def dist(qq: np.ndarray) -> np.ndarray:
        X = eval_fk(model, qq, device="cpu").numpy()[:, ankle, :3]
        return np.linalg.norm(X - q[:3] - mount, axis=-1)

    h = 0.05
    knees = []
    for ji in mov:
        s = m.joint_q_start[ji]
        qs = np.repeat(q[None], 3, axis=0)
        qs[1, s] -= h
        qs[2, s] += h
        d0, lo, hi = dist(qs)
        if abs(hi - lo) / (2 * h) < 0.01 * d0 and (hi + lo - 2 * d0) / h**2 < -0.1 * d0:
            knees.append(ji)
    return knees


def is_upright_biped(plan: BodyPlan) -> bool:
    """Two legs that hang nearly straight and vertical from their mounts at rest (a person's legs).

    Each leg's mount-to-foot vector at rest points down, leans at most 0.25 of its height sideways
    or fore-aft, and spans at least 95 % of the leg's summed segment lengths.
    """
    if len(plan.legs) != 2:
        return False
    for leg in plan.legs:
        v = np.asarray(leg.tip_rest) - np.asarray(leg.mount_rest)
        if v[2] >= 0 or np.hypot(v[0], v[1]) > 0.25 * abs(v[2]) or np.linalg.norm(v) < 0.95 * leg.reach:
            return False
    return True


def _ankle_points(m: Morphology, solver: LimbSolver, plan: BodyPlan) -> np.ndarray:
    """Per leg [NL, 3]: the vector from its IK point to its ankle (the last moving joint's child) at rest, root
    frame, for legs whose IK holds the foot level with every ankle hinge in the solve (the foot point is then
    on the sole, beside and below the ankle); zero for the others, whose IK point is their ankle or foot."""
    rest = m.rest_link_poses()
    out = np.zeros((len(plan.legs), 3))
    for li in set(solver.tilt_leg.tolist()):
        leg = plan.legs[li]
        mov = [m.joint_index(n) for n in leg.joints
               if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None]
        out[li] = rest[m.link_index(m.joints[mov[-1]].child), :3] - np.asarray(leg.tip_rest)
    return out


def _leg_lengths(m: Morphology, solver: LimbSolver, plan: BodyPlan, ik_rest: np.ndarray) -> np.ndarray:
    """Chain length [NL] from each leg's mount through its moving joints to its IK point (at rest, root frame)."""
    rest = m.rest_link_poses()
    out = np.zeros(len(plan.legs))
    for li, leg in enumerate(plan.legs):
        mov = [m.joint_index(n) for n in leg.joints
               if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None]
        if solver.ankles[li] is not None:
            mov = mov[:-1]
        pts = [np.asarray(leg.mount_rest)] + [rest[m.link_index(m.joints[j].child), :3] for j in mov[1:]]
        pts.append(ik_rest[li])
        out[li] = sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(pts))
    return out


def _ee_point(model, X: np.ndarray, ee: int) -> np.ndarray:
    T = X[int(model.ee_link[ee])]
    return T[:3] + quat_rotate(T[3:], np.asarray(model.ee_offset[ee], dtype=float))


def ground_mobility(solver: LimbSolver, q: np.ndarray) -> np.ndarray:
    r"""[NL, 2] bool: whether each leg's joints can move its IK point fore-aft (x) and sideways (y) without
    changing its height, at pose ``q`` [C] (a level root facing +x: world axes are the heading frame's).

    Direction $e$ is reachable when $J \, \delta q = e$ has a solution ($J$ the leg's positional
    Jacobian): a leg whose joints all pitch has a zero sideways row and cannot step sideways.
    """
    J = eval_ee_jacobian(solver.model, q[None], ee=solver.leg_ee, dof_mask=solver.leg_mask)[0].numpy()[0]
    out = np.ones((len(solver.leg_ee), 2), dtype=bool)
    for li in range(len(solver.leg_ee)):
        Jl = J[3 * li:3 * li + 3]
        for k in range(2):
            e = np.zeros(3)
            e[k] = 1.0
            x = np.linalg.lstsq(Jl, e, rcond=1e-6)[0]
            out[li, k] = bool(np.linalg.norm(Jl @ x - e) < 0.5)
    return out


def _hinge_knees(m: Morphology, solver: LimbSolver, plan: BodyPlan, q: np.ndarray
                 ) -> tuple[tuple[int, float, float], ...]:
    """Revolute knees of upright legs at stance pose ``q`` [C]: ``(q index, rest angle, sign)``.

    A knee is a revolute joint below a leg's first one whose turning changes the mount-to-IK-point
    distance; it bends toward ``sign`` from its rest (straight) angle.
    """
    model = solver.model
    q_rest = m.rest_q()
    out = []
    for li, leg in enumerate(plan.legs):
        ee = int(solver.leg_ee[li])
        mount = np.asarray(leg.mount_rest) + q[:3]
        mov = [m.joint_index(n) for n in leg.joints
               if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None]
        if solver.ankles[li] is not None:
            mov = mov[:-1]
        for ji in mov[1:]:
            if m.joints[ji].type != JointType.REVOLUTE:
                continue
            s = m.joint_q_start[ji]
            bend = q[s] - q_rest[s]
            if abs(bend) < 1e-3:
                continue
            d = []
            for delta in (-0.01, 0.01):
                qc = q.copy()
                qc[s] += delta
                X = eval_fk(model, qc[None], device="cpu").numpy()[0]
                d.append(np.linalg.norm(_ee_point(model, X, ee) - mount))
            if abs(d[1] - d[0]) > 1e-5:
                out.append((int(s), float(q_rest[s]), float(np.sign(bend))))
    return tuple(out)


def _level_foot_knees(m: Morphology, solver: LimbSolver, plan: BodyPlan, q: np.ndarray
                      ) -> tuple[tuple[int, float, float], ...]:
    """Knees of legs whose IK holds the foot level with every ankle hinge in the solve, at stance pose ``q`` [C]:
    ``(q index, straight angle, sign)`` as :func:`_hinge_knees`'s, upright or not.

    The knee is the revolute joint that changes the mount-to-ankle distance most at stance; its straight angle is
    where that distance is largest (sampled over its range, the other joints as at stance). The warm start's
    constant-velocity step extrapolates a knee that straightens at touchdown past straight, where the six-hinge
    leg is singular and one DLS step threw the G1's shin up to its hip's limit."""
    model = solver.model
    lower, upper = model.coordinate_lower, model.coordinate_upper
    out = []
    for li in sorted(set(solver.tilt_leg.tolist())):
        leg = plan.legs[li]
        mov = [m.joint_index(n) for n in leg.joints
               if m.joint(n).type == JointType.REVOLUTE and m.joint(n).mimic is None]
        if len(mov) < 2:
            continue
        ankle = model.link_index(m.joints[mov[-1]].child)
        mount = q[:3] + quat_rotate(q[3:7], np.asarray(leg.mount_rest))

        def dist(qs: np.ndarray, ankle: int = ankle, mount: np.ndarray = mount) -> np.ndarray:
            return np.linalg.norm(eval_fk(model, qs, device="cpu").numpy()[:, ankle, :3] - mount, axis=-1)

        slopes = []
        for ji in mov[1:]:
            s = m.joint_q_start[ji]
            qs = np.repeat(q[None], 2, axis=0)
            qs[0, s] -= 1e-4
            qs[1, s] += 1e-4
            d = dist(qs)
            slopes.append(abs(float(d[1] - d[0])) / 2e-4)
        s = m.joint_q_start[mov[1 + int(np.argmax(slopes))]]
        grid = np.linspace(max(lower[s], q[s] - np.pi), min(upper[s], q[s] + np.pi), 721)
        qs = np.repeat(q[None], len(grid), axis=0)
        qs[:, s] = grid
        straight = float(grid[int(np.argmax(dist(qs)))])
        if abs(q[s] - straight) > 1e-3:
            out.append((int(s), straight, float(np.sign(q[s] - straight))))
    return tuple(out)


def keep_hinge_knees_bent(q: np.ndarray, knees: tuple[tuple[int, float, float], ...], margin: float,
                          lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Keep revolute knees of poses ``q`` [B, C] bent at least ``margin`` [rad] from straight, in place.

    ``knees`` holds ``(q index, straight angle, sign)`` (:attr:`LegRig.hinge_knees`); a nearly straight
    leg's DLS step cannot bend a knee that reached straight (the Jacobian loses the leg's length
    direction there), so the warm start never gets there. Limits ``lower``/``upper`` [C] still hold.
    """
    for s, straight, sign in knees:
        want = np.clip(straight + sign * margin, lower[s], upper[s])
        bad = sign * (q[:, s] - want) < 0
        q[bad, s] = want
    return q


@dataclass
class _Stance:
    """One candidate stance (:meth:`_StanceSearch.stance_at`): its heights and poses, the body poses it allows and
    its step region (semi-axis factors ``a``, ``b`` of the leg reach)."""

    h: float
    """Root height the step region is calibrated at [m] (an upright biped's root dips to it)."""
    h_stand: float
    """Root height at stance [m]."""
    q_nom: np.ndarray
    """Coordinates [C] at height ``h``, feet on their nominal points."""
    q_stand: np.ndarray
    """Coordinates [C] at stance."""
    err: np.ndarray
    """IK residual [NL] of the nominal posture [m]."""
    upright: bool
    lengths: np.ndarray | None
    """Upright bipeds: chain length per leg [NL] [m]."""
    mounts: np.ndarray | None
    """Upright bipeds: leg mount points in the root frame [NL, 3] [m]."""
    fixed: np.ndarray
    """[NL, 2] bool: directions (fore-aft, sideways) a leg cannot move its foot along the ground."""
    region: _StepRegion
    """The step-region test, with the body-pose bounds (``hr``, ``pitch``, ``roll``) it ended with."""
    bound_stats: dict
    bound_warnings: list[str]
    a: float
    b: float


class _StepRegion:
    """Whether step ellipses of semi-axes ``(a, b)`` times each leg's reach are feasible at one stance: IK reaches
    every foot on the ellipse at every corner of the body poses (heights ``hr`` [m], pitch and roll ±[rad]),
    neighbouring legs at opposite extremes do not collide, and random feet inside collide in at most 1 % of
    poses. Random poses come from a fixed seed (12345)."""

    def __init__(self, cal: _Calibrator, nominal_xy: np.ndarray, h: float, q_nom: np.ndarray, fixed: np.ndarray,
                 hr: tuple[float, float], pitch: float, roll: float) -> None:
        cfg, NL = cal.cfg, cal.NL
        self.cal = cal
        self.nominal_xy = nominal_xy
        self.h = h
        self.q_nom = q_nom
        self.free = (~fixed).astype(float)
        self.hr, self.pitch, self.roll = hr, pitch, roll
        self.corners = self._corners()
        rng = np.random.default_rng(12345)
        self.rand_body = np.stack([
            rng.uniform(hr[0], hr[1], cfg.calibration_random_poses),
            rng.uniform(-pitch, pitch, cfg.calibration_random_poses),
            rng.uniform(-roll, roll, cfg.calibration_random_poses),
        ], axis=1)
        self.rand_r = np.sqrt(rng.random((cfg.calibration_random_poses, NL)))
        self.rand_t = rng.uniform(0, 2 * np.pi, (cfg.calibration_random_poses, NL))
        self.angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        # neighbouring legs (each leg's two nearest by nominal foot distance): tested at opposite extremes
        dist = np.linalg.norm(nominal_xy[:, None] - nominal_xy[None], axis=-1) + np.eye(NL) * 1e9
        self.pairs = sorted({tuple(sorted((i, int(j)))) for i in range(NL)
                             for j in np.argsort(dist[i])[:min(2, NL - 1)]})
        self.pair_angles = np.array([0.0, 0.5 * np.pi, np.pi, 1.5 * np.pi])
        self.lift_test = 0.5 * cfg.swing_height * cal.reach

    def _corners(self) -> np.ndarray:
        """Body poses [9, 3] (height offset [m], pitch, roll [rad]): every extreme, and level."""
        hr, pitch, roll = self.hr, self.pitch, self.roll
        return np.array([*itertools.product(hr, (-pitch, pitch), (-roll, roll)), (0.0, 0.0, 0.0)])

    def halve_body_poses(self) -> None:
        """Halve the body poses tested (heights, pitch, roll, the random ones too)."""
        self.hr = (0.5 * self.hr[0], 0.5 * self.hr[1])
        self.pitch *= 0.5
        self.roll *= 0.5
        self.corners = self._corners()
        self.rand_body *= 0.5

    def poses(self, a: float, b: float, lift: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """Body poses [B, 3], foot offsets [B, NL, 2] and lifts [B, NL]; counts of boundary and pair poses."""
        NL, reach = self.cal.NL, self.cal.reach
        corners, angles = self.corners, self.angles
        ax = np.stack([a * reach, b * reach], axis=1) * self.free  # [NL, 2]
        # boundary poses: every corner x every angle, all legs at the same angle
        body = [np.repeat(corners, len(angles), axis=0)]
        th = np.tile(angles, len(corners))[:, None].repeat(NL, axis=1)
        off = [np.stack([np.cos(th) * ax[:, 0], np.sin(th) * ax[:, 1]], axis=-1)]
        up = [np.full((len(body[0]), NL), lift)]
        nb = len(body[0])
        # neighbouring pairs at opposite extremes, one of them lifted or not, body level or low and pitched
        npair = 0
        for i, j in self.pairs:
            for t in self.pair_angles:
                for lifted in (0.0, 1.0):
                    for bp in ((0.0, 0.0, 0.0), (self.hr[0], self.pitch, 0.0)):
                        o = np.zeros((NL, 2))
                        o[i] = (np.cos(t) * ax[i, 0], np.sin(t) * ax[i, 1])
                        o[j] = (-np.cos(t) * ax[j, 0], -np.sin(t) * ax[j, 1])
                        u = np.full(NL, lift)
                        # the swing-height test (lift > 0) lifts no foot above the height it tests: held at lift_test
                        # below it, a pair that collides there would fail every lower swing height too
                        u[i] = lift if lift > 0 else lifted * self.lift_test[i]
                        body.append(np.array([bp]))
                        off.append(o[None])
                        up.append(u[None])
                        npair += 1
        rand_r, rand_t = self.rand_r, self.rand_t
        body.append(self.rand_body)
        off.append(np.stack([rand_r * np.cos(rand_t) * ax[:, 0], rand_r * np.sin(rand_t) * ax[:, 1]], axis=-1))
        up.append(np.full((len(self.rand_body), NL), lift))
        return np.concatenate(body), np.concatenate(off), np.concatenate(up), nb, npair

    def feasible(self, a: float, b: float, lift: float = 0.0) -> bool:
        """Whether semi-axes ``(a, b)`` of the reach work, with every foot raised ``lift`` [m] (one of a pair more)."""
        cal, cfg = self.cal, self.cal.cfg
        body, off, up, nb, npair = self.poses(a, b, lift)
        B = len(body)
        feet = np.concatenate([self.nominal_xy[None] + off, up[..., None]], axis=-1)
        q = cal.root_q(np.repeat(self.q_nom[None], B, axis=0), self.h + body[:, 0], body[:, 1], body[:, 2])
        q, err = cal.solve(q, feet, cfg.calibration_iterations)
        if err.max() > cfg.reach_tolerance:
            return False
        hit = cal.collisions(q)
        return not hit[:nb + npair].any() and hit[nb + npair:].mean() <= 0.01


def _bisect(test, lo: float, hi: float, steps: int = 6) -> float:
    """The largest value in [lo, hi] that passes ``test`` (``hi`` if it does, else ``steps`` bisections)."""
    if test(hi):
        return hi
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if test(mid):
            lo = mid
        else:
            hi = mid
    return lo


class _StanceSearch:
    """The stance calibration's state (:func:`calibrate_legs`): the legs' rest geometry and effective reach, and the
    steps that find a stance at a given leg extension (:meth:`stance_at`)."""

    def __init__(self, m: Morphology, plan: BodyPlan, solver: LimbSolver, cfg: LegConfig, *,
                 height_fraction: tuple[float, float], pitch: float, roll: float, ground: GroundGuard | None) -> None:
        self.cal = cal = _Calibrator(m, plan, solver, cfg)
        self.m, self.plan, self.solver, self.cfg, self.ground = m, plan, solver, cfg, ground
        self.NL = NL = cal.NL
        self.q_rest = m.rest_q()
        self.feet_rest = np.array([leg.tip_rest for leg in plan.legs])
        """Feet at rest in the root frame [NL, 3] [m]."""
        self.nominal_xy = self.feet_rest[:, :2].copy()
        self.default_extension = cfg.stance_extension if cfg.stance_extension is not None else (
            cfg.biped_stance_extension_fallback if NL <= 2 else cfg.stance_extension_fallback)
        self.upright = is_upright_biped(plan) if cfg.upright is None else bool(cfg.upright)
        if self.upright:
            k, kh = cfg.upright_pose_scale, cfg.upright_height_scale
            height_fraction = (kh * height_fraction[0], kh * height_fraction[1])
            pitch, roll = k * pitch, k * roll
        self.height_fraction, self.pitch, self.roll = height_fraction, pitch, roll
        self.q0 = _prebend(m, solver, self.q_rest, plan)
        # IK points at rest (foot, or ankle for levelled feet) and their chains' reach
        self.ank = solver.ankle_offsets(np.zeros((1, NL)))[0]  # foot - ik point at rest (level foot)
        self.ankle_xyz = _ankle_points(m, solver, plan)
        self.h_rest = plan.body_height
        self.eff = self._effective_reach()

    def _effective_reach(self) -> np.ndarray:
        """[NL] how far each leg's IK point gets from its mount when stretched toward the rest direction [m] (joint
        limits may stop it well short of the summed segment lengths)."""
        cal, solver, plan, NL, cfg = self.cal, self.solver, self.plan, self.NL, self.cfg
        feet_rest, ank = self.feet_rest, self.ank
        q_far = cal.root_q(self.q0[None], np.zeros(1), np.zeros(1), np.zeros(1))
        far = np.zeros((1, NL, 3))
        for li, leg in enumerate(plan.legs):
            mount = np.asarray(leg.mount_rest)
            d = feet_rest[li] - ank[li] - mount
            far[0, li] = mount + d / max(np.linalg.norm(d), 1e-9) * cfg.reach_stretch * leg.reach
        q_far, _ = solver.step(q_far, far, ee=solver.leg_ee, mask=solver.leg_mask, iterations=cfg.stance_iterations,
                               max_error=cfg.reach_stretch_error * float(cal.reach.mean()))
        X = eval_fk(cal.model, q_far, device="cpu").numpy()[0]
        eff = np.array([np.linalg.norm(_ee_point(cal.model, X, int(solver.leg_ee[li])) - np.asarray(leg.mount_rest))
                        for li, leg in enumerate(plan.legs)])
        # a six-hinge leg (its IK holds the foot level) reaches at least as far as its own rest pose: the stretch
        # of its redundant chain stalls short of a nearly straight rest pose (OP3's keyframe: 1.08 of the stretch)
        rest_dist = np.array([np.linalg.norm(feet_rest[li] - ank[li] - np.asarray(leg.mount_rest))
                              for li, leg in enumerate(plan.legs)])
        posed = np.isin(np.arange(NL), solver.tilt_leg)
        return np.where(posed, np.maximum(eff, rest_dist), eff)

    def rest_extension(self) -> float:
        """The rest pose's largest mount-to-IK-point distance as a fraction of the effective reach."""
        return float(max(np.linalg.norm(self.feet_rest[li] - self.ank[li] - np.asarray(leg.mount_rest)) / self.eff[li]
                         for li, leg in enumerate(self.plan.legs)))

    def height_at(self, e: float) -> float:
        """Root height at which no leg is stretched beyond ``e`` of its effective reach (at most the rest's)."""
        hh = self.h_rest
        for li, leg in enumerate(self.plan.legs):
            mount = np.asarray(leg.mount_rest)
            target = self.feet_rest[li] - self.ank[li]  # ik point relative to the root at rest
            dxy = np.hypot(*(target[:2] - mount[:2]))
            lim = e * self.eff[li]
            if dxy < lim:
                # at stance height hh the ik point is at z = -hh - ank_z (root frame): mount_z + hh + ank_z = vertical
                hh = min(hh, np.sqrt(lim**2 - dxy**2) - mount[2] - self.ank[li, 2])
        return max(hh, self.cfg.stance_height_min * self.h_rest)

    def nominal(self, hh: float) -> tuple[np.ndarray, np.ndarray]:
        """IK posture [C] with the root level at height ``hh`` [m] and the feet on their nominal points, and the
        residual [NL] [m]."""
        q = self.q0.copy()[None]
        q = self.cal.root_q(q, np.array([hh]), np.zeros(1), np.zeros(1))
        feet = np.concatenate([self.nominal_xy, np.zeros((self.NL, 1))], axis=1)[None]
        qs, err = self.cal.solve(q, feet, self.cfg.stance_iterations)
        return qs[0], err[0]

    def settle(self, hh: float) -> tuple[float, np.ndarray, np.ndarray]:
        """``hh`` raised toward the rest height until IK puts every foot at its nominal point."""
        cfg = self.cfg
        q_n, e_n = self.nominal(hh)
        tries = 0
        while e_n.max() > cfg.stance_residual and tries < cfg.settle_tries:
            tries += 1
            hh = hh + cfg.settle_step * (self.h_rest - hh)
            q_n, e_n = self.nominal(hh)
        return hh, q_n, e_n

    def stand_tall(self, h: float) -> tuple[float, np.ndarray, np.ndarray, np.ndarray] | None:
        """Upright bipeds: the tall standing height [m] and pose [C] (legs at ``upright_extension`` of their chain
        lengths), the chain lengths [NL] and mounts [NL, 3]; None where that is no taller than ``h`` or IK fails."""
        cfg, plan = self.cfg, self.plan
        # stand tall: the step region is still calibrated at the lower height h (the root dips to
        # where every stance foot is reachable, see upright_root_height), the stance is upright
        # legs that hold their foot level stretch to the ankle, not to the sole point beside and below it
        ik_rest = self.feet_rest - self.ank + self.ankle_xyz
        lengths = _leg_lengths(self.m, self.solver, plan, ik_rest)
        mounts = np.array([leg.mount_rest for leg in plan.legs])
        hh = self.h_rest
        for li in range(self.NL):
            dxy = np.hypot(*(ik_rest[li, :2] - mounts[li, :2]))
            lim = cfg.upright_extension * lengths[li]
            if dxy < lim:
                hh = min(hh, float(np.sqrt(lim**2 - dxy**2) - mounts[li, 2] - self.ank[li, 2] + self.ankle_xyz[li, 2]))
        if hh > h:
            q_up, err_up = self.nominal(hh)
            if err_up.max() <= cfg.stance_residual:
                return hh, q_up, lengths, mounts
        return None

    def stance_at(self, ext: float) -> _Stance:
        """Stance, body-pose bounds and step region with the legs at ``ext`` of their reach."""
        upright, cfg = self.upright, self.cfg
        pitch, roll = self.pitch, self.roll
        h, q_nom, err = self.settle(self.height_at(ext))
        if err.max() > cfg.stance_residual:  # keep the rest pose: feet on the ground by construction
            h = self.h_rest
            q_nom = self.cal.root_q(self.q_rest[None], np.array([h]), np.zeros(1), np.zeros(1))[0]
        h_stand, q_stand = h, q_nom
        lengths = mounts = None
        if upright:
            tall = self.stand_tall(h)
            if tall is None:
                upright = False
            else:
                h_stand, q_stand, lengths, mounts = tall

        # legs whose joints cannot move the foot along the ground in some direction (all pitch: no
        # sideways step) calibrate and step only in the directions they can; the body keeps level
        # across the direction they cannot (roll needs sideways reach, pitch fore-aft reach)
        fixed = ~ground_mobility(self.solver, q_nom)
        if fixed[:, 0].any():
            pitch = 0.0
        if fixed[:, 1].any():
            roll = 0.0

        hr = (self.height_fraction[0] * h_stand, self.height_fraction[1] * h_stand)
        bound_warnings: list[str] = []
        bound_stats: dict = {}
        if self.ground is not None:
            low, hr, pitch, roll, bound_stats, bound_warnings = _bound_body(self.cal, self.ground, q_stand, h, h_stand,
                                                                           hr, pitch, roll)
            if low > h + 1e-6:  # an upright biped's root dips to h: calibrate its steps where the links stay up
                q_up, err_up = self.nominal(low)
                if err_up.max() <= cfg.stance_residual:
                    h, q_nom = low, q_up
                    if not upright:
                        h_stand, q_stand = h, q_nom
        region = _StepRegion(self.cal, self.nominal_xy, h, q_nom, fixed, hr, pitch, roll)
        small, large, steps = cfg.step_region_min, cfg.step_region_max, cfg.step_region_bisections
        if not region.feasible(small, small):
            # the commanded body poses are out of reach: shrink them until the stance works
            for _ in range(cfg.body_pose_halvings):
                region.halve_body_poses()
                if region.feasible(small, small):
                    break
        a = _bisect(lambda x: region.feasible(x, small), small, large, steps)
        b = _bisect(lambda y: region.feasible(a, y), small, large, steps)
        a *= cfg.step_region_margin
        b *= cfg.step_region_margin
        return _Stance(h=h, h_stand=h_stand, q_nom=q_nom, q_stand=q_stand, err=err, upright=upright, lengths=lengths,
                       mounts=mounts, fixed=fixed, region=region, bound_stats=bound_stats,
                       bound_warnings=bound_warnings, a=a, b=b)

    def described_stance(self, rest_ext: float) -> tuple[_Stance, float, str | None, str | None]:
        """The described stance: legs as extended as at rest, or as near it as leaves them room to step.

        Returns the stance, its extension, and a note and a warning (or None) on standing lower than described.
        """
        cfg, ext = self.cfg, self.default_extension
        stance_note = stance_warning = None
        st = None
        if cfg.stance_extension is None and not self.upright and rest_ext > ext + cfg.rest_extension_tolerance:
            tried = [e for e in (min(rest_ext, cfg.stance_extension_max), *cfg.stance_extension_steps)
                     if ext < e <= rest_ext]
            chosen = ext
            for e in tried:
                cand = self.stance_at(e)
                if cand.err.max() <= cfg.stance_residual and all(cand.fixed[:, k].all() or ab >= cfg.stance_step_test[k]
                                                  for k, ab in enumerate((cand.a, cand.b))):
                    st, chosen = cand, e
                    break
            reasons = []
            if rest_ext > cfg.stance_extension_max:
                reasons.append(f"straighter than {cfg.stance_extension_max:g} the legs are singular")
            failed = [x for x in tried if x > chosen]
            if failed:
                reasons.append(f"at {min(failed):.2f} and above they step less than "
                               f"{100 * cfg.stance_step_test[0]:g} % of their reach fore-aft")
            if chosen < rest_ext - cfg.stance_note_tolerance:
                stance_note = (f"legs stand at {chosen:.2f} of their reach, the rest pose's at {rest_ext:.2f}: "
                               + "; ".join(reasons))
            if st is None:
                stance_warning = (f"legs: stand lower than described ({stance_note}): bend the legs in the rest "
                                  "pose, or widen their joints' limits")
            ext = chosen
        if st is None:
            st = self.stance_at(ext)
        return st, ext, stance_note, stance_warning


def _leg_warnings(plan: BodyPlan, cfg: LegConfig, fixed: np.ndarray, a: float, b: float, reach: np.ndarray,
                  swing_height: float) -> list[str]:
    """One line per leg that cannot step along the ground (``fixed`` [NL, 2]), for short step regions (semi-axis
    factors ``a``, ``b`` of the ``reach`` [NL] [m]) and for a low swing height [m]."""
    warnings = []
    for li, leg in enumerate(plan.legs):
        if fixed[li].all():
            warnings.append(f"leg {leg.end_effector}: its joints cannot move the foot along the ground at all: "
                            "the creature stands in place")
        elif fixed[li].any():
            cannot, can = ("fore-aft", "sideways") if fixed[li, 0] else ("sideways", "fore-aft")
            warnings.append(f"leg {leg.end_effector}: its joints cannot move the foot {cannot} on the ground (they all "
                            f"turn in one plane): it steps only {can}, turns at most {cfg.fixed_axis_yaw_rate:g} rad/s")
    longest = np.where(fixed, 0.0, [a, b]).max(axis=1)  # the longest step each leg can take, / reach
    small = ~fixed.all(axis=1) & (longest < 0.1)
    if small.any():
        names = ", ".join(plan.legs[li].end_effector for li in np.flatnonzero(small))
        warnings.append(f"legs {names}: step at most {100 * float((longest * reach)[small].min()):.2g} cm from their "
                        "stance point: IK reaches no further at the commanded body poses, or the legs would collide")
    if swing_height < 0.5 * cfg.swing_height * float(reach.mean()):
        warnings.append(f"legs: lift their feet at most {100 * swing_height:.2g} cm: a higher foot is out of reach")
    return warnings


def calibrate_legs(m: Morphology, plan: BodyPlan, solver: LimbSolver, cfg: LegConfig, *, fps: float,
                   height_fraction: tuple[float, float], pitch: float, roll: float,
                   ground: GroundGuard | None = None) -> LegRig:
    """Stance height, nominal posture, step ellipses and swing height of a legged creature.

    Args:
        m: The creature (legs from ``plan``).
        plan: Its body plan (at least one leg).
        solver: The creature's limb IK.
        cfg: Leg parameters.
        fps: Frame rate the rig will step at.
        height_fraction: Body height offsets commands will ask for, as fractions of the stance height.
        pitch: Body pitch commands will ask for ±[rad].
        roll: Body roll commands will ask for ±[rad].
        ground: The upper body's ground guard: the body's dip, pitch and roll are bounded so that its joints
            can keep every upper-body link above the ground (:func:`_bound_body`).
    """
    search = _StanceSearch(m, plan, solver, cfg, height_fraction=height_fraction, pitch=pitch, roll=roll,
                           ground=ground)
    nominal_xy, eff = search.nominal_xy, search.eff
    rest_ext = search.rest_extension()
    st, ext, stance_note, stance_warning = search.described_stance(rest_ext)
    h, h_stand, q_stand, err, upright = st.h, st.h_stand, st.q_stand, st.err, st.upright
    lengths, mounts, fixed, a, b = st.lengths, st.mounts, st.fixed, st.a, st.b
    hr, pitch, roll = st.region.hr, st.region.pitch, st.region.roll
    reach = search.cal.reach
    H = cfg.swing_height * float(reach.mean())
    for _ in range(8):
        if st.region.feasible(0.3 * a, 0.3 * b, lift=H):
            break
        H *= 0.75
    t_swing_min = max(cfg.min_swing_seconds, cfg.min_swing_frames / fps)
    semi_axes = np.stack([a * reach, b * reach], axis=1)
    semi_axes = np.where(fixed, cfg.fixed_axis_semi_axis * reach[:, None], semi_axes)
    stats = {"ellipse_factors": (float(a), float(b)), "nominal_residual_m": float(err.max()),
             "effective_reach_m": eff.round(4).tolist(), "stance_extension": round(float(ext), 4),
             "rest_extension": round(rest_ext, 4), **st.bound_stats}
    if stance_note:
        stats["stance_note"] = stance_note
    warnings = list(st.bound_warnings) + ([stance_warning] if stance_warning else [])
    warnings += _leg_warnings(plan, cfg, fixed, a, b, reach, H)
    if fixed.any():
        stats["fixed_axes"] = fixed.tolist()
    if upright:
        assert lengths is not None
        stats.update(calibration_height_m=round(float(h), 4), leg_length_m=lengths.round(4).tolist())
    return LegRig(
        nominal_xy=nominal_xy,
        stance_height=float(h_stand),
        semi_axes=semi_axes,
        swing_height=float(H),
        q_nominal=q_stand,
        cadence_hz=float(cfg.cadence * np.sqrt(GRAVITY / max(h_stand, 1e-3)) / (2 * np.pi)),
        bands=gait_bands(nominal_xy, 2.0 / (fps * t_swing_min)),
        height_range=(float(hr[0]), float(hr[1])),
        pitch=float(pitch),
        roll=float(roll),
        extension=float(ext),
        t_swing_min=float(t_swing_min),
        dt=1.0 / fps,
        stats=stats,
        upright=upright,
        mount_xyz=mounts if upright else None,
        leg_length=lengths if upright else None,
        max_extension=float(cfg.upright_max_extension) if upright else 1.0,
        ankle_xyz=search.ankle_xyz if upright else None,
        fixed_axes=fixed if fixed.any() else None,
        hinge_knees=(_hinge_knees(m, solver, plan, q_stand) if upright else ()) + _level_foot_knees(m, solver, plan,
                                                                                                   q_stand),
        warnings=tuple(warnings),
    )


def _bound_body(cal: _Calibrator, ground: GroundGuard, q: np.ndarray, h: float, h_stand: float,
                hr: tuple[float, float], pitch: float, roll: float
                ) -> tuple[float, tuple[float, float], float, float, dict, list[str]]:
    """The body's lowest root height, height offsets, pitch and roll bounded so that the upper body's joints can
    keep every link above the ground (:meth:`GroundGuard.root_floor` at the tilt corners).

    The root goes as low as ``h + hr[0]`` (an upright biped's, whose offsets are 0, dips to ``h`` over long
    steps). Pitch and roll are scaled down (bisection) until the links' floor at full tilt is at most the
    stance height ``h_stand``; then the dip is cut to that floor — for an upright biped by calibrating its
    steps at the floor instead of ``h``. Where even the level stance puts a link below the ground, one
    warning names it and the body is kept level without dipping.

    Returns:
        The lowest calibration height, ``hr``, ``pitch``, ``roll``, figures for the rig's stats (only when
        something was bounded) and the warnings.
    """
    margin = ground.margin

    def floor(s: float) -> tuple[float, str]:
        tilt = np.array([(0.0, 0.0), *itertools.product((-s * pitch, s * pitch), (-s * roll, s * roll))])
        qs = cal.root_q(np.repeat(q[None], len(tilt), axis=0), np.zeros(len(tilt)), tilt[:, 0], tilt[:, 1])
        z, names = ground.root_floor(qs)
        k = int(np.argmax(z))
        return float(z[k]) + margin, names[k]

    need, link = floor(1.0)
    if need <= h + hr[0]:
        return h, hr, pitch, roll, {}, []
    level, level_link = floor(0.0)
    if level > h_stand:
        warning = (f"link {level_link}: its joints cannot keep it above the ground even with the body level at its "
                   f"stance height ({100 * (level - h_stand):.2g} cm short): widen their limits or raise the link "
                   "in the description")
        return h_stand, (0.0, max(hr[1], 0.0)), 0.0, 0.0, {"ground_bound": {"link": level_link}}, [warning]
    s = 1.0
    if need > h_stand:
        lo, hi = 0.0, 1.0
        for _ in range(8):
            mid = 0.5 * (lo + hi)
            if floor(mid)[0] <= h_stand:
                lo = mid
            else:
                hi = mid
        s = lo
        need, link = floor(s)
    low = max(h + hr[0], need)
    hr = (low - h, max(hr[1], low - h)) if low <= h else (0.0, max(hr[1], 0.0))
    stats = {"ground_bound": {"link": link, "tilt_scale": round(s, 3), "lowest_root_m": round(low, 4)}}
    return max(h, low), hr, s * pitch, s * roll, stats, []


def keep_knees_bent(q: np.ndarray, knees: list[tuple[int, int, float]], margin: float) -> np.ndarray:
    """Turn hinge-only ball knees of poses ``q`` [B, C] to at least ``margin`` [rad] of bend, in place.

    ``knees`` holds ``(q start, hinge axis, sign)`` per knee: its quaternion is a rotation by $\\theta$
    about local axis ``hinge axis`` and it bends the right way while ``sign`` $\\theta$ >= ``margin``.
    """
    for s, ax, sign in knees:
        th = wrap_angle(2.0 * np.arctan2(q[:, s + ax], q[:, s + 3]))
        bad = sign * th < margin
        if bad.any():
            half = 0.5 * sign * margin
            q[bad, s:s + 4] = 0.0
            q[bad, s + ax] = np.sin(half)
            q[bad, s + 3] = np.cos(half)
    return q


def upright_root_height(rig: LegRig, ik_points: np.ndarray, root_xy: np.ndarray, rot: np.ndarray,
                        z_command: np.ndarray, fps: float, smoothing_seconds: float) -> np.ndarray:
    r"""Root heights [R, T] of an upright biped: the commanded height where the legs allow it, lower
    where a foot far ahead or behind needs the hip to come down.

    For leg $l$ with mount $m_l$ (root frame), IK point $a_l$ (world) and chain length $L_l$, the root
    height $z$ keeps $\lVert a_l - (p_{xy}, z) - R m_l \rVert \le e L_l$ ($e$ = ``max_extension``):
    $z \le b_l = a_{l,z} - (R m_l)_z + \sqrt{(e L_l)^2 - d_l^2}$ with $d_l$ the horizontal distance.
    The bound is taken over every leg, swinging ones included (a raised foot relaxes it, and a foot
    about to touch down bounds the root where its stance will). A minimum filter of half-width $w$
    then a moving average of the same width keep the result below the bound at every frame (each
    averaged value is a minimum over a window that contains the frame) while rounding its kinks
    (where the limiting leg changes, and where a swinging foot drops to the ground).

    Args:
        rig: An upright rig (``rig.upright``).
        ik_points: World targets of the legs' IK points [R, T, NL, 3].
        root_xy: Root positions [R, T, 2].
        rot: Root orientations [R, T, 4] (xyzw).
        z_command: Commanded root heights [R, T] [m].
        fps: Frame rate [1/s].
        smoothing_seconds: Half-width $w$ [s] (rounded to frames).
    """
    assert rig.mount_xyz is not None and rig.leg_length is not None
    R, T, NL, _ = ik_points.shape
    if rig.ankle_xyz is not None and np.any(rig.ankle_xyz):
        # the ankle of a level sole: its offset turned with the body's heading (a planted foot's own heading
        # differs by what the body turned since touchdown, a few millimetres at a sole's size)
        heading = quat_from_yaw(yaw_from_quat(rot))
        ik_points = ik_points + quat_rotate(heading[:, :, None, :], np.broadcast_to(rig.ankle_xyz, (R, T, NL, 3)))
    mount = quat_rotate(rot[:, :, None, :], np.broadcast_to(rig.mount_xyz, (R, T, NL, 3)))  # [R, T, NL, 3]
    d = np.linalg.norm(ik_points[..., :2] - root_xy[:, :, None, :] - mount[..., :2], axis=-1)
    lim = rig.max_extension * rig.leg_length
    bound = ik_points[..., 2] - mount[..., 2] + np.sqrt(np.maximum(lim**2 - d**2, 0.0))  # [R, T, NL]
    z = np.minimum(z_command, bound.min(axis=-1))
    w = round(smoothing_seconds * fps)
    if w < 1 or T < 2:
        return z
    pad = np.pad(z, ((0, 0), (w, w)), mode="edge")
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * w + 1, axis=1)  # [R, T, 2w + 1]
    low = np.pad(win.min(axis=-1), ((0, 0), (w, w)), mode="edge")
    c = np.cumsum(np.pad(low, ((0, 0), (1, 0))), axis=1)
    return (c[:, 2 * w + 1:] - c[:, :-(2 * w + 1)]) / (2 * w + 1)


# ---------------------------------------------------------------------------------------------
# stepping
# ---------------------------------------------------------------------------------------------
class LeggedController:
    """Footstep planning and swing arcs for R rollouts at once (see the module docstring).

    Args:
        rig: The creature's calibration.
        cfg: Leg parameters.
        fps: Frames per second.
        xy0: Initial root positions [R, 2].
        yaw0: Initial root yaw [R].
        min_support: Feet that stay on the ground whatever the gait says: a lift that would leave fewer
            in stance waits (the feet deepest inside their ellipses wait first) until another foot
            touches down. 0 (the synthesis) lets the gait's own flights happen.
    """

    def __init__(self, rig: LegRig, cfg: LegConfig, fps: float, xy0: np.ndarray, yaw0: np.ndarray,
                 *, min_support: int = 0) -> None:
        self.rig = rig
        self.cfg = cfg
        self.min_support = int(min_support)
        self.fps = fps
        self.dt = 1.0 / fps
        R, NL = len(xy0), rig.leg_count
        self.t_swing_min = rig.t_swing_min
        self.n_swing_min = max(3, int(np.ceil(self.t_swing_min * fps - 1e-9)))
        self.span_min = rig.stance_span(rig.duty_min)
        self.clock = GaitClock(rig.bands, R)
        c, s = np.cos(yaw0), np.sin(yaw0)
        self.foot_xy = xy0[:, None, :] + rotate2(c[:, None], s[:, None], rig.nominal_xy[None])
        self.foot_z = np.zeros((R, NL))
        self.foot_yaw = np.repeat(yaw0[:, None], NL, axis=1).astype(float)
        self.stance = np.ones((R, NL), dtype=bool)
        self.armed = np.zeros((R, NL), dtype=bool)
        self.k = np.zeros((R, NL), dtype=np.int64)
        self.nsw = np.full((R, NL), self.n_swing_min, dtype=np.int64)
        self.lift_xy = self.foot_xy.copy()
        self.lift_yaw = self.foot_yaw.copy()
        self.td_xy = self.foot_xy.copy()
        self.td_yaw = self.foot_yaw.copy()
        self.emergencies = 0

    def step(self, t: int, path_xy: np.ndarray, path_yaw: np.ndarray, v: np.ndarray, w: np.ndarray,
             choice: np.ndarray, *, lift: np.ndarray | None = None, swing_frames: np.ndarray | None = None,
             hold: np.ndarray | None = None) -> None:
        """Advance one frame.

        Args:
            t: Frame index into the paths.
            path_xy: Root path of the batch [R, T', 2] (with look-ahead beyond the last frame).
            path_yaw: Root yaw path [R, T'].
            v: Commanded heading-frame velocity at frame ``t`` [R, 2].
            w: Commanded yaw rate at frame ``t`` [R].
            choice: Segment random number [R] (gait alternatives).
            lift: [R, NL] bool: stance feet to lift now whatever the gait's phase (``min_support`` still
                applies); None: none.
            swing_frames: [R, NL] frames from such a lift to its touchdown (at least the shortest swing);
                needed with ``lift``.
            hold: [R, NL] bool: legs whose lifts the gait's phase does not decide this frame (they lift
                by ``lift`` or at their ellipse's edge only); None: none.
        """
        rig, cfg = self.rig, self.cfg
        p = rig.nominal_xy
        ax = rig.semi_axes
        rate_l = rig.stroke_rate(v, w)  # [R, NL] strokes per second
        rate = rate_l.max(axis=1)
        s = rate * self.span_min / cfg.max_stroke_usage
        moving = rate > 1e-3 * rig.cadence_hz
        tsw = self.t_swing_min
        dt = self.dt
        # normalised distance the body moves in one frame, per leg: the airborne frames' overshoot
        frame_step = 2.0 * rate_l * dt

        def frequency(duty: np.ndarray) -> np.ndarray:
            # stance + two frames may use stroke_usage of the ellipse: rate (duty / f + 2 dt) <= usage
            room = cfg.stroke_usage / np.maximum(rate, 1e-12) - 2.0 * dt
            fmax = (1.0 - duty) / tsw
            need = np.where(room > 0, duty / np.maximum(room, 1e-12), fmax)
            return np.minimum(np.maximum(rig.cadence_hz, need), fmax)

        psi = self.clock.advance(s, choice, frequency, self.dt)
        duty = self.clock.duty
        f = self.clock.frequency
        root_xy = path_xy[:, t]
        yaw = path_yaw[:, t]
        c, sn = np.cos(yaw)[:, None], np.sin(yaw)[:, None]

        # where each stance foot is within its ellipse
        rel = rotate2(c, -sn, self.foot_xy - root_xy[:, None, :]) - p[None]
        rho = np.sqrt((rel[..., 0] / ax[:, 0]) ** 2 + (rel[..., 1] / ax[:, 1]) ** 2)
        in_stance_phase = psi < duty[:, None]
        self.armed |= self.stance & in_stance_phase
        emergency = self.stance & (rho > cfg.emergency_limit - frame_step)
        by_phase = self.armed & ~in_stance_phase & (moving[:, None] | (rho > 0.12))
        if hold is not None:
            by_phase &= ~hold
        asked = lift
        lift = self.stance & (by_phase | emergency)
        if asked is not None:
            lift |= self.stance & asked
        if self.min_support > 0:
            lift = self._keep_support(lift, rho)
        self.emergencies += int((emergency & lift).sum())
        if lift.any():
            rows = np.nonzero(lift)[0]
            n = np.maximum(self.n_swing_min, np.round((1.0 - duty) / f * self.fps)).astype(np.int64)
            self.nsw[lift] = n[rows]
            if asked is not None and swing_frames is not None:
                mine = lift & asked
                self.nsw[mine] = np.maximum(self.n_swing_min, swing_frames[mine])
            self.k[lift] = 0
            self.stance[lift] = False
            self.armed[lift] = False
            self.lift_xy[lift] = self.foot_xy[lift]
            self.lift_yaw[lift] = self.foot_yaw[lift]
        swing = ~self.stance
        if not swing.any():
            return
        self.k[swing] += 1
        Tn = path_xy.shape[1]
        plan = swing & (self.k <= self.nsw - 2)
        if plan.any():
            rows, legs = np.nonzero(plan)
            n_td = self.nsw[rows, legs] - self.k[rows, legs]
            half = np.round(0.5 * duty[rows] / f[rows] * self.fps).astype(np.int64)
            i_td = np.minimum(t + n_td, Tn - 1)
            i_mid = np.minimum(t + n_td + half, Tn - 1)
            pl = p[legs]
            ym = path_yaw[rows, i_mid]
            tgt = path_xy[rows, i_mid] + rotate2(np.cos(ym), np.sin(ym), pl)
            yt = path_yaw[rows, i_td]
            ct, st = np.cos(yt), np.sin(yt)
            body = path_xy[rows, i_td]
            rel_td = rotate2(ct, -st, tgt - body) - pl
            a_l = ax[legs]
            r_td = np.sqrt((rel_td[:, 0] / a_l[:, 0]) ** 2 + (rel_td[:, 1] / a_l[:, 1]) ** 2)
            lim = np.maximum(cfg.touchdown_limit - frame_step[rows, legs], 0.3)
            k = np.where(r_td > lim, lim / np.maximum(r_td, 1e-12), 1.0)
            self.td_xy[rows, legs] = body + rotate2(ct, st, pl + rel_td * k[:, None])
            self.td_yaw[rows, legs] = ym
        rows, legs = np.nonzero(swing)
        k = self.k[rows, legs]
        n = self.nsw[rows, legs]
        hor = smoothstep((k - 1) / np.maximum(n - 2, 1))
        frac = np.clip(k / n, 0.0, 1.0)
        H = rig.swing_height
        z = np.maximum(4.0 * H * frac * (1.0 - frac), min(H, cfg.lift_clearance))  # parabola, lifted clear
        done = k >= n
        lx = self.lift_xy[rows, legs]
        self.foot_xy[rows, legs] = lx + (self.td_xy[rows, legs] - lx) * hor[:, None]
        self.foot_z[rows, legs] = np.where(done, 0.0, z)
        ly = self.lift_yaw[rows, legs]
        self.foot_yaw[rows, legs] = ly + wrap_angle(self.td_yaw[rows, legs] - ly) * hor
        if done.any():
            dr, dl = rows[done], legs[done]
            self.foot_xy[dr, dl] = self.td_xy[dr, dl]
            self.foot_yaw[dr, dl] = self.td_yaw[dr, dl]
            self.stance[dr, dl] = True

    def _keep_support(self, lift: np.ndarray, rho: np.ndarray) -> np.ndarray:
        """``lift`` [R, NL] less the lifting feet that must stay down for ``min_support`` stance feet."""
        short = self.min_support - (self.stance & ~lift).sum(axis=1)  # [R] feet still to keep down
        if not (short > 0).any():
            return lift
        lift = lift.copy()
        for r in np.nonzero(short > 0)[0]:
            candidates = np.nonzero(lift[r])[0]
            keep = candidates[np.argsort(rho[r, candidates], kind="stable")][: short[r]]
            lift[r, keep] = False
        return lift

    def feet(self) -> np.ndarray:
        """Foot targets in world [R, NL, 3]."""
        return np.concatenate([self.foot_xy, self.foot_z[..., None]], axis=-1)
