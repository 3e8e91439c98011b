"""Warp device helpers: base and joint transforms, heading frames (generic over float32/float64).

Every function here is a ``@wp.func`` (pure math, no allocation); the kernels in
:mod:`morphkit.kernels.fk` and :mod:`morphkit.kernels.end_effectors` compose them. Quaternions are
xyzw, transforms ``[p, q]`` (:mod:`morphkit.conventions`).
"""

from __future__ import annotations

from typing import Any

import warp as wp

__all__ = [
    "base_floating",
    "base_planar",
    "heading_transform",
    "joint_prismatic",
    "joint_revolute",
    "joint_spherical",
    "quat_about_z",
]


@wp.func
def quat_about_z(yaw: Any):
    """Rotation by ``yaw`` [rad] about +z."""
    h = yaw * type(yaw)(0.5)
    z = type(yaw)(0.0)
    return wp.quaternion(z, z, wp.sin(h), wp.cos(h))


@wp.func
def base_floating(px: Any, py: Any, pz: Any, qx: Any, qy: Any, qz: Any, qw: Any):
    """``T_world_root`` of a floating base; the quaternion is normalised (so any non-zero 4-vector is a pose)."""
    return wp.transformation(wp.vector(px, py, pz), wp.normalize(wp.quaternion(qx, qy, qz, qw)))


@wp.func
def base_planar(x: Any, y: Any, yaw: Any):
    """``T_world_root`` of a planar or wheeled base: root on the ground plane (z = 0), turned by ``yaw``."""
    return wp.transformation(wp.vector(x, y, type(x)(0.0)), quat_about_z(yaw))


@wp.func
def joint_revolute(axis: Any, angle: Any):
    """Motion of a revolute/continuous joint: rotation by ``angle`` [rad] about the unit ``axis``."""
    z = type(angle)(0.0)
    return wp.transformation(wp.vector(z, z, z), wp.quat_from_axis_angle(axis, angle))


@wp.func
def joint_prismatic(axis: Any, d: Any):
    """Motion of a prismatic joint: translation by ``d`` [m] along the unit ``axis``."""
    z = type(d)(0.0)
    return wp.transformation(axis * d, wp.quaternion(z, z, z, type(d)(1.0)))


@wp.func
def joint_spherical(qx: Any, qy: Any, qz: Any, qw: Any):
    """Motion of a spherical joint: the normalised quaternion ``(qx, qy, qz, qw)``."""
    z = type(qx)(0.0)
    return wp.transformation(wp.vector(z, z, z), wp.normalize(wp.quaternion(qx, qy, qz, qw)))


@wp.func
def heading_transform(T_world_root: Any):
    """``T_world_heading``: origin on the ground under the root, x along the root's facing direction, z up.

    The facing direction is the root's x axis projected on the ground plane. Where that
    projection vanishes (root x axis vertical) the heading is the world x axis and the
    gradient of the yaw is zero.
    """
    p = wp.transform_get_translation(T_world_root)
    z = type(p[0])(0.0)
    f = wp.quat_rotate(wp.transform_get_rotation(T_world_root), wp.vector(type(p[0])(1.0), z, z))
    n2 = f[0] * f[0] + f[1] * f[1]
    yaw = z
    if n2 > type(p[0])(1.0e-12):
        yaw = wp.atan2(f[1], f[0])
    return wp.transformation(wp.vector(p[0], p[1], z), quat_about_z(yaw))
