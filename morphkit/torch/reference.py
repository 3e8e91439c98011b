"""Pure-PyTorch forward kinematics: the test oracle and the escape hatch.

Slower than the Warp kernels (one batched torch op chain per joint) but plain autograd all
the way down, so it gives what the Warp path does not:

- gradients with respect to *model parameters*: joint origin translations ("bone offsets",
  per batch element if you like, as NKN needs) and rotations;
- double backward (Hessian-vector products, gradient penalties);
- float64 everywhere, for finite-difference checks.

:class:`~morphkit.torch.ForwardKinematics` switches to it with ``backend="reference"`` or
``differentiable_offsets=True``. It follows exactly the conventions of
:mod:`morphkit.kernels.fk` (``docs/design/q-layout.md``): floating-base and spherical
quaternions are normalised, planar/wheeled roots sit on z = 0, mimic joints follow their target,
wheel angles come from ``wheel_q`` (0 when omitted).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from morphkit.errors import GraphError
from morphkit.graph.types import BaseType, JointType
from morphkit.model.kinematic_model import KinematicModel

__all__ = [
    "end_effectors_reference",
    "fk_reference",
    "heading_transforms_reference",
    "quat_from_axis_angle",
    "quat_multiply",
    "quat_rotate",
    "transform_inverse",
    "transform_multiply",
    "wheel_angles_reference",
]


# ---- quaternion and transform helpers (xyzw, broadcasting over leading dims) -----------------
def quat_multiply(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product ``a * b`` of xyzw quaternions [..., 4]."""
    ax, ay, az, aw = a.unbind(-1)
    bx, by, bz, bw = b.unbind(-1)
    return torch.stack(
        (
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ),
        dim=-1,
    )


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors ``v`` [..., 3] by unit xyzw quaternions ``q`` [..., 4]."""
    shape = torch.broadcast_shapes(q.shape[:-1], v.shape[:-1])
    u = q[..., :3].expand(*shape, 3)
    w = q[..., 3:]
    v = v.expand(*shape, 3)
    t = 2.0 * torch.linalg.cross(u, v)
    return v + w * t + torch.linalg.cross(u, t)


def quat_from_axis_angle(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """xyzw quaternion of a rotation by ``angle`` [...] [rad] about unit ``axis`` [..., 3]."""
    half = 0.5 * angle[..., None]
    return torch.cat((axis * torch.sin(half), torch.cos(half)), dim=-1)


def transform_multiply(T_a_b: torch.Tensor, T_b_c: torch.Tensor) -> torch.Tensor:
    """Compose poses [..., 7]: returns ``T_a_c``."""
    p = T_a_b[..., :3] + quat_rotate(T_a_b[..., 3:], T_b_c[..., :3])
    return torch.cat((p, quat_multiply(T_a_b[..., 3:], T_b_c[..., 3:])), dim=-1)


def transform_inverse(T_a_b: torch.Tensor) -> torch.Tensor:
    """``T_b_a`` from ``T_a_b`` [..., 7] (unit quaternions)."""
    q_inv = torch.cat((-T_a_b[..., 3:6], T_a_b[..., 6:]), dim=-1)
    return torch.cat((-quat_rotate(q_inv, T_a_b[..., :3]), q_inv), dim=-1)


def _quat_about_z(yaw: torch.Tensor) -> torch.Tensor:
    z = torch.zeros_like(yaw)
    return torch.stack((z, z, torch.sin(0.5 * yaw), torch.cos(0.5 * yaw)), dim=-1)


def _normalize(q: torch.Tensor) -> torch.Tensor:
    return q / torch.linalg.vector_norm(q, dim=-1, keepdim=True)


def _constants(model: KinematicModel, dtype: torch.dtype, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """Joint origins [J, 7] and axes [J, 3] as tensors, cached per dtype and device."""
    cache = model.kernel_cache()
    key = ("reference", dtype, device)
    hit = cache.get(key)
    if hit is None:
        hit = cache[key] = (
            torch.tensor(np.array(model.joint_X_parent), dtype=dtype, device=device),
            torch.tensor(np.array(model.joint_axis), dtype=dtype, device=device),
        )
    return hit


# ---- FK -------------------------------------------------------------------------------------
def fk_reference(
    model: KinematicModel,
    q: torch.Tensor,
    *,
    wheel_q: torch.Tensor | None = None,
    joint_offsets: torch.Tensor | None = None,
    joint_rotations: torch.Tensor | None = None,
) -> torch.Tensor:
    """World transforms of every link, in plain PyTorch.

    For joint $j$ with parent link $p$ and child link $c = j + 1$:
    $T_{world,c} = T_{world,p} \\cdot X_j \\cdot M_j(q)$ where $X_j$ is the joint origin
    (``joint_X_parent``, or ``joint_offsets`` / ``joint_rotations`` when given) and $M_j$ the joint
    motion (rotation about the axis, translation along it, or the spherical quaternion).

    Args:
        model: The compiled morphology.
        q: Coordinates, shape [..., C]; its dtype and device are used throughout.
        wheel_q: Wheel angles [rad], shape [..., W] (default: 0).
        joint_offsets: Joint origin translations ("bone offsets") [m], shape [..., J, 3] broadcasting
            against the batch; replaces the model's. Gradients flow to it.
        joint_rotations: Joint origin rotations (xyzw), shape [..., J, 4], likewise.

    Returns:
        ``Ts_world_link``, shape [..., L, 7].
    """
    C = model.coordinate_count
    if q.shape[-1] != C:
        raise GraphError(f"q: expected shape [..., {C}] for {model.name!r}, got {list(q.shape)}")
    lead = q.shape[:-1]
    dt, dev = q.dtype, q.device
    X, axis = _constants(model, dt, dev)
    J = model.joint_count
    if joint_offsets is not None and joint_offsets.shape[-2:] != (J, 3):
        raise GraphError(f"joint_offsets: expected shape [..., {J}, 3], got {list(joint_offsets.shape)}")
    if joint_rotations is not None and joint_rotations.shape[-2:] != (J, 4):
        raise GraphError(f"joint_rotations: expected shape [..., {J}, 4], got {list(joint_rotations.shape)}")

    base = BaseType(model.base_type)
    if base == BaseType.FLOATING:
        T0 = torch.cat((q[..., 0:3], _normalize(q[..., 3:7])), dim=-1)
    elif base in (BaseType.PLANAR, BaseType.WHEELED):
        T0 = torch.cat((q[..., 0:2], torch.zeros_like(q[..., :1]), _quat_about_z(q[..., 2])), dim=-1)
    else:
        T0 = torch.zeros((*lead, 7), dtype=dt, device=dev)
        T0 = T0 + torch.tensor([0, 0, 0, 0, 0, 0, 1.0], dtype=dt, device=dev)

    Ts = [T0]
    qs = model.joint_q_start
    for j in range(J):
        jt = JointType(int(model.joint_type[j]))
        if joint_offsets is None and joint_rotations is None:
            X_j = X[j]
        else:
            p_off = joint_offsets[..., j, :] if joint_offsets is not None else X[j, :3]
            r_off = joint_rotations[..., j, :] if joint_rotations is not None else X[j, 3:]
            shape = torch.broadcast_shapes(p_off.shape[:-1], r_off.shape[:-1])
            X_j = torch.cat((p_off.expand(*shape, 3), r_off.expand(*shape, 4)), dim=-1)
        T_joint = transform_multiply(Ts[int(model.joint_parent[j])], X_j)
        if jt in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            target = int(model.joint_mimic_target[j])
            wheel = int(model.joint_wheel[j])
            if target >= 0:
                value = float(model.joint_mimic_multiplier[j]) * q[..., int(qs[target])] + float(
                    model.joint_mimic_offset[j]
                )
            elif wheel >= 0:
                value = wheel_q[..., wheel] if wheel_q is not None else torch.zeros_like(q[..., 0])
            else:
                value = q[..., int(qs[j])]
            if jt == JointType.PRISMATIC:
                p = axis[j] * value[..., None]
                quat = torch.zeros((*lead, 4), dtype=dt, device=dev) + torch.tensor([0, 0, 0, 1.0], dtype=dt,
                                                                                    device=dev)
            else:
                p = torch.zeros((*lead, 3), dtype=dt, device=dev)
                quat = quat_from_axis_angle(axis[j], value)
            T = transform_multiply(T_joint, torch.cat((p, quat), dim=-1))
        elif jt == JointType.SPHERICAL:
            s = int(qs[j])
            quat = _normalize(q[..., s : s + 4])
            T = torch.cat((T_joint[..., :3], quat_multiply(T_joint[..., 3:], quat)), dim=-1)
        else:
            T = T_joint
        Ts.append(T)
    return torch.stack(torch.broadcast_tensors(*Ts), dim=-2)


def heading_transforms_reference(T_world_root: torch.Tensor) -> torch.Tensor:
    """``T_world_heading`` [..., 7] of root poses [..., 7]: origin under the root on the ground, x along
    the root's facing direction (its x axis projected on the ground), z up."""
    f = quat_rotate(T_world_root[..., 3:], torch.tensor([1.0, 0.0, 0.0], dtype=T_world_root.dtype,
                                                        device=T_world_root.device).expand_as(T_world_root[..., :3]))
    # Where the facing direction is vertical the heading is world x with zero gradient (as in the kernels).
    degenerate = f[..., 0] * f[..., 0] + f[..., 1] * f[..., 1] <= 1e-12
    fx = torch.where(degenerate, torch.ones_like(f[..., 0]), f[..., 0])
    fy = torch.where(degenerate, torch.zeros_like(f[..., 1]), f[..., 1])
    yaw = torch.atan2(fy, fx)
    p = torch.cat((T_world_root[..., :2], torch.zeros_like(T_world_root[..., 2:3])), dim=-1)
    return torch.cat((p, _quat_about_z(yaw)), dim=-1)


def end_effectors_reference(model: KinematicModel, Ts_world_link: torch.Tensor, *,
                            frame: str = "world") -> torch.Tensor:
    """End-effector poses [..., E, 7] from link transforms [..., L, 7].

    The position is the end-effector point (its offset in the link frame); the orientation is
    its link's. ``frame="heading"`` expresses both in the root's heading frame.
    """
    idx = torch.tensor(np.array(model.ee_link), dtype=torch.long, device=Ts_world_link.device)
    off = torch.tensor(np.array(model.ee_offset), dtype=Ts_world_link.dtype, device=Ts_world_link.device)
    T_link = Ts_world_link[..., idx, :]
    ident = torch.tensor([0, 0, 0, 1.0], dtype=off.dtype, device=off.device).expand(*off.shape[:-1], 4)
    T_ee = transform_multiply(T_link, torch.cat((off, ident), dim=-1))
    if frame == "world":
        return T_ee
    if frame == "heading":
        T_heading = heading_transforms_reference(Ts_world_link[..., 0, :])
        return transform_multiply(transform_inverse(T_heading)[..., None, :], T_ee)
    raise GraphError(f"unknown frame {frame!r}; expected one of: world, heading")


def wheel_angles_reference(model: KinematicModel, q: torch.Tensor) -> torch.Tensor:
    """Wheel angles [..., T, W] [rad] of a wheeled base following the motion ``q`` [..., T, C].

    Only the base coordinates ``q[..., 0:3]`` = (x, y, yaw) matter.
    Between frames the base is assumed to move on a circular arc (constant forward speed and
    yaw rate); wheel ``w`` at lateral offset $y_w$ rolls the arc length
    $s_w = s - y_w \\Delta\\psi$ where $s$ is the root's arc length, so its angle grows by
    $\\sigma_w s_w / r$ ($\\sigma_w$ the axis sign). Angles start at 0 at ``t = 0``.
    """
    if model.wheel_count == 0:
        return q.new_zeros((*q.shape[:-1], 0))
    base_q = q[..., :3]
    x, y, yaw = base_q.unbind(-1)
    dx, dy = x[..., 1:] - x[..., :-1], y[..., 1:] - y[..., :-1]
    dpsi = torch.remainder(yaw[..., 1:] - yaw[..., :-1] + math.pi, 2 * math.pi) - math.pi
    mid = yaw[..., :-1] + 0.5 * dpsi
    chord = dx * torch.cos(mid) + dy * torch.sin(mid)
    h = 0.5 * dpsi
    small = h.abs() < 1e-4
    h_safe = torch.where(small, torch.ones_like(h), h)
    arc_factor = torch.where(small, 1.0 + h * h / 6.0, h_safe / torch.sin(h_safe))
    s = chord * arc_factor
    lateral = torch.tensor(np.array(model.wheel_lateral), dtype=base_q.dtype, device=base_q.device)
    sign = torch.tensor(np.array(model.wheel_sign), dtype=base_q.dtype, device=base_q.device)
    dtheta = sign * (s[..., None] - lateral * dpsi[..., None]) / model.wheel_radius
    zero = torch.zeros_like(dtheta[..., :1, :])
    return torch.cat((zero, torch.cumsum(dtheta, dim=-2)), dim=-2)
