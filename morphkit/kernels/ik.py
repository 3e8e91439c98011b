"""Damped-least-squares inverse kinematics for end-effector positions (kernels and launchers).

One step, per pose ``b`` of a batch (one thread each):

1. forward kinematics at ``q`` (:func:`~morphkit.kernels.eval_fk`) and the residual
   $e = p^* - p(q)$ of the targeted end-effectors, stacked to $e \\in \\mathbb{R}^{3E}$;
2. the positional Jacobian $J \\in \\mathbb{R}^{3E \\times n}$ over the $n$ moving DoFs, analytic per
   joint type from the link transforms: revolute $a \\times (p - o)$, prismatic $a$, spherical
   $R e_k \\times (p - o)$ for the three axes of the child frame; mimic joints add
   ``multiplier`` × their column to the joint they follow; the floating base translates along
   and rotates about the world axes, the planar base moves along x, y and turns about z, the
   wheeled base drives along its heading and turns about z;
3. the damped least-squares update $\\Delta = (J^\\top J + \\lambda^2 I)^{-1} J^\\top e$, solved by a
   Cholesky factorisation in the kernel — or, when $3E < n$, the identical
   $\\Delta = J^\\top (J J^\\top + \\lambda^2 I)^{-1} e$ on the smaller system;
4. the step $\\alpha\\Delta$ scaled down as a whole if any entry exceeds ``max_step`` (far from
   the target the linearisation overshoots), then applied to $q$ respecting its layout: 1-DoF
   joints add and are clamped into their limits, spherical joints compose
   $q_j \\leftarrow q_j \\otimes \\exp(\\alpha\\Delta_j)$ (a rotation vector in the child frame), the
   floating base composes $\\exp(\\alpha\\omega) \\otimes q_0$ in the world frame; quaternions are
   re-normalised.

DoFs are indexed like ``qd`` (:attr:`~morphkit.model.KinematicModel.joint_qd_start`): the base's
DoFs first (floating 6: ``vx, vy, vz, wx, wy, wz``; planar 3: ``x, y, yaw``; wheeled 2: ``forward,
yaw``), then each independent joint's. A mask chooses which DoFs move (default: every joint DoF,
base fixed); DoFs that reach none of the targeted end-effectors are left out of the solve.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from morphkit.errors import GraphError
from morphkit.graph.types import BaseType, JointType
from morphkit.kernels.dtypes import vec3_type
from morphkit.kernels.fk import eval_fk
from morphkit.kernels.launch import as_batch, check_device, output_array, resolve_device
from morphkit.model.kinematic_model import KinematicModel

__all__ = ["IKResult", "eval_ee_jacobian", "ik_dof_mask", "ik_solve", "ik_step"]

# IK is a solver step, never differentiated: skip generating adjoints (halves compile time).
wp.set_module_options({"enable_backward": False})

JOINT_REVOLUTE = wp.constant(int(JointType.REVOLUTE))
JOINT_CONTINUOUS = wp.constant(int(JointType.CONTINUOUS))
JOINT_PRISMATIC = wp.constant(int(JointType.PRISMATIC))
JOINT_SPHERICAL = wp.constant(int(JointType.SPHERICAL))
BASE_FLOATING = wp.constant(int(BaseType.FLOATING))
BASE_PLANAR = wp.constant(int(BaseType.PLANAR))
BASE_WHEELED = wp.constant(int(BaseType.WHEELED))


@wp.func
def _add_column(Jm: Any, b: int, row: int, col: int, v: Any):
    if col >= 0:
        Jm[b, row, col] = Jm[b, row, col] + v[0]
        Jm[b, row + 1, col] = Jm[b, row + 1, col] + v[1]
        Jm[b, row + 2, col] = Jm[b, row + 2, col] + v[2]


@wp.func
def _unit(v: Any, k: int):
    z = v[0] * type(v[0])(0.0)
    e = type(v)(z, z, z)
    e[k] = type(v[0])(1.0)
    return e


@wp.func
def _fill_jacobian(
    b: int,
    q: Any,
    link_X: Any,
    ee_link: Any,
    ee_offset: Any,
    link_parent: Any,
    joint_type: Any,
    joint_axis: Any,
    joint_qd_start: Any,
    joint_mimic_target: Any,
    joint_mimic_multiplier: Any,
    joint_wheel: Any,
    base_type: int,
    col_of_dof: Any,
    Jm: Any,
):
    """Add every targeted end-effector's positional Jacobian rows for pose ``b`` into ``Jm[b]`` (zeroed)."""
    E = ee_link.shape[0]
    for e in range(E):
        row = 3 * e
        l_ee = ee_link[e]
        p = wp.transform_point(link_X[b, l_ee], ee_offset[e])
        l = l_ee
        while l > 0:
            j = l - 1
            jt = joint_type[j]
            target = joint_mimic_target[j]
            dof = joint_qd_start[j]
            scale = p[0] * type(p[0])(0.0) + type(p[0])(1.0)
            if target >= 0:
                dof = joint_qd_start[target]
                scale = joint_mimic_multiplier[j]
            if joint_wheel[j] < 0:
                X = link_X[b, l]
                o = wp.transform_get_translation(X)
                r = wp.transform_get_rotation(X)
                if jt == JOINT_REVOLUTE or jt == JOINT_CONTINUOUS:
                    a = wp.quat_rotate(r, joint_axis[j])
                    _add_column(Jm, b, row, col_of_dof[dof], wp.cross(a, p - o) * scale)
                elif jt == JOINT_PRISMATIC:
                    _add_column(Jm, b, row, col_of_dof[dof], wp.quat_rotate(r, joint_axis[j]) * scale)
                elif jt == JOINT_SPHERICAL:
                    for k in range(3):
                        a = wp.quat_rotate(r, _unit(p, k))
                        _add_column(Jm, b, row, col_of_dof[dof + k], wp.cross(a, p - o))
            l = link_parent[l]
        o0 = wp.transform_get_translation(link_X[b, 0])
        if base_type == BASE_FLOATING:
            for k in range(3):
                _add_column(Jm, b, row, col_of_dof[k], _unit(p, k))
                _add_column(Jm, b, row, col_of_dof[3 + k], wp.cross(_unit(p, k), p - o0))
        elif base_type == BASE_PLANAR:
            _add_column(Jm, b, row, col_of_dof[0], _unit(p, 0))
            _add_column(Jm, b, row, col_of_dof[1], _unit(p, 1))
            _add_column(Jm, b, row, col_of_dof[2], wp.cross(_unit(p, 2), p - o0))
        elif base_type == BASE_WHEELED:
            yaw = q[b, 2]
            z = yaw * type(yaw)(0.0)
            _add_column(Jm, b, row, col_of_dof[0], type(p)(wp.cos(yaw), wp.sin(yaw), z))
            _add_column(Jm, b, row, col_of_dof[1], wp.cross(_unit(p, 2), p - o0))


@wp.func
def _quat_exp(v: Any):
    """Unit quaternion of the rotation vector ``v`` [rad]."""
    angle = wp.length(v)
    z = angle * type(angle)(0.0)
    half = angle * type(angle)(0.5)
    s = type(angle)(0.5)  # sin(half) / angle -> 1/2 as angle -> 0
    if angle > type(angle)(1.0e-9):
        s = wp.sin(half) / angle
    return wp.quaternion(v[0] * s, v[1] * s, v[2] * s, wp.cos(half) + z)


@wp.kernel
def ee_jacobian_kernel(
    q: wp.array2d[Any],
    link_X: wp.array2d[Any],
    ee_link: wp.array[wp.int32],
    ee_offset: wp.array[Any],
    link_parent: wp.array[wp.int32],
    joint_type: wp.array[wp.int32],
    joint_axis: wp.array[Any],
    joint_qd_start: wp.array[wp.int32],
    joint_mimic_target: wp.array[wp.int32],
    joint_mimic_multiplier: wp.array[Any],
    joint_wheel: wp.array[wp.int32],
    base_type: int,
    col_of_dof: wp.array[wp.int32],
    out: wp.array3d[Any],
):
    """``out[b]``: the [3E, n] positional Jacobian of pose ``b`` (``out`` zeroed by the launcher)."""
    b = wp.tid()
    _fill_jacobian(b, q, link_X, ee_link, ee_offset, link_parent, joint_type, joint_axis, joint_qd_start,
                   joint_mimic_target, joint_mimic_multiplier, joint_wheel, base_type, col_of_dof, out)


@wp.kernel
def dls_step_kernel(
    q: wp.array2d[Any],
    link_X: wp.array2d[Any],
    targets: wp.array2d[Any],
    ee_weight: wp.array2d[Any],
    ee_link: wp.array[wp.int32],
    ee_offset: wp.array[Any],
    link_parent: wp.array[wp.int32],
    joint_type: wp.array[wp.int32],
    joint_axis: wp.array[Any],
    joint_q_start: wp.array[wp.int32],
    joint_qd_start: wp.array[wp.int32],
    joint_mimic_target: wp.array[wp.int32],
    joint_mimic_multiplier: wp.array[Any],
    joint_wheel: wp.array[wp.int32],
    coordinate_lower: wp.array[Any],
    coordinate_upper: wp.array[Any],
    base_type: int,
    col_of_dof: wp.array[wp.int32],
    damping: Any,
    step_size: Any,
    max_step: Any,
    max_error: Any,
    clamp: int,
    use_dual: int,
    Jm: wp.array3d[Any],
    A: wp.array3d[Any],
    y: wp.array2d[Any],
    delta: wp.array2d[Any],
    err: wp.array2d[Any],
    q_out: wp.array2d[Any],
    residual: wp.array2d[Any],
):
    """One damped-least-squares step for pose ``b`` (``Jm`` zeroed by the launcher; ``A``, ``y``, ``delta``, ``err``
    scratch); ``ee_weight[b, e]`` scales end-effector ``e``'s rows of the least-squares problem (0: it is free)."""
    b = wp.tid()
    E = ee_link.shape[0]
    m = 3 * E
    n = delta.shape[1]
    zero = damping * type(damping)(0.0)

    # 1. residual and Jacobian; the error driving the step is clamped to max_error per end-effector
    #    (far or unreachable targets: the linearisation ignores the residual's curvature).
    for e in range(E):
        r = targets[b, e] - wp.transform_point(link_X[b, ee_link[e]], ee_offset[e])
        residual[b, e] = r
        rn = wp.length(r)
        if max_error > zero and rn > max_error:
            r = r * (max_error / rn)
        err[b, e] = r * ee_weight[b, e]
    _fill_jacobian(b, q, link_X, ee_link, ee_offset, link_parent, joint_type, joint_axis, joint_qd_start,
                   joint_mimic_target, joint_mimic_multiplier, joint_wheel, base_type, col_of_dof, Jm)
    for e in range(E):
        we = ee_weight[b, e]
        for k in range(3):
            for c in range(n):
                Jm[b, 3 * e + k, c] = Jm[b, 3 * e + k, c] * we

    # 2. normal equations on the smaller side: A = J^T J + l^2 I, y = J^T e (primal) or A = J J^T + l^2 I, y = e
    K = n
    if use_dual != 0:
        K = m
    lam2 = damping * damping
    for i in range(K):
        for k in range(i + 1):
            s = zero
            if use_dual != 0:
                for c in range(n):
                    s += Jm[b, i, c] * Jm[b, k, c]
            else:
                for rr in range(m):
                    s += Jm[b, rr, i] * Jm[b, rr, k]
            if i == k:
                s += lam2
            A[b, i, k] = s
        s = zero
        if use_dual != 0:
            s = err[b, i // 3][i % 3]
        else:
            for rr in range(m):
                s += Jm[b, rr, i] * err[b, rr // 3][rr % 3]
        y[b, i] = s

    # 3. Cholesky A = L L^T in the lower triangle, then L L^T x = y in place.
    tiny = type(damping)(1.0e-30)
    for i in range(K):
        for k in range(i + 1):
            s = A[b, i, k]
            for c in range(k):
                s -= A[b, i, c] * A[b, k, c]
            if i == k:
                A[b, i, i] = wp.sqrt(wp.max(s, tiny))  # singular only without damping
            else:
                A[b, i, k] = s / A[b, k, k]
    for i in range(K):
        s = y[b, i]
        for c in range(i):
            s -= A[b, i, c] * y[b, c]
        y[b, i] = s / A[b, i, i]
    for ii in range(K):
        i = K - 1 - ii
        s = y[b, i]
        for c in range(i + 1, K):
            s -= A[b, c, i] * y[b, c]
        y[b, i] = s / A[b, i, i]
    largest = zero
    for c in range(n):
        s = zero
        if use_dual != 0:
            for rr in range(m):
                s += Jm[b, rr, c] * y[b, rr]
        else:
            s = y[b, c]
        delta[b, c] = s * step_size
        largest = wp.max(largest, wp.abs(delta[b, c]))
    # Far from the target the linearisation overshoots: shrink the whole step to |delta|_inf <= max_step.
    if max_step > zero and largest > max_step:
        shrink = max_step / largest
        for c in range(n):
            delta[b, c] = delta[b, c] * shrink

    # 4. apply along the q layout
    C = q.shape[1]
    for i in range(C):
        q_out[b, i] = q[b, i]
    if base_type == BASE_FLOATING:
        for k in range(3):
            if col_of_dof[k] >= 0:
                q_out[b, k] = q[b, k] + delta[b, col_of_dof[k]]
        w = wp.vector(zero, zero, zero)
        for k in range(3):
            if col_of_dof[3 + k] >= 0:
                w[k] = delta[b, col_of_dof[3 + k]]
        q0 = wp.normalize(wp.quaternion(q[b, 3], q[b, 4], q[b, 5], q[b, 6]))
        q1 = wp.normalize(_quat_exp(w) * q0)
        for k in range(4):
            q_out[b, 3 + k] = q1[k]
    elif base_type == BASE_PLANAR:
        for k in range(3):
            if col_of_dof[k] >= 0:
                q_out[b, k] = q[b, k] + delta[b, col_of_dof[k]]
    elif base_type == BASE_WHEELED:
        yaw = q[b, 2]
        if col_of_dof[0] >= 0:
            d = delta[b, col_of_dof[0]]
            q_out[b, 0] = q[b, 0] + d * wp.cos(yaw)
            q_out[b, 1] = q[b, 1] + d * wp.sin(yaw)
        if col_of_dof[1] >= 0:
            q_out[b, 2] = yaw + delta[b, col_of_dof[1]]
    J = joint_type.shape[0]
    for j in range(J):
        width = joint_q_start[j + 1] - joint_q_start[j]
        s0 = joint_q_start[j]
        d0 = joint_qd_start[j]
        if width == 1:
            c = col_of_dof[d0]
            if c >= 0:
                v = q[b, s0] + delta[b, c]
                if clamp != 0:
                    v = wp.clamp(v, coordinate_lower[s0], coordinate_upper[s0])
                q_out[b, s0] = v
        elif width == 4:
            w = wp.vector(zero, zero, zero)
            for k in range(3):
                if col_of_dof[d0 + k] >= 0:
                    w[k] = delta[b, col_of_dof[d0 + k]]
            qj = wp.normalize(wp.quaternion(q[b, s0], q[b, s0 + 1], q[b, s0 + 2], q[b, s0 + 3]))
            qn = wp.normalize(qj * _quat_exp(w))
            for k in range(4):
                q_out[b, s0 + k] = qn[k]


for _s, _v, _t in ((wp.float32, wp.vec3f, wp.transformf), (wp.float64, wp.vec3d, wp.transformd)):
    wp.overload(
        ee_jacobian_kernel,
        [wp.array2d[_s], wp.array2d[_t], wp.array[wp.int32], wp.array[_v], wp.array[wp.int32], wp.array[wp.int32],
         wp.array[_v], wp.array[wp.int32], wp.array[wp.int32], wp.array[_s], wp.array[wp.int32], int,
         wp.array[wp.int32], wp.array3d[_s]],
    )
    wp.overload(
        dls_step_kernel,
        [wp.array2d[_s], wp.array2d[_t], wp.array2d[_v], wp.array2d[_s], wp.array[wp.int32], wp.array[_v],
         wp.array[wp.int32], wp.array[wp.int32], wp.array[_v], wp.array[wp.int32], wp.array[wp.int32],
         wp.array[wp.int32], wp.array[_s], wp.array[wp.int32], wp.array[_s], wp.array[_s], int, wp.array[wp.int32],
         _s, _s, _s, _s, int,
         int, wp.array3d[_s], wp.array3d[_s], wp.array2d[_s], wp.array2d[_s], wp.array2d[_v], wp.array2d[_s],
         wp.array2d[_v]],
    )


# ---------------------------------------------------------------------------------------------
# host side
# ---------------------------------------------------------------------------------------------
def _dof_count(model: KinematicModel) -> int:
    return int(model.joint_qd_start[-1]) if model.joint_count else int(_base_dof(model))


def _base_dof(model: KinematicModel) -> int:
    return {BaseType.FIXED: 0, BaseType.FLOATING: 6, BaseType.PLANAR: 3, BaseType.WHEELED: 2}[
        BaseType(model.base_type)
    ]


def ik_dof_mask(model: KinematicModel, *, base: bool = False, joints: Any = None) -> np.ndarray:
    """A DoF mask for :func:`ik_step`: which entries of ``qd`` may move, shape [D], bool.

    Args:
        model: The compiled morphology.
        base: Whether the base DoFs move.
        joints: Names of the joints that move (default: all independent joints).
    """
    D = _dof_count(model)
    nb = _base_dof(model)
    mask = np.zeros(D, dtype=bool)
    mask[:nb] = base
    names = set(model.joint_names) if joints is None else set(joints)
    unknown = names - set(model.joint_names)
    if unknown:
        raise GraphError(f"no joint {sorted(unknown)[0]!r} (joints: {', '.join(model.joint_names)})")
    for j, name in enumerate(model.joint_names):
        if name in names:
            mask[int(model.joint_qd_start[j]) : int(model.joint_qd_start[j + 1])] = True
    return mask


def _ee_indices(model: KinematicModel, ee: Any) -> np.ndarray:
    if ee is None:
        idx = np.arange(model.ee_count)
    else:
        items = [ee] if isinstance(ee, (str, int, np.integer)) else list(ee)
        idx = np.array([model.ee_index(e) if isinstance(e, str) else int(e) for e in items], dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= model.ee_count):
            raise GraphError(f"ee: indices {idx.tolist()} out of range for {model.ee_count} end-effectors")
    if idx.size == 0:
        raise GraphError(f"{model.name!r}: no end-effector to solve for")
    return idx.astype(np.int32)


def _columns(model: KinematicModel, ee_idx: np.ndarray, dof_mask: Any) -> np.ndarray:
    """``col_of_dof`` [D]: the Jacobian column of each DoF, -1 where masked or reaching no targeted end-effector."""
    D = _dof_count(model)
    if dof_mask is None:
        mask = ik_dof_mask(model)
    else:
        mask = np.asarray(dof_mask, dtype=bool).reshape(-1)
        if mask.shape != (D,):
            raise GraphError(f"dof_mask: expected {D} entries (base DoFs then joint DoFs), got {mask.shape[0]}")
    reach = np.zeros(D, dtype=bool)
    reach[: _base_dof(model)] = True
    for e in ee_idx:
        link = int(model.ee_link[e])
        while link > 0:
            j = link - 1
            target = int(model.joint_mimic_target[j])
            if int(model.joint_wheel[j]) < 0:
                src = target if target >= 0 else j
                reach[int(model.joint_qd_start[src]) : int(model.joint_qd_start[src + 1])] = True
            link = int(model.link_parent[link])
    active = mask & reach
    col = np.full(D, -1, dtype=np.int32)
    col[active] = np.arange(int(active.sum()), dtype=np.int32)
    return col


@dataclass
class _Plan:
    ee_link: wp.array
    ee_offset: wp.array
    col_of_dof: wp.array
    n: int


def _plan(model: KinematicModel, ee_idx: np.ndarray, dof_mask: Any, device: Any, scalar: Any) -> _Plan:
    mask_key = None if dof_mask is None else np.asarray(dof_mask, dtype=bool).tobytes()
    key = ("ik_plan", tuple(int(i) for i in ee_idx), mask_key, device.alias, scalar.__name__)
    cache = model.kernel_cache()
    hit = cache.get(key)
    if hit is None:
        col = _columns(model, ee_idx, dof_mask)
        vec3 = vec3_type(scalar)
        np_float = np.float64 if scalar == wp.float64 else np.float32
        hit = _Plan(
            ee_link=wp.array(np.asarray(model.ee_link)[ee_idx], dtype=wp.int32, device=device),
            ee_offset=wp.array(np.asarray(model.ee_offset, dtype=np_float)[ee_idx], dtype=vec3, device=device),
            col_of_dof=wp.array(col, dtype=wp.int32, device=device),
            n=int((col >= 0).sum()),
        )
        cache[key] = hit
    return hit


def _targets(targets: Any, lead: tuple[int, ...], E: int, scalar: Any, device: Any) -> wp.array:
    vec3 = vec3_type(scalar)
    if isinstance(targets, wp.array):
        t = targets if targets.is_contiguous else targets.contiguous()
        if t.dtype == scalar:
            t = t.view(vec3)
        if t.dtype != vec3:
            raise GraphError(f"targets: expected {wp.types.type_repr(vec3)} (the precision of q), "
                             f"got {wp.types.type_repr(t.dtype)}")
        check_device(t, device, "targets")
    else:
        arr = np.asarray(targets, dtype=np.float64 if scalar == wp.float64 else np.float32)
        if arr.ndim < 1 or arr.shape[-1] != 3:
            raise GraphError(f"targets: expected shape [..., {E}, 3], got {list(arr.shape)}")
        t = wp.array(np.ascontiguousarray(arr), dtype=vec3, device=device)
    if tuple(t.shape) != (*lead, E):
        raise GraphError(f"targets: expected shape {[*lead, E, 3]} (one target per end-effector), "
                         f"got {[*t.shape, 3]}")
    B = int(np.prod(lead)) if lead else 1
    return t.reshape((B, E))


def eval_ee_jacobian(model: KinematicModel, q: Any, *, ee: Any = None, dof_mask: Any = None,
                     device: Any = None) -> tuple[wp.array, np.ndarray]:
    """Positional Jacobian of the end-effectors with respect to the moving DoFs (world frame).

    Row ``3 e + i`` is coordinate ``i`` of end-effector ``ee[e]``; column ``c`` is DoF ``dofs[c]``
    (a ``qd`` index, see the module docstring for the DoF conventions).

    Args:
        model: The compiled morphology.
        q: Coordinates, shape [..., C], float32 or float64.
        ee: End-effector names or indices (default all), shape [E].
        dof_mask: Which ``qd`` entries may move, shape [D] (default: :func:`ik_dof_mask`).
        device: Launch device (default: ``q``'s, else the model's).

    Returns:
        ``(J, dofs)``: ``J`` of shape [..., 3E, n] and the ``qd`` index of every column, shape [n].
    """
    device = resolve_device(device, q, model)
    q2, lead, scalar = as_batch(model, q, device)
    ee_idx = _ee_indices(model, ee)
    plan = _plan(model, ee_idx, dof_mask, device, scalar)
    B = q2.shape[0]
    E = len(ee_idx)
    out = wp.zeros((B, 3 * E, plan.n), dtype=scalar, device=device)
    if B and plan.n:
        X = eval_fk(model, q2, device=device)
        a = model.arrays(device, scalar)
        wp.launch(ee_jacobian_kernel, dim=B,
                  inputs=[q2, X, plan.ee_link, plan.ee_offset, a.link_parent, a.joint_type, a.joint_axis,
                          a.joint_qd_start, a.joint_mimic_target, a.joint_mimic_multiplier, a.joint_wheel,
                          int(model.base_type), plan.col_of_dof],
                  outputs=[out], device=device)
    col = plan.col_of_dof.numpy()
    dofs = np.flatnonzero(col >= 0)[np.argsort(col[col >= 0])]
    return out.reshape((*lead, 3 * E, plan.n)), dofs.astype(np.int32)


def ik_step(model: KinematicModel, q: Any, targets: Any, *, ee: Any = None, damping: float = 1e-2,
            step_size: float = 1.0, max_step: float | None = 0.5, max_error: float | None = None,
            dof_mask: Any = None, clamp_to_limits: bool = True, weight: Any = None,
            out: wp.array | None = None, device: Any = None) -> tuple[wp.array, wp.array]:
    """One damped-least-squares step towards end-effector position targets.

    Args:
        model: The compiled morphology.
        q: Coordinates, shape [..., C], float32 or float64 (Warp array, or anything NumPy reads).
        targets: World positions [m] for the chosen end-effectors, shape [..., E, 3] (or [..., E] vec3).
        ee: End-effector names or indices to drive (default: all), shape [E].
        damping: $\\lambda$ [m], > 0 keeps the step bounded near singularities and out of reach.
        step_size: $\\alpha$, scales the update (1: the full Gauss–Newton-like step).
        max_step: Largest change of any DoF in one step [rad or m]: a longer step is scaled
            down as a whole (keeps its direction); ``None`` for no limit.
        max_error: Longest error vector per end-effector the step works on [m] (longer ones are
            shortened; the returned residual is not). For targets that may be out of reach, set it
            (e.g. a tenth of the limb length) with a damping of a fraction of the limb length:
            full Gauss–Newton steps oscillate about the stretched singularity. ``None``: no clamping.
        dof_mask: Which ``qd`` entries may move, shape [D] (default: every joint DoF, base fixed;
            see :func:`ik_dof_mask`).
        clamp_to_limits: Clamp 1-DoF joints into their limits after the step.
        weight: Weight of each end-effector's error in the least-squares step, shape [..., E] or [E]
            (default 1; 0 leaves an end-effector free, e.g. a foot's orientation points in the air).
        out: Optional output for the new coordinates, shape [..., C] (may not alias ``q``).
        device: Launch device (default: ``q``'s, else the model's).

    Returns:
        ``(q_new, residual)``: the updated coordinates [..., C] and the residual $p^* - p(q)$ at the
        *input* ``q`` [m], shape [..., E] of vec3 (the error this step set out to remove).

    Raises:
        GraphError: on wrong shapes, dtypes, devices, unknown end-effectors or a negative damping.
    """
    if not np.isfinite(damping) or damping < 0:
        raise GraphError(f"damping must be >= 0, got {damping!r}")
    device = resolve_device(device, q, model, out=out)
    q2, lead, scalar = as_batch(model, q, device)
    ee_idx = _ee_indices(model, ee)
    E = len(ee_idx)
    t = _targets(targets, lead, E, scalar, device)
    plan = _plan(model, ee_idx, dof_mask, device, scalar)
    B, C = q2.shape
    vec3 = vec3_type(scalar)
    out = output_array(out, (*lead, C), scalar, device)
    residual = wp.empty((*lead, E), dtype=vec3, device=device)
    if B == 0:
        return out, residual
    n = plan.n
    m = 3 * E
    use_dual = int(m < n)
    K = max(min(m, n), 1)
    Jm = wp.zeros((B, m, max(n, 1)), dtype=scalar, device=device)
    A = wp.empty((B, K, K), dtype=scalar, device=device)
    y = wp.empty((B, K), dtype=scalar, device=device)
    delta = wp.empty((B, n), dtype=scalar, device=device)
    err = wp.empty((B, E), dtype=vec3, device=device)
    w = np.ones((B, E)) if weight is None else np.broadcast_to(np.asarray(weight, dtype=float), (*lead, E))
    if not np.all(np.isfinite(w)) or (w < 0).any():
        raise GraphError("weight must be finite and >= 0")
    w = wp.array(np.ascontiguousarray(w.reshape(B, E)), dtype=scalar, device=device)
    X = eval_fk(model, q2, device=device)
    a = model.arrays(device, scalar)
    wp.launch(
        dls_step_kernel,
        dim=B,
        inputs=[q2, X, t, w, plan.ee_link, plan.ee_offset, a.link_parent, a.joint_type, a.joint_axis, a.joint_q_start,
                a.joint_qd_start, a.joint_mimic_target, a.joint_mimic_multiplier, a.joint_wheel, a.coordinate_lower,
                a.coordinate_upper, int(model.base_type), plan.col_of_dof, scalar(damping), scalar(step_size),
                scalar(0.0 if max_step is None else max_step), scalar(0.0 if max_error is None else max_error),
                int(clamp_to_limits), use_dual if n else 0, Jm, A, y, delta, err],
        outputs=[out.reshape((B, C)), residual.reshape((B, E))],
        device=device,
    )
    return out, residual


@dataclass(frozen=True)
class IKResult:
    """What :func:`ik_solve` returns."""

    q: wp.array
    """Final coordinates, shape [..., C]."""
    error: np.ndarray
    """Distance of each end-effector from its target at ``q`` [m], shape [..., E]."""
    iterations: int
    """Steps taken."""
    converged: bool
    """Whether every error is below the tolerance."""


def ik_solve(model: KinematicModel, q: Any, targets: Any, *, ee: Any = None, iterations: int = 50,
             tolerance: float = 1e-4, damping: float = 1e-2, step_size: float = 1.0,
             max_step: float | None = 0.5, max_error: float | None = None, dof_mask: Any = None,
             clamp_to_limits: bool = True, device: Any = None) -> IKResult:
    """Repeat :func:`ik_step` until every end-effector is within ``tolerance`` [m] of its target.

    Arguments as :func:`ik_step`; ``iterations`` bounds the number of steps. The error is read
    back to the host after each step to test convergence (one synchronisation per step).
    """
    if iterations < 0:
        raise GraphError(f"iterations must be >= 0, got {iterations}")
    device = resolve_device(device, q, model)
    q2, lead, _ = as_batch(model, q, device)
    cur = wp.clone(q2).reshape((*lead, model.coordinate_count))  # never write into the caller's array
    buf = wp.empty_like(cur)
    for it in range(iterations + 1):
        new, res = ik_step(model, cur, targets, ee=ee, damping=damping, step_size=step_size, max_step=max_step,
                           max_error=max_error, dof_mask=dof_mask, clamp_to_limits=clamp_to_limits, out=buf,
                           device=device)
        err = np.linalg.norm(res.numpy(), axis=-1)
        if it == iterations or (err < tolerance).all():
            return IKResult(q=cur, error=err, iterations=it, converged=bool((err < tolerance).all()))
        cur, buf = new, cur
    raise AssertionError("unreachable")  # pragma: no cover
