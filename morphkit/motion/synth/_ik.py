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
  This leaves three DoFs per three-segment leg, so warm-started steps never drift in a null space.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import warp as wp

from morphkit.conventions import quat_conjugate, quat_multiply, quat_rotate
from morphkit.graph import EndEffector, EndEffectorRole, JointType, Morphology
from morphkit.kernels import eval_fk
from morphkit.kernels.ik import ik_step
from morphkit.model import KinematicModel, compile_model
from morphkit.motion.synth._util import quat_from_yaw
from morphkit.motion.synth.analysis import BodyPlan, Limb

__all__ = ["Ankle", "LimbSolver"]

_PROXY_PREFIX = "__synth_ankle_"


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


def _moving(m: Morphology, names: tuple[str, ...]) -> list[int]:
    out = []
    for n in names:
        j = m.joint(n)
        if j.type == JointType.FIXED or j.mimic is not None or n in m.wheel_joints:
            continue
        out.append(m.joint_index(n))
    return out


class LimbSolver:
    """Batched DLS IK of all limbs of a creature (see the module docstring for which DoFs move).

    Args:
        m: The creature.
        plan: Its body plan.
        damping: DLS damping [m].
        max_step: Largest DoF change per iteration [rad or m].
    """

    def __init__(self, m: Morphology, plan: BodyPlan, *, damping: float = 0.004, max_step: float = 0.35) -> None:
        self.morphology = m
        self.plan = plan
        self.damping = damping
        self.max_step = max_step
        rest = m.rest_link_poses()
        self.ankles: list[Ankle | None] = []
        extra: list[EndEffector] = []
        leg_dofs: list[list[int]] = []
        qd = m.joint_qd_start
        for leg in plan.legs:
            ee = m.end_effector(leg.end_effector)
            mov = _moving(m, leg.joints)
            ankle = None
            if len(mov) >= 3:
                last = m.joints[mov[-1]]
                positional = sum(1 if m.joints[j].type != JointType.SPHERICAL else 2 for j in mov[:-1])
                if last.type == JointType.SPHERICAL and last.child == ee.link and positional >= 3:
                    ji = mov[-1]
                    ankle = Ankle(
                        joint=ji,
                        q_start=m.joint_q_start[ji],
                        parent_link=m.link_index(last.parent),
                        origin_quat=np.asarray(last.origin.quat, dtype=float),
                        foot_rest_quat=rest[m.link_index(last.child), 3:].copy(),
                        foot_offset=np.asarray(ee.offset, dtype=float),
                    )
                    extra.append(EndEffector(_PROXY_PREFIX + leg.end_effector, last.child, (0.0, 0.0, 0.0),
                                             EndEffectorRole.TOOL))
                    mov = mov[:-1]
            self.ankles.append(ankle)
            leg_dofs.append(self._leg_dofs(m, leg, mov, rest, ankle))
        self.ik_morphology = dataclasses.replace(m, end_effectors=m.end_effectors + tuple(extra)) if extra else m
        self.model: KinematicModel = compile_model(self.ik_morphology, device="cpu")
        self.leg_ee = np.array([
            self.model.ee_index(_PROXY_PREFIX + leg.end_effector if a is not None else leg.end_effector)
            for leg, a in zip(plan.legs, self.ankles, strict=True)
        ], dtype=np.int64)
        self.arm_ee = np.array([self.model.ee_index(a.end_effector) for a in plan.arms], dtype=np.int64)
        D = qd[-1] if m.joints else m.base_dof
        self.leg_mask = np.zeros(D, dtype=bool)
        for d in leg_dofs:
            self.leg_mask[d] = True
        self.arm_mask = np.zeros(D, dtype=bool)
        for arm in plan.arms:
            for ji in _moving(m, arm.joints):
                self.arm_mask[qd[ji]:qd[ji + 1]] = True
        self.all_mask = self.leg_mask | self.arm_mask
        self.all_ee = np.concatenate([self.leg_ee, self.arm_ee]).astype(np.int64)
        self._bufs: dict[tuple[int, ...], tuple[wp.array, wp.array]] = {}

    @staticmethod
    def _leg_dofs(m: Morphology, leg: Limb, mov: list[int], rest: np.ndarray, ankle: Ankle | None) -> list[int]:
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
            if k == 0:
                twist = int(np.argmax(np.abs(bone)))
                dofs.extend(qd[ji] + a for a in range(3) if a != twist)
            else:
                local = quat_rotate(quat_conjugate(child[3:]), hinge)
                dofs.append(qd[ji] + int(np.argmax(np.abs(local))))
        return dofs

    # ---- solving --------------------------------------------------------------------------
    def step(self, q: np.ndarray, targets: np.ndarray, *, ee: np.ndarray, mask: np.ndarray,
             iterations: int) -> tuple[np.ndarray, np.ndarray]:
        """``iterations`` DLS steps from ``q`` [B, C] toward world ``targets`` [B, E, 3] of end-effectors ``ee``.

        Returns ``(q, residual)``: the new coordinates and the residual [B, E, 3] at the input of
        the last step (zeros when ``iterations`` is 0).
        """
        B = q.shape[0]
        if iterations <= 0 or B == 0 or len(ee) == 0:
            return q, np.zeros((B, len(ee), 3))
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
            cur, res = ik_step(self.model, cur, tgt, ee=ee, dof_mask=mask, damping=self.damping,
                               max_step=self.max_step, out=out)
        return cur.numpy().copy(), res.numpy()

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
            q[:, a.q_start:a.q_start + 4] = local / np.linalg.norm(local, axis=-1, keepdims=True)
        return q

    def ankle_offsets(self, foot_yaw: np.ndarray) -> np.ndarray:
        """World vector from each leg's IK point to its foot point [B, NL, 3] (0 for legs without ankle)."""
        B, NL = foot_yaw.shape
        out = np.zeros((B, NL, 3))
        for i, a in enumerate(self.ankles):
            if a is not None:
                out[:, i] = quat_rotate(quat_from_yaw(foot_yaw[:, i]),
                                        np.broadcast_to(quat_rotate(a.foot_rest_quat, a.foot_offset), (B, 3)))
        return out
