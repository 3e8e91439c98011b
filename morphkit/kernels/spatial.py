"""Warp device helpers: the heading frame (generic over float32/float64).

Every function here is a ``@wp.func`` (pure math, no allocation) used by the kernels in
:mod:`morphkit.kernels.end_effectors`; it is the Warp twin of :func:`morphkit.rotations.heading_frame`
(tests hold the two equal). Quaternions are xyzw, transforms ``[p, q]`` (:mod:`morphkit.conventions`).
"""

from __future__ import annotations

from typing import Any

import warp as wp

__all__ = ["heading_transform"]


@wp.func
def heading_transform(T_world_root: Any):
    """``T_world_heading``: origin at the root, x along the root's facing direction, z up.

    The facing direction is the root's x axis projected on the ground plane. Where that
    projection vanishes (root x axis vertical) the heading is the world x axis and the
    gradient of the yaw is zero.
    """
    p = wp.transform_get_translation(T_world_root)
    z = type(p[0])(0.0)
    f = wp.quat_rotate(wp.transform_get_rotation(T_world_root), wp.vector(type(p[0])(1.0), z, z))
    n2 = f[0] * f[0] + f[1] * f[1]
    h = z
    if n2 > type(p[0])(1.0e-12):
        h = wp.atan2(f[1], f[0]) * type(p[0])(0.5)
    return wp.transformation(p, wp.quaternion(z, z, wp.sin(h), wp.cos(h)))
