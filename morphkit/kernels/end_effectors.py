"""End-effector kernels: poses in the world or the root's heading frame, and velocities of motions.

The heading frame ``T_world_heading`` is :mod:`morphkit.conventions`' one heading frame: origin at
the root, x along the root's facing direction (its x axis projected on the ground), z up; it is
the local frame of the ACE states. Velocities are backward differences (the conventions' one
velocity rule). End-effector positions are their points (``ee_offset``
in the link frame); orientations are their links'.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

from morphkit.errors import GraphError
from morphkit.kernels.fk import eval_fk, eval_fk_adjoint
from morphkit.kernels.launch import as_batch, check_device, launch, output_array, resolve_device
from morphkit.kernels.spatial import heading_transform
from morphkit.model.kinematic_model import KinematicModel

__all__ = [
    "eval_end_effector_velocities",
    "eval_end_effectors",
    "eval_end_effectors_adjoint",
    "eval_finite_difference",
    "eval_heading_transforms",
    "frame_code",
]

FRAMES = ("world", "heading")


def frame_code(frame: str) -> int:
    """0 for ``"world"``, 1 for ``"heading"``.

    Raises:
        GraphError: naming the valid frames.
    """
    if frame not in FRAMES:
        raise GraphError(f"unknown frame {frame!r}; expected one of: {', '.join(FRAMES)}")
    return FRAMES.index(frame)


# ---- kernels ----------------------------------------------------------------------------------
@wp.kernel
def end_effector_poses(
    Ts: wp.array2d[Any],
    ee_link: wp.array[wp.int32],
    ee_offset: wp.array[Any],
    heading: int,
    offset: int,
    pos: wp.array2d[Any],
    rot: wp.array2d[Any],
):
    """``pos[b, e]``, ``rot[b, e]``: end-effector point and link orientation, in world or heading frame."""
    i, e = wp.tid()
    b = i + offset
    T = Ts[b, ee_link[e]]
    if heading != 0:
        T = wp.transform_multiply(wp.transform_inverse(heading_transform(Ts[b, 0])), T)
    pos[b, e] = wp.transform_point(T, ee_offset[e])
    rot[b, e] = wp.transform_get_rotation(T)


@wp.kernel
def heading_transforms(Ts: wp.array2d[Any], offset: int, out: wp.array[Any]):
    """``out[b]`` = ``T_world_heading`` of pose ``b``'s root."""
    i = wp.tid()
    b = i + offset
    out[b] = heading_transform(Ts[b, 0])


@wp.kernel
def finite_difference(x: wp.array3d[Any], inv_dt: Any, offset: int, v: wp.array3d[Any]):
    """``v[b, t, n]``: backward difference ``x[t] - x[t-1]`` times ``inv_dt``; frame 0 copies frame 1."""
    i, t, n = wp.tid()
    b = i + offset
    T = x.shape[1]
    if T < 2:
        v[b, t, n] = x[b, t, n] - x[b, t, n]
    elif t == 0:
        v[b, t, n] = (x[b, 1, n] - x[b, 0, n]) * inv_dt
    else:
        v[b, t, n] = (x[b, t, n] - x[b, t - 1, n]) * inv_dt


@wp.kernel
def rotate_into_heading(Ts: wp.array2d[Any], v: wp.array2d[Any], offset: int, out: wp.array2d[Any]):
    """``out[b, n]`` = ``v[b, n]`` expressed in pose ``b``'s heading frame (rotation only)."""
    i, n = wp.tid()
    b = i + offset
    H = heading_transform(Ts[b, 0])
    out[b, n] = wp.quat_rotate_inv(wp.transform_get_rotation(H), v[b, n])


def _overloads() -> None:
    for s, v, q, t in ((wp.float32, wp.vec3, wp.quat, wp.transform), (wp.float64, wp.vec3d, wp.quatd, wp.transformd)):
        wp.overload(end_effector_poses, {"Ts": wp.array2d(dtype=t), "ee_offset": wp.array(dtype=v),
                                         "pos": wp.array2d(dtype=v), "rot": wp.array2d(dtype=q)})
        wp.overload(heading_transforms, {"Ts": wp.array2d(dtype=t), "out": wp.array(dtype=t)})
        wp.overload(finite_difference, {"x": wp.array3d(dtype=v), "inv_dt": s, "v": wp.array3d(dtype=v)})
        wp.overload(rotate_into_heading, {"Ts": wp.array2d(dtype=t), "v": wp.array2d(dtype=v),
                                          "out": wp.array2d(dtype=v)})


_overloads()


# ---- launchers --------------------------------------------------------------------------------
def _types(dtype: Any) -> tuple[Any, Any, Any]:
    if dtype == wp.float64:
        return wp.vec3d, wp.quatd, wp.transformd
    return wp.vec3, wp.quat, wp.transform


def eval_end_effectors(
    model: KinematicModel,
    q: Any,
    *,
    frame: str = "world",
    Ts_world_link: wp.array | None = None,
    out_positions: wp.array | None = None,
    out_orientations: wp.array | None = None,
    wheel_q: Any = None,
    device: Any = None,
) -> tuple[wp.array, wp.array]:
    """End-effector positions and orientations.

    Args:
        model: The compiled morphology.
        q: Coordinates, shape [..., C] (float32 or float64).
        frame: ``"world"`` or ``"heading"`` (the root's heading frame, see the module docstring).
        Ts_world_link: Link transforms of ``q`` from :func:`~morphkit.kernels.eval_fk`, shape [..., L];
            computed when not given.
        out_positions: Optional output, shape [..., E] of vec3.
        out_orientations: Optional output, shape [..., E] of quat.
        wheel_q: Wheel angles, shape [..., W] (see :func:`~morphkit.kernels.eval_fk`).
        device: Launch device.

    Returns:
        ``(positions, orientations)``: shape [..., E] of vec3 [m] and of xyzw quaternions.
    """
    heading = frame_code(frame)
    device = resolve_device(device, q, model, out=out_positions if Ts_world_link is None else Ts_world_link)
    q2, lead, dtype = as_batch(model, q, device)
    B, E, L = q2.shape[0], model.ee_count, model.link_count
    vec3, quat, _ = _types(dtype)
    if Ts_world_link is None:
        Ts_world_link = eval_fk(model, q2, wheel_q=None if wheel_q is None else _flat(wheel_q, B), device=device)
    elif tuple(Ts_world_link.shape) != (*lead, L):
        raise GraphError(f"Ts_world_link: expected shape {[*lead, L]}, got {list(Ts_world_link.shape)}")
    check_device(Ts_world_link, device, "Ts_world_link")
    pos = output_array(out_positions, (*lead, E), vec3, device, "out_positions")
    rot = output_array(out_orientations, (*lead, E), quat, device, "out_orientations")
    if B == 0 or E == 0:
        return pos, rot
    a = model.arrays(device, dtype)
    launch(end_effector_poses, B, device, [Ts_world_link.reshape((B, L)), a.ee_link, a.ee_offset, heading, 0],
           [pos.reshape((B, E)), rot.reshape((B, E))], dim_tail=(E,))
    return pos, rot


def _flat(wheel_q: Any, B: int) -> Any:
    if isinstance(wheel_q, wp.array):
        return wheel_q.reshape((B, wheel_q.shape[-1]))
    arr = np.asarray(wheel_q)
    return arr.reshape(B, arr.shape[-1])


def eval_end_effectors_adjoint(
    model: KinematicModel,
    q: Any,
    Ts_world_link: wp.array,
    adj_positions: wp.array | None,
    adj_orientations: wp.array | None,
    *,
    frame: str = "world",
    adj_q: wp.array | None = None,
    wheel_q: Any = None,
    device: Any = None,
) -> wp.array:
    """Vector–Jacobian product of :func:`eval_end_effectors` with respect to ``q``, accumulated into ``adj_q``.

    ``adj_positions`` ([..., E] vec3) and ``adj_orientations`` ([..., E] quat) are the gradients of a
    scalar loss with respect to the outputs (``None`` for zero). Runs the end-effector adjoint
    into the link transforms, then the FK adjoint.
    """
    heading = frame_code(frame)
    device = resolve_device(device, q, model, out=Ts_world_link)
    for a, what in ((Ts_world_link, "Ts_world_link"), (adj_positions, "adj_positions"),
                    (adj_orientations, "adj_orientations"), (adj_q, "adj_q")):
        check_device(a, device, what)
    q2, lead, dtype = as_batch(model, q, device)
    B, E, L = q2.shape[0], model.ee_count, model.link_count
    vec3, quat, transform = _types(dtype)
    if adj_q is None:
        adj_q = wp.zeros((*lead, model.coordinate_count), dtype=dtype, device=device)
    if B == 0 or E == 0:
        return adj_q
    a = model.arrays(device, dtype)
    adj_pos = wp.zeros((B, E), dtype=vec3, device=device) if adj_positions is None else adj_positions.reshape((B, E))
    adj_rot = wp.zeros((B, E), dtype=quat, device=device) if adj_orientations is None else \
        adj_orientations.reshape((B, E))
    adj_Ts = wp.zeros((B, L), dtype=transform, device=device)
    Ts = Ts_world_link.reshape((B, L))
    launch(end_effector_poses, B, device, [Ts, a.ee_link, a.ee_offset, heading, 0], [adj_pos, adj_rot],
           adjoint=True, adj_inputs=[adj_Ts, None, None, 0, 0], adj_outputs=[adj_pos, adj_rot], dim_tail=(E,))
    eval_fk_adjoint(model, q2, adj_Ts, adj_q=adj_q.reshape((B, model.coordinate_count)),
                    wheel_q=None if wheel_q is None else _flat(wheel_q, B), device=device)
    return adj_q


def eval_heading_transforms(model: KinematicModel, Ts_world_link: wp.array, *, out: wp.array | None = None,
                            device: Any = None) -> wp.array:
    """``T_world_heading`` of every pose, shape [...] of transforms, from link transforms [..., L]."""
    device = wp.get_device(device) if device is not None else Ts_world_link.device
    lead = tuple(Ts_world_link.shape[:-1])
    B = int(np.prod(lead)) if lead else 1
    transform = Ts_world_link.dtype
    out = output_array(out, lead, transform, device, "out")
    if B:
        launch(heading_transforms, B, device, [Ts_world_link.reshape((B, model.link_count)), 0],
               [out.reshape((B,))])
    return out


def eval_finite_difference(x: wp.array, *, dt: float, out: wp.array | None = None, device: Any = None) -> wp.array:
    """Time derivative of a series of 3-vectors by finite differences.

    Args:
        x: Shape [..., T, N] of vec3 (leading shape flattened to B).
        dt: Time step [s] between frames.
        out: Optional output of the same shape.

    Returns:
        ``v``, shape [..., T, N]: $(x_t - x_{t-1}) / \\Delta t$, frame 0 copying frame 1, zeros when
        T = 1 (the conventions' backward difference).
    """
    if x.ndim < 2:
        raise GraphError(f"x: expected shape [..., T, N], got {list(x.shape)}")
    if not dt > 0:
        raise GraphError(f"dt must be > 0, got {dt}")
    device = wp.get_device(device) if device is not None else x.device
    lead, T, N = tuple(x.shape[:-2]), x.shape[-2], x.shape[-1]
    B = int(np.prod(lead)) if lead else 1
    out = output_array(out, tuple(x.shape), x.dtype, device, "out")
    scalar = x.dtype._wp_scalar_type_
    if B * T * N:
        launch(finite_difference, B, device, [x.contiguous().reshape((B, T, N)), scalar(1.0 / dt), 0],
               [out.reshape((B, T, N))], dim_tail=(T, N))
    return out


def eval_end_effector_velocities(
    model: KinematicModel,
    q: Any,
    *,
    dt: float,
    frame: str = "world",
    wheel_q: Any = None,
    device: Any = None,
) -> wp.array:
    """End-effector linear velocities of motions, by finite differences along time.

    Args:
        q: Motions, shape [..., T, C].
        dt: Time step [s].
        frame: ``"world"``: $\\dot p$ in world; ``"heading"``: the world velocity expressed in each
            frame's heading frame (rotated, not differentiated in the moving frame).

    Returns:
        Velocities [m/s], shape [..., T, E] of vec3.
    """
    heading = frame_code(frame)
    device = resolve_device(device, q, model)
    q2, lead, _ = as_batch(model, q, device)
    if len(lead) < 1:
        raise GraphError(f"q: expected a motion of shape [..., T, {model.coordinate_count}], got {list(q.shape)}")
    E = model.ee_count
    Ts = eval_fk(model, q2, wheel_q=None if wheel_q is None else _flat(wheel_q, q2.shape[0]), device=device)
    pos, _ = eval_end_effectors(model, q2, Ts_world_link=Ts, device=device)
    T = lead[-1]
    B = q2.shape[0] // T if T else 0
    v = eval_finite_difference(pos.reshape((B, T, E)), dt=dt, device=device)
    if heading:
        out = wp.empty((B * T, E), dtype=v.dtype, device=device)
        if B * T and E:
            launch(rotate_into_heading, B * T, device, [Ts, v.reshape((B * T, E)), 0], [out], dim_tail=(E,))
        v = out
    return v.reshape((*lead, E))
