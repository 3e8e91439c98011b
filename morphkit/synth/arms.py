"""Arms and the remaining joints: smooth random reaching and waving, solved by IK within limits.

**Upper-body pose pool** (:func:`calibrate_arms`, once per creature). The joints that are not
legs — arms, plus *other* joints: heads, necks, spines, tails, grippers — are sampled together:
each 1-DoF joint uniform within ``joint_range`` of its span about rest (within limits, so prismatic
lifts and telescopes extend too; other joints within ``other_range``, a third of that for joints
carrying a leg, none below a foot), ball joints turned up to ``spherical_angle`` (``other_angle``)
about a random axis; in ``limit_share`` of the draws one limited joint sits within the outer 5 % of its
travel. Beside the stance (pose 0) the pool holds, per non-leg chain, the poses that put its end-effector
at its lowest and its highest, and each joint at its limits (``reach_extremes``). Poses where any of
these links hits the body, the legs at stance or the ground are dropped. Each pose is linked to its
nearest neighbours (joint space), and a link is kept only if *moving along it the way rollouts do* —
arm tips on straight lines in the root frame, solved by IK, other joints blended in joint space —
collides with nothing and stays above the ground. Rollouts walk this graph at random from a random
pose, so reaching motions are collision-checked before they are ever generated.

**Motion** (per rollout, drawn up front): the upper body moves from pose to pose of the walk
along a smoothstep (move, then hold), arm tips on straight lines in the root frame; in some
segments an arm waves (a sinusoid of random amplitude, frequency and direction added to its
target, faded in and out). IK (:mod:`morphkit.synth._ik`) solves the arm targets every
frame, pulled toward the joint-space blend of the two poses so that redundant arms keep a natural
posture and never drift; other joints follow that blend directly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from morphkit.conventions import quat_multiply, quat_rotate
from morphkit.graph import EndEffectorRole, JointType, Morphology
from morphkit.kernels import eval_fk
from morphkit.kernels.contact import eval_self_collision_distance, self_collision_pairs
from morphkit.synth._ik import LimbSolver
from morphkit.synth._util import coordinate_ascent, nlerp, smoothstep
from morphkit.synth.analysis import BodyPlan
from morphkit.synth.legged import limb_links

__all__ = ["ArmConfig", "PosePool", "UpperBodyTrack", "calibrate_arms", "draw_upper_body", "other_joints"]


@dataclass(frozen=True)
class ArmConfig:
    """Arm and other-joint motion parameters (see the module docstring)."""

    pool_size: int = 160
    """Random upper-body poses drawn (before filtering)."""
    neighbours: int = 8
    """Links per pose in the pose graph (before validation)."""
    validation_steps: int = 8
    """Points checked along each link."""
    joint_range: float = 1.0
    """Fraction of each arm joint's span (about rest, within limits) that poses are drawn from."""
    limit_share: float = 0.25
    """Share of pose draws in which one limited arm or other joint is put within the outer 5 % of its travel
    (a joint near its limit is often feasible only with the rest of its chain in a narrow region that
    uniform draws rarely hit)."""
    spherical_angle: float = 0.8
    """Largest rotation of an arm ball joint from rest [rad]."""
    continuous_angle: float = 2.0
    """Largest rotation of an arm continuous joint from rest [rad]."""
    other_range: float = 1.0
    """Fraction of an other joint's span its poses are drawn from (a third of it for joints carrying a leg)."""
    other_angle: float = 0.25
    """Largest rotation of an other ball joint from rest [rad]."""
    move_seconds: tuple[float, float] = (0.6, 2.0)
    hold_seconds: tuple[float, float] = (0.2, 1.5)
    wave_probability: float = 0.3
    wave_amplitude: tuple[float, float] = (0.03, 0.08)
    """Wave amplitude as a fraction of the arm's reach."""
    wave_hz: tuple[float, float] = (0.7, 2.0)
    posture_gain: float = 0.3
    """Per-frame pull of arm joints toward the blended pool posture, before IK."""
    ground_clearance: float = 0.05
    """Upper-body links and arm tips stay this high above the ground at stance [m]."""
    collision_margin: float = 0.01
    """Pool poses keep this clearance [m] between shapes (links between them only need no contact)."""
    leg_clearance: float = 0.15
    """Upper-body poses and the moves between them keep this fraction of the mean leg reach between
    upper-body and leg shapes (poses are checked with the legs at stance, and legs swing while walking)."""
    reach_extremes: bool = True
    """Pool the poses that put each non-leg chain's end-effector (arm tip, head, tail, tool) at its lowest and
    its highest (within its joints' limits, every upper-body point above the ground, the feet planted): a
    head that can reach the ground does. Arms only where ``joint_range`` is 1."""
    hang_share: float = 0.0
    """Share of the pose walk's moves that go to the neighbour whose arm tips hang lowest (mean tip height in
    the root frame) instead of a random neighbour: arms then spend their time low and rise now and then, as a
    person's hands mostly hang. 0: every move random."""
    walk_from_any_pose: bool = True
    """Each rollout's walk on the pose graph starts at a random pose (False: at the stance), so that poses many
    moves away from the stance — a joint's limits, a chain's lowest and highest reach — are visited too."""
    branch_check: float = 0.1
    """An arm coordinate further than this [rad or m] from the pooled posture after a frame's IK has that frame
    checked for self-collision; a colliding arm takes the posture (IK can flip to a branch the pose graph's
    validated moves never saw)."""
    collision_rest_margin: float = 0.005
    """Shape pairs closer than this at rest [m] touch by design and are not checked."""

    @classmethod
    def partial_travel(cls) -> ArmConfig:
        """Arm poses within 70 % of each arm joint's span about rest, no draws at the limits, no extreme
        reach poses for arms (other joints: as by default).

        What ACE's character data use with ``data.full_arm_travel`` off, and the embedded human's arms.
        """
        return cls(joint_range=0.7, limit_share=0.0, leg_clearance=0.0)


@dataclass(frozen=True, eq=False)
class PosePool:
    """Upper-body poses and the graph of safe moves between them (from :func:`calibrate_arms`)."""

    coords: np.ndarray
    """Indices in ``q`` of every pooled coordinate [D]."""
    quat_offsets: tuple[int, ...]
    """Offsets in ``coords`` where a ball joint's quaternion starts."""
    q: np.ndarray
    """Pooled coordinates [P, D] (pose 0: the stance)."""
    tips: np.ndarray
    """Arm tip positions in the root frame [P, A, 3] [m]."""
    neighbours: np.ndarray
    """[P, K] poses reachable from each pose by a validated move (-1: none)."""
    arm_coords: np.ndarray
    """Indices in ``q`` of the coordinates IK moves [n] (a subset of ``coords``)."""
    arm_quat_offsets: tuple[int, ...]
    """Offsets in ``arm_coords`` where a quaternion starts."""
    direct: np.ndarray
    """Positions in ``coords`` of the coordinates set directly from the blend (other joints)."""
    reach: np.ndarray
    """Per arm reach [A] [m]."""
    stats: dict = field(default_factory=dict)

    @property
    def arm_count(self) -> int:
        """A."""
        return self.tips.shape[1]

    @property
    def empty(self) -> bool:
        """No pooled coordinate at all."""
        return self.coords.size == 0


def _joint_coords(m: Morphology, joints: Sequence[int]) -> tuple[list[int], list[int]]:
    """Coordinates of the given joints and the offsets of ball-joint quaternions among them."""
    coords: list[int] = []
    quats: list[int] = []
    for ji in joints:
        j = m.joints[ji]
        s, e = m.joint_q_start[ji], m.joint_q_start[ji + 1]
        if e == s:
            continue
        if j.type == JointType.SPHERICAL:
            quats.append(len(coords))
        coords.extend(range(s, e))
    return coords, quats


def _moving_joints(m: Morphology, names: Sequence[str]) -> list[int]:
    return [m.joint_index(n) for n in names
            if m.joint(n).type != JointType.FIXED and m.joint(n).mimic is None and n not in m.wheel_joints]


def _random_rotation(rng: np.random.Generator, n: int, max_angle: float) -> np.ndarray:
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = max_angle * rng.random(n) ** (1 / 3)  # uniform in the ball of rotation vectors
    return np.concatenate([axis * np.sin(0.5 * angle)[:, None], np.cos(0.5 * angle)[:, None]], axis=1)


def _sample(rng: np.random.Generator, m: Morphology, q: np.ndarray, ji: int, fraction: float, ball_angle: float,
            continuous_angle: float) -> None:
    """Draw joint ``ji`` of every row of ``q`` [n, C] about its current (rest) value, within limits, in place."""
    lower, upper = m.coordinate_limits
    j = m.joints[ji]
    s = m.joint_q_start[ji]
    n = len(q)
    if j.type == JointType.SPHERICAL:
        q[:, s:s + 4] = quat_multiply(q[:, s:s + 4], _random_rotation(rng, n, ball_angle))
    elif j.type == JointType.CONTINUOUS or not (np.isfinite(lower[s]) and np.isfinite(upper[s])):
        q[:, s] = q[:, s] + continuous_angle * fraction * rng.uniform(-1, 1, n)
    else:
        lo = q[:, s] - fraction * (q[:, s] - lower[s])
        hi = q[:, s] + fraction * (upper[s] - q[:, s])
        q[:, s] = rng.uniform(lo, hi)


def other_joints(m: Morphology, plan: BodyPlan) -> tuple[list[int], list[int]]:
    """Joints that are neither leg nor arm nor below a foot, and those among them carrying a leg."""
    in_limb = {n for limb in plan.legs + plan.arms for n in limb.joints}
    below_feet: set[str] = set()
    for leg in plan.legs:
        below_feet |= limb_links(m, leg.joints)
    leg_mounts = {n for leg in plan.legs for n in m.chain(leg.mount_link)}
    out, carrying = [], []
    for ji, j in enumerate(m.joints):
        if j.type == JointType.FIXED or j.mimic is not None or j.name in m.wheel_joints or j.name in in_limb:
            continue
        if j.child in below_feet:
            continue
        out.append(ji)
        if j.name in leg_mounts:
            carrying.append(ji)
    return out, carrying


class _UpperBodyCheck:
    """Whether upper-body poses keep clear of the body (legs by ``leg_clearance`` of their reach) and above the
    ground floor [m, world], and where the arm tips are (root frame, [B, A, 3] [m]).

    The floor is ``ground_clearance``, or lower where the stance itself reaches lower (a fixed base mounted at
    the origin hangs its arms below z = 0).
    """

    def __init__(self, m: Morphology, plan: BodyPlan, solver: LimbSolver, q_stance: np.ndarray, cfg: ArmConfig,
                 all_joints: list[int]) -> None:
        self.model = model = solver.model
        self.A = len(plan.arms)
        # which shape pairs and links concern the upper body
        upper_links: set[str] = set()
        for ji in all_joints:
            upper_links |= limb_links(m, (m.joints[ji].name,))
        self.uidx = np.array(sorted(model.link_index(n) for n in upper_links), dtype=np.int64)
        self.pairs = pairs = self_collision_pairs(model, rest_margin=cfg.collision_rest_margin).touching(self.uidx)
        leg_links: set[str] = set()
        for leg in plan.legs:
            leg_links |= limb_links(m, leg.joints)
        lidx = np.array(sorted(model.link_index(n) for n in leg_links - upper_links), dtype=np.int64)
        self.leg_pair = np.isin(pairs.link_a, lidx) ^ np.isin(pairs.link_b, lidx)
        self.leg_clear = cfg.leg_clearance * float(np.mean([leg.reach for leg in plan.legs])) if plan.legs else 0.0
        self.ee = solver.arm_ee
        root = q_stance[:3].copy() if m.base_coordinate_count >= 3 else np.zeros(3)
        if m.base_coordinate_count == 3:  # planar / wheeled: (x, y, yaw)
            root = np.array([q_stance[0], q_stance[1], 0.0])
        self.root = root
        """The stance's root position [3] [m] (world)."""
        self.floor = -np.inf
        _, tips0 = self.check(q_stance[None], -np.inf)
        X0 = eval_fk(model, q_stance[None], device="cpu").numpy()[0]
        lowest = min([float(X0[self.uidx, 2].min())] if self.uidx.size else [np.inf])
        if self.A:
            lowest = min(lowest, float(tips0[0, :, 2].min() + root[2]))
        self.floor = min(cfg.ground_clearance, lowest - 0.01)

    def check(self, qs: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """[B] ok flags (no contact closer than ``margin``, above the ground) and arm tips [B, A, 3] (root frame)."""
        model, pairs, uidx, A, root = self.model, self.pairs, self.uidx, self.A, self.root
        Xw = eval_fk(model, qs, device="cpu")
        X = Xw.numpy()
        ok = np.ones(len(qs), dtype=bool)
        if pairs.pair_count:
            # pairs that are close at rest by design only need to keep half their rest clearance
            need = np.minimum(np.where(self.leg_pair, max(margin, self.leg_clear), margin), 0.5 * pairs.rest_distance)
            ok &= (eval_self_collision_distance(model, pairs, Xw).numpy() > need).all(axis=1)
        if uidx.size:
            ok &= (X[:, uidx, 2] > self.floor).all(axis=1)
        tips = np.zeros((len(qs), A, 3))
        for a in range(A):
            e = int(self.ee[a])
            T = X[:, int(model.ee_link[e])]
            tips[:, a] = T[:, :3] + quat_rotate(T[:, 3:], np.asarray(model.ee_offset[e], dtype=float)) - root
        if A:
            ok &= (tips[:, :, 2] + root[2] > self.floor).all(axis=1)
        return ok, tips

    def lowest_point(self, qs: np.ndarray) -> np.ndarray:
        """[B] height of the lowest upper-body link origin or arm tip of poses ``qs`` [B, C] [m]."""
        X = eval_fk(self.model, qs, device="cpu").numpy()
        _, tips = self.check(qs, -np.inf)
        low = X[:, self.uidx, 2].min(axis=1) if self.uidx.size else np.full(len(qs), np.inf)
        return np.minimum(low, tips[:, :, 2].min(axis=1) + self.root[2]) if self.A else low


def _draw_poses(rng: np.random.Generator, m: Morphology, q_stance: np.ndarray, cfg: ArmConfig, flat_arm: list[int],
                others: list[int], carrying: list[int], held: set[int], ends: list[int]) -> np.ndarray:
    """``pool_size`` random upper-body poses [P, C] about the stance: arm joints (but ``held``) within
    ``joint_range``, other joints within ``other_range`` (a third of it for those ``carrying`` legs); a
    ``limit_share`` of rows with one joint of ``ends`` (q indices) in the outer 5 % of its travel."""
    lower, upper = m.coordinate_limits
    q = np.repeat(q_stance[None], cfg.pool_size, axis=0)
    for ji in flat_arm:
        if ji not in held:
            _sample(rng, m, q, ji, cfg.joint_range, cfg.spherical_angle, cfg.continuous_angle)
    for ji in others:
        k = 1.0 / 3.0 if ji in carrying else 1.0
        _sample(rng, m, q, ji, cfg.other_range * k, cfg.other_angle * k, np.pi * k)
    if ends and cfg.limit_share > 0:
        # a joint near its limit is often feasible only with the rest of its chain in a narrow region
        # that uniform draws rarely hit: some draws put one joint within the outer 5 % of its travel
        rows = np.nonzero(rng.random(cfg.pool_size) < cfg.limit_share)[0]
        cols = np.asarray(ends)[rng.integers(len(ends), size=rows.size)]
        edge = 0.05 * rng.random(rows.size)
        top = rng.random(rows.size) < 0.5
        q[rows, cols] = np.where(top, upper[cols] - edge * (upper[cols] - lower[cols]),
                                 lower[cols] + edge * (upper[cols] - lower[cols]))
    return q


def _validate_moves(solver: LimbSolver, checker: _UpperBodyCheck, cfg: ArmConfig, q: np.ndarray, tips: np.ndarray,
                    pool_q: np.ndarray, coords: list[int], quats: list[int], arm_coords: list[int],
                    arm_quats: list[int], src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """[E] bool: whether each move ``src`` -> ``dst`` (pool indices) stays clear along the way, stepped as
    rollouts step it (joint-space blend, arms pulled toward it and their tips tracked by IK)."""
    A = checker.A
    valid = np.ones(len(src), dtype=bool)
    if not len(src):
        return valid
    arm_pos = np.arange(len(arm_coords))  # arm joints come first in coords
    direct = np.arange(len(arm_coords), len(coords))
    cur = q[src].copy()
    mask = solver.arm_mask
    # rollouts pull toward the blend every frame: over the frames one check stands for (a move of
    # mean length at 30 fps) the pull compounds to gain_eff
    frames_per_step = 30.0 * 0.5 * (cfg.move_seconds[0] + cfg.move_seconds[1]) / cfg.validation_steps
    gain_eff = 1.0 - (1.0 - cfg.posture_gain) ** max(frames_per_step, 1.0)
    for k in range(1, cfg.validation_steps + 1):
        a = np.full(len(src), smoothstep(k / cfg.validation_steps))
        blend = _blend(pool_q[src], pool_q[dst], a, quats)
        nxt = cur.copy()
        nxt[:, np.asarray(coords)[direct]] = blend[:, direct]
        if A:
            target = tips[src] + (tips[dst] - tips[src]) * a[:, None, None] + checker.root
            nxt[:, arm_coords] = nxt[:, arm_coords] + gain_eff * (blend[:, arm_pos] - nxt[:, arm_coords])
            for o in arm_quats:
                sl = slice(o, o + 4)
                nxt[:, np.asarray(arm_coords)[sl]] = nlerp(cur[:, np.asarray(arm_coords)[sl]],
                                                         blend[:, arm_pos[sl]], a * 0 + gain_eff)
            nxt, _ = solver.step(nxt, target, ee=solver.arm_ee, mask=mask, iterations=3)
        step_ok, _ = checker.check(nxt, 0.0)
        valid &= step_ok
        cur = nxt
    return valid


def calibrate_arms(m: Morphology, plan: BodyPlan, solver: LimbSolver, q_stance: np.ndarray, cfg: ArmConfig,
                   seed: int = 0, fixed_arms: Sequence[int] = ()) -> PosePool:
    """The upper-body pose pool and its validated move graph, with the creature standing at ``q_stance`` [C].

    Arms in ``fixed_arms`` (indices into ``plan.arms``; moved by something else, like
    :mod:`~morphkit.synth.actions`) stay at their stance pose in every pooled pose.
    """
    model = solver.model
    rng = np.random.default_rng(seed + 7919)
    arm_joints = [_moving_joints(m, arm.joints) for arm in plan.arms]
    held = {j for a in fixed_arms for j in arm_joints[a]}
    others, carrying = other_joints(m, plan)
    flat_arm = [j for js in arm_joints for j in js]
    arm_coords, arm_quats = _joint_coords(m, flat_arm)
    all_joints = flat_arm + others
    coords, quats = _joint_coords(m, all_joints)
    A = len(plan.arms)
    if not coords:
        return PosePool(np.zeros(0, np.int64), (), np.zeros((1, 0)), np.zeros((1, A, 3)), np.full((1, 1), -1),
                        np.zeros(0, np.int64), (), np.zeros(0, np.int64), np.zeros(A))
    checker = _UpperBodyCheck(m, plan, solver, q_stance, cfg, all_joints)
    # each non-leg chain's end-effector at its lowest and highest, as pool poses beside the stance
    kept_q = [q_stance[None]]
    lower, upper = m.coordinate_limits
    free = {ji for ji in others if ji not in carrying}
    if cfg.joint_range >= 1.0:
        free |= {ji for ji in flat_arm if ji not in held}
    extremes = (_reach_extremes(m, model, q_stance, free, lambda qs: checker.check(qs, cfg.collision_margin)[0],
                                checker.lowest_point, 0.5 * cfg.ground_clearance)
                if cfg.reach_extremes else np.zeros((0, len(q_stance))))
    kept_q.append(extremes)
    # draw until the pool is full (poses that collide are dropped), at most four rounds
    ends = [int(m.joint_q_start[ji]) for ji in flat_arm + others if ji not in held and ji not in carrying
            and m.joints[ji].type in (JointType.REVOLUTE, JointType.PRISMATIC)
            and np.isfinite(lower[m.joint_q_start[ji]]) and np.isfinite(upper[m.joint_q_start[ji]])]
    for _ in range(4):
        need = cfg.pool_size - sum(len(k) for k in kept_q) + 1
        if need <= 0:
            break
        q = _draw_poses(rng, m, q_stance, cfg, flat_arm, others, carrying, held, ends)
        ok, _ = checker.check(q, cfg.collision_margin)
        kept_q.append(q[ok][:need])
    q = np.concatenate(kept_q)
    _, tips = checker.check(q, cfg.collision_margin)
    P = len(q)
    pool_q = q[:, coords]

    # pose graph: nearest neighbours in joint space, scaled by each coordinate's spread
    spread = pool_q.std(axis=0) + 1e-9
    z = pool_q / spread
    d2 = ((z[:, None] - z[None]) ** 2).sum(-1) + np.eye(P) * 1e18
    K = min(cfg.neighbours, P - 1)
    nbr = np.argsort(d2, axis=1)[:, :K] if K > 0 else np.zeros((P, 0), dtype=np.int64)
    src = np.repeat(np.arange(P), K)
    dst = nbr.reshape(-1)
    valid = _validate_moves(solver, checker, cfg, q, tips, pool_q, coords, quats, arm_coords, arm_quats, src, dst)
    graph = np.where(valid.reshape(P, K), nbr, -1) if K > 0 else np.full((P, 1), -1)
    arm_q_off = tuple(int(o) for o in arm_quats)
    direct = np.arange(len(arm_coords), len(coords))
    return PosePool(
        coords=np.asarray(coords, dtype=np.int64), quat_offsets=tuple(quats), q=pool_q, tips=tips, neighbours=graph,
        arm_coords=np.asarray(arm_coords, dtype=np.int64), arm_quat_offsets=arm_q_off, direct=direct.astype(np.int64),
        reach=np.array([arm.reach for arm in plan.arms]),
        stats={"poses": int(P), "moves": int(valid.sum()),
               "moves_tried": len(src)},
    )


def _reach_extremes(m: Morphology, model, q_stance: np.ndarray, free: set[int], allowed, lowest_point,
                    ee_floor: float) -> np.ndarray:
    """Pool poses [N, C] at the edges of what ``free`` joints can do, each found from the stance by
    :func:`~morphkit.synth._util.coordinate_ascent` over the 1-DoF joints of ``free`` on one chain, among poses
    that ``allowed`` ([B, C] -> [B] bool) accepts:

    - per end-effector those joints move (not a foot): its lowest pose (keeping it ``ee_floor`` [m] above the
      ground) and its highest;
    - per joint of ``free``: the joint at each of its limits (or 2 or 4 % of its way short of it, where nothing
      at the limit is allowed), the rest of its chain (the longest through it to such an end-effector, if any)
      where ``lowest_point`` ([B, C] -> [B], the upper body's lowest height [m]) is highest.

    Poses no different from the stance, or that no joint values make allowed, are dropped.
    """
    lower, upper = m.coordinate_limits
    limited = [ji for ji in sorted(free) if m.joints[ji].type in (JointType.REVOLUTE, JointType.PRISMATIC)
               and np.isfinite(lower[m.joint_q_start[ji]]) and np.isfinite(upper[m.joint_q_start[ji]])]
    out = []

    def search(q0: np.ndarray, cols: np.ndarray, objective) -> bool:
        q, f = coordinate_ascent(q0[None], cols, lower[cols], upper[cols], objective)
        if np.isfinite(f[0]) and np.abs(q[0] - q_stance).max() > 1e-6:
            out.append(q[0])
            return True
        return False

    chains: dict[int, np.ndarray] = {}
    for e in m.end_effectors:
        if e.role == EndEffectorRole.FOOT:
            continue
        on_chain = {m.joint_index(n) for n in m.chain(e.link)}
        cols = np.array([int(m.joint_q_start[ji]) for ji in limited if ji in on_chain], dtype=np.int64)
        if cols.size == 0:
            continue
        for ji in limited:
            if ji in on_chain:
                prev = chains.get(ji)
                chains[ji] = cols if prev is None or len(cols) > len(prev) else prev
        k = model.ee_index(e.name)
        link, offset = int(model.ee_link[k]), np.asarray(model.ee_offset[k], dtype=float)

        def height(qs: np.ndarray, link: int = link, offset: np.ndarray = offset) -> np.ndarray:
            T = eval_fk(model, qs, device="cpu").numpy()[:, link]
            return T[:, 2] + quat_rotate(T[:, 3:], np.broadcast_to(offset, T[:, :3].shape))[:, 2]

        for sign in (-1.0, 1.0):
            def reach(qs: np.ndarray, sign: float = sign, height=height) -> np.ndarray:
                z = height(qs)
                return np.where(allowed(qs) & (z >= ee_floor), sign * z, -np.inf)

            search(q_stance, cols, reach)

    def clear(qs: np.ndarray) -> np.ndarray:
        return np.where(allowed(qs), lowest_point(qs), -np.inf)

    for ji in limited:  # a joint no end-effector hangs from (a finger, a camera tilt): alone
        chains.setdefault(ji, np.array([int(m.joint_q_start[ji])], dtype=np.int64))
    for ji, cols in chains.items():
        c = int(m.joint_q_start[ji])
        for limit in (lower[c], upper[c]):
            for f in (1.0, 0.98, 0.96):  # where the limit itself collides whatever the chain does: just short of it
                q0 = q_stance.copy()
                q0[c] = q_stance[c] + f * (limit - q_stance[c])
                if search(q0, cols[cols != c], clear):
                    break
    return np.array(out) if out else np.zeros((0, len(q_stance)))


def _blend(a: np.ndarray, b: np.ndarray, w: np.ndarray, quats: Sequence[int]) -> np.ndarray:
    out = a + (b - a) * w[:, None]
    for o in quats:
        out[:, o:o + 4] = nlerp(a[:, o:o + 4], b[:, o:o + 4], w)
    return out


@dataclass
class UpperBodyTrack:
    """Per-frame upper-body plan of a batch: pool poses ``i0 -> i1`` blended by ``alpha``, plus arm waves."""

    i0: np.ndarray
    """[R, T] int."""
    i1: np.ndarray
    """[R, T] int."""
    alpha: np.ndarray
    """[R, T]."""
    wave: np.ndarray
    """[R, T, A, 3] wave offsets of the arm targets (root frame) [m]."""

    def posture(self, pool: PosePool, t: int) -> np.ndarray:
        """Blended pooled coordinates [R, D] at frame ``t``."""
        return _blend(pool.q[self.i0[:, t]], pool.q[self.i1[:, t]], self.alpha[:, t], pool.quat_offsets)

    def tips(self, pool: PosePool, t: int) -> np.ndarray:
        """Arm targets in the root frame [R, A, 3] at frame ``t``."""
        a = self.alpha[:, t][:, None, None]
        t0, t1 = pool.tips[self.i0[:, t]], pool.tips[self.i1[:, t]]
        return t0 + (t1 - t0) * a + self.wave[:, t]


def draw_upper_body(rngs: Sequence[np.random.Generator], pool: PosePool, frames: int, fps: float,
                    cfg: ArmConfig) -> UpperBodyTrack:
    """Random walks on the pose graph, timing and waves for a batch of rollouts (each from its own generator)."""
    R = len(rngs)
    A = pool.arm_count
    t = np.arange(frames) / fps
    i0 = np.zeros((R, frames), dtype=np.int64)
    i1 = np.zeros((R, frames), dtype=np.int64)
    alpha = np.zeros((R, frames))
    wave = np.zeros((R, frames, A, 3))
    duration = frames / fps + 1.0
    S = int(np.ceil(duration / max(cfg.move_seconds[0] + cfg.hold_seconds[0], 1e-3))) + 2
    for r, rng in enumerate(rngs):
        mv = rng.uniform(*cfg.move_seconds, S)
        hd = rng.uniform(*cfg.hold_seconds, S)
        steps = rng.random(S)
        walk = np.zeros(S + 1, dtype=np.int64)
        if cfg.walk_from_any_pose:
            walk[0] = rng.integers(len(pool.q))
        hang = rng.random(S) < cfg.hang_share if cfg.hang_share > 0 else np.zeros(S, dtype=bool)
        for s in range(S):
            nb = pool.neighbours[walk[s]]
            nb = nb[nb >= 0]
            if not len(nb):
                walk[s + 1] = walk[s]
            elif hang[s] and A:
                walk[s + 1] = nb[np.argmin(pool.tips[nb, :, 2].mean(axis=1))]
            else:
                walk[s + 1] = nb[int(steps[s] * len(nb))]
        starts = np.concatenate([[0.0], np.cumsum(mv + hd)[:-1]])
        seg = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, S - 1)
        i0[r], i1[r] = walk[seg], walk[seg + 1]
        alpha[r] = smoothstep((t - starts[seg]) / mv[seg])
        if A:
            waving = rng.random((S, A)) < cfg.wave_probability
            amp = rng.uniform(*cfg.wave_amplitude, (S, A)) * pool.reach[None] * waving
            hz = rng.uniform(*cfg.wave_hz, (S, A))
            phase = rng.uniform(0, 2 * np.pi, (S, A))
            d = rng.normal(size=(S, A, 3))
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            u = np.clip((t - starts[seg]) / (mv[seg] + hd[seg]), 0.0, 1.0)
            env = np.sin(np.pi * u) ** 2
            s_wave = amp[seg] * env[:, None] * np.sin(2 * np.pi * hz[seg] * t[:, None] + phase[seg])
            wave[r] = s_wave[..., None] * d[seg]
    return UpperBodyTrack(i0, i1, alpha, wave)
