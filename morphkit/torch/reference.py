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
from morphkit.rotations import (
    heading_frame,
    quat_from_axis_angle,
    quat_from_yaw,
    quat_multiply,
    quat_normalize,
    transform_inverse,
    transform_multiply,
)

__all__ = [
    "end_effectors_reference",
    "fk_reference",
    "wheel_angles_reference",
]


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
        T0 = torch.cat((q[..., 0:3], quat_normalize(q[..., 3:7])), dim=-1)
    elif base in (BaseType.PLANAR, BaseType.WHEELED):
        T0 = torch.cat((q[..., 0:2], torch.zeros_like(q[..., :1]), quat_from_yaw(q[..., 2])), dim=-1)
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
            quat = quat_normalize(q[..., s : s + 4])
            T = torch.cat((T_joint[..., :3], quat_multiply(T_joint[..., 3:], quat)), dim=-1)
        else:
            T = T_joint
        Ts.append(T)
    return torch.stack(torch.broadcast_tensors(*Ts), dim=-2)


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
        T_heading = heading_frame(Ts_world_link[..., 0, :])
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
