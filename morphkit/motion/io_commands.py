"""Robot commands from a motion (ACE §7.6): what a legged or wheeled robot's vendor API takes.

Per frame, one CSV row: time [s]; the base velocity command in the body's heading frame
(``vx``, ``vy`` [m/s], ``yaw_rate`` [rad/s]; :func:`~morphkit.motion.heading.heading_velocity`); the body
``height`` [m] and ``pitch`` / ``roll`` [rad] (the root's tilt in its heading frame); then the
angle of every 1-DoF joint on a chain to a ``hand`` or ``tool`` end-effector ("arm joints", named
by their joint names) [rad or m].

A wheeled base that names its wheels (:func:`~morphkit.body.wheels.drive_of`) is commanded as its wheels allow:
each row's ``vx``, ``vy``, ``yaw_rate`` is the constant twist that drives, along an arc, from the frame before to
this one (frame 0 copies frame 1), clipped as :func:`~morphkit.synth.wheeled.drivable` clips a path
(:meth:`~morphkit.body.wheels.Drive.clamp_path`): ``vy`` is 0 but on a holonomic base, an Ackermann base turns no
tighter than its steering allows. Integrated as arcs the commands drive a drivable path exactly. An Ackermann base
gets a ``steering_angle`` column [rad] after ``roll``: the bicycle model's ``atan(L · yaw_rate / vx)``, ``L`` the
signed distance [m] from the driven axle (the root) forward to the steering joints, as vendor Ackermann APIs
take it (held while the base stands).
"""

from __future__ import annotations

import csv
import io
import os

import numpy as np

from morphkit._atomic import atomic_write_text
from morphkit.body.kinematics import BodyKinematics
from morphkit.body.wheels import Drive, drive_of
from morphkit.graph import JointType, Morphology
from morphkit.motion.heading import heading_velocity
from morphkit.motion.motion import Motion
from morphkit.rotations import quat_conjugate, quat_from_yaw, quat_multiply, rpy_from_quat

__all__ = ["arm_joints", "drive_commands", "robot_commands", "steering_angle", "wheelbase",
           "write_robot_commands"]


def arm_joints(morphology: Morphology) -> tuple[str, ...]:
    """1-DoF joints on the chains to hand and tool end-effectors, in joint order."""
    on_arm = {j for ee in morphology.end_effectors if ee.role.on_arm
              for j in morphology.end_effector_chains[ee.name]}
    return tuple(j.name for j in morphology.joints if j.name in on_arm and not morphology.is_driven(j)
                 and j.type in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC))


def drive_commands(drive: Drive, path: np.ndarray, fps: float) -> np.ndarray:
    r"""Heading-frame twists [T, 3] (forward, lateral [m/s], yaw rate [rad/s]) that drive a wheeled base along
    root path ``path`` [T, 3] = (x, y [m], yaw [rad]) sampled at ``fps`` [1/s], as its wheels allow.

    Row ``t`` is the step from frame ``t - 1`` to ``t`` (frame 0 copies frame 1; zeros for one frame). A constant
    twist $(v_x, v_y, \omega)$ held for $\Delta t$ moves the base by its chord, which in the step's mid heading
    frame is $(v_x, v_y)\,\Delta t\,\mathrm{sinc}(\omega \Delta t / 2)$; the chord's velocity is clipped
    (:meth:`Drive.clamp_path`, as :func:`~morphkit.synth.wheeled.drivable` does) and divided by that sinc, so that
    a drivable path's commands reproduce it exactly, an arc's ``yaw_rate / vx`` being its curvature.
    """
    p = np.asarray(path, dtype=float)
    if len(p) < 2:
        return np.zeros((len(p), 3))
    step, _ = drive.path_steps(p, fps)
    half = 0.5 * step[:, 2] / fps
    step[:, :2] /= np.sinc(half / np.pi)[:, None]  # np.sinc(x) = sin(pi x) / (pi x)
    return np.concatenate([step[:1], step], axis=0)


def wheelbase(morphology: Morphology) -> float | None:
    """Signed distance [m] along the base's x from the root (the driven axle's middle) to the steering joints'
    mean, at rest; ``None`` for a body with no steering joints."""
    wl = morphology.wheels
    if wl is None or not wl.steering:
        return None
    kin = BodyKinematics(morphology)
    P = kin.poses(kin.rest[None])[0]
    return float(np.mean([P[morphology.joint_index(n) + 1][0, 3] for n in wl.steering]))


def steering_angle(command: np.ndarray, wheelbase: float, *, still: float = 1e-3) -> np.ndarray:
    """The bicycle model's steering angle [T] [rad], ``atan(wheelbase · yaw_rate / vx)``, of heading-frame twists
    ``command`` [T, 3]; held (from 0) where ``|vx|`` is under ``still`` [m/s]."""
    v, w = command[:, 0], command[:, 2]
    moving = np.abs(v) >= still
    delta = np.arctan(wheelbase * w / np.where(moving, v, 1.0))
    out = np.zeros(len(v))
    prev = 0.0
    for t in range(len(v)):  # a held angle: the last moving frame's
        prev = float(delta[t]) if moving[t] else prev
        out[t] = prev
    return out


def robot_commands(motion: Motion) -> tuple[list[str], np.ndarray]:
    """``(columns, rows)``: the commands of every frame, rows [T, 7 + arm joints] (an Ackermann base: 8 + arm
    joints, ``steering_angle`` before the arm joints)."""
    m = motion.morphology
    pose = motion.root_pose()
    vel = heading_velocity(pose, motion.fps)
    v, w = vel.linear, vel.yaw_rate
    heading = quat_from_yaw(vel.yaw)
    tilt = rpy_from_quat(quat_multiply(quat_conjugate(heading), pose[:, 3:]))
    drive_cols: list[str] = []
    drive_rows: list[np.ndarray] = []
    drive = drive_of(m)
    if drive is not None:  # the base's own coordinates are its path: (x, y, yaw)
        twist = drive_commands(drive, motion.q[:, :3], motion.fps)
        v, w = twist[:, :2], twist[:, 2]
        L = wheelbase(m) if drive.kind == "ackermann" else None
        if L is not None:
            drive_cols.append("steering_angle")
            drive_rows.append(steering_angle(twist, L))
    arms = arm_joints(m)
    cols = [m.joint_q_start[m.joint_index(j)] for j in arms]
    t = np.arange(motion.frame_count) / motion.fps
    rows = np.column_stack([t, v[:, 0], v[:, 1], w, pose[:, 2], tilt[:, 1], tilt[:, 0], *drive_rows,
                            motion.q[:, cols]])
    return ["time", "vx", "vy", "yaw_rate", "height", "pitch", "roll", *drive_cols, *arms], rows


def write_robot_commands(motion: Motion, path: str | os.PathLike[str]) -> None:
    """Write :func:`robot_commands` as CSV (atomically)."""
    columns, rows = robot_commands(motion)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([[f"{v:.6g}" for v in r] for r in rows])
    atomic_write_text(path, buf.getvalue())
