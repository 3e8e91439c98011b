"""Robot commands from a motion (ACE §7.6): what a legged or wheeled robot's vendor API takes.

Per frame, one CSV row: time [s]; the base velocity command in the body's heading frame
(``vx``, ``vy`` [m/s], ``yaw_rate`` [rad/s]; :func:`~morphkit.motion.heading.heading_velocity`); the body
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
from morphkit.motion.heading import heading_velocity
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_conjugate, quat_from_yaw, quat_multiply, rpy_from_quat

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
    vel = heading_velocity(pose, motion.fps)
    v, w = vel.linear, vel.yaw_rate
    heading = quat_from_yaw(vel.yaw)
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
