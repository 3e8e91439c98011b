"""Bases that move without legs: wheeled and planar drives, gliding floating bases, fixed bases.

The paper (§7.1) assumes a wheeled robot "can walk with arbitrary speeds and directions using
low-level controllers": the root follows the commanded forward speed and yaw rate, and sideways speed
too where the base allows it. A wheeled base drives as its wheels allow
(:class:`~morphkit.body.wheels.Drive`, from :attr:`Morphology.wheels <morphkit.graph.Morphology.wheels>`):
differential and skid-steer bases never move sideways, an Ackermann base turns no tighter than its steering
allows and never on the spot, a holonomic base (powered casters, omni wheels) moves sideways too. Every command
is scaled into the wheels' top speed: no wheel's rim moves faster than
:attr:`~morphkit.body.wheels.Drive.top_speed`, the wheels' velocity limit × radius where the description gives
one, else one track width per second (a Stretch: 0.34 m/s).

Wheel joints on fixed axles have no coordinates of their own: the FK wheel-angle scan
(:func:`~morphkit.kernels.eval_wheel_angles`, used by :meth:`Motion.link_poses`) turns them so
they roll without slipping along the root path. Steering and caster joints, and the wheels they carry, keep
their coordinates; :func:`steer_wheels` sets them from the root path (each wheel points along its centre's
velocity and rolls the distance its centre travels), and :func:`drivable` makes any motion's root path one the
wheels can drive. A floating base without legs glides with its lowest rest point on the ground; a fixed base
stays put and only moves its arms and other joints.
"""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from morphkit.body.kinematics import BodyKinematics
from morphkit.body.wheels import drive_of
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.rotations import quat_from_yaw
from morphkit.synth._util import rotate2
from morphkit.synth.analysis import BodyPlan

__all__ = ["Locomotion", "base_coordinates", "drivable", "glide_height", "locomotion_of", "rolled_angle",
           "steer_wheels"]



class Locomotion(Enum):
    """How a creature's root moves."""

    LEGGED = "legged"
    """Floating base carried by feet on the ground."""
    WHEELED = "wheeled"
    """Planar or wheeled base driven along the commands."""
    GLIDE = "glide"
    """Floating base without legs, sliding along the ground."""
    FIXED = "fixed"
    """Fixed base."""


def locomotion_of(m: Morphology, plan: BodyPlan) -> Locomotion:
    """The locomotion mode of a creature."""
    if m.base == BaseType.FIXED:
        return Locomotion.FIXED
    if m.base in (BaseType.PLANAR, BaseType.WHEELED):
        return Locomotion.WHEELED
    return Locomotion.LEGGED if plan.legs else Locomotion.GLIDE


def lateral_allowed(m: Morphology) -> bool:
    """Whether the base can move sideways (floating, planar and holonomic wheeled bases)."""
    holonomic = m.base == BaseType.WHEELED and m.wheels is not None and m.wheels.drive == "holonomic"
    return m.base in (BaseType.FLOATING, BaseType.PLANAR) or holonomic


def rolled_angle(centres: np.ndarray, axes: np.ndarray, radius: float) -> np.ndarray:
    r"""Angle [rad] a wheel turns about its axle rolling without slip, from 0 at the first frame.

    Between frames the centre moves $\Delta c$; rolling about axis $a$ (unit, horizontal) with the contact point
    still, the centre moves $r \dot\theta (a \times \hat z)$, so $\Delta\theta = \Delta c \cdot (a \times \hat z)
    / r$ with $a$ at the mid frame. The part of $\Delta c$ along the axle is slip (a skid-steer turn).

    Args:
        centres: Wheel centres [..., T, 2 or 3] (world) [m].
        axes: Spin axes [..., T, 3] (world, unit).
        radius: [m].
    """
    d = np.diff(centres[..., :2], axis=-2)
    a = 0.5 * (axes[..., 1:, :] + axes[..., :-1, :])
    roll_dir = np.stack([a[..., 1], -a[..., 0]], axis=-1)  # (a × z) in the plane
    roll_dir /= np.maximum(np.linalg.norm(roll_dir, axis=-1, keepdims=True), 1e-12)
    step = (d * roll_dir).sum(axis=-1) / radius
    return np.concatenate([np.zeros((*step.shape[:-1], 1)), np.cumsum(step, axis=-1)], axis=-1)


def steer_wheels(m: Morphology, q: np.ndarray, fps: float, *, still: float = 1e-3) -> None:
    """Set the steering, caster and steered-wheel coordinates of motions ``q`` [..., T, C] in place from their
    root paths ``q[..., :3] = (x, y, yaw)``.

    Each steering joint turns its wheel to point along the velocity of the joint's axis (a caster with trail
    so that its wheel trails behind the axis; a steering joint or powered caster the nearer way, rolling
    backward where that is nearer, within its limits); below ``still`` [m/s] it holds its angle. Each steered
    wheel then rolls the distance its centre travels (:func:`rolled_angle`).
    """
    wl = m.wheels
    if wl is None or not wl.steered or m.base != BaseType.WHEELED:
        return
    kin = BodyKinematics(m)
    P = kin.poses(kin.rest[None])[0]
    rest = dict(m.rest_pose)
    starts = m.joint_q_start
    xy, yaw = q[..., 0:2], q[..., 2]
    dt = 1.0 / fps
    radii = wl.steered_radii or (wl.radius,) * len(wl.steered)
    for spin, radius in zip(wl.steered, radii, strict=True):
        si = m.joint_index(spin)
        # the steering joint above this wheel (through fixed joints)
        li, steer = m.link_parent[si + 1], None
        while li > 0:
            pj = m.joints[li - 1]
            if pj.name in wl.steering:
                steer = pj
                break
            li = m.link_parent[li]
        Tw = P[si + 1]
        axis0 = Tw[:3, :3] @ np.asarray(m.joints[si].axis, dtype=float)
        axis0 /= np.linalg.norm(axis0)
        c0 = Tw[:3, 3]
        if steer is None:
            pivot, sign, trail_caster, lim = c0[:2], 1.0, False, None
        else:
            Ts = P[li]
            pivot = Ts[:3, 3][:2]
            sign = float(np.sign((Ts[:3, :3] @ np.asarray(steer.axis, dtype=float))[2]) or 1.0)
            lim = steer.limit if steer.type == JointType.REVOLUTE else None
            q_rest = rest.get(steer.name, 0.0)
            trail_caster = wl.drive != "holonomic" and lim is None and float(np.linalg.norm(c0[:2] - pivot)) > 1e-3
        roll0 = np.array([axis0[1], -axis0[0]])
        heading0 = math.atan2(roll0[1], roll0[0])
        # the pivot's velocity in the root frame (central differences; ends one-sided)
        world = xy + rotate2(np.cos(yaw), np.sin(yaw), np.broadcast_to(pivot, xy.shape))
        vel = np.gradient(world, dt, axis=-2) if world.shape[-2] > 1 else np.zeros_like(world)
        local = rotate2(np.cos(-yaw), np.sin(-yaw), vel)
        speed = np.linalg.norm(local, axis=-1)
        want = np.arctan2(local[..., 1], local[..., 0]) - heading0
        if trail_caster:
            # the wheel trails behind its axis: its centre offset turns to point against the velocity
            off = c0[:2] - pivot
            want = np.arctan2(local[..., 1], local[..., 0]) + math.pi - math.atan2(off[1], off[0])
        delta = np.zeros(want.shape)
        prev = np.zeros(want.shape[:-1])
        for t in range(want.shape[-1]):
            d = want[..., t]
            step = math.pi if not trail_caster else 2.0 * math.pi  # a steered wheel may roll backward
            d = d - step * np.round((d - prev) / step)
            if lim is not None:
                d = np.clip(d, *sorted(((lim.lower - q_rest) * sign, (lim.upper - q_rest) * sign)))
            prev = np.where(speed[..., t] > still, d, prev)
            delta[..., t] = prev
        off = c0[:2] - pivot
        arm = rotate2(np.cos(delta), np.sin(delta), np.broadcast_to(off, (*delta.shape, 2)))
        centre = xy + rotate2(np.cos(yaw), np.sin(yaw), pivot + arm)
        ang = yaw + delta
        axes = np.stack([np.cos(ang) * axis0[0] - np.sin(ang) * axis0[1],
                         np.sin(ang) * axis0[0] + np.cos(ang) * axis0[1], np.full(ang.shape, axis0[2])], axis=-1)
        theta = rolled_angle(centre, axes, radius)
        q[..., starts[si]] = rest.get(spin, 0.0) + theta
        if steer is not None:
            q[..., starts[m.joint_index(steer.name)]] = rest.get(steer.name, 0.0) + sign * delta


def glide_height(m: Morphology) -> float:
    """Root height [m] that puts a creature's lowest rest point (link origin or end-effector) on the ground."""
    return float(-m.rest_points()[:, 2].min())


def base_coordinates(m: Morphology, xy: np.ndarray, yaw: np.ndarray, z: np.ndarray | None = None,
                     quat: np.ndarray | None = None) -> np.ndarray:
    """Base coordinates [R, base_coordinate_count] of root poses.

    Args:
        m: The creature.
        xy: Root positions [R, 2] [m].
        yaw: Root yaw [R] [rad].
        z: Root heights [R] [m] (floating bases; default 0).
        quat: Root orientations [R, 4] xyzw (floating bases; default the yaw rotation).
    """
    R = len(yaw)
    if m.base == BaseType.FLOATING:
        out = np.empty((R, 7))
        out[:, :2] = xy
        out[:, 2] = 0.0 if z is None else z
        out[:, 3:] = quat_from_yaw(yaw) if quat is None else quat
        return out
    if m.base in (BaseType.PLANAR, BaseType.WHEELED):
        return np.stack([xy[:, 0], xy[:, 1], yaw], axis=1)
    return np.zeros((R, 0))


def drivable(m: Morphology, q: np.ndarray, fps: float) -> np.ndarray:
    """A motion ``q`` [T, C] of a wheeled base made drivable (a copy), for exports of motions not born of the
    drive's commands (retargeted ones: contacts, robot commands).

    Each step's heading-frame velocity (its chord at the step's mid heading) is clipped into what the wheels allow
    (:meth:`~morphkit.body.wheels.Drive.clamp_path`: no sideways motion but on a holonomic base, no turn tighter
    than the steering allows, no wheel over the top speed), the root path re-integrated from the first frame, and
    the steering, caster and steered-wheel angles set from it (:func:`steer_wheels`). A path the drive can follow
    comes back unchanged (to rounding); other bases' motions come back as they are.
    """
    d = drive_of(m)
    out = np.array(q, dtype=float, copy=True)
    if d is None or len(out) < 2:
        return out
    step, yaw = d.path_steps(out, fps)
    step = step / fps
    yaw_new = yaw[0] + np.concatenate([[0.0], np.cumsum(step[:, 2])])
    mid = yaw_new[:-1] + 0.5 * step[:, 2]
    c, s = np.cos(mid), np.sin(mid)
    world = np.stack([c * step[:, 0] - s * step[:, 1], s * step[:, 0] + c * step[:, 1]], axis=1)
    out[:, :2] = out[0, :2] + np.concatenate([np.zeros((1, 2)), np.cumsum(world, axis=0)])
    out[:, 2] = yaw_new
    steer_wheels(m, out, fps)
    return out
