"""The NumPy reference forward kinematics of a morphology: link poses of batches of coordinate vectors.

For queries off a device (rest poses, scale, reading and mapping motion files); motion, training and anything
on a device go through the Warp kernels (:mod:`morphkit.kernels.fk`), which this matches to float precision.
Poses compose as ``T_world_child = T_world_parent · T_origin · T_motion(q)`` with
:func:`~morphkit.rotations.transform_multiply` (xyzw quaternions); mimic joints follow their target.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from morphkit.graph.types import BaseType, JointType
from morphkit.rotations import quat_from_axis_angle, quat_multiply, quat_normalize, transform_multiply

if TYPE_CHECKING:
    from morphkit.graph.morphology import Morphology

__all__ = ["link_poses", "link_poses_of_values"]

_Z = np.array([0.0, 0.0, 1.0])


def link_poses(m: Morphology, q: np.ndarray, *, root_at_origin: bool = False) -> np.ndarray:
    """Link poses ``T_world_link`` [N, link_count, 7] of coordinate vectors ``q`` [N, coordinate_count].

    The base's coordinates place the root (floating: position and quaternion, normalised; planar and wheeled:
    x, y, yaw; fixed: the origin); ``root_at_origin`` ignores them. Ball joints' quaternions are normalised.
    """
    q = np.asarray(q, dtype=float)
    n = q.shape[0]
    starts = m.joint_q_start
    value = np.zeros((n, m.joint_count))
    for ji, j in enumerate(m.joints):
        if not m.is_driven(j) and j.type in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            value[:, ji] = q[:, starts[ji]]
    root = np.zeros((n, 7))
    root[:, 6] = 1.0
    if not root_at_origin and m.base == BaseType.FLOATING:
        root[:, :3] = q[:, :3]
        root[:, 3:] = quat_normalize(q[:, 3:7])
    elif not root_at_origin and m.base in (BaseType.PLANAR, BaseType.WHEELED):
        root[:, :2] = q[:, :2]
        root[:, 3:] = quat_from_axis_angle(_Z, q[:, 2])
    balls = {ji: quat_normalize(q[:, starts[ji] : starts[ji] + 4]) for ji, j in enumerate(m.joints)
             if j.type == JointType.SPHERICAL and not m.is_driven(j)}
    return _compose(m, value, balls, root, range(m.joint_count))


def link_poses_of_values(m: Morphology, values: np.ndarray, joints: Sequence[int] | None = None) -> np.ndarray:
    """Link poses ``T_root_link`` [N, link_count, 7] of joint value rows ``values`` [N, joint_count].

    A row holds each 1-DoF joint's angle [rad] or travel [m] (other joints' entries are ignored: ball joints
    at identity; a mimic joint follows its target's entry). ``joints`` (closed under ancestors, in joint
    order) limits the work to the links they move; the other links' poses are left zero.
    """
    values = np.asarray(values, dtype=float)
    root = np.zeros((values.shape[0], 7))
    root[:, 6] = 1.0
    return _compose(m, values.copy(), {}, root, range(m.joint_count) if joints is None else joints)


def _compose(m: Morphology, value: np.ndarray, balls: dict[int, np.ndarray], root: np.ndarray,
             joints: Iterable[int]) -> np.ndarray:
    n = value.shape[0]
    for ji, j in enumerate(m.joints):  # mimic joints follow their target
        if j.mimic is not None:
            value[:, ji] = j.mimic.multiplier * value[:, m.joint_index(j.mimic.joint)] + j.mimic.offset
    poses = np.zeros((n, m.link_count, 7))
    poses[:, 0] = root
    parent = m.link_parent
    for ji in joints:
        j = m.joints[ji]
        local = np.broadcast_to(j.origin.as_array(), (n, 7))
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            turn = quat_from_axis_angle(np.asarray(j.axis, dtype=float), value[:, ji])
            local = transform_multiply(local, np.concatenate([np.zeros((n, 3)), turn], axis=-1))
        elif j.type == JointType.PRISMATIC:
            slide = value[:, ji, None] * np.asarray(j.axis, dtype=float)
            local = transform_multiply(local, np.concatenate([slide, np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))], axis=-1))
        elif ji in balls:  # a ball turns about the joint's origin: only the rotation changes
            local = np.concatenate([local[:, :3], quat_multiply(local[:, 3:], balls[ji])], axis=-1)
        poses[:, ji + 1] = transform_multiply(poses[:, parent[ji + 1]], local)
    return poses
