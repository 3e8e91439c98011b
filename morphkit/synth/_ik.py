"""Limb inverse kinematics for synthesis: the morphkit DLS kernel over every limb at once.

All legs and arms of a pose are solved in one :func:`~morphkit.kernels.ik.ik_step` per iteration
(the Jacobian is block-diagonal, so one solve is the same as one per limb). Which DoFs move:

- 1-DoF joints of a limb: all (clamped into their limits by the kernel);
- ball (spherical) joints of an arm: all three axes;
- ball joints of a leg: an *ankle* (the last moving joint, when it carries the foot and the joints
  above it already place the foot in 3-D) is left out of the solve and turned afterwards so the foot
  stays level with the yaw it was given — its IK target is the ankle point itself, through an
  extra end-effector on the foot link; the hip (first moving joint) drops its twist about the bone;
  every other ball joint (a knee) keeps only its hinge axis, across the leg's plane of bending.
  This leaves three DoFs per three-segment leg, so warm-started steps never drift in a null space;
- a leg of 1-DoF joints with two or more hinges that turn it out of its plane of bending (a hip's yaw and
  abduction, a scapula's turns): all but the one that moves the foot most sideways are held at their rest
  angle, out of the solve (:func:`_held_hinges`), as a ball hip drops its twist; a leg that still has more
  DoFs than its foot point is leaned toward its stance posture before each solve (by the rollout);
- a leg of six or more hinges that sets its flat foot's whole pose (a humanoid's hip yaw-roll-pitch,
  knee, ankle pitch-roll): every hinge is in the solve, and two more points of the foot (ahead of and
  beside its sole) hold it level; a foot in the air is then placed exactly by a second solve that
  leaves its orientation free (:meth:`LimbSolver.leg_step_weights`), as its ankle may not reach level;
- a leg of five hinges ending in one ankle hinge on a sole of several shapes (hip yaw-roll-pitch, knee,
  ankle pitch): every hinge is in the solve with one more point, ahead of the sole: position, pitch and
  heading held, five coordinates for five hinges (:func:`_five_hinge_sole`);
- a sole made of several shapes (the G1's four spheres) is one flat foot, even where its point lies on one
  of them (:func:`_is_sole_of_several_shapes`): it is held level, not rolled on that sphere;
- a ball foot whose point is the ball's bottom (as :mod:`morphkit.body.anatomy` places it) has its
  target raised by what the ball turned (:meth:`LimbSolver.rolling_lift`), so it rolls, not sinks.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import warp as wp

from morphkit.graph import EndEffector, EndEffectorRole, JointType, Morphology, Shape, ShapeType
from morphkit.kernels import eval_fk, fk_module
from morphkit.kernels.ik import dls_step_kernel, eval_ee_jacobian, ik_step
from morphkit.kernels.launch import cpu_pool, cpu_thread_count
from morphkit.model import KinematicModel, compile_model
from morphkit.rotations import (
    matrix_from_quat,
    quat_conjugate,
    quat_from_matrix,
    quat_from_yaw,
    quat_multiply,
    quat_rotate,
)
from morphkit.synth.analysis import BodyPlan, Limb

__all__ = ["Ankle", "LimbSolver"]

_PROXY_PREFIX = "__synth_ankle_"
_POINT_PREFIX = "__synth_point_"
_TILT_PREFIX = "__synth_tilt_"


@dataclass(frozen=True)
class Ankle:
    """A leg's ankle: a ball joint turned to keep the foot level, outside the IK solve."""

    joint: int
    """Joint index."""
    q_start: int
    """Index of its quaternion in ``q``."""
    parent_link: int
    origin_quat: np.ndarray
    """Rotation of the joint origin in the parent link frame (xyzw)."""
    foot_rest_quat: np.ndarray
    """Foot link orientation at rest relative to the root (xyzw): the level foot."""
    foot_offset: np.ndarray
    """The foot end-effector's offset in the foot link frame [m]."""
    axis: np.ndarray | None = None
    """A revolute ankle's axis in its joint frame (None: a ball joint)."""


def _moving(m: Morphology, names: tuple[str, ...]) -> list[int]:
    out = []
    for n in names:
        j = m.joint(n)
        if j.type == JointType.FIXED or j.mimic is not None or n in m.wheel_joints:
            continue
        out.append(m.joint_index(n))
    return out


class _Workspace:
    """Buffers and recorded kernel launches for repeated DLS steps on a batch of ``B`` poses.

    Mirrors :func:`~morphkit.kernels.ik.ik_step` (FK, then the DLS step kernel) with every buffer
    allocated once and both launches recorded (``wp.launch(..., record_cmd=True)``), so a step
    costs the kernels and little else; the batch is split in ``parts`` launched from threads
    (Warp's CPU kernels release the GIL).
    """

    def __init__(self, model: KinematicModel, ee: np.ndarray, mask: np.ndarray, B: int, parts: int,
                 damping: float, max_step: float, max_error: float | None) -> None:
        C = model.coordinate_count
        E = len(ee)
        dofs = eval_ee_jacobian(model, model.rest_q[None].astype(np.float64), ee=ee, dof_mask=mask)[1]
        D = len(mask)
        col = np.full(D, -1, dtype=np.int32)
        col[dofs] = np.arange(len(dofs), dtype=np.int32)
        n = len(dofs)
        m = 3 * E
        use_dual = int(m < n)
        K = max(min(m, n), 1)
        dev = "cpu"
        f64, v3 = wp.float64, wp.vec3d
        self.B, self.C, self.E = B, C, E
        self.q = [wp.zeros((B, C), dtype=f64, device=dev), wp.zeros((B, C), dtype=f64, device=dev)]
        self.targets = wp.zeros((B, E), dtype=v3, device=dev)
        self.weight = wp.ones((B, E), dtype=f64, device=dev)
        self.weight_np = self.weight.numpy().reshape(B, E) if E else np.zeros((B, 0))
        self.X = wp.zeros((B, model.link_count), dtype=wp.transformd, device=dev)
        self.Jm = wp.zeros((B, m, max(n, 1)), dtype=f64, device=dev)
        A = wp.zeros((B, K, K), dtype=f64, device=dev)
        y = wp.zeros((B, K), dtype=f64, device=dev)
        delta = wp.zeros((B, max(n, 1)), dtype=f64, device=dev)
        err = wp.zeros((B, E), dtype=v3, device=dev)
        self.residual = wp.zeros((B, E), dtype=v3, device=dev)
        self.q_np = [a.numpy() for a in self.q]
        self.targets_np = self.targets.numpy().reshape(B, E, 3) if E else np.zeros((B, 0, 3))
        self.residual_np = self.residual.numpy().reshape(B, E, 3) if E else np.zeros((B, 0, 3))
        self.Jm_np = self.Jm.numpy()
        a = model.arrays(dev, f64)
        ee_link = wp.array(np.asarray(model.ee_link)[ee].astype(np.int32), dtype=wp.int32, device=dev)
        ee_offset = wp.array(np.asarray(model.ee_offset, dtype=np.float64)[ee], dtype=v3, device=dev)
        col_w = wp.array(col, dtype=wp.int32, device=dev)
        self._keep = (ee_link, ee_offset, col_w, A, y, delta, err)
        fk = fk_module(model, wp.float64).fk_transforms
        wheel = wp.zeros((1, max(model.wheel_count, 1)), dtype=f64, device=dev)
        self._keep += (wheel,)
        bounds = np.linspace(0, B, parts + 1).astype(int)
        self.launches: list[list[list]] = [[], []]  # [source buffer][part] -> [fk, dls]
        for src in (0, 1):
            qs, qd = self.q[src], self.q[1 - src]
            for lo, hi in itertools.pairwise(bounds):
                if hi <= lo:
                    continue
                sl = slice(int(lo), int(hi))
                cmd_fk = wp.launch(fk, dim=hi - lo, inputs=[qs[sl], wheel, 0, 0], outputs=[self.X[sl]], device=dev,
                                   record_cmd=True)
                cmd_dls = wp.launch(
                    dls_step_kernel, dim=hi - lo,
                    inputs=[qs[sl], self.X[sl], self.targets[sl], self.weight[sl], ee_link, ee_offset, a.link_parent,
                            a.joint_type, a.joint_axis, a.joint_q_start, a.joint_qd_start, a.joint_mimic_target,
                            a.joint_mimic_multiplier, a.joint_wheel, a.coordinate_lower, a.coordinate_upper,
                            int(model.base_type), col_w, f64(damping), f64(1.0), f64(max_step),
                            f64(0.0 if max_error is None else max_error), 1, use_dual if n else 0,
                            self.Jm[sl], A[sl], y[sl], delta[sl], err[sl]],
                    outputs=[qd[sl], self.residual[sl]], device=dev, record_cmd=True)
                self.launches[src].append([cmd_fk, cmd_dls])

    def run(self, src: int, pool: ThreadPoolExecutor | None) -> int:
        """One DLS step from ``q[src]`` into ``q[1 - src]``; returns the destination index."""
        self.Jm_np.fill(0.0)
        parts = self.launches[src]
        if pool is None or len(parts) == 1:
            for fk, dls in parts:
                fk.launch()
                dls.launch()
        else:
            futures = [pool.submit(_run_pair, p) for p in parts[1:]]
            _run_pair(parts[0])
            for f in futures:
                f.result()
        return 1 - src


def _set_weight(ws: _Workspace, ee_weight: np.ndarray | None, B: int) -> None:
    """Load end-effector weights [B, E] into a workspace (1 where None; padding rows copy the first)."""
    if ee_weight is None:
        ws.weight_np.fill(1.0)
    else:
        ws.weight_np[:B] = ee_weight
        ws.weight_np[B:] = ee_weight[0]


def _run_pair(pair: list) -> None:
    pair[0].launch()
    pair[1].launch()


def _generic_pose(model: KinematicModel, m: Morphology, mov: list[int]) -> np.ndarray:
    """A pose where no leg joint sits at a special angle: every 1-DoF joint of ``mov`` drawn within 0.4 of its
    rest value and within its limits by a fixed generator (at rest a straight leg is singular)."""
    q = model.rest_q.astype(np.float64).copy()
    rng = np.random.default_rng(1)
    lower, upper = model.coordinate_lower, model.coordinate_upper
    for ji in mov:
        s, e = m.joint_q_start[ji], m.joint_q_start[ji + 1]
        if m.joints[ji].type != JointType.SPHERICAL:
            q[s:e] = rng.uniform(np.maximum(lower[s:e], q[s:e] - 0.4), np.minimum(upper[s:e], q[s:e] + 0.4))
    return q


def _point_jacobian(m: Morphology, q: np.ndarray, joints: list[int],
                    point_of: Callable[[np.ndarray], np.ndarray]) -> np.ndarray | None:
    """Central-difference Jacobian [P, dofs] of ``point_of(q)`` over the 1-DoF ``joints`` (None: a ball joint,
    which moves a point every way)."""
    cols = []
    for ji in joints:
        if m.joints[ji].type == JointType.SPHERICAL:
            return None
        s = m.joint_q_start[ji]
        for d in range(m.joint_qd_start[ji + 1] - m.joint_qd_start[ji]):
            hi, lo = q.copy(), q.copy()
            hi[s + d] += 1e-6
            lo[s + d] -= 1e-6
            cols.append((point_of(hi) - point_of(lo)) / 2e-6)
    return np.stack(cols, axis=1) if cols else np.zeros((0, 0))


def _rank(J: np.ndarray) -> int:
    sv = np.linalg.svd(J, compute_uv=False) if J.size else np.zeros(0)
    return int((sv > 1e-6 * max(float(sv.max()) if sv.size else 0.0, 1e-12)).sum())


def _link_point(model: KinematicModel, link: int, offset: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """``q -> `` world position(s) [..., 3] of ``offset`` [3] or [K, 3] on ``link``."""
    def point(q: np.ndarray) -> np.ndarray:
        T = eval_fk(model, q[None], device="cpu").numpy()[0, link]
        return (T[:3] + quat_rotate(np.broadcast_to(T[3:], (*offset.shape[:-1], 4)), offset)).reshape(-1)
    return point


def _redundant_last_joint(model: KinematicModel, m: Morphology, mov: list[int], ee: EndEffector) -> bool:
    """Whether the joints above a leg's last one move its foot link origin in every direction that all of
    the leg's joints move its foot (a pitch ankle below a pitch hip and knee): the last joint then only
    tilts the foot, and is better kept level than left to the IK.

    Compares the ranks of the two positional Jacobians at a generic pose (:func:`_generic_pose`).
    """
    q = _generic_pose(model, m, mov)
    foot_link = model.link_index(ee.link)
    above = _point_jacobian(m, q, mov[:-1], _link_point(model, foot_link, np.zeros(3)))
    whole = _point_jacobian(m, q, mov, _link_point(model, foot_link, np.asarray(ee.offset, dtype=np.float64)))
    # a ball joint moves a point every way
    return (3 if above is None else _rank(above)) == (3 if whole is None else _rank(whole))


def _shape_lowest_z(shape: Shape, foot_quat: np.ndarray) -> float | None:
    """Height [m] of a primitive shape's lowest point relative to its link's origin, the link turned by
    ``foot_quat`` (xyzw); None for a shape without one here (a mesh)."""
    centre = quat_rotate(foot_quat, np.asarray(shape.origin.xyz, dtype=float))
    turn = quat_multiply(foot_quat, np.asarray(shape.origin.quat, dtype=float))
    if shape.type == ShapeType.SPHERE:
        return float(centre[2] - shape.radius)
    if shape.type == ShapeType.CAPSULE:
        tip = quat_rotate(turn, np.array([0.0, 0.0, 0.5 * shape.length]))
        return float(centre[2] - abs(tip[2]) - shape.radius)
    if shape.type == ShapeType.BOX:
        corners = 0.5 * np.array(list(itertools.product((-1.0, 1.0), repeat=3))) * np.asarray(shape.size, dtype=float)
        return float(centre[2] + quat_rotate(np.broadcast_to(turn, (8, 4)), corners)[:, 2].min())
    return None


def _is_sole_of_several_shapes(m: Morphology, ee: EndEffector) -> bool:
    """Whether ``ee``'s point lies on a sole made of several shapes of its link: two or more of them reach down
    to the point's height at rest (within a tenth of the smallest such shape's size, at least 1 mm), the G1's
    four sole spheres. Such a foot is flat, whatever shape holds the point: it does not roll on one ball."""
    foot = m.rest_link_poses()[m.link_index(ee.link), 3:]
    point_z = float(quat_rotate(foot, np.asarray(ee.offset, dtype=float))[2])
    low = 0
    for shape in m.link(ee.link).shapes:
        z = _shape_lowest_z(shape, foot)
        size = shape.radius if shape.type in (ShapeType.SPHERE, ShapeType.CAPSULE) else float(min(shape.size))
        if z is not None and abs(z - point_z) <= max(1e-3, 0.1 * size):
            low += 1
    return low >= 2


def _round_shapes_holding(m: Morphology, ee: EndEffector) -> list[Shape]:
    """The spheres and capsules of ``ee``'s link whose surface holds its point (a toe ball, a paw); none where the
    point lies on a sole of several shapes (:func:`_is_sole_of_several_shapes`)."""
    if _is_sole_of_several_shapes(m, ee):
        return []
    offset = np.asarray(ee.offset, dtype=float)
    found: list[Shape] = []
    for shape in m.link(ee.link).shapes:
        if shape.type not in (ShapeType.SPHERE, ShapeType.CAPSULE) or shape.radius <= 0:
            continue
        # the point in the shape's frame, and its distance from the shape's core segment (a point for a sphere)
        local = quat_rotate(quat_conjugate(np.asarray(shape.origin.quat, dtype=float)),
                            offset - np.asarray(shape.origin.xyz, dtype=float))
        half = 0.5 * shape.length if shape.type == ShapeType.CAPSULE else 0.0
        core = np.array([0.0, 0.0, np.clip(local[2], -half, half)])
        if abs(np.linalg.norm(local - core) - shape.radius) < 1e-4 * max(1.0, shape.radius):
            found.append(shape)
    return found


def _sphere_under(m: Morphology, ee: EndEffector) -> list[tuple[np.ndarray, float]]:
    """``[(centre, radius)]`` of the sphere on ``ee``'s link whose surface holds the point (a ball foot's sole,
    as :mod:`morphkit.body.anatomy` places it); empty for any other foot (Spot's point is its ball's centre)."""
    return [(np.asarray(sh.origin.xyz, dtype=float), float(sh.radius))
            for sh in _round_shapes_holding(m, ee) if sh.type == ShapeType.SPHERE][:1]


def _held_hinges(m: Morphology, mov: list[int], rest: np.ndarray, tip: np.ndarray) -> list[int]:
    """Hinges of a leg of 1-DoF joints held at their rest angle, out of the IK: all but one of the joints that
    turn out of the leg's plane of bending.

    The plane's normal is the axis most of the leg's hinges share at rest (within 45°: a hip's pitch, the knee,
    the ankle); the other hinges (a hip's yaw, an abduction, a scapula's rotation) swing the foot out of that
    plane or twist the leg about itself. One of them is enough to reach sideways: the one that moves the foot
    point ``tip`` [3] (root frame, at rest) most across the plane is kept. With more in the solve the DLS turns
    the leg in a null space every frame (planted paws twisting and sliding, legs swinging into each other), as
    a ball hip would with its twist, which :meth:`LimbSolver._leg_dofs` drops for the same reason. Nothing is
    held in a leg with a ball joint, fewer than two hinges sharing an axis, or fewer than two others.
    """
    if any(m.joints[ji].type == JointType.SPHERICAL for ji in mov):
        return []
    hinges = [ji for ji in mov if m.joints[ji].type in (JointType.REVOLUTE, JointType.CONTINUOUS)]
    if len(hinges) < 4:
        return []
    # a revolute joint's axis is the same in its child's frame as in its own
    axes = np.array([quat_rotate(rest[m.link_index(m.joints[ji].child), 3:], np.asarray(m.joints[ji].axis, dtype=float))
                     for ji in hinges])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    shared = np.abs(axes @ axes.T) >= np.sqrt(0.5)
    group = shared[int(np.argmax(shared.sum(axis=1)))]
    normal = np.linalg.eigh(axes[group].T @ axes[group])[1][:, -1]  # the group's mean axis, sign-free
    in_plane = np.abs(axes @ normal) >= np.sqrt(0.5)
    others = [i for i in range(len(hinges)) if not in_plane[i]]
    if in_plane.sum() < 2 or len(others) < 2:
        return []
    across = [abs(float(np.cross(axes[i], tip - rest[m.link_index(m.joints[hinges[i]].child), :3]) @ normal))
              for i in others]
    keep = others[int(np.argmax(across))]
    return [hinges[i] for i in others if i != keep]


def _foot_pose_rank(model: KinematicModel, m: Morphology, mov: list[int], ee: EndEffector) -> int:
    """How many of its flat foot's six pose coordinates a leg of 1-DoF joints sets (the rank at a generic pose);
    0 for a ball-jointed leg, one of fewer than five joints, or a round foot (its point on a sphere or capsule),
    which rolls on any orientation and is left to the position IK."""
    if len(mov) < 5 or _round_shapes_holding(m, ee):
        return 0
    q = _generic_pose(model, m, mov)
    # three points of the foot, not on one line, stand for its pose
    pts = np.asarray(ee.offset, dtype=np.float64) + np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
    J = _point_jacobian(m, q, mov, _link_point(model, model.link_index(ee.link), pts))
    return 0 if J is None else _rank(J)


def _poses_foot(model: KinematicModel, m: Morphology, mov: list[int], ee: EndEffector) -> bool:
    """Whether a leg of 1-DoF joints sets its flat foot's whole pose (rank 6, :func:`_foot_pose_rank`), as the
    six-hinge legs of humanoids do: its IK then holds the foot level itself."""
    return len(mov) >= 6 and _foot_pose_rank(model, m, mov, ee) == 6


def _five_hinge_sole(model: KinematicModel, m: Morphology, mov: list[int], ee: EndEffector) -> bool:
    """Whether a leg of 1-DoF joints ending in one ankle hinge sets all but one coordinate of its flat foot's pose
    (rank 5: a hip's yaw, roll and pitch, a knee and an ankle pitch) on a sole of several shapes. Its IK holds the
    foot point and a point ahead of it (the foot's position, pitch and heading: five coordinates for five hinges);
    the foot's roll is what its hip's roll makes it."""
    return (len(mov) == 5 and m.joints[mov[-1]].child == ee.link and _is_sole_of_several_shapes(m, ee)
            and _foot_pose_rank(model, m, mov, ee) == 5)


class LimbSolver:
    """Batched DLS IK of all limbs of a creature (see the module docstring for which DoFs move).

    Args:
        m: The creature.
        plan: Its body plan.
        damping: DLS damping [m].
        max_step: Largest DoF change per iteration [rad or m]; the kernel scales the whole step of a
            pose (all limbs) when one DoF exceeds it, so it is only a guard against blow-ups.
        max_error: Longest error per end-effector a step works on [m] (default a quarter of the mean
            limb reach): limits each limb's step on its own, where ``max_step`` would couple them.
        points: Extra points ``(link, offset in the link frame)`` the model gets end-effectors for
            (:attr:`point_ee`), e.g. the upper body's lowest points for :mod:`~morphkit.synth.ground`.
    """

    def __init__(self, m: Morphology, plan: BodyPlan, *, damping: float = 0.004, max_step: float = 1.5,
                 max_error: float | None = None,
                 points: Sequence[tuple[str, tuple[float, float, float]]] = ()) -> None:
        self.morphology = m
        self.plan = plan
        self.damping = damping
        self.max_step = max_step
        reaches = [limb.reach for limb in plan.legs + plan.arms]
        self.max_error = max_error if max_error is not None else (0.25 * float(np.mean(reaches)) if reaches else None)
        rest = m.rest_link_poses()
        self.ankles: list[Ankle | None] = []
        self.ball_constraints: list[tuple[int, int, int]] = []
        """Leg ball joints ``(q start, axis, hinge)``: a hip (``hinge >= 0``, or -1 without one) loses its
        twist about the local bone ``axis``; a knee (``hinge == -2``) keeps only its rotation about
        ``axis`` (see :meth:`constrain`)."""
        self.held_joints: list[int] = []
        """Leg joints kept at their rest angle, out of the solve (:func:`_held_hinges`)."""
        self.redundant_coordinates: list[int] = []
        """``q`` indices of the hinges of legs whose IK point has more DoFs in the solve than its three coordinates:
        the warm start leans them toward the stance posture, or they drift in the null space."""
        extra: list[EndEffector] = []
        leg_dofs: list[list[int]] = []
        tilt_leg: list[int] = []
        tilt_level: list[np.ndarray] = []
        qd = m.joint_qd_start
        base_model = compile_model(m, device="cpu")
        for li, leg in enumerate(plan.legs):
            ee = m.end_effector(leg.end_effector)
            mov = _moving(m, leg.joints)
            ankle = None
            five = _five_hinge_sole(base_model, m, mov, ee)
            poses_foot = five or _poses_foot(base_model, m, mov, ee)
            if poses_foot:
                # a point ahead of the sole and one beside it (not for five hinges: the roll is not theirs to set),
                # held where the level foot has them
                foot = rest[m.link_index(ee.link), 3:]
                for k, axis in enumerate(np.eye(3)[:1 if five else 2]):
                    level = 0.25 * leg.reach * axis
                    offset = np.asarray(ee.offset, dtype=float) + quat_rotate(quat_conjugate(foot), level)
                    extra.append(EndEffector(f"{_TILT_PREFIX}{k}_{leg.end_effector}", ee.link,
                                             tuple(float(v) for v in offset), EndEffectorRole.TOOL))
                    tilt_leg.append(li)
                    tilt_level.append(level)
            elif len(mov) >= 2:
                last = m.joints[mov[-1]]
                positional = sum(1 if m.joints[j].type != JointType.SPHERICAL else 2 for j in mov[:-1])
                ball = last.type == JointType.SPHERICAL and len(mov) >= 3 and positional >= 3
                hinge = (last.type == JointType.REVOLUTE and last.child == ee.link
                         and _redundant_last_joint(base_model, m, mov, ee))
                if (ball or hinge) and last.child == ee.link:
                    ji = mov[-1]
                    ankle = Ankle(
                        joint=ji,
                        q_start=m.joint_q_start[ji],
                        parent_link=m.link_index(last.parent),
                        origin_quat=np.asarray(last.origin.quat, dtype=float),
                        foot_rest_quat=rest[m.link_index(last.child), 3:].copy(),
                        foot_offset=np.asarray(ee.offset, dtype=float),
                        axis=None if ball else np.asarray(last.axis, dtype=float),
                    )
                    extra.append(EndEffector(_PROXY_PREFIX + leg.end_effector, last.child, (0.0, 0.0, 0.0),
                                             EndEffectorRole.TOOL))
                    mov = mov[:-1]
            self.ankles.append(ankle)
            held = [] if poses_foot else _held_hinges(m, mov, rest, np.asarray(leg.tip_rest, dtype=float))
            self.held_joints.extend(held)
            mov = [ji for ji in mov if ji not in held]
            leg_dofs.append(self._leg_dofs(m, leg, mov, rest, ankle, self.ball_constraints))
            if not poses_foot and len(leg_dofs[-1]) > 3 and all(m.joints[ji].type != JointType.SPHERICAL for ji in mov):
                self.redundant_coordinates.extend(m.joint_q_start[ji] for ji in mov)
        extra += [EndEffector(f"{_POINT_PREFIX}{i}", link, offset, EndEffectorRole.TOOL)
                  for i, (link, offset) in enumerate(points)]
        self.ik_morphology = dataclasses.replace(m, end_effectors=m.end_effectors + tuple(extra)) if extra else m
        self.model: KinematicModel = compile_model(self.ik_morphology, device="cpu") if extra else base_model
        self.leg_ee = np.array([
            self.model.ee_index(_PROXY_PREFIX + leg.end_effector if a is not None else leg.end_effector)
            for leg, a in zip(plan.legs, self.ankles, strict=True)
        ], dtype=np.int64)
        # feet whose point is the bottom of a sphere: (leg, link, centre [3], radius)
        self.balls = [(li, m.link_index(e.link), c, r) for li, leg in enumerate(plan.legs)
                      for e in [m.end_effector(leg.end_effector)]
                      for c, r in _sphere_under(m, e)]
        """Ball feet ``(leg, link, centre, radius)`` whose point is the ball's bottom (:meth:`rolling_lift`)."""
        self._ball_down = [(np.asarray(m.end_effector(plan.legs[li].end_effector).offset) - c) / r
                           for li, _link, c, r in self.balls]
        self.tilt_ee = np.array([self.model.ee_index(e.name) for e in extra if e.name.startswith(_TILT_PREFIX)],
                                dtype=np.int64)
        """End-effector index in :attr:`model` of the points that hold six-hinge legs' feet level [P]."""
        self.tilt_leg = np.array(tilt_leg, dtype=np.int64)
        """Leg of each of :attr:`tilt_ee` [P]."""
        self.tilt_level = np.array(tilt_level, dtype=float).reshape(-1, 3)
        """World vector from its foot point to each of :attr:`tilt_ee` with the foot level, heading +x [P, 3]."""
        self.leg_targets_ee = np.concatenate([self.leg_ee, self.tilt_ee]).astype(np.int64)
        """End-effectors of :meth:`leg_targets`: each leg's IK point, then :attr:`tilt_ee`."""
        self.arm_ee = np.array([self.model.ee_index(a.end_effector) for a in plan.arms], dtype=np.int64)
        self.point_ee = np.array([self.model.ee_index(f"{_POINT_PREFIX}{i}") for i in range(len(points))],
                                 dtype=np.int64)
        """End-effector index in :attr:`model` of each of ``points``."""
        D = qd[-1] if m.joints else m.base_dof
        self.leg_mask = np.zeros(D, dtype=bool)
        for d in leg_dofs:
            self.leg_mask[d] = True
        self.arm_mask = np.zeros(D, dtype=bool)
        for arm in plan.arms:
            for ji in _moving(m, arm.joints):
                self.arm_mask[qd[ji]:qd[ji + 1]] = True
        self.all_mask = self.leg_mask | self.arm_mask
        self.all_ee = np.concatenate([self.leg_targets_ee, self.arm_ee]).astype(np.int64)
        self._bufs: dict[tuple[int, ...], tuple[wp.array, wp.array]] = {}
        self._ws: dict[tuple[str, int], _Workspace] = {}
        self._fk: dict[int, tuple[np.ndarray, np.ndarray, object, tuple]] = {}

    @staticmethod
    def _leg_dofs(m: Morphology, leg: Limb, mov: list[int], rest: np.ndarray, ankle: Ankle | None,
                  constraints: list[tuple[int, int, int]]) -> list[int]:
        qd = m.joint_qd_start
        dofs: list[int] = []
        # leg direction decides the knee hinge: upright legs bend fore-aft, sprawled legs up-down
        v = np.asarray(leg.tip_rest) - np.asarray(leg.mount_rest)
        horizontal = np.hypot(v[0], v[1])
        if horizontal < abs(v[2]):
            hinge = np.array([0.0, 1.0, 0.0])
        else:
            hinge = np.cross([0.0, 0.0, 1.0], [v[0] / horizontal, v[1] / horizontal, 0.0])
        ee = m.end_effector(leg.end_effector)
        for k, ji in enumerate(mov):
            j = m.joints[ji]
            if j.type != JointType.SPHERICAL:
                dofs.append(qd[ji])
                continue
            child = rest[m.link_index(j.child)]
            if k + 1 < len(mov):
                nxt = rest[m.link_index(m.joints[mov[k + 1]].child), :3]
            elif ankle is not None:
                nxt = rest[m.link_index(m.joints[ankle.joint].child), :3]
            else:
                T = rest[m.link_index(ee.link)]
                nxt = T[:3] + quat_rotate(T[3:], np.asarray(ee.offset, dtype=float))
            bone = quat_rotate(quat_conjugate(child[3:]), nxt - child[:3])
            local = quat_rotate(quat_conjugate(child[3:]), hinge)
            h = int(np.argmax(np.abs(local)))
            if k == 0:
                twist = int(np.argmax(np.abs(bone)))
                dofs.extend(qd[ji] + a for a in range(3) if a != twist)
                constraints.append((m.joint_q_start[ji], twist, h if h != twist else -1))
            else:
                dofs.append(qd[ji] + h)
                constraints.append((m.joint_q_start[ji], h, -2))
        return dofs

    # ---- solving --------------------------------------------------------------------------
    def step(self, q: np.ndarray, targets: np.ndarray, *, ee: np.ndarray, mask: np.ndarray,
             iterations: int, max_error: float | None = None,
             ee_weight: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``iterations`` DLS steps from ``q`` [B, C] toward world ``targets`` [B, E, 3] of end-effectors ``ee``.

        Returns ``(q, residual)``: the new coordinates and the residual [B, E, 3] at the input of
        the last step (zeros when ``iterations`` is 0). ``max_error`` [m] shortens the error each step
        works on (for targets that may be out of reach); ``ee_weight`` [B, E] weighs each end-effector's
        error in the step (default 1, see :func:`~morphkit.kernels.ik.ik_step`).
        """
        B = q.shape[0]
        if iterations <= 0 or B == 0 or len(ee) == 0:
            return q, np.zeros((B, len(ee), 3))
        if max_error is None:
            # recorded launches on buffers kept per (end-effectors, mask, padded batch): the per-frame lift
            # calls this with small, changing batches, where building arrays and launches each call cost
            # several times the kernels (same kernels and arguments as ik_step, so the same numbers)
            size = 1 << int(np.ceil(np.log2(max(B, 8))))
            ee = np.asarray(ee, dtype=np.int64)
            ws = self._workspace(f"step:{ee.tobytes().hex()}:{np.packbits(mask).tobytes().hex()}", ee, mask, size)
            ws.q_np[0][:B] = q
            ws.q_np[0][B:] = q[0]
            ws.targets_np[:B] = targets
            ws.targets_np[B:] = targets[0]
            _set_weight(ws, ee_weight, B)
            src = 0
            pool = cpu_pool()
            for _ in range(iterations):
                src = ws.run(src, pool)
            return ws.q_np[src][:B].copy(), ws.residual_np[:B].copy()
        key = (B, q.shape[1])
        bufs = self._bufs.get(key)
        if bufs is None:
            bufs = (wp.empty(key, dtype=wp.float64, device="cpu"), wp.empty(key, dtype=wp.float64, device="cpu"))
            self._bufs[key] = bufs
        cur = wp.array(np.ascontiguousarray(q, dtype=np.float64), dtype=wp.float64, device="cpu")
        tgt = wp.array(np.ascontiguousarray(targets, dtype=np.float64), dtype=wp.vec3d, device="cpu")
        res = None
        for i in range(iterations):
            out = bufs[i % 2]
            cur, res = ik_step(self.model, cur, tgt, ee=ee, dof_mask=mask, damping=self.damping, max_step=self.max_step,
                               max_error=max_error, weight=ee_weight, out=out)
        return cur.numpy().copy(), res.numpy()

    def link_transforms(self, q: np.ndarray) -> np.ndarray:
        """``T_world_link`` [B, L, 7] of poses ``q`` [B, C] (float64), through a recorded FK launch per batch
        size; the result is a buffer the next call with the same ``B`` overwrites."""
        B = q.shape[0]
        hit = self._fk.get(B)
        if hit is None:
            model = self.model
            qa = wp.zeros((B, model.coordinate_count), dtype=wp.float64, device="cpu")
            X = wp.zeros((B, model.link_count), dtype=wp.transformd, device="cpu")
            wheel = wp.zeros((1, max(model.wheel_count, 1)), dtype=wp.float64, device="cpu")
            cmd = wp.launch(fk_module(model, wp.float64).fk_transforms, dim=B, inputs=[qa, wheel, 0, 0], outputs=[X],
                            device="cpu", record_cmd=True)
            hit = (qa.numpy(), X.numpy().reshape(B, model.link_count, 7), cmd, (qa, X, wheel))
            self._fk[B] = hit
        q_np, X_np, cmd, _ = hit
        q_np[:] = q
        cmd.launch()  # type: ignore[attr-defined]
        return X_np

    def _workspace(self, key: str, ee: np.ndarray, mask: np.ndarray, B: int) -> _Workspace:
        ws = self._ws.get((key, B))
        if ws is None:
            workers = cpu_thread_count()
            parts = min(workers, max(1, B // 32))
            ws = _Workspace(self.model, ee, mask, B, parts, self.damping, self.max_step, self.max_error)
            self._ws[(key, B)] = ws
        return ws

    def solve(self, q: np.ndarray, targets: np.ndarray, *, key: str, ee: np.ndarray, mask: np.ndarray,
              min_iterations: int = 2, max_iterations: int = 8, tolerance: float = 1e-4,
              weight: np.ndarray | None = None, ee_weight: np.ndarray | None = None) -> np.ndarray:
        """DLS steps until every end-effector of a pose is within ``tolerance`` [m] of its target.

        Every pose takes ``min_iterations`` steps; poses whose residual before the last step still
        exceeded the tolerance (a touchdown, a sudden change) take more, up to ``max_iterations``,
        as a shrinking sub-batch (padded to a power of two so its buffers are reused).

        Args:
            q: Coordinates [B, C] (warm start).
            targets: World targets [B, E, 3] of the end-effectors ``ee``.
            key: Names the (ee, mask) combination, for caching buffers.
            ee: End-effector indices in :attr:`model` [E].
            mask: DoF mask [D].
            min_iterations: Steps every pose takes.
            max_iterations: Most steps a pose takes.
            tolerance: Residual [m] that ends iterating.
            weight: [B, E] multiplies each residual before the tolerance test (0 ignores an
                end-effector, e.g. a swinging foot whose exact position does not matter).
            ee_weight: [B, E] weighs each end-effector's error in the steps (default 1; 0 leaves it free).

        Returns:
            The new coordinates [B, C].
        """
        B = q.shape[0]
        if B == 0 or len(ee) == 0 or min_iterations <= 0:
            return q
        pool = cpu_pool()
        ws = self._workspace(key, ee, mask, B)
        ws.q_np[0][:] = q
        ws.targets_np[:] = targets
        _set_weight(ws, ee_weight, B)
        src = 0
        for _ in range(min_iterations):
            src = ws.run(src, pool)
        q = ws.q_np[src].copy()
        err = np.linalg.norm(ws.residual_np, axis=-1)
        if weight is not None:
            err = err * weight
        active = np.nonzero(err.max(axis=-1) > tolerance)[0]
        it = min_iterations
        while active.size and it < max_iterations:
            n = int(active.size)
            size = min(B, 1 << int(np.ceil(np.log2(max(n, 8)))))
            sub = self._workspace(key, ee, mask, size)
            pad = np.concatenate([active, np.full(size - n, active[0])])
            sub.q_np[0][:] = q[pad]
            sub.targets_np[:] = targets[pad]
            _set_weight(sub, None if ee_weight is None else ee_weight[pad], size)
            sub.run(0, pool)
            q[active] = sub.q_np[1][:n]
            err = np.linalg.norm(sub.residual_np[:n], axis=-1)
            if weight is not None:
                err = err * weight[active]
            active = active[err.max(axis=-1) > tolerance]
            it += 1
        return q

    def constrain(self, q: np.ndarray) -> np.ndarray:
        """Project leg ball joints back onto their allowed rotations, in place; returns ``q``.

        Steps about two local axes compose into a small rotation about the third (they do not
        commute), so over a long rollout a hip would slowly twist and swing its knee sideways. A hip
        is projected onto ``R_h(a) R_o(b)`` (flexion about the hinge axis ``h``, then abduction about
        the remaining axis ``o``, no twist about the bone ``t``): the rotation that points the bone
        where it points now while the abduction axis stays perpendicular to the hinge axis, so the
        knee below keeps bending in the leg's plane. A knee keeps only its rotation about its hinge.
        """
        for s, t, h in self.ball_constraints:
            quat = q[:, s:s + 4]
            if h == -2:  # knee: the twist part about the hinge axis t
                hinge = np.zeros_like(quat)
                hinge[:, t] = quat[:, t]
                hinge[:, 3] = quat[:, 3]
                q[:, s:s + 4] = hinge / np.maximum(np.linalg.norm(hinge, axis=1, keepdims=True), 1e-12)
                continue
            if h == -1:  # no usable hinge: plain swing-twist, drop the twist
                tw = np.zeros_like(quat)
                tw[:, t] = quat[:, t]
                tw[:, 3] = quat[:, 3]
                tw /= np.maximum(np.linalg.norm(tw, axis=1, keepdims=True), 1e-12)
                sw = quat_multiply(quat, quat_conjugate(tw))
                q[:, s:s + 4] = sw / np.linalg.norm(sw, axis=1, keepdims=True)
                continue
            o = 3 - t - h
            R = matrix_from_quat(quat)
            d = R[:, :, t]
            eh = np.zeros(3)
            eh[h] = 1.0
            co = np.cross(eh, d)
            co /= np.maximum(np.linalg.norm(co, axis=1, keepdims=True), 1e-12)
            co *= np.where(np.sum(co * R[:, :, o], axis=1, keepdims=True) < 0, -1.0, 1.0)
            cols = np.empty_like(R)
            cols[:, :, t] = d
            cols[:, :, o] = co
            cols[:, :, h] = np.cross(d, co) if (t + 1) % 3 == o else np.cross(co, d)
            q[:, s:s + 4] = quat_from_matrix(cols)
        return q

    def level_ankles(self, q: np.ndarray, foot_yaw: np.ndarray) -> np.ndarray:
        """Turn every ankle so its foot is level with heading ``foot_yaw`` [B, NL] [rad]; returns ``q``."""
        idx = [i for i, a in enumerate(self.ankles) if a is not None]
        if not idx:
            return q
        X = eval_fk(self.model, np.ascontiguousarray(q, dtype=np.float64), device="cpu").numpy()
        for i in idx:
            a = self.ankles[i]
            assert a is not None
            parent = X[:, a.parent_link, 3:]
            joint_frame = quat_multiply(parent, a.origin_quat)
            want = quat_multiply(quat_from_yaw(foot_yaw[:, i]), a.foot_rest_quat)
            local = quat_multiply(quat_conjugate(joint_frame), want)
            if a.axis is None:
                q[:, a.q_start:a.q_start + 4] = local / np.linalg.norm(local, axis=-1, keepdims=True)
                continue
            # a hinge: the angle about its axis closest to the level foot (the twist of the wanted rotation)
            angle = 2.0 * np.arctan2(local[:, :3] @ a.axis, local[:, 3])
            angle = (angle + np.pi) % (2.0 * np.pi) - np.pi
            lo, hi = self.model.coordinate_lower[a.q_start], self.model.coordinate_upper[a.q_start]
            q[:, a.q_start] = np.clip(angle, lo, hi)
        return q

    def rolling_lift(self, q: np.ndarray) -> np.ndarray:
        """How far [m] above the ground each leg's foot point must be at poses ``q`` [B, C] [B, NL] so that its
        ball touches the ground: ``r (1 - cos theta)`` as the ball turns by ``theta`` from its rest orientation
        (0 for feet that are no ball's bottom). Holding the point there, planted, the ball rolls without slip
        (to first order) instead of sinking in as the shin turns."""
        lift = np.zeros((q.shape[0], len(self.plan.legs)))
        if not self.balls:
            return lift
        X = self.link_transforms(np.ascontiguousarray(q, dtype=np.float64))
        for (li, link, _c, r), local in zip(self.balls, self._ball_down, strict=True):
            down = quat_rotate(X[:, link, 3:], np.broadcast_to(local, (q.shape[0], 3)))
            lift[:, li] = r * (1.0 + down[:, 2])
        return lift

    def leg_targets(self, feet: np.ndarray, foot_yaw: np.ndarray) -> np.ndarray:
        """World targets [B, NL + P, 3] of :attr:`leg_targets_ee` for foot points ``feet`` [B, NL, 3] with
        headings ``foot_yaw`` [B, NL] [rad] and level feet."""
        ik = feet - self.ankle_offsets(foot_yaw)
        if not self.tilt_ee.size:
            return ik
        yaw = foot_yaw[:, self.tilt_leg]
        level = np.broadcast_to(self.tilt_level, (*yaw.shape, 3))
        tilt = feet[:, self.tilt_leg] + quat_rotate(quat_from_yaw(yaw), level)
        return np.concatenate([ik, tilt], axis=1)

    def leg_weights(self, weight: np.ndarray) -> np.ndarray:
        """Per-foot weights [B, NL] spread over :attr:`leg_targets_ee` [B, NL + P]."""
        return np.concatenate([weight, weight[:, self.tilt_leg]], axis=1)

    def leg_step_weights(self, planted: np.ndarray) -> np.ndarray:
        """Step weights [B, NL + P] of :attr:`leg_targets_ee` (``ee_weight``) that leave the orientation of the
        feet not ``planted`` [B, NL] (bool) free: 1, but 0 for the orientation points of a foot in the air.

        A level foot lifted by a bending knee may need more ankle than the joint has; the IK that holds it
        level then misses its position. Solving with these weights after a solve with all weights 1 puts
        the foot where it must be while turning it away from level no more than that takes.
        """
        tilt = np.where(planted[:, self.tilt_leg], 1.0, 0.0)
        return np.concatenate([np.ones(planted.shape), tilt], axis=1)

    def place_airborne_feet(self, q: np.ndarray, targets: np.ndarray, planted: np.ndarray, *, key: str,
                            ee: np.ndarray, mask: np.ndarray, weight: np.ndarray, max_iterations: int,
                            tolerance: float) -> np.ndarray:
        """After a :meth:`solve` toward ``targets`` [B, E, 3] (:attr:`leg_targets_ee` first), place the feet not
        ``planted`` [B, NL] exactly with their orientation free (:meth:`leg_step_weights`); ``q`` unchanged where
        no leg holds its foot level or every foot is planted. ``weight`` as :meth:`solve`'s."""
        if not self.tilt_ee.size or planted.all():
            return q
        free = np.ones(targets.shape[:2])
        free[:, :len(self.leg_targets_ee)] = self.leg_step_weights(planted)
        return self.solve(q, targets, key=key, ee=ee, mask=mask, min_iterations=1, max_iterations=max_iterations,
                          tolerance=tolerance, weight=weight * free, ee_weight=free)

    def ankle_offsets(self, foot_yaw: np.ndarray) -> np.ndarray:
        """World vector from each leg's IK point to its foot point [B, NL, 3] (0 for legs without ankle)."""
        B, NL = foot_yaw.shape
        out = np.zeros((B, NL, 3))
        for i, a in enumerate(self.ankles):
            if a is not None:
                out[:, i] = quat_rotate(quat_from_yaw(foot_yaw[:, i]),
                                        np.broadcast_to(quat_rotate(a.foot_rest_quat, a.foot_offset), (B, 3)))
        return out
