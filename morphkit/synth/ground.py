"""Keeping arms, tails and heads above the ground: the upper body's lowest points and a per-frame lift.

Legs are planned to touch the ground with their feet only. The upper body (arms, and the other
joints the pose pool moves: tails, heads, necks) is drawn from poses checked at stance, but a body
that dips, pitches or rolls, an arm's wave, or IK between two poses can still take it below the
ground. Every frame, after IK, :class:`GroundGuard` measures the lowest point of every upper-body
shape and arm tip — sphere and capsule: centre (capsule: both end centres) less the radius; box: its
eight corners; cylinder: both end centres less the radius (a bound); meshes are not measured — and
lifts a pose with one below the ground: damped-least-squares steps of the upper-body joints move
that point straight up until it clears the ground by ``margin``. A limb pressed into the ground so
rests on it and slides along it instead of going through. A creature whose upper body never reaches
the ground is left exactly as it was.

Before any frame, :meth:`GroundGuard.root_floor` tells the leg calibration how low the body may go:
for a body pitch and roll, the lowest root height at which the upper body's joints can still hold
every point above the ground (the upper body's joints swept over their limits, each kept where the
lowest point is highest; positions shift with the root height one for one, so one search per tilt
answers every height). The calibration bounds the body's dip, pitch and roll by it
(:func:`~morphkit.synth.legged.calibrate_legs`), so the per-frame lift only has the arms' own
reaching and waving left to undo.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from morphkit.graph import JointType, Morphology, ShapeType
from morphkit.rotations import quat_rotate
from morphkit.synth._util import coordinate_ascent

__all__ = ["GroundGuard", "GroundPoint", "GroundStats", "lift_coordinates", "lift_mask", "upper_body_points"]


@dataclass(frozen=True)
class GroundPoint:
    """A point of an upper-body shape (or an arm tip) that may be its lowest."""

    link: str
    offset: tuple[float, float, float]
    """Position in the link frame [m]."""
    radius: float
    """Distance [m] the shape reaches below the point (0 for box corners and tips)."""


def _shape_points(shape) -> list[tuple[np.ndarray, float]]:
    """Candidate lowest points of a shape in its own frame, with the radius below each."""
    if shape.type == ShapeType.SPHERE:
        return [(np.zeros(3), float(shape.radius))]
    if shape.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        h = 0.5 * float(shape.length)
        return [(np.array([0.0, 0.0, -h]), float(shape.radius)), (np.array([0.0, 0.0, h]), float(shape.radius))]
    if shape.type == ShapeType.BOX:
        half = 0.5 * np.asarray(shape.size, dtype=float)
        return [(half * np.array(s), 0.0) for s in itertools.product((-1.0, 1.0), repeat=3)]
    return []  # meshes: no analytic lowest point


def upper_body_points(m: Morphology, links: set[str]) -> list[GroundPoint]:
    """Candidate lowest points of every shape on ``links`` (link frames)."""
    out = []
    for link in m.links:
        if link.name not in links:
            continue
        for shape in link.shapes:
            o = shape.origin
            for p, r in _shape_points(shape):
                xyz = np.asarray(o.xyz, dtype=float) + quat_rotate(np.asarray(o.quat, dtype=float), p)
                out.append(GroundPoint(link.name, tuple(float(v) for v in xyz), r))  # type: ignore[arg-type]
    return out


class GroundGuard:
    """Per-frame lift of upper-body points below the ground (see the module docstring).

    Args:
        model: The IK model (:attr:`LimbSolver.model`), holding one end-effector per point.
        ee: End-effector index of each point in ``model`` [P].
        radius: Radius below each point [P] [m].
        mask: DoFs that may move to lift a point (the upper body's) [D].
        step: ``LimbSolver.step``-like callable ``(q, targets, ee=, mask=, iterations=)``.
        fk: ``LimbSolver.link_transforms``-like callable: poses [B, C] -> ``T_world_link`` [B, L, 7].
        coordinates: The upper body's 1-DoF coordinates (indices in ``q``) and their lower and upper
            limits, for :meth:`root_floor` (none: it only measures).
        margin: Height [m] a lifted point is put at above the ground.
        rounds: Most lifting rounds per frame (each lifts every pose's lowest point).
    """

    def __init__(self, model, ee: np.ndarray, radius: np.ndarray, mask: np.ndarray, step, fk, *,
                 coordinates: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 margin: float = 0.002, rounds: int = 4, report_depth: float = 0.005) -> None:
        self.model = model
        self.fk = fk
        self.ee = np.asarray(ee, dtype=np.int64)
        self.radius = np.asarray(radius, dtype=float)
        self.link = np.asarray(model.ee_link, dtype=np.int64)[self.ee]
        self.offset = np.asarray(model.ee_offset, dtype=float)[self.ee]
        self.mask = mask
        none = np.zeros(0, dtype=np.int64)
        self.coordinates, self.lower, self.upper = coordinates if coordinates is not None else (none, none, none)
        self.step = step
        self.margin = margin
        self.rounds = rounds
        self.report_depth = report_depth

    def points(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World positions [B, P, 3] of the points and their clearance above the ground [B, P] [m]."""
        T = self.fk(q)[:, self.link]  # [B, P, 7]
        pos = T[..., :3] + quat_rotate(T[..., 3:], np.broadcast_to(self.offset, T[..., :3].shape))
        return pos, pos[..., 2] - self.radius

    def clearance(self, q: np.ndarray) -> np.ndarray:
        """Clearance of the points above the ground [B, P] [m] (the height alone: the frame's cheap check)."""
        T = self.fk(q)[:, self.link]
        x, y, z, w = T[..., 3], T[..., 4], T[..., 5], T[..., 6]
        o = self.offset
        # the z row of the rotation matrix of (x, y, z, w), times the offset
        up = 2.0 * (x * z - w * y) * o[:, 0] + 2.0 * (y * z + w * x) * o[:, 1] + (1.0 - 2.0 * (x * x + y * y)) * o[:, 2]
        return T[..., 2] + up - self.radius

    def root_floor(self, q: np.ndarray) -> tuple[np.ndarray, list[str]]:
        """Lowest root height [B] [m] at which the upper body's joints can hold every point above the ground
        (:func:`~morphkit.synth._util.coordinate_ascent` of the lowest point's height over the upper body's
        1-DoF joints, from ``q``).

        Args:
            q: Poses [B, C] of a floating base (root height in ``q[:, 2]``, the body's tilt in its quaternion).
        Returns:
            The heights [B], and per pose the link of the point that decides it.
        """
        def lowest(qq: np.ndarray) -> np.ndarray:
            return self.clearance(qq).min(axis=1)

        q, best = coordinate_ascent(q, self.coordinates, self.lower, self.upper, lowest)
        worst = np.argmin(self.clearance(q), axis=1)
        return q[:, 2] - best, [self.model.link_names[int(self.link[k])] for k in worst]

    def sweep(self, q: np.ndarray, need: float, *, passes: int = 2, samples: int = 9,
              refine: int = 6) -> tuple[np.ndarray, np.ndarray]:
        """Coordinate search lifting poses ``q`` [B, C] until their lowest point clears ``need`` [m].

        Each of the upper body's 1-DoF joints (``coordinates``) in turn is tried at ``samples`` values
        across its limits (a whole turn for an unlimited one): where one clears ``need``, the joint moves
        to the clearing value nearest its own (bisected ``refine`` times toward it, so the lift is as
        small as the grid allows and changes smoothly from frame to frame); where none does, to the value
        whose lowest point is highest, if that is higher than now. Coordinate search rather than DLS:
        lifting a point straight up is a max-min over joints pinned at their limits, where DLS steps trade
        height for sideways error (a hanging tail's DLS step curls its tip up and swings its base down).

        Returns:
            The poses and their lowest points' clearance [B] [m].
        """
        q = q.copy()
        best = self.clearance(q).min(axis=1)
        for _ in range(passes):
            for c, lo, hi in zip(self.coordinates, self.lower, self.upper, strict=True):
                rows = np.flatnonzero(best < need)
                if rows.size == 0:
                    return q, best
                n = rows.size
                values = np.linspace(lo, hi, samples)
                trial = np.repeat(q[rows][None], samples, axis=0)  # [S, n, C]
                trial[:, :, c] = values[:, None]
                low = self.clearance(trial.reshape(samples * n, -1)).min(axis=1).reshape(samples, n)
                cur = q[rows, c]
                ok = low >= need
                near = np.argmin(np.where(ok, np.abs(values[:, None] - cur[None]), np.inf), axis=0)
                top = np.argmax(low, axis=0)
                cleared = ok.any(axis=0)
                new = np.where(cleared, values[near], values[top])
                new_low = np.where(cleared, low[near, np.arange(n)], low[top, np.arange(n)])
                if cleared.any() and refine:
                    a, b = new[cleared].copy(), cur[cleared].copy()  # a clears, b does not
                    qq = q[rows[cleared]].copy()
                    a_low = new_low[cleared].copy()
                    for _ in range(refine):
                        qq[:, c] = 0.5 * (a + b)
                        m = self.clearance(qq).min(axis=1)
                        good = m >= need
                        a = np.where(good, qq[:, c], a)
                        a_low = np.where(good, m, a_low)
                        b = np.where(good, b, qq[:, c])
                    new[cleared], new_low[cleared] = a, a_low
                up = new_low > best[rows]
                q[rows[up], c] = new[up]
                best[rows[up]] = new_low[up]
        return q, best

    def lift(self, q: np.ndarray, stats: GroundStats) -> np.ndarray:
        """Poses ``q`` [B, C] with every point lifted above the ground where the upper body can do it;
        counts what it did into ``stats``.

        DLS steps move each pose's lowest point straight up (small, smooth changes of whole chains);
        a pose they leave below the ground is taken back to where it was and lifted by :meth:`sweep`.
        """
        rows = np.nonzero(self.clearance(q).min(axis=1) < 0.0)[0]
        if rows.size == 0:
            return q
        q = q.copy()
        q_in = q[rows].copy()
        pos, clear = self.points(q[rows])
        stats.lifted += int(rows.size)
        for _ in range(self.rounds):
            low = np.argmin(clear, axis=1)
            for k in np.unique(low):
                sel = low == k
                r = rows[sel]
                target = pos[sel, k].copy()
                target[:, 2] += self.margin - clear[sel, k]
                q[r], _ = self.step(q[r], target[:, None, :], ee=self.ee[k:k + 1], mask=self.mask, iterations=2)
            pos, clear = self.points(q[rows])
            keep = clear.min(axis=1) < -1e-4
            if not keep.any():
                return q
            rows, pos, clear, q_in = rows[keep], pos[keep], clear[keep], q_in[keep]
        if self.coordinates.size:
            q[rows], _ = self.sweep(q_in, self.margin)
            clear = self.clearance(q[rows])
        # what the upper body's joints could not lift (at their limits, or a point they do not move)
        low = np.argmin(clear, axis=1)
        depth = -clear[np.arange(len(low)), low]
        for k, dd in zip(low, depth, strict=True):
            if dd > self.report_depth:
                name = self.model.link_names[int(self.link[k])]
                n, worst = stats.stuck.get(name, (0, 0.0))
                stats.stuck[name] = (n + 1, max(worst, float(dd)))
        return q


@dataclass
class GroundStats:
    """What :meth:`GroundGuard.lift` did over some frames."""

    lifted: int = 0
    """Poses lifted (one per rollout and frame)."""
    stuck: dict[str, tuple[int, float]] = field(default_factory=dict)
    """Per link: poses left more than ``report_depth`` below the ground, and the deepest [m]."""

    def merge(self, other: GroundStats) -> GroundStats:
        """The sum of two counts."""
        stuck = dict(self.stuck)
        for name, (n, worst) in other.stuck.items():
            n0, w0 = stuck.get(name, (0, 0.0))
            stuck[name] = (n0 + n, max(w0, worst))
        return GroundStats(self.lifted + other.lifted, stuck)

    def warnings(self) -> list[str]:
        """One line per link the lift could not keep above the ground."""
        return [f"link {name}: its joints cannot lift it clear of the ground in {n} poses (up to "
                f"{100 * worst:.2g} cm below): they are at their limits where the body dips, pitches or rolls"
                for name, (n, worst) in self.stuck.items()]


def lift_coordinates(m: Morphology, joints: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coordinates (indices in ``q``) of the given joints' 1-DoF DoFs, with their lower and upper limits (a
    whole turn about rest for an unlimited one)."""
    lower, upper = m.coordinate_limits
    rest = m.rest_q()
    idx, lo, hi = [], [], []
    for ji in joints:
        j = m.joints[ji]
        if j.type not in (JointType.REVOLUTE, JointType.PRISMATIC, JointType.CONTINUOUS) or j.mimic is not None:
            continue
        s = m.joint_q_start[ji]
        finite = np.isfinite(lower[s]) and np.isfinite(upper[s])
        idx.append(s)
        lo.append(lower[s] if finite else rest[s] - np.pi)
        hi.append(upper[s] if finite else rest[s] + np.pi)
    return np.array(idx, dtype=np.int64), np.array(lo, dtype=float), np.array(hi, dtype=float)


def lift_mask(m: Morphology, joints: list[int], dof_count: int) -> np.ndarray:
    """DoF mask [D] of the given joints (their non-mimic, non-fixed DoFs)."""
    mask = np.zeros(dof_count, dtype=bool)
    qd = m.joint_qd_start
    for ji in joints:
        j = m.joints[ji]
        if j.type == JointType.FIXED or j.mimic is not None:
            continue
        mask[qd[ji]:qd[ji + 1]] = True
    return mask
