"""Ground contact, foot sliding and self-collision queries (kernels and launchers).

Ground queries read end-effector positions (from :func:`~morphkit.kernels.eval_end_effectors`)
and a horizontal ground plane ``z = ground_height``:

- **height** of each foot above the ground, $h = p_z - z_g$ [m];
- **penetration depth** $\\max(0, -h)$ [m] (differentiable: $\\partial/\\partial p_z = -1$ below ground);
- **contact flags** over a motion: $h < h_\\text{thr}$ and horizontal speed
  $\\lVert (v_x, v_y) \\rVert < v_\\text{thr}$;
- **sliding speed** over a motion: the horizontal speed $\\lVert (v_x, v_y) \\rVert$ [m/s] where
  $h < h_\\text{thr}$, else 0 (differentiable w.r.t. the positions; the gate is not).

Velocities of a motion ``[..., T, E]`` are finite differences along time times ``fps``, as
:func:`~morphkit.kernels.end_effectors.eval_finite_difference`: the backward difference
$v_t = (p_t - p_{t-1})\\,\\text{fps}$, frame 0 copying frame 1 (a single frame has zero
velocity). The sliding gate uses the height only, so a foot that skates fast on the ground still
counts (a speed threshold would hide exactly that).

Self-collision measures the link shapes (:mod:`morphkit.kernels.geometry`) pairwise over a list
of candidate pairs built once on the host by :func:`self_collision_pairs`, given the link
transforms from :func:`~morphkit.kernels.eval_fk`: the signed distance per pair and the
penetration depth $\\max(0, -d)$, both with Warp adjoints.

Every launcher accepts any leading batch shape, ``out=`` to reuse a buffer and ``device=``
(default: the input array's device), and works in float32 or float64 (the input's precision).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import warp as wp

from morphkit.contact_rules import UFR
from morphkit.errors import GraphError
from morphkit.graph.types import EndEffectorRole, JointType, ShapeType
from morphkit.kernels._collision_kernels import self_collision_kernel, shape_ground_kernel
from morphkit.kernels.dtypes import transform_type, vec3_type
from morphkit.kernels.launch import check_device, launch, output_array, resolve_device
from morphkit.model.kinematic_model import KinematicModel

__all__ = [
    "RecordedSelfCollision",
    "SelfCollisionPairs",
    "eval_contact_flags",
    "eval_foot_heights",
    "eval_foot_heights_adjoint",
    "eval_penetration_depth",
    "eval_penetration_depth_adjoint",
    "eval_self_collision_distance",
    "eval_self_collision_distance_adjoint",
    "eval_self_collision_penetration",
    "eval_self_collision_penetration_adjoint",
    "eval_shape_ground_distance",
    "eval_shape_ground_distance_adjoint",
    "eval_sliding_speed",
    "eval_sliding_speed_adjoint",
    "foot_indices",
    "rigid_bodies",
    "self_collision_pairs",
]


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
@wp.kernel
def foot_height_kernel(
    points: wp.array2d[Any],
    feet: wp.array[wp.int32],
    ground: Any,
    penetration: int,
    out: wp.array2d[Any],
):
    """``out[n, f]``: height of point ``feet[f]`` above the ground, or its penetration depth."""
    n, f = wp.tid()
    h = points[n, feet[f]][2] - ground
    if penetration != 0:
        h = wp.max(-h, h * type(h)(0.0))
    out[n, f] = h


@wp.func
def _frame_velocity(points: Any, n: int, t: int, e: int, fps: Any):
    # Backward difference, frame 0 copying frame 1 (as eval_finite_difference), zero for a single frame.
    T = points.shape[1]
    t0 = wp.max(t - 1, 0)
    t1 = wp.min(t0 + 1, T - 1)
    v = points[n, t, e] * (fps * type(fps)(0.0))
    if t1 > t0:
        v = (points[n, t1, e] - points[n, t0, e]) * fps
    return v


@wp.kernel
def sliding_speed_kernel(
    points: wp.array3d[Any],
    feet: wp.array[wp.int32],
    ground: Any,
    height_threshold: Any,
    fps: Any,
    out: wp.array3d[Any],
):
    """``out[n, t, f]``: horizontal speed of foot ``feet[f]`` at frame ``t`` where it is below the height threshold."""
    n, t, f = wp.tid()
    e = feet[f]
    v = _frame_velocity(points, n, t, e, fps)
    s = v[0] * type(fps)(0.0)
    if points[n, t, e][2] - ground < height_threshold:
        s = wp.length(wp.vector(v[0], v[1]))
    out[n, t, f] = s


@wp.kernel
def contact_flags_kernel(
    points: wp.array3d[Any],
    feet: wp.array[wp.int32],
    ground: Any,
    height_threshold: Any,
    speed_threshold: Any,
    fps: Any,
    out: wp.array3d[wp.bool],
):
    """``out[n, t, f]``: foot ``feet[f]`` is below the height threshold and horizontally slower than the speed
    threshold."""
    n, t, f = wp.tid()
    e = feet[f]
    v = _frame_velocity(points, n, t, e, fps)
    out[n, t, f] = points[n, t, e][2] - ground < height_threshold and wp.length(wp.vector(v[0], v[1])) < speed_threshold


# Concrete instances, so ahead-of-time compilation builds both precisions.
for _s, _v in ((wp.float32, wp.vec3f), (wp.float64, wp.vec3d)):
    wp.overload(foot_height_kernel, [wp.array2d[_v], wp.array[wp.int32], _s, int, wp.array2d[_s]])
    wp.overload(sliding_speed_kernel, [wp.array3d[_v], wp.array[wp.int32], _s, _s, _s, wp.array3d[_s]])
    wp.overload(contact_flags_kernel, [wp.array3d[_v], wp.array[wp.int32], _s, _s, _s, _s, wp.array3d[wp.bool]])


# ---------------------------------------------------------------------------------------------
# input handling
# ---------------------------------------------------------------------------------------------
def _scalar_of(dtype: Any) -> Any:
    return wp.float64 if getattr(dtype, "_wp_scalar_type_", dtype) == wp.float64 else wp.float32


def _as_vec_array(x: Any, width: int, vec_of: Any, device: Any, what: str) -> wp.array:
    """``x`` as a contiguous Warp array of ``width``-vectors (or transforms) of shape [...].

    Accepts a Warp array of such vectors, a Warp float array [..., width] (viewed, no copy) or
    anything NumPy reads as [..., width] (copied to ``device``).
    """
    if isinstance(x, wp.array):
        check_device(x, device, what)
        if not x.is_contiguous:
            x = x.contiguous()
        if x.dtype in (wp.float32, wp.float64):
            if x.ndim < 1 or x.shape[-1] != width:
                raise GraphError(f"{what}: expected shape [..., {width}], got {list(x.shape)}")
            return x.view(vec_of(x.dtype))
        if wp.types.type_size(x.dtype) != width or getattr(x.dtype, "_wp_scalar_type_", None) not in (
            wp.float32,
            wp.float64,
        ):
            raise GraphError(f"{what}: expected float {width}-vectors, got {wp.types.type_repr(x.dtype)}")
        return x
    arr = np.asarray(x)
    if arr.dtype not in (np.float32, np.float64):
        arr = arr.astype(np.float32)
    if arr.ndim < 1 or arr.shape[-1] != width:
        raise GraphError(f"{what}: expected shape [..., {width}], got {list(arr.shape)}")
    scalar = wp.float64 if arr.dtype == np.float64 else wp.float32
    return wp.array(np.ascontiguousarray(arr), dtype=vec_of(scalar), device=device)


def _as_points(points: Any, device: Any, what: str = "points") -> wp.array:
    return _as_vec_array(points, 3, vec3_type, device, what)


_feet_cache: dict[tuple[str, tuple[int, ...]], wp.array] = {}


def _feet_array(feet: Any, E: int, device: Any) -> wp.array:
    """Foot indices as an int32 Warp array on ``device`` (cached: callers pass the same few lists)."""
    if feet is None:
        idx = tuple(range(E))
    else:
        idx = tuple(int(i) for i in np.asarray(feet, dtype=np.int64).reshape(-1))
        if idx and (min(idx) < 0 or max(idx) >= E):
            raise GraphError(f"feet: indices {list(idx)} out of range for {E} end-effectors")
    key = (str(device), idx)
    hit = _feet_cache.get(key)
    if hit is None:
        if len(_feet_cache) > 256:
            _feet_cache.clear()
        hit = _feet_cache[key] = wp.array(np.asarray(idx, dtype=np.int32), dtype=wp.int32, device=device)
    return hit


def foot_indices(model: KinematicModel) -> np.ndarray:
    """Indices of the model's end-effectors whose role is ``foot``, shape [F], int32."""
    return np.flatnonzero(np.asarray(model.ee_role) == int(EndEffectorRole.FOOT)).astype(np.int32)


# ---------------------------------------------------------------------------------------------
# ground: heights and penetration
# ---------------------------------------------------------------------------------------------
def _foot_height(points: Any, feet: Any, ground_height: float, penetration: int, out: Any, device: Any) -> wp.array:
    device = resolve_device(device, points, out=out)
    pts = _as_points(points, device)
    if pts.ndim < 1:
        raise GraphError(f"points: expected shape [..., E], got {list(pts.shape)}")
    lead, E = tuple(pts.shape[:-1]), pts.shape[-1]
    N = int(np.prod(lead)) if lead else 1
    feet_a = _feet_array(feet, E, device)
    F = feet_a.shape[0]
    scalar = _scalar_of(pts.dtype)
    out = output_array(out, (*lead, F), scalar, device, zeros=True, requires_grad=pts.requires_grad)
    if N and F:
        wp.launch(foot_height_kernel, dim=(N, F),
                  inputs=[pts.reshape((N, E)), feet_a, scalar(ground_height), penetration],
                  outputs=[out.reshape((N, F))], device=device)
    return out


def eval_foot_heights(points: Any, *, feet: Any = None, ground_height: float = 0.0, out: wp.array | None = None,
                      device: Any = None) -> wp.array:
    """Height of each foot above the ground plane, $h = p_z - z_g$.

    Args:
        points: End-effector positions, shape [..., E] of ``wp.vec3`` (or a float array [..., E, 3]),
            world frame [m].
        feet: Which of the E points are feet (indices, shape [F]); default all. See :func:`foot_indices`.
        ground_height: Ground plane height $z_g$ [m].
        out: Optional output, shape [..., F], the input's float type.
        device: Launch device (default: the input's).

    Returns:
        Heights [m], shape [..., F].
    """
    return _foot_height(points, feet, ground_height, 0, out, device)


def eval_penetration_depth(points: Any, *, feet: Any = None, ground_height: float = 0.0,
                           out: wp.array | None = None, device: Any = None) -> wp.array:
    """Penetration depth of each foot into the ground, $\\max(0, z_g - p_z)$ [m], shape [..., F].

    Same arguments as :func:`eval_foot_heights`. A foot 1 cm below the ground gives 0.01.
    """
    return _foot_height(points, feet, ground_height, 1, out, device)


def _foot_height_adjoint(points: Any, adj_out: wp.array, feet: Any, ground_height: float, penetration: int,
                         adj_points: Any, device: Any) -> wp.array:
    device = resolve_device(device, points, out=adj_out)
    check_device(adj_out, device, "adj_out")
    pts = _as_points(points, device)
    lead, E = tuple(pts.shape[:-1]), pts.shape[-1]
    N = int(np.prod(lead)) if lead else 1
    feet_a = _feet_array(feet, E, device)
    F = feet_a.shape[0]
    scalar = _scalar_of(pts.dtype)
    adj_points = output_array(adj_points, tuple(pts.shape), pts.dtype, device, zeros=True)
    if tuple(adj_out.shape) != (*lead, F):
        raise GraphError(f"adj_out: expected shape {[*lead, F]}, got {list(adj_out.shape)}")
    if N and F:
        out = adj_out.contiguous().reshape((N, F))
        wp.launch(foot_height_kernel, dim=(N, F),
                  inputs=[pts.reshape((N, E)), feet_a, scalar(ground_height), penetration], outputs=[out],
                  adj_inputs=[adj_points.reshape((N, E)), None, scalar(0.0), 0], adj_outputs=[out],
                  adjoint=True, device=device)
    return adj_points


def eval_foot_heights_adjoint(points: Any, adj_out: wp.array, *, feet: Any = None, ground_height: float = 0.0,
                              adj_points: wp.array | None = None, device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_foot_heights` into ``adj_points`` ([..., E] vec3)."""
    return _foot_height_adjoint(points, adj_out, feet, ground_height, 0, adj_points, device)


def eval_penetration_depth_adjoint(points: Any, adj_out: wp.array, *, feet: Any = None, ground_height: float = 0.0,
                                   adj_points: wp.array | None = None, device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_penetration_depth` into ``adj_points`` ([..., E] vec3)."""
    return _foot_height_adjoint(points, adj_out, feet, ground_height, 1, adj_points, device)


# ---------------------------------------------------------------------------------------------
# motions: contact flags and sliding
# ---------------------------------------------------------------------------------------------
def _motion_points(points: Any, device: Any) -> tuple[wp.array, tuple[int, ...], int, int, int]:
    pts = _as_points(points, device)
    if pts.ndim < 2:
        raise GraphError(f"points: expected shape [..., T, E] (a motion), got {list(pts.shape)}")
    lead, T, E = tuple(pts.shape[:-2]), pts.shape[-2], pts.shape[-1]
    N = int(np.prod(lead)) if lead else 1
    return pts, lead, N, T, E


def _check_fps(fps: float) -> None:
    if not np.isfinite(fps) or fps <= 0:
        raise GraphError(f"fps must be a positive number, got {fps!r}")


def eval_sliding_speed(points: Any, fps: float, *, feet: Any = None, height_threshold: float = UFR.height,
                       ground_height: float = 0.0, out: wp.array | None = None, device: Any = None) -> wp.array:
    """Horizontal foot speed while in contact, per frame.

    $s_t = \\lVert (v_{t,x}, v_{t,y}) \\rVert$ where $p_{t,z} - z_g <$ ``height_threshold``, else 0,
    with $v_t$ the backward difference times ``fps`` (frame 0 copies frame 1). A foot moving
    1 cm per frame on the ground at 30 fps slides at 0.3 m/s.

    Args:
        points: End-effector positions of a motion, shape [..., T, E] of ``wp.vec3`` (or [..., T, E, 3]) [m].
        fps: Frames per second [1/s].
        feet: Which of the E points are feet (indices [F]); default all.
        height_threshold: A foot lower than this above the ground is in contact [m].
        ground_height: Ground plane height [m].
        out: Optional output [..., T, F].
        device: Launch device.

    Returns:
        Sliding speeds [m/s], shape [..., T, F].
    """
    _check_fps(fps)
    device = resolve_device(device, points, out=out)
    pts, lead, N, T, E = _motion_points(points, device)
    feet_a = _feet_array(feet, E, device)
    F = feet_a.shape[0]
    scalar = _scalar_of(pts.dtype)
    out = output_array(out, (*lead, T, F), scalar, device, zeros=True, requires_grad=pts.requires_grad)
    if N and T and F:
        wp.launch(sliding_speed_kernel, dim=(N, T, F),
                  inputs=[pts.reshape((N, T, E)), feet_a, scalar(ground_height), scalar(height_threshold),
                          scalar(fps)],
                  outputs=[out.reshape((N, T, F))], device=device)
    return out


def eval_sliding_speed_adjoint(points: Any, adj_out: wp.array, fps: float, *, feet: Any = None,
                               height_threshold: float = UFR.height, ground_height: float = 0.0,
                               adj_points: wp.array | None = None, device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_sliding_speed` into ``adj_points`` ([..., T, E] vec3).

    The contact gate is piecewise constant and gets no gradient; at zero speed the gradient is zero.
    """
    _check_fps(fps)
    device = resolve_device(device, points, out=adj_out)
    check_device(adj_out, device, "adj_out")
    pts, lead, N, T, E = _motion_points(points, device)
    feet_a = _feet_array(feet, E, device)
    F = feet_a.shape[0]
    scalar = _scalar_of(pts.dtype)
    adj_points = output_array(adj_points, tuple(pts.shape), pts.dtype, device, zeros=True)
    if tuple(adj_out.shape) != (*lead, T, F):
        raise GraphError(f"adj_out: expected shape {[*lead, T, F]}, got {list(adj_out.shape)}")
    if N and T and F:
        out = adj_out.contiguous().reshape((N, T, F))
        wp.launch(sliding_speed_kernel, dim=(N, T, F),
                  inputs=[pts.reshape((N, T, E)), feet_a, scalar(ground_height), scalar(height_threshold),
                          scalar(fps)],
                  outputs=[out],
                  adj_inputs=[adj_points.reshape((N, T, E)), None, scalar(0.0), scalar(0.0), scalar(0.0)],
                  adj_outputs=[out], adjoint=True, device=device)
    return adj_points


def eval_contact_flags(points: Any, fps: float, *, feet: Any = None, height_threshold: float = UFR.height,
                       speed_threshold: float = UFR.speed, ground_height: float = 0.0, out: wp.array | None = None,
                       device: Any = None) -> wp.array:
    """Foot contact flags of a motion: below ``height_threshold`` [m] and slower than ``speed_threshold`` [m/s].

    The one contact rule (:mod:`morphkit.contact_rules`; defaults its ``ufr`` preset): the speed is the
    horizontal backward-difference speed of :func:`eval_sliding_speed` (frame 0 copies frame 1).
    Same array arguments as :func:`eval_sliding_speed`; returns ``wp.bool`` flags, shape [..., T, F].
    """
    _check_fps(fps)
    device = resolve_device(device, points, out=out)
    pts, lead, N, T, E = _motion_points(points, device)
    feet_a = _feet_array(feet, E, device)
    F = feet_a.shape[0]
    scalar = _scalar_of(pts.dtype)
    out = output_array(out, (*lead, T, F), wp.bool, device, zeros=True)
    if N and T and F:
        wp.launch(contact_flags_kernel, dim=(N, T, F),
                  inputs=[pts.reshape((N, T, E)), feet_a, scalar(ground_height), scalar(height_threshold),
                          scalar(speed_threshold), scalar(fps)],
                  outputs=[out.reshape((N, T, F))], device=device)
    return out


# ---------------------------------------------------------------------------------------------
# link shapes: ground and self-collision
# ---------------------------------------------------------------------------------------------
def _link_transforms(model: KinematicModel, link_X: Any, device: Any) -> tuple[wp.array, tuple[int, ...], int]:
    X = _as_vec_array(link_X, 7, transform_type, device, "link_X")
    L = model.link_count
    if X.ndim < 1 or X.shape[-1] != L:
        raise GraphError(f"link_X: expected shape [..., {L}] of transforms for {model.name!r}, got {list(X.shape)}")
    lead = tuple(X.shape[:-1])
    return X, lead, int(np.prod(lead)) if lead else 1


def eval_shape_ground_distance(model: KinematicModel, link_X: Any, *, ground_height: float = 0.0,
                               out: wp.array | None = None, device: Any = None) -> wp.array:
    """Height of every link shape's lowest point above the ground (negative: below it).

    Args:
        model: The compiled morphology (its ``shape_*`` arrays).
        link_X: Link transforms ``T_world_link`` from :func:`~morphkit.kernels.eval_fk`, shape [..., L].
        ground_height: Ground plane height [m].
        out: Optional output [..., S].
        device: Launch device.

    Returns:
        Signed heights [m], shape [..., S]; mesh shapes get :data:`~morphkit.kernels.geometry.NO_CONTACT_DISTANCE`.
    """
    device = resolve_device(device, link_X, out=out)
    X, lead, N = _link_transforms(model, link_X, device)
    scalar = _scalar_of(X.dtype)
    S = model.shape_count
    out = output_array(out, (*lead, S), scalar, device, zeros=True, requires_grad=X.requires_grad)
    if N and S:
        a = model.arrays(device, scalar)
        launch(shape_ground_kernel, N, device,
               [X.reshape((N, model.link_count)), a.shape_link, a.shape_type, a.shape_X_link, a.shape_params,
                scalar(ground_height), 0],
               [out.reshape((N, S))], dim_tail=(S,))
    return out


def eval_shape_ground_distance_adjoint(model: KinematicModel, link_X: Any, adj_out: wp.array, *,
                                       ground_height: float = 0.0, adj_link_X: wp.array | None = None,
                                       device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_shape_ground_distance` into ``adj_link_X`` ([..., L])."""
    device = resolve_device(device, link_X, out=adj_out)
    check_device(adj_out, device, "adj_out")
    X, lead, N = _link_transforms(model, link_X, device)
    scalar = _scalar_of(X.dtype)
    S, L = model.shape_count, model.link_count
    adj_link_X = output_array(adj_link_X, (*lead, L), X.dtype, device, zeros=True)
    if tuple(adj_out.shape) != (*lead, S):
        raise GraphError(f"adj_out: expected shape {[*lead, S]}, got {list(adj_out.shape)}")
    if N and S:
        a = model.arrays(device, scalar)
        out = adj_out.contiguous().reshape((N, S))
        launch(shape_ground_kernel, N, device,
               [X.reshape((N, L)), a.shape_link, a.shape_type, a.shape_X_link, a.shape_params,
                scalar(ground_height), 0],
               [out], adjoint=True,
               adj_inputs=[adj_link_X.reshape((N, L)), None, None, None, None, scalar(0.0), 0],
               adj_outputs=[out], dim_tail=(S,))
    return adj_link_X


@dataclass(frozen=True, eq=False)
class SelfCollisionPairs:
    """Candidate shape pairs for self-collision queries (build with :func:`self_collision_pairs`).

    ``P`` is the number of pairs; shape indices refer to the model's ``shape_*`` arrays.
    """

    shape_a: np.ndarray
    """First shape of each pair, shape [P], int32."""
    shape_b: np.ndarray
    """Second shape of each pair, shape [P], int32."""
    link_a: np.ndarray
    """Link of ``shape_a``, shape [P], int32."""
    link_b: np.ndarray
    """Link of ``shape_b``, shape [P], int32."""
    rest_distance: np.ndarray
    """Signed distance of each pair at the model's rest pose [m], shape [P]."""
    names: tuple[str, ...]
    """``"link_a[i] / link_b[j]"`` per pair (``i``, ``j``: the shape's index on its link), shape [P]."""
    skipped: dict[str, int]
    """How many shape pairs each filter removed: ``same_body``, ``adjacent``, ``rest_overlap``, ``unsupported``."""
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def pair_count(self) -> int:
        """Number of candidate pairs P."""
        return len(self.shape_a)

    def touching(self, links: Iterable[int]) -> SelfCollisionPairs:
        """The pairs with a shape on at least one of ``links`` (link indices), in the same order.

        ``skipped`` is copied unchanged: it counts what :func:`self_collision_pairs` filtered, not this selection.
        """
        idx = np.array(sorted(int(i) for i in links), dtype=np.int64)
        return self.select(np.isin(self.link_a, idx) | np.isin(self.link_b, idx))

    def apart_from(self, links: Iterable[int]) -> SelfCollisionPairs:
        """The pairs with no shape on any of ``links`` (link indices), in the same order (``skipped`` as
        :meth:`touching`)."""
        idx = np.array(sorted(int(i) for i in links), dtype=np.int64)
        return self.select(~(np.isin(self.link_a, idx) | np.isin(self.link_b, idx)))

    def select(self, keep: np.ndarray) -> SelfCollisionPairs:
        """The pairs where ``keep`` [P] is true, in the same order (``skipped`` as :meth:`touching`)."""
        keep = np.asarray(keep, dtype=bool)
        return SelfCollisionPairs(
            shape_a=self.shape_a[keep], shape_b=self.shape_b[keep], link_a=self.link_a[keep],
            link_b=self.link_b[keep], rest_distance=self.rest_distance[keep],
            names=tuple(n for n, k in zip(self.names, keep, strict=True) if k), skipped=dict(self.skipped),
        )

    def arrays(self, device: Any = None) -> tuple[wp.array, wp.array]:
        """``(shape_a, shape_b)`` as int32 Warp arrays on ``device`` (cached)."""
        dev = wp.get_device(device)
        hit = self._cache.get(dev.alias)
        if hit is None:
            hit = (
                wp.array(self.shape_a, dtype=wp.int32, device=dev),
                wp.array(self.shape_b, dtype=wp.int32, device=dev),
            )
            self._cache[dev.alias] = hit
        return hit


def rigid_bodies(model: KinematicModel) -> np.ndarray:
    """Body id of every link [L]: links joined by fixed joints share one (they never move apart)."""
    body = np.arange(model.link_count)
    for j in range(model.joint_count):
        if int(model.joint_type[j]) == JointType.FIXED:
            body[j + 1] = body[int(model.joint_parent[j])]  # parents precede children: already resolved
    return body


def self_collision_pairs(model: KinematicModel, *, rest_margin: float = 0.0, skip_adjacent: bool = True,
                         rest_q: Any = None) -> SelfCollisionPairs:
    """Candidate shape pairs for self-collision, filtered once on the host.

    Every unordered pair of supported shapes (sphere, capsule, box, cylinder; meshes are for
    rendering and skipped) is kept unless:

    - both shapes are on the same rigid body (one link, or links joined by fixed joints):
      their distance never changes;
    - their bodies are joined by one moving joint (parent–child), when ``skip_adjacent``:
      neighbouring shapes touch at the joint by design;
    - their links are a pair of ``model.collision_exclude`` (MJCF ``<contact><exclude>``);
    - they are closer than ``rest_margin`` [m] at the rest pose (overlapping there for a
      margin of 0): such overlaps are part of the design, not collisions.

    Args:
        model: The compiled morphology.
        rest_margin: Pairs with rest distance ≤ this are skipped [m].
        skip_adjacent: Skip parent–child body pairs.
        rest_q: The reference pose, shape [C]; default ``model.rest_q``.

    Returns:
        The pairs, with their rest distances and per-filter skip counts.
    """
    from morphkit.kernels.fk import eval_fk  # the FK launcher lives beside; imported here to keep this module light

    body = rigid_bodies(model)
    parent_body = np.full(model.link_count, -1)
    for j in range(model.joint_count):
        child = j + 1
        if body[child] == child:  # the child starts a new body: its parent body is across a moving joint
            parent_body[child] = body[int(model.joint_parent[j])]
    excluded = {frozenset((int(body[a]), int(body[b]))) for a, b in np.asarray(model.collision_exclude)}
    supported = {int(t) for t in (ShapeType.SPHERE, ShapeType.CAPSULE, ShapeType.BOX, ShapeType.CYLINDER)}
    S = model.shape_count
    skipped = {"same_body": 0, "adjacent": 0, "excluded": 0, "rest_overlap": 0, "unsupported": 0}
    cand_a: list[int] = []
    cand_b: list[int] = []
    for a in range(S):
        for b in range(a + 1, S):
            la, lb = int(model.shape_link[a]), int(model.shape_link[b])
            ba, bb = body[la], body[lb]
            if int(model.shape_type[a]) not in supported or int(model.shape_type[b]) not in supported:
                skipped["unsupported"] += 1
            elif ba == bb:
                skipped["same_body"] += 1
            elif skip_adjacent and (parent_body[ba] == bb or parent_body[bb] == ba):
                skipped["adjacent"] += 1
            elif frozenset((int(ba), int(bb))) in excluded:
                skipped["excluded"] += 1
            else:
                cand_a.append(a)
                cand_b.append(b)

    rest = np.zeros(0)
    if cand_a:
        q0 = np.asarray(model.rest_q if rest_q is None else rest_q, dtype=np.float64)
        if q0.shape != (model.coordinate_count,):
            raise GraphError(f"rest_q: expected shape [{model.coordinate_count}], got {list(q0.shape)}")
        X = eval_fk(model, q0[None], device="cpu")
        pa = wp.array(np.asarray(cand_a, np.int32), dtype=wp.int32, device="cpu")
        pb = wp.array(np.asarray(cand_b, np.int32), dtype=wp.int32, device="cpu")
        out = wp.zeros((1, len(cand_a)), dtype=wp.float64, device="cpu")
        a = model.arrays("cpu", wp.float64)
        wp.launch(self_collision_kernel, dim=(1, len(cand_a)),
                  inputs=[X, a.shape_link, a.shape_type, a.shape_X_link, a.shape_params, pa, pb, 0, 0],
                  outputs=[out], device="cpu")
        rest = out.numpy()[0]
    keep = rest > rest_margin
    skipped["rest_overlap"] = int((~keep).sum())
    sa = np.asarray(cand_a, dtype=np.int32)[keep]
    sb = np.asarray(cand_b, dtype=np.int32)[keep]

    shape_rank = np.zeros(S, dtype=int)  # index of each shape among its link's shapes
    seen: dict[int, int] = {}
    for s in range(S):
        link = int(model.shape_link[s])
        shape_rank[s] = seen.get(link, 0)
        seen[link] = shape_rank[s] + 1
    names = tuple(
        f"{model.link_names[model.shape_link[a]]}[{shape_rank[a]}] / {model.link_names[model.shape_link[b]]}"
        f"[{shape_rank[b]}]"
        for a, b in zip(sa, sb, strict=True)
    )

    def ro(x: np.ndarray, dtype: Any) -> np.ndarray:
        y = np.array(x, dtype=dtype)
        y.setflags(write=False)
        return y

    return SelfCollisionPairs(
        shape_a=ro(sa, np.int32),
        shape_b=ro(sb, np.int32),
        link_a=ro(np.asarray(model.shape_link)[sa], np.int32),
        link_b=ro(np.asarray(model.shape_link)[sb], np.int32),
        rest_distance=ro(rest[keep], np.float64),
        names=names,
        skipped=skipped,
    )


def _self_collision(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any, penetration: int, out: Any,
                    device: Any) -> wp.array:
    device = resolve_device(device, link_X, out=out)
    X, lead, N = _link_transforms(model, link_X, device)
    scalar = _scalar_of(X.dtype)
    P = pairs.pair_count
    out = output_array(out, (*lead, P), scalar, device, zeros=True, requires_grad=X.requires_grad)
    if N and P:
        a = model.arrays(device, scalar)
        pa, pb = pairs.arrays(device)
        launch(self_collision_kernel, N, device,
               [X.reshape((N, model.link_count)), a.shape_link, a.shape_type, a.shape_X_link, a.shape_params,
                pa, pb, penetration, 0],
               [out.reshape((N, P))], dim_tail=(P,))
    return out


def eval_self_collision_distance(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any, *,
                                 out: wp.array | None = None, device: Any = None) -> wp.array:
    """Signed distance of every candidate shape pair (negative: overlapping).

    Args:
        model: The compiled morphology.
        pairs: Candidate pairs from :func:`self_collision_pairs` for this model.
        link_X: Link transforms ``T_world_link`` from :func:`~morphkit.kernels.eval_fk`, shape [..., L]
            (or a float array [..., L, 7]).
        out: Optional output [..., P].
        device: Launch device.

    Returns:
        Signed distances [m], shape [..., P] (see :mod:`morphkit.kernels.geometry` for which pairs are exact).
    """
    return _self_collision(model, pairs, link_X, 0, out, device)


class RecordedSelfCollision:
    """:func:`eval_self_collision_distance` on the CPU in float64 for a fixed batch of ``batch`` poses, its launch
    recorded once (``record_cmd``): for many small calls, such as a per-frame check, whose cost would otherwise be
    argument packing rather than the kernel.

    Call it with link transforms [batch, L, 7] (NumPy, ``T_world_link``); it returns the signed distances
    [batch, P] [m] in a buffer the next call overwrites.
    """

    def __init__(self, model: KinematicModel, pairs: SelfCollisionPairs, batch: int) -> None:
        L, P = model.link_count, pairs.pair_count
        self._X = wp.zeros((batch, L), dtype=wp.transformd, device="cpu")
        self._out = wp.zeros((batch, max(P, 1)), dtype=wp.float64, device="cpu")
        self._X_np = self._X.numpy().reshape(batch, L, 7)
        self._out_np = self._out.numpy()[:, :P]
        a = model.arrays("cpu", wp.float64)
        pa, pb = pairs.arrays("cpu")
        self._keep = (a, pa, pb)
        self._cmd = wp.launch(self_collision_kernel, dim=(batch, P), device="cpu", record_cmd=True,
                              inputs=[self._X, a.shape_link, a.shape_type, a.shape_X_link, a.shape_params, pa, pb,
                                      0, 0],
                              outputs=[self._out]) if P else None

    def __call__(self, link_X: np.ndarray) -> np.ndarray:
        if self._cmd is not None:
            self._X_np[:] = link_X
            self._cmd.launch()
        return self._out_np


def eval_self_collision_penetration(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any, *,
                                    out: wp.array | None = None, device: Any = None) -> wp.array:
    """Penetration depth $\\max(0, -d)$ of every candidate pair [m], shape [..., P] (arguments as
    :func:`eval_self_collision_distance`)."""
    return _self_collision(model, pairs, link_X, 1, out, device)


def _self_collision_adjoint(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any, adj_out: wp.array,
                            penetration: int, adj_link_X: Any, device: Any) -> wp.array:
    device = resolve_device(device, link_X, out=adj_out)
    check_device(adj_out, device, "adj_out")
    X, lead, N = _link_transforms(model, link_X, device)
    scalar = _scalar_of(X.dtype)
    P = pairs.pair_count
    L = model.link_count
    adj_link_X = output_array(adj_link_X, (*lead, L), X.dtype, device, zeros=True)
    if tuple(adj_out.shape) != (*lead, P):
        raise GraphError(f"adj_out: expected shape {[*lead, P]}, got {list(adj_out.shape)}")
    if N and P:
        a = model.arrays(device, scalar)
        pa, pb = pairs.arrays(device)
        out = adj_out.contiguous().reshape((N, P))
        launch(self_collision_kernel, N, device,
               [X.reshape((N, L)), a.shape_link, a.shape_type, a.shape_X_link, a.shape_params, pa, pb,
                penetration, 0],
               [out], adjoint=True,
               adj_inputs=[adj_link_X.reshape((N, L)), None, None, None, None, None, None, 0, 0],
               adj_outputs=[out], dim_tail=(P,))
    return adj_link_X


def eval_self_collision_distance_adjoint(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any,
                                         adj_out: wp.array, *, adj_link_X: wp.array | None = None,
                                         device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_self_collision_distance` into ``adj_link_X`` ([..., L])."""
    return _self_collision_adjoint(model, pairs, link_X, adj_out, 0, adj_link_X, device)


def eval_self_collision_penetration_adjoint(model: KinematicModel, pairs: SelfCollisionPairs, link_X: Any,
                                            adj_out: wp.array, *, adj_link_X: wp.array | None = None,
                                            device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_self_collision_penetration` into ``adj_link_X``."""
    return _self_collision_adjoint(model, pairs, link_X, adj_out, 1, adj_link_X, device)

