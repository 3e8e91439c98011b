"""PyTorch autograd over the contact kernels: ground penetration, foot sliding, self-collision.

Notation: ``p`` [..., E, 3] end-effector points (e.g. from
:func:`~morphkit.torch.end_effector_positions`) or [..., T, E, 3] over motions, ``Ts`` [..., L, 7]
link transforms (from :func:`~morphkit.torch.fk`); ``F`` feet, ``P`` candidate shape pairs.
Each forward wraps its inputs zero-copy (``wp.from_torch``) and launches the Warp kernel of
:mod:`morphkit.kernels.contact` on torch's current stream; each backward launches the same
kernel in adjoint mode, $\\bar x = (\\partial y / \\partial x)^\\top \\bar y$. Thresholded gates
(contact while below a height) are piecewise constant and pass no gradient; everything else is
differentiable where the quantity is (the kinks at zero penetration and zero speed get the
one-sided value 0). Once differentiable; compose with the FK functions for gradients w.r.t. ``q``.
"""

from __future__ import annotations

from typing import Any

import torch
import warp as wp
from torch.autograd.function import once_differentiable

from morphkit.contact_rules import UFR
from morphkit.errors import GraphError
from morphkit.kernels import contact as _ck
from morphkit.kernels.contact import SelfCollisionPairs
from morphkit.model.kinematic_model import KinematicModel
from morphkit.torch.streams import on_torch_stream

__all__ = [
    "FootHeightFunction",
    "SelfCollisionFunction",
    "ShapeGroundFunction",
    "SlidingSpeedFunction",
    "contact_flags",
    "foot_heights",
    "penetration_depth",
    "self_collision_distance",
    "self_collision_penetration",
    "shape_ground_distance",
    "sliding_speed",
]

_VEC3 = {torch.float32: wp.vec3f, torch.float64: wp.vec3d}
_TRANSFORM = {torch.float32: wp.transformf, torch.float64: wp.transformd}


def _wrap(t: torch.Tensor, dtype_of: dict) -> wp.array:
    """Zero-copy Warp view of a contiguous [..., 3] or [..., 7] tensor as vectors/transforms [...]."""
    return wp.from_torch(t, dtype=dtype_of[t.dtype], requires_grad=False)


def _check_points(p: Any, what: str, min_dim: int) -> None:
    if not isinstance(p, torch.Tensor):
        raise GraphError(f"{what}: expected a torch.Tensor, got {type(p).__name__}")
    if p.dtype not in _VEC3:
        raise GraphError(f"{what}: expected float32 or float64, got {p.dtype}")
    if p.dim() < min_dim or p.shape[-1] != 3:
        shape = "[..., T, E, 3]" if min_dim == 3 else "[..., E, 3]"
        raise GraphError(f"{what}: expected shape {shape}, got {list(p.shape)}")


def _feet(feet: Any) -> tuple[int, ...] | None:
    if feet is None:
        return None
    if isinstance(feet, torch.Tensor):
        feet = feet.tolist()
    return tuple(int(i) for i in feet)


# ---- ground -----------------------------------------------------------------------------------
class FootHeightFunction(torch.autograd.Function):
    """$h = p_z - z_g$ (``penetration=False``) or $\\max(0, z_g - p_z)$, shape [B, F], from points [B, E, 3].

    Backward: $\\bar p_z = \\bar h$ (heights) or $-\\bar d$ where below ground (penetration).
    """

    @staticmethod
    def forward(ctx: Any, p: torch.Tensor, feet: tuple[int, ...] | None, ground_height: float,
                penetration: bool) -> torch.Tensor:
        p = p.contiguous()  # [B, E, 3]
        F = p.shape[1] if feet is None else len(feet)
        out = torch.empty((p.shape[0], F), dtype=p.dtype, device=p.device)  # [B, F]
        launch = _ck.eval_penetration_depth if penetration else _ck.eval_foot_heights
        with on_torch_stream(p.device) as dev:
            launch(_wrap(p, _VEC3), feet=feet, ground_height=ground_height,
                   out=wp.from_torch(out, requires_grad=False), device=dev)
        ctx.save_for_backward(p)
        ctx.args = (feet, ground_height, penetration)
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None, None]:
        (p,) = ctx.saved_tensors
        if not ctx.needs_input_grad[0]:
            return None, None, None, None
        feet, ground_height, penetration = ctx.args
        grad_p = torch.zeros_like(p)  # [B, E, 3]
        adjoint = _ck.eval_penetration_depth_adjoint if penetration else _ck.eval_foot_heights_adjoint
        with on_torch_stream(p.device) as dev:
            adjoint(_wrap(p, _VEC3), wp.from_torch(grad_out.contiguous(), requires_grad=False), feet=feet,
                    ground_height=ground_height, adj_points=_wrap(grad_p, _VEC3), device=dev)
        return grad_p, None, None, None


def foot_heights(p: torch.Tensor, *, feet: Any = None, ground_height: float = 0.0) -> torch.Tensor:
    """Height of each foot above the ground plane, $p_z - z_g$ [m], shape [..., F]; differentiable.

    Args:
        p: End-effector points [..., E, 3] [m], world frame.
        feet: Indices of the feet among the E points (default all; see
            :func:`~morphkit.kernels.contact.foot_indices`).
        ground_height: Ground plane height $z_g$ [m].
    """
    _check_points(p, "p", 2)
    lead = p.shape[:-2]
    out = FootHeightFunction.apply(p.reshape(-1, p.shape[-2], 3), _feet(feet), float(ground_height), False)
    return out.reshape(*lead, out.shape[-1])


def penetration_depth(p: torch.Tensor, *, feet: Any = None, ground_height: float = 0.0) -> torch.Tensor:
    """Penetration depth of each foot into the ground, $\\max(0, z_g - p_z)$ [m], shape [..., F].

    Arguments as :func:`foot_heights`. The gradient is $-1$ on $p_z$ below the ground, 0 above.
    """
    _check_points(p, "p", 2)
    lead = p.shape[:-2]
    out = FootHeightFunction.apply(p.reshape(-1, p.shape[-2], 3), _feet(feet), float(ground_height), True)
    return out.reshape(*lead, out.shape[-1])


# ---- motions ----------------------------------------------------------------------------------
class SlidingSpeedFunction(torch.autograd.Function):
    """Horizontal foot speed where below the height threshold, [B, T, F], from points [B, T, E, 3].

    Backward: the adjoint of $\\lVert (v_x, v_y) \\rVert$ with $v$ the backward difference × fps;
    the contact gate passes no gradient.
    """

    @staticmethod
    def forward(ctx: Any, P: torch.Tensor, fps: float, feet: tuple[int, ...] | None, height_threshold: float,
                ground_height: float) -> torch.Tensor:
        P = P.contiguous()  # [B, T, E, 3]
        F = P.shape[2] if feet is None else len(feet)
        out = torch.empty((P.shape[0], P.shape[1], F), dtype=P.dtype, device=P.device)  # [B, T, F]
        with on_torch_stream(P.device) as dev:
            _ck.eval_sliding_speed(_wrap(P, _VEC3), fps, feet=feet, height_threshold=height_threshold,
                                   ground_height=ground_height, out=wp.from_torch(out, requires_grad=False),
                                   device=dev)
        ctx.save_for_backward(P)
        ctx.args = (fps, feet, height_threshold, ground_height)
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None, None, None]:
        (P,) = ctx.saved_tensors
        if not ctx.needs_input_grad[0]:
            return None, None, None, None, None
        fps, feet, height_threshold, ground_height = ctx.args
        grad_P = torch.zeros_like(P)  # [B, T, E, 3]
        with on_torch_stream(P.device) as dev:
            _ck.eval_sliding_speed_adjoint(_wrap(P, _VEC3), wp.from_torch(grad_out.contiguous(), requires_grad=False),
                                           fps, feet=feet, height_threshold=height_threshold,
                                           ground_height=ground_height, adj_points=_wrap(grad_P, _VEC3), device=dev)
        return grad_P, None, None, None, None


def sliding_speed(P: torch.Tensor, fps: float, *, feet: Any = None, height_threshold: float = UFR.height,
                  ground_height: float = 0.0) -> torch.Tensor:
    """Horizontal foot speed while in contact [m/s], shape [..., T, F]; differentiable w.r.t. ``P``.

    $s_t = \\lVert (v_{t,x}, v_{t,y}) \\rVert$ where $P_{t,z} - z_g <$ ``height_threshold``, else 0;
    $v_t$ is the backward difference along T times ``fps`` (frame 0 copies frame 1). A foot moving
    1 cm per frame on the ground at 30 fps slides at 0.3 m/s.

    Args:
        P: End-effector points of motions [..., T, E, 3] [m].
        fps: Frames per second.
        feet: Indices of the feet among the E points (default all).
        height_threshold: In contact below this height [m].
        ground_height: Ground plane height [m].
    """
    _check_points(P, "P", 3)
    lead = P.shape[:-3]
    T, E = P.shape[-3], P.shape[-2]
    out = SlidingSpeedFunction.apply(P.reshape(-1, T, E, 3), float(fps), _feet(feet), float(height_threshold),
                                     float(ground_height))
    return out.reshape(*lead, T, out.shape[-1])


def contact_flags(P: torch.Tensor, fps: float, *, feet: Any = None, height_threshold: float = UFR.height,
                  speed_threshold: float = UFR.speed, ground_height: float = 0.0) -> torch.Tensor:
    """Foot contact flags of motions [..., T, F] (bool, no gradient): below ``height_threshold`` [m]
    and horizontally slower than ``speed_threshold`` [m/s] (the one contact rule, :mod:`morphkit.contact_rules`:
    backward differences, frame 0 copying frame 1)."""
    _check_points(P, "P", 3)
    lead = P.shape[:-3]
    T, E = P.shape[-3], P.shape[-2]
    Pd = P.detach().reshape(-1, T, E, 3).contiguous()
    F = E if feet is None else len(_feet(feet) or ())
    out = torch.empty((Pd.shape[0], T, F), dtype=torch.bool, device=P.device)
    with on_torch_stream(Pd.device) as dev:
        _ck.eval_contact_flags(_wrap(Pd, _VEC3), fps, feet=_feet(feet), height_threshold=height_threshold,
                               speed_threshold=speed_threshold, ground_height=ground_height,
                               out=wp.from_torch(out, dtype=wp.bool, requires_grad=False), device=dev)
    return out.reshape(*lead, T, F)


# ---- link shapes ------------------------------------------------------------------------------
def _check_transforms(model: KinematicModel, Ts: Any) -> None:
    if not isinstance(model, KinematicModel):
        raise GraphError(f"expected a KinematicModel (morphkit.model.compile_model(...)), got {type(model).__name__}")
    if not isinstance(Ts, torch.Tensor):
        raise GraphError(f"Ts: expected a torch.Tensor, got {type(Ts).__name__}")
    if Ts.dtype not in _TRANSFORM:
        raise GraphError(f"Ts: expected float32 or float64, got {Ts.dtype}")
    if Ts.dim() < 2 or tuple(Ts.shape[-2:]) != (model.link_count, 7):
        raise GraphError(f"Ts: expected shape [..., {model.link_count}, 7] for {model.name!r}, got {list(Ts.shape)}")


class SelfCollisionFunction(torch.autograd.Function):
    """Signed distance (or penetration depth) of candidate shape pairs, [B, P], from link transforms [B, L, 7].

    Backward: the adjoint of the pair distances (:mod:`morphkit.kernels.geometry`) into $\\bar{Ts}$
    [B, L, 7], through both shapes' poses.
    """

    @staticmethod
    def forward(ctx: Any, Ts: torch.Tensor, model: KinematicModel, pairs: SelfCollisionPairs,
                penetration: bool) -> torch.Tensor:
        Ts = Ts.contiguous()  # [B, L, 7]
        out = torch.empty((Ts.shape[0], pairs.pair_count), dtype=Ts.dtype, device=Ts.device)  # [B, P]
        launch = _ck.eval_self_collision_penetration if penetration else _ck.eval_self_collision_distance
        with on_torch_stream(Ts.device) as dev:
            launch(model, pairs, _wrap(Ts, _TRANSFORM), out=wp.from_torch(out, requires_grad=False), device=dev)
        ctx.save_for_backward(Ts)
        ctx.args = (model, pairs, penetration)
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None, None]:
        (Ts,) = ctx.saved_tensors
        if not ctx.needs_input_grad[0]:
            return None, None, None, None
        model, pairs, penetration = ctx.args
        grad_Ts = torch.zeros_like(Ts)  # [B, L, 7]
        adjoint = (_ck.eval_self_collision_penetration_adjoint if penetration
                   else _ck.eval_self_collision_distance_adjoint)
        with on_torch_stream(Ts.device) as dev:
            adjoint(model, pairs, _wrap(Ts, _TRANSFORM), wp.from_torch(grad_out.contiguous(), requires_grad=False),
                    adj_link_X=_wrap(grad_Ts, _TRANSFORM), device=dev)
        return grad_Ts, None, None, None


def self_collision_distance(model: KinematicModel, pairs: SelfCollisionPairs, Ts: torch.Tensor) -> torch.Tensor:
    """Signed distance of every candidate pair [m], shape [..., P] (negative: overlapping); differentiable.

    Args:
        model: The compiled morphology.
        pairs: Candidate pairs from :func:`~morphkit.kernels.contact.self_collision_pairs`.
        Ts: Link transforms [..., L, 7] (e.g. :func:`~morphkit.torch.fk`).
    """
    _check_transforms(model, Ts)
    lead = Ts.shape[:-2]
    out = SelfCollisionFunction.apply(Ts.reshape(-1, model.link_count, 7), model, pairs, False)
    return out.reshape(*lead, pairs.pair_count)


def self_collision_penetration(model: KinematicModel, pairs: SelfCollisionPairs, Ts: torch.Tensor) -> torch.Tensor:
    """Penetration depth $\\max(0, -d)$ of every candidate pair [m], shape [..., P]; arguments as
    :func:`self_collision_distance`. Sum it for a self-collision loss."""
    _check_transforms(model, Ts)
    lead = Ts.shape[:-2]
    out = SelfCollisionFunction.apply(Ts.reshape(-1, model.link_count, 7), model, pairs, True)
    return out.reshape(*lead, pairs.pair_count)


class ShapeGroundFunction(torch.autograd.Function):
    """Height of every link shape's lowest point above the ground, [B, S], from link transforms [B, L, 7]."""

    @staticmethod
    def forward(ctx: Any, Ts: torch.Tensor, model: KinematicModel, ground_height: float) -> torch.Tensor:
        Ts = Ts.contiguous()  # [B, L, 7]
        out = torch.empty((Ts.shape[0], model.shape_count), dtype=Ts.dtype, device=Ts.device)  # [B, S]
        with on_torch_stream(Ts.device) as dev:
            _ck.eval_shape_ground_distance(model, _wrap(Ts, _TRANSFORM), ground_height=ground_height,
                                           out=wp.from_torch(out, requires_grad=False), device=dev)
        ctx.save_for_backward(Ts)
        ctx.args = (model, ground_height)
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None]:
        (Ts,) = ctx.saved_tensors
        if not ctx.needs_input_grad[0]:
            return None, None, None
        model, ground_height = ctx.args
        grad_Ts = torch.zeros_like(Ts)  # [B, L, 7]
        with on_torch_stream(Ts.device) as dev:
            _ck.eval_shape_ground_distance_adjoint(model, _wrap(Ts, _TRANSFORM),
                                                   wp.from_torch(grad_out.contiguous(), requires_grad=False),
                                                   ground_height=ground_height, adj_link_X=_wrap(grad_Ts, _TRANSFORM),
                                                   device=dev)
        return grad_Ts, None, None


def shape_ground_distance(model: KinematicModel, Ts: torch.Tensor, *, ground_height: float = 0.0) -> torch.Tensor:
    """Height of every link shape's lowest point above the ground [m], shape [..., S]; differentiable.

    ``relu(-shape_ground_distance(...))`` is the shapes' ground penetration. Mesh shapes report a
    large constant (no contact).
    """
    _check_transforms(model, Ts)
    lead = Ts.shape[:-2]
    out = ShapeGroundFunction.apply(Ts.reshape(-1, model.link_count, 7), model, float(ground_height))
    return out.reshape(*lead, model.shape_count)
