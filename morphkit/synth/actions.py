"""Upper-body actions and arm swing for arms that end in hands: reach, wave, point, push.

**Key poses** (:func:`calibrate_actions`, once per creature). Each arm ending in a ``hand``
end-effector is read as shoulder, upper arm, elbow and forearm: the *shoulder* is the moving joint
that starts the arm's longest segment (joints before it, a clavicle, stay as they are), the
*elbow* the next moving joint, and the forearm runs from the elbow to the hand (joints after the
elbow, a wrist, stay as they are). A key pose names a direction for the upper arm and one for the
forearm in the root frame — forward $F$, outward $O$ (the arm's side) and up $U$ — and DLS IK
(:func:`~morphkit.kernels.ik.ik_step`, shoulder to elbow DoFs only) puts the elbow and the hand
there, approached in stages from the previous pose so that the elbow keeps bending the way it
should. An arm whose elbow limits keep it bent (a humanoid robot's) takes each pose as near as they
allow: the hand drawn in along its shoulder ray to the arm's longest extent, the elbow where the two
segments then meet. Poses the arm cannot reach (residual over ``reach_tolerance`` of its reach), or that hit
the body, the other arm or the ground — checked at the pose and along the joint-space blends
actions use — are dropped, and an action is offered only if all its poses were kept:

=============  ===============================================================================
action         poses
=============  ===============================================================================
``reach``      neutral → hand ahead at hip, chest or shoulder height (one arm) → hold → neutral
``wave``       neutral → hand above the head, forearm up → forearm rocking sideways → neutral
``point``      neutral → arm straight, forward or out to the side (one arm) → hold → neutral
``push``       neutral → hands before the chest → both arms straight ahead → hold → chest → neutral
=============  ===============================================================================

The *neutral* pose is the arms hanging at the sides for an upright biped
(:func:`~morphkit.synth.legged.is_upright_biped`), else the arm's stance pose.

**Arm swing** (upright bipeds): walking, each arm swings opposite to the leg on its side — toward
a forward pose while the other leg's foot is ahead, toward a backward pose while its own is. The
swing signal $s = g \\min(1, |v| / v_1)\\,\\mathrm{clip}((x_c - x_i) / 2 u a, -1, 1)$ comes from
the planned feet ($x_i$, $x_c$: fore-aft offsets of the same-side and other-side foot from their
nominal points in the heading frame; $a$ the step ellipse's fore-aft semi-axis and $u$ the stroke
usage, so that a full stride gives $\\pm 1$), scaled by the commanded speed $|v|$ up to
$v_1$ = ``swing_full_speed`` ($g$ = ``swing_gain``) and smoothed: the swing is as wide as the walk
is fast, and a creature standing still hangs its arms.

**Timing** (:func:`draw_actions`, per rollout, drawn up front from its generator): actions of a
random kind, arm and duration follow each other with random gaps; poses blend along smoothsteps
(quaternions by nlerp), the swing fades out while an action starts and back in while it ends,
and the rollout's commanded speed and yaw rate are capped around each action
(:func:`limit_speed`) so that actions happen while standing or walking slowly.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from morphkit.graph import EndEffector, EndEffectorRole, JointType, Morphology
from morphkit.kernels import eval_fk
from morphkit.kernels.contact import eval_self_collision_distance, self_collision_pairs
from morphkit.kernels.ik import ik_step
from morphkit.model import compile_model
from morphkit.rotations import quat_conjugate, quat_rotate
from morphkit.synth._util import nlerp, rotate2, smoothstep
from morphkit.synth.analysis import BodyPlan
from morphkit.synth.legged import limb_links

__all__ = [
    "ACTION_NAMES",
    "ActionConfig",
    "ActionRig",
    "ActionSpan",
    "ActionTrack",
    "arm_swing",
    "calibrate_actions",
    "draw_actions",
    "limit_speed",
    "neutral_stance",
]

ACTION_NAMES = ("none", "reach", "wave", "point", "push")
"""Per-frame action codes (index into this tuple): ``none`` is walking, turning or standing with
the arms swinging or hanging."""

_PROXY_PREFIX = "__synth_elbow_"

# key poses: (upper arm direction, forearm direction) as (forward, outward, up) components
_KEY_POSES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "hang": ((0.0, 0.26, -1.0), (0.3, 0.12, -1.0)),
    "swing_fwd": ((0.38, 0.24, -1.0), (0.8, 0.06, -1.0)),
    "swing_back": ((-0.36, 0.26, -1.0), (-0.15, 0.14, -1.0)),
    "reach_low": ((0.75, 0.15, -1.0), (1.0, -0.05, -0.35)),
    "reach_mid": ((1.0, 0.15, -0.6), (1.0, -0.05, -0.05)),
    "reach_high": ((1.0, 0.12, -0.1), (1.0, -0.05, 0.2)),
    "point_fwd": ((1.0, 0.12, 0.12), (1.0, 0.12, 0.18)),
    "point_side": ((0.45, 1.0, 0.12), (0.5, 1.0, 0.18)),
    "wave_a": ((0.2, 1.0, 0.45), (0.15, 0.55, 1.0)),
    "wave_b": ((0.2, 1.0, 0.45), (0.15, -0.25, 1.0)),
    "push_chest": ((-0.1, 0.35, -1.0), (1.0, -0.3, 0.5)),
    "push_out": ((1.0, -0.14, -0.05), (1.0, -0.14, -0.05)),
}
_NEUTRAL = "neutral"
_WAVE_MID = "wave_mid"
POSE_NAMES = (_NEUTRAL, *(k for k in _KEY_POSES if k != "hang"), _WAVE_MID)
"""Key poses of :class:`ActionRig` (``neutral`` first: hanging arms for an upright biped)."""

_KIND_POSES = {
    "reach": ("reach_low", "reach_mid", "reach_high"),
    "wave": ("wave_a", "wave_b", _WAVE_MID),
    "point": ("point_fwd", "point_side"),
    "push": ("push_chest", "push_out"),
}
_SWING_POSES = ("swing_fwd", "swing_back")


@dataclass(frozen=True)
class ActionConfig:
    """Actions and arm swing (see the module docstring)."""

    enabled: bool | None = None
    """Upper-body actions for arms ending in hands: None for upright bipeds only, True for any
    creature with hand arms (actions its arms cannot do are left out), False for none."""
    kinds: tuple[str, ...] = ("reach", "wave", "point", "push")
    """Actions drawn (from ``reach``, ``wave``, ``point``, ``push``)."""
    weights: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    """Relative probability of each of ``kinds``."""
    first_seconds: tuple[float, float] = (0.5, 4.0)
    """Time before a rollout's first action [s]."""
    gap_seconds: tuple[float, float] = (2.0, 7.0)
    """Time between actions [s]."""
    swing_gain: float = 1.0
    """Arm swing $g$ (upright bipeds; 0: none)."""
    swing_full_speed: float = 1.2
    """Speed $v_1$ [m/s] at the reference size (scaled like the command ranges) from which the arms
    swing fully."""
    swing_smoothing_seconds: float = 0.08
    """Half-width of the moving average that rounds the swing signal [s]."""
    max_speed: float = 0.4
    """Commanded speed limit during an action [m/s] at the reference size (scaled like the command
    ranges)."""
    max_yaw_rate: float = 0.5
    """Commanded yaw rate limit during an action [rad/s]."""
    speed_ramp_seconds: float = 0.8
    """The speed limit fades in over this time before an action and out after it [s]."""
    reach_tolerance: float = 0.03
    """A key pose counts as reached when elbow and hand are within this fraction of the arm's reach."""
    collision_margin: float = 0.01
    """Clearance [m] key poses keep between shapes (pairs closer at rest keep half their rest distance)."""
    collision_rest_margin: float = 0.005
    """Shape pairs closer than this at rest [m] touch by design and are not checked."""


@dataclass(frozen=True)
class ActionSpan:
    """One action in a motion: its kind, frames ``[start, stop)`` and the hands that do it."""

    kind: str
    start: int
    stop: int
    arms: tuple[str, ...]
    """Hand end-effector names."""


@dataclass(frozen=True, eq=False)
class ActionRig:
    """Calibrated key poses of a creature's acting arms (from :func:`calibrate_actions`)."""

    arms: tuple[int, ...]
    """Indices into ``plan.arms`` of the arms that act."""
    names: tuple[str, ...]
    """Their hand end-effector names."""
    coords: tuple[np.ndarray, ...]
    """Per acting arm: indices in ``q`` of its coordinates [n_a]."""
    quat_offsets: tuple[tuple[int, ...], ...]
    """Per acting arm: offsets in its coordinates where a ball joint's quaternion starts."""
    key_q: tuple[np.ndarray, ...]
    """Per acting arm: its coordinates in each key pose [K, n_a] (:data:`POSE_NAMES` order)."""
    key_tips: np.ndarray
    """Hand positions in the root frame [K, A, 3] [m] at stance."""
    valid: np.ndarray
    """[K, A] bool: the arm reached the key pose without collision."""
    kinds: tuple[str, ...]
    """Actions available (some arm can do them)."""
    swing: bool
    """Arms swing with the legs (an upright biped whose swing poses were all kept)."""
    swing_legs: np.ndarray
    """Per acting arm: (same-side leg, other-side leg) indices into ``plan.legs`` [A, 2] (-1 without)."""
    stats: dict = field(default_factory=dict)

    @property
    def arm_count(self) -> int:
        """A."""
        return len(self.arms)

    def pose_index(self, name: str) -> int:
        """Index of a key pose in :data:`POSE_NAMES`."""
        return POSE_NAMES.index(name)

    def kind_arms(self, kind: str) -> list[int]:
        """Acting arms (positions in :attr:`arms`) that can do ``kind``."""
        need = [self.pose_index(p) for p in _KIND_POSES[kind]]
        if kind in ("reach", "point"):  # any variant will do; variants are drawn among the valid ones
            return [a for a in range(self.arm_count) if self.valid[need, a].any()]
        return [a for a in range(self.arm_count) if self.valid[need, a].all()]


def _moving(m: Morphology, names: Sequence[str]) -> list[int]:
    return [m.joint_index(n) for n in names
            if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None and n not in m.wheel_joints]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _slerp_dir(a: np.ndarray, b: np.ndarray, w: float) -> np.ndarray:
    """Unit directions from ``a`` to ``b`` (both [..., 3]) at fraction ``w`` along the great circle."""
    a, b = _unit(a), _unit(b)
    dot = np.clip(np.sum(a * b, axis=-1, keepdims=True), -1.0, 1.0)
    th = np.arccos(dot)
    s = np.sin(th)
    lin = a + w * (b - a)
    out = np.where(s > 1e-6, (np.sin((1 - w) * th) * a + np.sin(w * th) * b) / np.maximum(s, 1e-12), lin)
    return _unit(out)


def _blend(a: np.ndarray, b: np.ndarray, w: np.ndarray, quats: Sequence[int]) -> np.ndarray:
    """Joint-space blend of coordinate rows [N, n] (quaternions by nlerp) with weights [N]."""
    out = a + (b - a) * w[:, None]
    for o in quats:
        out[:, o:o + 4] = nlerp(a[:, o:o + 4], b[:, o:o + 4], w)
    return out


@dataclass
class _ArmChains:
    """The arms that end in hands, per arm (indices into ``plan.arms`` in ``arms``): the shoulder's position in
    its chain, the elbow joint, the joints IK moves (shoulder to elbow) and all its moving joints."""

    arms: list[int]
    shoulders: list[int]
    elbows: list[int]
    ik_joints: list[list[int]]
    chains: list[list[int]]


def _hand_arms(m: Morphology, plan: BodyPlan) -> _ArmChains:
    """Find each hand arm's shoulder (the joint before its longest segment, with the joints at its place) and
    elbow (the next joint along), at rest; arms of fewer than two moving joints are left out."""
    cand = [i for i, arm in enumerate(plan.arms) if arm.role == EndEffectorRole.HAND]
    rest = m.rest_link_poses()
    out = _ArmChains([], [], [], [], [])
    for i in cand:
        arm = plan.arms[i]
        mov = _moving(m, arm.joints)
        ee = m.end_effector(arm.end_effector)
        T = rest[m.link_index(ee.link)]
        tip = T[:3] + quat_rotate(T[3:], np.asarray(ee.offset, dtype=float))
        pts = [rest[m.link_index(m.joints[j].child), :3] for j in mov] + [tip]
        seg = np.array([np.linalg.norm(pts[k + 1] - pts[k]) for k in range(len(mov))])
        if len(mov) < 2 or seg.sum() <= 0:
            continue
        s = int(np.argmax(seg[:-1])) if len(seg) > 1 else 0
        # joints at the shoulder's place belong to it (a yaw-pitch-roll shoulder of three revolutes)
        near = 0.02 * seg.sum()
        first = s
        while first > 0 and np.linalg.norm(pts[first - 1] - pts[s]) < near:
            first -= 1
        e = s + 1
        while e < len(mov) - 1 and np.linalg.norm(pts[e] - pts[s]) < near:
            e += 1
        last = e
        while last + 1 < len(mov) and np.linalg.norm(pts[last + 1] - pts[e]) < near:
            last += 1
        out.arms.append(i)
        out.shoulders.append(s)
        out.elbows.append(mov[e])
        out.ik_joints.append(mov[first:last + 1])
        out.chains.append(mov)
    return out


class _KeyPoseSolver:
    """IK of the hand arms' key poses at stance ``q_stance`` [C]: each elbow and hand is put at the end of its
    upper arm (length ``l1`` [A] [m]) and forearm (``l2``) pointing along given directions from the shoulder
    (``sh`` [A, 3], root frame). Elbows are IK targets through proxy end-effectors on the elbow's link."""

    def __init__(self, m: Morphology, plan: BodyPlan, chains: _ArmChains, q_stance: np.ndarray) -> None:
        arms = chains.arms
        self.A = A = len(arms)
        proxies = tuple(EndEffector(_PROXY_PREFIX + plan.arms[i].end_effector, m.joints[chains.elbows[a]].child,
                                    (0.0, 0.0, 0.0), EndEffectorRole.TOOL) for a, i in enumerate(arms))
        ik_m = dataclasses.replace(m, end_effectors=m.end_effectors + proxies)
        self.model = model = compile_model(ik_m, device="cpu")
        tip_ee = np.array([model.ee_index(plan.arms[i].end_effector) for i in arms], dtype=np.int64)
        elb_ee = np.array([model.ee_index(p.name) for p in proxies], dtype=np.int64)
        self.ee = np.concatenate([elb_ee, tip_ee])
        qd = m.joint_qd_start
        D = qd[-1] if m.joints else m.base_dof
        self.mask = np.zeros(D, dtype=bool)
        for js in chains.ik_joints:
            for j in js:
                self.mask[qd[j]:qd[j + 1]] = True

        # stance geometry in the root frame
        self.root = model.link_index(m.root)
        self.Tr0, self.elb0, self.tip0 = self.root_frame(q_stance[None])
        self.sh = np.zeros((A, 3))
        self.X0 = eval_fk(model, q_stance[None], device="cpu").numpy()[0]
        """Link transforms at stance [L, 7]."""
        for a in range(A):
            p = self.X0[m.link_index(m.joints[chains.chains[a][chains.shoulders[a]]].child), :3]
            self.sh[a] = quat_rotate(quat_conjugate(self.Tr0[0, 3:]), p - self.Tr0[0, :3])
        self.l1 = np.linalg.norm(self.elb0[0] - self.sh, axis=-1)
        self.l2 = np.linalg.norm(self.tip0[0] - self.elb0[0], axis=-1)
        self.side = np.where(self.sh[:, 1] < -1e-3, -1.0, 1.0)
        """[A] +1 for a left arm, -1 for a right one."""
        self.reach = np.array([plan.arms[i].reach for i in arms])
        self.extent = self._extent(m, chains.elbows, q_stance)
        """[A] farthest the hand gets from the shoulder over the elbow's limits [m]: below ``l1 + l2`` where the
        limits keep the elbow bent (a humanoid robot whose forearms cannot hang straight)."""
        self.bent = self.extent < (self.l1 + self.l2) * (1.0 - 1e-3)

    def _extent(self, m: Morphology, elbows: list[int], q_stance: np.ndarray) -> np.ndarray:
        """Shoulder-to-hand distance maximised over each revolute elbow's range (others: ``l1 + l2``) [A]."""
        out = self.l1 + self.l2
        for a, j in enumerate(elbows):
            lim = m.joints[j].limit
            if m.joints[j].type != JointType.REVOLUTE or lim is None:
                continue
            qs = np.repeat(q_stance[None], 65, axis=0)
            qs[:, m.joint_q_start[j]] = np.linspace(lim.lower, lim.upper, 65)
            tips = self.root_frame(qs)[2][:, a]
            out[a] = min(out[a], float(np.linalg.norm(tips - self.sh[a], axis=-1).max()))
        return out

    def root_frame(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """FK of poses [B, C]: root transforms [B, 7], elbow and hand points in the root frame [B, A, 3]."""
        model = self.model
        X = eval_fk(model, qs, device="cpu").numpy()
        Tr = X[:, self.root]
        pts = []
        for e_ in self.ee:
            Tl = X[:, int(model.ee_link[e_])]
            p = Tl[:, :3] + quat_rotate(Tl[:, 3:], np.asarray(model.ee_offset[e_], dtype=float))
            pts.append(quat_rotate(quat_conjugate(Tr[:, 3:]), p - Tr[:, :3]))
        P = np.stack(pts, axis=1)
        return Tr, P[:, :self.A], P[:, self.A:]

    def dirs(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Upper-arm and forearm directions [A, 3] of key pose ``name`` (mirrored for right arms)."""
        u, f = _KEY_POSES[name]
        U = np.array([[u[0], s * u[1], u[2]] for s in self.side])
        Fd = np.array([[f[0], s * f[1], f[2]] for s in self.side])
        return _unit(U), _unit(Fd)

    def _bent_targets(self, E: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Elbow and hand targets [B, A, 3] of the arms that cannot straighten made reachable: the hand drawn in
        along its shoulder ray to the arm's extent, the elbow where upper arm and forearm then meet, on the side of
        the ideal elbow (keeping the pose's swivel)."""
        sh, l1, l2 = self.sh[None], self.l1[None, :, None], self.l2[None, :, None]
        d = H - sh
        n = np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-9)
        w = d / n
        n = np.clip(n, np.abs(l1 - l2) + 1e-6, self.extent[None, :, None])
        H2 = sh + w * n
        x = (l1 ** 2 - l2 ** 2 + n ** 2) / (2 * n)  # along the ray, from the shoulder
        h = np.sqrt(np.maximum(l1 ** 2 - x ** 2, 0.0))
        perp = (E - sh) - np.sum((E - sh) * w, axis=-1, keepdims=True) * w
        # an ideal straight arm has no side: bend the elbow down (or back, for an arm pointing down)
        for fb in (np.array([0.0, 0.0, -1.0]), np.array([-1.0, 0.0, 0.0])):
            alt = fb - np.sum(fb * w, axis=-1, keepdims=True) * w
            small = np.linalg.norm(perp, axis=-1, keepdims=True) < 1e-3 * l1
            perp = np.where(small, alt, perp)
        E2 = sh + x * w + h * _unit(perp)
        bent = self.bent[None, :, None]
        return np.where(bent, E2, E), np.where(bent, H2, H)

    def solve(self, q: np.ndarray, u0: np.ndarray, f0: np.ndarray, u1: np.ndarray, f1: np.ndarray,
              stages: int) -> tuple[np.ndarray, np.ndarray]:
        """Move elbows and hands of poses [B, C] from directions (u0, f0) to (u1, f1) [B, A, 3] in stages; returns
        the poses and each arm's larger residual of elbow and hand [B, A] [m] (for an arm whose elbow cannot
        straighten, from the targets the limits allow: :meth:`_bent_targets`)."""
        model, ee, mask, A, reach = self.model, self.ee, self.mask, self.A, self.reach
        Tr = np.repeat(self.Tr0, len(q), axis=0)
        for k in range(1, stages + 1):
            w = k / stages
            u, f = _slerp_dir(u0, u1, w), _slerp_dir(f0, f1, w)
            E = self.sh[None] + self.l1[None, :, None] * u
            H = E + self.l2[None, :, None] * f
            if self.bent.any():
                E, H = self._bent_targets(E, H)
            tg = np.concatenate([_world(Tr, E), _world(Tr, H)], axis=1)
            it = 40 if k < stages else 120
            for _ in range(it):
                qa, _ = ik_step(model, q, tg, ee=ee, dof_mask=mask, damping=0.01 * float(reach.mean()),
                                max_step=0.3, max_error=0.1 * float(reach.mean()), device="cpu")
                q = qa.numpy()
        _, resw = ik_step(model, q, tg, ee=ee, dof_mask=mask, damping=0.01, max_step=0.3, device="cpu")
        err = np.linalg.norm(resw.numpy(), axis=-1)  # [B, 2A]
        return q, np.maximum(err[:, :A], err[:, A:])

    def key_poses(self, q_stance: np.ndarray, upright: bool) -> tuple[np.ndarray, np.ndarray]:
        """Every key pose but the wave's middle [K, C] (:data:`POSE_NAMES` order; neutral first: hanging arms for an
        upright biped, else the stance's), reached from the neutral one, and residuals [K, A] [m]."""
        A = self.A
        u_rest = _unit(self.elb0[0] - self.sh)[None]
        f_rest = _unit(self.tip0[0] - self.elb0[0])[None]
        names = [n for n in POSE_NAMES if n not in (_NEUTRAL, _WAVE_MID)]
        K = len(POSE_NAMES)
        q_keys = np.repeat(q_stance[None], K, axis=0)
        err = np.zeros((K, A))
        if upright:
            u_h, f_h = self.dirs("hang")
            q_n, err_n = self.solve(q_stance[None].copy(), u_rest, f_rest, u_h[None], f_h[None], stages=6)
            u_n, f_n = u_h, f_h
        else:
            q_n, err_n = q_stance[None].copy(), np.zeros((1, A))
            u_n, f_n = u_rest[0], f_rest[0]
        q_keys[0], err[0] = q_n[0], err_n[0]
        U1 = np.stack([self.dirs(n)[0] for n in names])
        F1 = np.stack([self.dirs(n)[1] for n in names])
        qs, es = self.solve(np.repeat(q_n, len(names), axis=0), np.broadcast_to(u_n, U1.shape),
                            np.broadcast_to(f_n, F1.shape), U1, F1, stages=4)
        for k, n in enumerate(names):
            q_keys[POSE_NAMES.index(n)] = qs[k]
            err[POSE_NAMES.index(n)] = es[k]
        return q_keys, err


def _world(Tr: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Root-frame points ``p`` [B, A, 3] in the world, for root transforms ``Tr`` [B, 7]."""
    return Tr[:, None, :3] + quat_rotate(Tr[:, None, 3:], p)


def _chain_coords(m: Morphology, chains: list[list[int]]) -> tuple[list[np.ndarray], list[tuple[int, ...]]]:
    """Per arm: indices in ``q`` of its joints' coordinates, and the offsets among them where a quaternion starts."""
    coords, quats = [], []
    for js in chains:
        c, o = [], []
        for j in js:
            s0, s1 = m.joint_q_start[j], m.joint_q_start[j + 1]
            if m.joints[j].type == JointType.SPHERICAL:
                o.append(len(c))
            c.extend(range(s0, s1))
        coords.append(np.asarray(c, dtype=np.int64))
        quats.append(tuple(o))
    return coords, quats


class _ArmClearance:
    """Whether poses keep the hand arms' links clear of each other and the body (by ``collision_margin``, or half
    their distance at rest) and above the ground (2 cm, or 1 cm below the stance's lowest arm link) [m]."""

    def __init__(self, m: Morphology, plan: BodyPlan, arms: list[int], kp: _KeyPoseSolver, cfg: ActionConfig) -> None:
        self.model, self.cfg = kp.model, cfg
        arm_links: set[str] = set()
        for i in arms:
            arm_links |= limb_links(m, plan.arms[i].joints)
        self.aidx = aidx = np.array(sorted(kp.model.link_index(n) for n in arm_links), dtype=np.int64)
        self.pairs = self_collision_pairs(kp.model, rest_margin=cfg.collision_rest_margin).touching(aidx)
        # the ground limit [m, world]: 2 cm, or lower where the stance itself reaches lower
        self.ground = min(0.02, float(kp.X0[aidx, 2].min()) - 0.01) if aidx.size else -np.inf

    def clear(self, qs: np.ndarray) -> np.ndarray:
        """[B] bool for poses ``qs`` [B, C]."""
        model, pairs, aidx = self.model, self.pairs, self.aidx
        Xw = eval_fk(model, qs, device="cpu")
        ok = np.ones(len(qs), dtype=bool)
        if pairs.pair_count:
            need = np.minimum(self.cfg.collision_margin, 0.5 * pairs.rest_distance)
            ok &= (eval_self_collision_distance(model, pairs, Xw).numpy() > need).all(axis=1)
        if aidx.size:
            ok &= (Xw.numpy()[:, aidx, 2] > self.ground).all(axis=1)
        return ok


def _drop_colliding_poses(clearance: _ArmClearance, q_keys: np.ndarray, key_q: list[np.ndarray],
                          coords: list[np.ndarray], quats: list[tuple[int, ...]], valid: np.ndarray) -> None:
    """Mark key poses invalid (``valid`` [K, A], in place) where an arm collides: alone at the pose or along the
    blends actions use (the other arms neutral); an arm colliding when neutral loses every pose; the push
    poses with both arms at once."""
    A, K = len(key_q), len(POSE_NAMES)
    ia, ib = POSE_NAMES.index("wave_a"), POSE_NAMES.index("wave_b")

    def full(a: int, rows: np.ndarray) -> np.ndarray:
        q = np.repeat(q_keys[:1], len(rows), axis=0)
        for b in range(A):
            q[:, coords[b]] = key_q[b][0]
        q[:, coords[a]] = rows
        return q

    blends = [(0, k) for k in range(1, K)] + [(ia, ib), (POSE_NAMES.index("push_chest"), POSE_NAMES.index("push_out"))]
    ws = np.array([0.25, 0.5, 0.75, 1.0])
    for a in range(A):
        rows, owners = [key_q[a][0][None]], [(0, 0)]
        for i0, i1 in blends:
            r = _blend(np.repeat(key_q[a][i0][None], len(ws), 0), np.repeat(key_q[a][i1][None], len(ws), 0), ws,
                       quats[a])
            rows.append(r)
            owners += [(i0, i1)] * len(ws)
        ok = clearance.clear(full(a, np.concatenate(rows)))
        for (i0, i1), good in zip(owners, ok, strict=True):
            if not good:
                valid[i1, a] = False
                if (i0, i1) == (0, 0):
                    valid[:, a] = False
    # push moves both arms at once
    ip, io = POSE_NAMES.index("push_chest"), POSE_NAMES.index("push_out")
    both = np.repeat(q_keys[:1], 2, axis=0)
    for b in range(A):
        both[0, coords[b]] = key_q[b][ip]
        both[1, coords[b]] = key_q[b][io]
    if A > 1 and not clearance.clear(both).all():
        valid[[ip, io]] = False


def calibrate_actions(m: Morphology, plan: BodyPlan, q_stance: np.ndarray, cfg: ActionConfig, *,
                      upright: bool, nominal_xy: np.ndarray | None = None) -> ActionRig | None:
    """Key poses of the arms that end in hands, with the creature standing at ``q_stance`` [C].

    Args:
        m: The creature.
        plan: Its body plan.
        q_stance: Standing pose [C].
        cfg: Action parameters.
        upright: The creature is an upright biped (neutral = hanging arms, arm swing).
        nominal_xy: Nominal foot points in the heading frame [NL, 2] (to pair arms with legs).

    Returns:
        The rig, or None when no arm can act (or actions are off).
    """
    if cfg.enabled is False or (cfg.enabled is None and not upright):
        return None
    unknown = set(cfg.kinds) - set(_KIND_POSES)
    if unknown or len(cfg.weights) != len(cfg.kinds):
        from morphkit.errors import ConfigError

        raise ConfigError(f"actions: unknown kinds {sorted(unknown)} (expected some of {sorted(_KIND_POSES)}) "
                          "or weights not one per kind")
    chains = _hand_arms(m, plan)
    if not chains.arms:
        return None
    kp = _KeyPoseSolver(m, plan, chains, q_stance)
    A = kp.A
    q_keys, err = kp.key_poses(q_stance, upright)
    coords, quats = _chain_coords(m, chains.chains)
    key_q = [q_keys[:, c].copy() for c in coords]
    iw = POSE_NAMES.index(_WAVE_MID)
    ia, ib = POSE_NAMES.index("wave_a"), POSE_NAMES.index("wave_b")
    for a in range(A):
        key_q[a][iw] = _blend(key_q[a][ia][None], key_q[a][ib][None], np.array([0.5]), quats[a])[0]
    err[iw] = np.maximum(err[ia], err[ib])
    valid = err <= cfg.reach_tolerance * kp.reach[None]
    _drop_colliding_poses(_ArmClearance(m, plan, chains.arms, kp, cfg), q_keys, key_q, coords, quats, valid)

    qk = np.repeat(q_stance[None], len(POSE_NAMES), axis=0)
    for a in range(A):
        qk[:, coords[a]] = key_q[a]
    _, _, tips = kp.root_frame(qk)  # [K, A, 3]
    # arms that cannot take the neutral pose do not act
    keep = [a for a in range(A) if valid[0, a]]
    if not keep:
        return None
    sel = np.asarray(keep)
    arms = [chains.arms[a] for a in keep]
    coords = [coords[a] for a in keep]
    quats = [quats[a] for a in keep]
    key_q = [key_q[a] for a in keep]
    valid, side, tips = valid[:, sel], kp.side[sel], tips[:, sel]
    A = len(keep)
    ipsi = np.full((A, 2), -1, dtype=np.int64)
    if nominal_xy is not None and len(nominal_xy) == 2:
        for a in range(A):
            same = 0 if np.sign(nominal_xy[0, 1]) == side[a] else 1
            ipsi[a] = (same, 1 - same)
    swing = bool(upright and cfg.swing_gain > 0 and (ipsi >= 0).all()
                 and all(valid[POSE_NAMES.index(p)].all() for p in _SWING_POSES))
    rig = ActionRig(arms=tuple(arms), names=tuple(plan.arms[i].end_effector for i in arms), coords=tuple(coords),
                    quat_offsets=tuple(quats), key_q=tuple(key_q), key_tips=tips, valid=valid, kinds=(),
                    swing=swing, swing_legs=ipsi)
    kinds = tuple(k for k in cfg.kinds if (rig.kind_arms(k) if k != "push" else len(rig.kind_arms(k)) == A))
    stats = {"arms": list(rig.names), "kinds": list(kinds), "swing": swing,
             "poses_kept": int(valid.sum()), "poses": int(valid.size)}
    return dataclasses.replace(rig, kinds=kinds, stats=stats)


def neutral_stance(rig: ActionRig, q_stance: np.ndarray) -> np.ndarray:
    """``q_stance`` [C] with the acting arms in their neutral pose."""
    q = q_stance.copy()
    for a in range(rig.arm_count):
        q[rig.coords[a]] = rig.key_q[a][0]
    return q


@dataclass
class ActionTrack:
    """Per-frame plan of the acting arms of a batch (from :func:`draw_actions`)."""

    i0: np.ndarray
    """[R, T, A] key pose blended from."""
    i1: np.ndarray
    """[R, T, A] key pose blended to."""
    alpha: np.ndarray
    """[R, T, A] blend weight."""
    free: np.ndarray
    """[R, T, A] weight of the arm swing (1 between actions, 0 during one)."""
    code: np.ndarray
    """[R, T] int8 action code (:data:`ACTION_NAMES`)."""
    spans: list[list[ActionSpan]]
    """Per rollout: its actions in order."""
    swing: np.ndarray | None = None
    """[R, T, A] arm swing signal in [-1, 1] (set by the caller from the planned feet, :func:`arm_swing`)."""

    def posture(self, rig: ActionRig, t: int) -> list[np.ndarray]:
        """Coordinates of each acting arm at frame ``t``, [R, n_a] per arm."""
        out = []
        R = self.i0.shape[0]
        fwd, back = POSE_NAMES.index("swing_fwd"), POSE_NAMES.index("swing_back")
        for a in range(rig.arm_count):
            K = rig.key_q[a]
            qo = rig.quat_offsets[a]
            act = _blend(K[self.i0[:, t, a]], K[self.i1[:, t, a]], self.alpha[:, t, a], qo)
            if self.swing is not None and rig.swing:
                s = self.swing[:, t, a]
                to = np.where((s >= 0)[:, None], K[fwd], K[back])
                sw = _blend(np.repeat(K[:1], R, axis=0), to, np.abs(s), qo)
            else:
                sw = np.repeat(K[:1], R, axis=0)
            out.append(_blend(act, sw, self.free[:, t, a], qo))
        return out

    def activity(self, frames: int, fps: float, ramp_seconds: float) -> np.ndarray:
        """[R, frames] in [0, 1]: 1 during an action, fading to 0 over ``ramp_seconds`` before and after."""
        R = len(self.spans)
        t = np.arange(frames)
        w = np.zeros((R, frames))
        ramp = max(ramp_seconds * fps, 1.0)
        for r, spans in enumerate(self.spans):
            for sp in spans:
                dist = np.maximum(np.maximum(sp.start - t, t - (sp.stop - 1)), 0)
                w[r] = np.maximum(w[r], smoothstep(1.0 - dist / ramp))
        return w


def draw_actions(rngs: Sequence[np.random.Generator], rig: ActionRig, frames: int, fps: float,
                 cfg: ActionConfig) -> ActionTrack:
    """Random action timelines for a batch of rollouts (each from its own generator), ``frames`` long."""
    R, A = len(rngs), rig.arm_count
    i0 = np.zeros((R, frames, A), dtype=np.int64)
    i1 = np.zeros((R, frames, A), dtype=np.int64)
    alpha = np.zeros((R, frames, A))
    free = np.ones((R, frames, A))
    code = np.zeros((R, frames), dtype=np.int8)
    spans: list[list[ActionSpan]] = [[] for _ in range(R)]
    kinds = [k for k in cfg.kinds if k in rig.kinds]
    if not kinds:
        return ActionTrack(i0, i1, alpha, free, code, spans)
    p = np.array([cfg.weights[cfg.kinds.index(k)] for k in kinds], dtype=float)
    p /= p.sum()
    P = {n: i for i, n in enumerate(POSE_NAMES)}
    for r, rng in enumerate(rngs):
        t = rng.uniform(*cfg.first_seconds)
        while True:
            kind = kinds[int(rng.choice(len(kinds), p=p))]
            able = rig.kind_arms(kind)
            if kind == "push":
                who = list(range(A))
            else:
                who = [able[int(rng.integers(len(able)))]]
            phases: list[tuple[int, int, float, float]] = []  # (from, to, seconds, wave Hz or 0)
            if kind in ("reach", "point"):
                options = [P[n] for n in _KIND_POSES[kind] if rig.valid[P[n], who[0]]]
                x = options[int(rng.integers(len(options)))]
                hold = rng.uniform(0.4, 1.0) if kind == "reach" else rng.uniform(0.8, 1.6)
                go = rng.uniform(0.8, 1.1) if kind == "reach" else rng.uniform(0.6, 0.9)
                phases = [(0, x, go, 0.0), (x, x, hold, 0.0), (x, 0, rng.uniform(0.7, 1.0), 0.0)]
            elif kind == "wave":
                hz = rng.uniform(1.2, 2.0)
                cycles = int(rng.integers(2, 5))
                phases = [(0, P[_WAVE_MID], rng.uniform(0.7, 1.0), 0.0), (P["wave_a"], P["wave_b"], cycles / hz, hz),
                          (P[_WAVE_MID], 0, rng.uniform(0.7, 1.0), 0.0)]
            else:  # push
                c, o = P["push_chest"], P["push_out"]
                phases = [(0, c, rng.uniform(0.6, 0.8), 0.0), (c, c, rng.uniform(0.15, 0.3), 0.0)]
                for _ in range(int(rng.integers(1, 3))):
                    phases += [(c, o, rng.uniform(0.35, 0.55), 0.0), (o, o, rng.uniform(0.3, 0.6), 0.0),
                               (o, c, rng.uniform(0.45, 0.65), 0.0)]
                phases += [(c, 0, rng.uniform(0.6, 0.8), 0.0)]
            start = round(t * fps)
            if start >= frames:
                break
            f = start
            for k, (a0, a1, sec, hz) in enumerate(phases):
                n = max(1, round(sec * fps))
                sl = slice(f, min(f + n, frames))
                if sl.start >= frames:
                    break
                u = (np.arange(sl.start, sl.stop) - f + 1) / n
                for a in who:
                    i0[r, sl, a], i1[r, sl, a] = a0, a1
                    if hz > 0:
                        tau = u * n / fps
                        env = smoothstep(tau / 0.3) * smoothstep((n / fps - tau) / 0.3)
                        alpha[r, sl, a] = 0.5 + 0.5 * env * np.sin(2 * np.pi * hz * tau)
                    else:
                        alpha[r, sl, a] = smoothstep(u)
                    if k == 0:
                        free[r, sl, a] = 1.0 - smoothstep(u)
                    elif k == len(phases) - 1:
                        free[r, sl, a] = smoothstep(u)
                    else:
                        free[r, sl, a] = 0.0
                f += n
            stop = min(f, frames)
            code[r, start:stop] = ACTION_NAMES.index(kind)
            spans[r].append(ActionSpan(kind, start, stop, tuple(rig.names[a] for a in who)))
            t = f / fps + rng.uniform(*cfg.gap_seconds)
    return ActionTrack(i0, i1, alpha, free, code, spans)


def limit_speed(command: np.ndarray, activity: np.ndarray, max_speed: float, max_yaw_rate: float) -> None:
    """Cap the planar speed and yaw rate of commands [R, T, 6] in place where ``activity`` [R, T] is 1,
    blending to the uncapped command where it falls to 0 (channels as in
    :data:`~morphkit.synth.locomotion_commands.COMMAND_NAMES`)."""
    v = command[..., :2]
    sp = np.linalg.norm(v, axis=-1)
    k = 1.0 - activity * (1.0 - np.minimum(1.0, max_speed / np.maximum(sp, 1e-9)))
    command[..., :2] = v * k[..., None]
    w = command[..., 2]
    kw = 1.0 - activity * (1.0 - np.minimum(1.0, max_yaw_rate / np.maximum(np.abs(w), 1e-9)))
    command[..., 2] = w * kw


def arm_swing(rig: ActionRig, nominal_xy: np.ndarray, stride: float, feet_xy: np.ndarray, root_xy: np.ndarray,
              root_yaw: np.ndarray, speed: np.ndarray, full_speed: float, fps: float, cfg: ActionConfig) -> np.ndarray:
    """Arm swing signal [R, T, A] in [-1, 1] from planned feet (see the module docstring).

    Args:
        rig: The acting arms (with ``swing_legs``).
        nominal_xy: Nominal foot points in the heading frame [NL, 2].
        stride: Fore-aft distance $2ua$ [m] a foot travels relative to the body in a full stance.
        feet_xy: Planned foot points [R, T, NL, 2] (world).
        root_xy: Root positions [R, T, 2].
        root_yaw: Root yaw [R, T].
        speed: Commanded planar speed [R, T] [m/s].
        full_speed: $v_1$ [m/s] (scaled to the creature).
        fps: Frame rate.
        cfg: Action parameters.
    """
    c, s = np.cos(root_yaw), np.sin(root_yaw)
    rel = rotate2(c[..., None], -s[..., None], feet_xy - root_xy[:, :, None, :])
    x = rel[..., 0] - nominal_xy[None, None, :, 0]  # [R, T, NL]
    legs = rig.swing_legs
    d = x[..., legs[:, 1]] - x[..., legs[:, 0]]  # [R, T, A]
    k = cfg.swing_gain * np.minimum(1.0, speed / max(full_speed, 1e-9))
    sig = np.clip(k[..., None] * np.clip(d / max(stride, 1e-9), -1.0, 1.0), -1.0, 1.0)
    w = round(cfg.swing_smoothing_seconds * fps)
    if w >= 1 and sig.shape[1] > 1:
        pad = np.pad(sig, ((0, 0), (w, w), (0, 0)), mode="edge")
        cs = np.cumsum(np.pad(pad, ((0, 0), (1, 0), (0, 0))), axis=1)
        sig = (cs[:, 2 * w + 1:] - cs[:, :-(2 * w + 1)]) / (2 * w + 1)
    return sig
