"""Kernels over link shapes: ground distances and self-collision pair distances (launched by
:mod:`morphkit.kernels.contact`).

They live in their own Warp module because the shape-pair dispatch is by far the largest code
in the contact family: foot queries then compile in a couple of seconds without it. The last
input of each kernel is the batch ``offset`` of a chunk (large CPU batches are split over threads
by :func:`morphkit.kernels.launch.launch`).
"""

from __future__ import annotations

from typing import Any

import warp as wp

from morphkit.kernels.geometry import shape_ground_distance, shape_pair_distance

__all__ = ["self_collision_kernel", "shape_ground_kernel"]


@wp.kernel
def shape_ground_kernel(
    link_X: wp.array2d[Any],
    shape_link: wp.array[wp.int32],
    shape_type: wp.array[wp.int32],
    shape_X_link: wp.array[Any],
    shape_params: wp.array[Any],
    ground: Any,
    offset: int,
    out: wp.array2d[Any],
):
    """``out[n, s]``: height of shape ``s``'s lowest point above the ground (meshes: far); ``n`` from ``offset``."""
    i, s = wp.tid()
    n = i + offset
    X = wp.transform_multiply(link_X[n, shape_link[s]], shape_X_link[s])
    out[n, s] = shape_ground_distance(shape_type[s], X, shape_params[s], ground)


@wp.kernel
def self_collision_kernel(
    link_X: wp.array2d[Any],
    shape_link: wp.array[wp.int32],
    shape_type: wp.array[wp.int32],
    shape_X_link: wp.array[Any],
    shape_params: wp.array[Any],
    pair_a: wp.array[wp.int32],
    pair_b: wp.array[wp.int32],
    penetration: int,
    offset: int,
    out: wp.array2d[Any],
):
    """``out[n, p]``: signed distance of candidate pair ``p`` (or its penetration depth); ``n`` from ``offset``."""
    i, p = wp.tid()
    n = i + offset
    a = pair_a[p]
    b = pair_b[p]
    Xa = wp.transform_multiply(link_X[n, shape_link[a]], shape_X_link[a])
    Xb = wp.transform_multiply(link_X[n, shape_link[b]], shape_X_link[b])
    d = shape_pair_distance(shape_type[a], Xa, shape_params[a], shape_type[b], Xb, shape_params[b])
    if penetration != 0:
        d = wp.max(-d, d * type(d)(0.0))
    out[n, p] = d


# Concrete instances, so ahead-of-time compilation builds both precisions.
for _s, _v, _t in ((wp.float32, wp.vec3f, wp.transformf), (wp.float64, wp.vec3d, wp.transformd)):
    wp.overload(
        shape_ground_kernel,
        [wp.array2d[_t], wp.array[wp.int32], wp.array[wp.int32], wp.array[_t], wp.array[_v], _s, int, wp.array2d[_s]],
    )
    wp.overload(
        self_collision_kernel,
        [wp.array2d[_t], wp.array[wp.int32], wp.array[wp.int32], wp.array[_t], wp.array[_v], wp.array[wp.int32],
         wp.array[wp.int32], int, int, wp.array2d[_s]],
    )
