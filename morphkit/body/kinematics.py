"""The reference forward kinematics of the body package: link poses for batches of joint values (NumPy).

Used where a body question needs many poses of one creature at once without a device or a compiled model (the
stance search and the part finding of :mod:`morphkit.body.anatomy` pose thousands of samples of a leg); the Warp
kernels (:mod:`morphkit.kernels.fk`) serve motion, training and everything on a device. Rotations are
Rodrigues' formula on 4 × 4 matrices, in float64: the same poses as the reference FK
(:func:`morphkit.graph.kinematics.link_poses_of_values`) to rounding, kept apart because the stance search is a
multi-start search whose outcome follows the last bits (computed through the reference FK, 15 of 139 public robots'
searched stances change).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from morphkit.graph import JointType, Morphology

__all__ = ["BodyKinematics"]

_ONE_DOF = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


def _matrix(T: np.ndarray) -> np.ndarray:
    x, y, z, w = T[3:]
    M = np.eye(4)
    M[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    M[:3, 3] = T[:3]
    return M


class BodyKinematics:
    """Link poses of ``m`` for batches of 1-DoF joint values, root at the origin (NumPy, float64).

    A *value row* holds one number per joint, in joint order: the angle [rad] or travel [m] of a revolute,
    continuous or prismatic joint, ignored (0) for others; a mimic joint follows its target whatever its row
    says. ``lower`` / ``upper`` [joint_count] bound each value (the joint's limits; ±π for an unlimited hinge;
    0 for joints without one value), ``rest`` [joint_count] is the description's rest pose clipped into them.
    """

    def __init__(self, m: Morphology) -> None:
        self.m = m
        self.origins = np.stack([_matrix(j.origin.as_array()) for j in m.joints]) if m.joints else np.zeros((0, 4, 4))
        self.parent = np.asarray(m.link_parent)
        self.index = {j.name: i for i, j in enumerate(m.joints)}
        lo = np.full(m.joint_count, -math.pi)
        hi = np.full(m.joint_count, math.pi)
        for i, j in enumerate(m.joints):
            if j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
                lo[i], hi[i] = j.limit.lower, j.limit.upper
            elif j.type not in _ONE_DOF:
                lo[i] = hi[i] = 0.0
        self.lower, self.upper = lo, hi
        rest = dict(m.rest_pose)
        self.rest = np.clip([rest.get(j.name, 0.0) for j in m.joints], lo, hi) if m.joints else np.zeros(0)

    def chain(self, links: Sequence[int]) -> list[int]:
        """Indices of the joints that move ``links``: theirs and their ancestors', in joint order."""
        seen: set[int] = set()
        for li in links:
            while li and li not in seen:
                seen.add(li)
                li = self.m.link_parent[li]
        return sorted(li - 1 for li in seen)

    def poses(self, values: np.ndarray, joints: Sequence[int] | None = None) -> np.ndarray:
        """``T_root_link`` for values [N, joint_count] → [N, link_count, 4, 4].

        ``joints`` (from :meth:`chain`) limits the work to the links those joints move; the other
        links' poses are left zero. One limb's poses then cost its depth, not the body's size: the
        array is laid out links first (a view puts samples first), so that the zeros of the links not
        posed are never written.
        """
        m = self.m
        n = values.shape[0]
        out = np.zeros((m.link_count, n, 4, 4))
        out[0] = np.eye(4)
        for ji in range(m.joint_count) if joints is None else joints:
            j = m.joints[ji]
            v = values[:, ji]
            if j.mimic is not None:
                v = j.mimic.multiplier * values[:, self.index[j.mimic.joint]] + j.mimic.offset
            local = np.broadcast_to(self.origins[ji], (n, 4, 4)).copy()
            if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
                axis = np.asarray(j.axis, dtype=float)
                K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
                R = np.eye(3) + np.sin(v)[:, None, None] * K + (1 - np.cos(v))[:, None, None] * (K @ K)
                local[:, :3, :3] = local[:, :3, :3] @ R
            elif j.type == JointType.PRISMATIC:
                local[:, :3, 3] += (local[:, :3, :3] @ np.asarray(j.axis, dtype=float)) * v[:, None]
            out[ji + 1] = out[self.parent[ji + 1]] @ local
        return out.transpose(1, 0, 2, 3)

    def sample(self, joints: Sequence[int], n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` value rows: the rest values with ``joints`` drawn uniformly within their limits."""
        values = np.tile(self.rest, (n, 1))
        for ji in joints:
            values[:, ji] = rng.uniform(self.lower[ji], self.upper[ji], n)
        return values
