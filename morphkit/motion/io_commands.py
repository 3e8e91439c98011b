"""Robot commands from a motion (ACE §7.6): what a legged or wheeled robot's vendor API takes.

Per frame, one CSV row: time [s]; the base velocity command in the body's heading frame
(``vx``, ``vy`` [m/s], ``yaw_rate`` [rad/s]; backward differences, the conventions' rule); the body
``height`` [m] and ``pitch`` / ``roll`` [rad] (the root's tilt in its heading frame); then the
angle of every 1-DoF joint on a chain to a ``hand`` or ``tool`` end-effector ("arm joints", named
by their joint names) [rad or m].
"""

from __future__ import annotations

import csv
import io
import os

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.graph import JointType, Morphology
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_conjugate, quat_from_yaw, quat_multiply, quat_rotate, rpy_from_quat, yaw_from_quat

__all__ = ["arm_joints", "robot_commands", "write_robot_commands"]


def arm_joints(morphology: Morphology) -> tuple[str, ...]:
    """1-DoF joints on the chains to hand and tool end-effectors, in joint order."""
    on_arm = {j for ee in morphology.end_effectors if ee.role.on_arm
              for j in morphology.end_effector_chains[ee.name]}
    return tuple(j.name for j in morphology.joints if j.name in on_arm and not morphology.is_driven(j)
                 and j.type in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC))


def robot_commands(motion: Motion) -> tuple[list[str], np.ndarray]:
    """``(columns, rows)``: the commands of every frame, rows [T, 7 + arm joints]."""
    m = motion.morphology
    pose = motion.root_pose()
    yaw = np.unwrap(yaw_from_quat(pose[:, 3:]))
    heading = quat_from_yaw(yaw)
    d = np.zeros_like(pose[:, :3])
    if motion.frame_count > 1:
        d[1:] = np.diff(pose[:, :3], axis=0)
        d[0] = d[1]
    v = quat_rotate(quat_conjugate(heading), d) * motion.fps
    w = np.zeros(len(yaw))
    if motion.frame_count > 1:
        w[1:] = np.diff(yaw) * motion.fps
        w[0] = w[1]
    tilt = rpy_from_quat(quat_multiply(quat_conjugate(heading), pose[:, 3:]))
    arms = arm_joints(m)
    cols = [m.joint_q_start[m.joint_index(j)] for j in arms]
    t = np.arange(motion.frame_count) / motion.fps
    rows = np.column_stack([t, v[:, 0], v[:, 1], w, pose[:, 2], tilt[:, 1], tilt[:, 0], motion.q[:, cols]])
    return ["time", "vx", "vy", "yaw_rate", "height", "pitch", "roll", *arms], rows


def write_robot_commands(motion: Motion, path: str | os.PathLike[str]) -> None:
    """Write :func:`robot_commands` as CSV (atomically)."""
    columns, rows = robot_commands(motion)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([[f"{v:.6g}" for v in r] for r in rows])
    atomic_write_text(path, buf.getvalue())
