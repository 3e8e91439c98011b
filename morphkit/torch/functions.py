"""PyTorch autograd over the Warp kinematics kernels.

Notation: ``q`` [..., C] coordinates, ``Ts`` [..., L, 7] link transforms ``T_world_link``
(position [m] then xyzw quaternion), ``p`` [..., E, 3] end-effector points. For a scalar loss
$\\ell$ the backward pass returns $\\bar q = (\\partial y / \\partial q)^\\top \\bar y$ for the
output $y$, computed by Warp's adjoint of the same generated kernel (no autograd graph is built
on the torch side). Inputs are wrapped zero-copy (``wp.from_torch``) and kernels run on torch's
current CUDA stream. Model arrays and intermediate buffers are cached per model, device and
dtype; outputs and gradients are fresh torch tensors (the caching allocator makes this cheap),
so results stay valid across calls.

These functions are once differentiable. For double backward, gradients with respect to joint
origins ("bone offsets") or anything else the kernels treat as constant, use the pure-torch
escape hatch :mod:`morphkit.torch.reference` (same conventions, plain autograd), e.g. through
``ForwardKinematics(..., backend="reference")``.
"""

from __future__ import annotations

import threading
from typing import Any

import torch
import warp as wp
from torch.autograd.function import once_differentiable

from morphkit.errors import GraphError
from morphkit.kernels import end_effectors as _ee
from morphkit.kernels import fk as _fk
from morphkit.kernels.dtypes import quat_type, transform_type, vec3_type
from morphkit.kernels.launch import launch, launch_chunks, tape_active
from morphkit.model.kinematic_model import KinematicModel
from morphkit.rotations import heading_frame, quat_rotate_inverse
from morphkit.torch.streams import on_torch_stream

__all__ = [
    "EndEffectorFunction",
    "FKFunction",
    "end_effector_positions",
    "end_effector_velocities",
    "end_effectors",
    "fk",
    "link_positions",
    "wheel_angles",
]

_WP_SCALAR = {torch.float32: wp.float32, torch.float64: wp.float64}


def _ctype(t: torch.Tensor, dtype: Any) -> Any:
    """Zero-copy array descriptor of ``t`` for a non-generic kernel (the cheapest wrapping)."""
    return wp.from_torch(t, dtype=dtype, requires_grad=False, return_ctype=True)


def _array(t: torch.Tensor, dtype: Any) -> wp.array:
    """Zero-copy ``wp.array`` view of ``t`` (generic kernels need the typed array to pick an overload)."""
    return wp.from_torch(t, dtype=dtype, requires_grad=False)


def _zeros(shape: tuple[int, ...] | torch.Size, like: torch.Tensor) -> torch.Tensor:
    """A zeroed tensor; on the CPU cleared by Warp's memset (torch's multi-threaded fill stalls on a busy CPU)."""
    if like.device.type != "cpu":
        return torch.zeros(tuple(shape), dtype=like.dtype, device=like.device)  # on torch's stream
    t = torch.empty(tuple(shape), dtype=like.dtype, device=like.device)
    if t.numel():
        wp.from_torch(t.reshape(-1), requires_grad=False).zero_()
    return t


def _cotangent(g: torch.Tensor) -> torch.Tensor:
    """An incoming gradient [..., k] in a layout Warp can read without copying where possible.

    Warp reads any outer strides but needs the trailing component dimension contiguous. The
    common ``loss.sum()`` gradient is one value broadcast everywhere (all strides 0): only its
    last row is materialised and broadcast again, instead of copying the whole tensor.
    """
    if g.stride(-1) == 1:
        return g
    if all(st == 0 for st in g.stride()[:-1]):
        return g[(0,) * (g.dim() - 1)].contiguous().expand_as(g)
    return g.contiguous()


def _check(model: KinematicModel, q: torch.Tensor) -> None:
    if not isinstance(model, KinematicModel):
        raise GraphError(f"expected a KinematicModel (morphkit.model.compile_model(...)), got {type(model).__name__}")
    if not isinstance(q, torch.Tensor):
        raise GraphError(f"q: expected a torch.Tensor, got {type(q).__name__}")
    if q.dtype not in _WP_SCALAR:
        raise GraphError(f"q: expected float32 or float64, got {q.dtype}")
    if q.dim() < 1 or q.shape[-1] != model.coordinate_count:
        raise GraphError(
            f"q: expected shape [..., {model.coordinate_count}] for {model.name!r} "
            f"({model.coordinate_count} coordinates), got {list(q.shape)}"
        )


class _Ctx:
    """Per (model, device, dtype) state: the generated kernels, Warp device and wrapped constants."""

    def __init__(self, model: KinematicModel, device: torch.device, dtype: torch.dtype) -> None:
        wp.init()
        self.wp_device = wp.device_from_torch(device)
        self.scalar = _WP_SCALAR[dtype]
        self.module = _fk.fk_module(model, self.scalar)
        self.transform = transform_type(self.scalar)
        self.vec3 = vec3_type(self.scalar)
        self.quat = quat_type(self.scalar)
        self.arrays = model.arrays(self.wp_device, self.scalar)
        self.zero_wheels_array = wp.zeros((1, max(model.wheel_count, 1)), dtype=self.scalar, device=self.wp_device)
        self.zero_wheels = self.zero_wheels_array.__ctype__()
        self.replays: dict[str, Any] = {}
        self.lock = threading.Lock()

    def launch_fk(self, kernel: Any, q: torch.Tensor, outs: list[tuple[torch.Tensor, Any]], wheel: Any,
                  batched: int) -> None:
        """Launch a generated FK kernel on ``q`` [B, C] into ``outs`` (contiguous ``(tensor, Warp dtype)`` pairs).

        Small batches replay a recorded launch whose array descriptors are updated in place
        (a few µs instead of ~15 for ``wp.launch``); large CPU batches are split over threads.
        Call inside :func:`~morphkit.torch.streams.on_torch_stream`: the replay runs on the
        device's current stream.
        """
        B = q.shape[0]
        if len(launch_chunks(B, self.wp_device)) > 1 or tape_active():
            launch(kernel, B, self.wp_device, [_ctype(q, self.scalar), wheel, batched, 0],
                   [_ctype(t, dt) for t, dt in outs])
            return
        with self.lock:
            entry = self.replays.get(kernel.key)
            if entry is None:
                replay = wp.launch(kernel, dim=B, inputs=[_ctype(q, self.scalar), wheel, batched, 0],
                                   outputs=[_ctype(t, dt) for t, dt in outs], device=self.wp_device,
                                   record_cmd=True)
                self.replays[kernel.key] = entry = [replay, B]
            else:
                replay = entry[0]
                # params: [bounds, q, wheel_q, wheel_batched, offset, *outs]
                params = replay.params
                for arr, t in ((params[1], q), *((params[5 + i], o) for i, (o, _) in enumerate(outs))):
                    arr.data, arr.shape[0], arr.strides[0] = t.data_ptr(), B, t.stride(0) * t.element_size()
                replay.set_param_at_index_from_ctype(1, wheel)
                params[3].value = batched
                if entry[1] != B:
                    replay.set_dim(B)
                    entry[1] = B
            replay.launch()


def _ctx(model: KinematicModel, t: torch.Tensor) -> _Ctx:
    cache = model.kernel_cache()
    key = ("torch", t.device, t.dtype)
    c = cache.get(key)
    if c is None:
        c = cache[key] = _Ctx(model, t.device, t.dtype)
    return c


def _wheels(c: _Ctx, model: KinematicModel, wheel_q: torch.Tensor | None, B: int) -> tuple[Any, int]:
    """Kernel arguments for the wheel angles: a [B, W] tensor (prepared by ``_prepare``) or a zero row."""
    if wheel_q is None or model.wheel_count == 0:
        return c.zero_wheels, 0
    return _ctype(wheel_q, c.scalar), 1


def _flat_q(model: KinematicModel, q: torch.Tensor) -> torch.Tensor:
    return q.reshape(-1, model.coordinate_count).contiguous()


class FKFunction(torch.autograd.Function):
    """$Ts = FK(q)$ (``kind="transforms"``, [B, L, 7]) or link origins (``kind="positions"``, [B, L, 3]).

    Backward: $\\bar q = J^\\top \\bar y$. For transforms, by Warp's adjoint of the generated
    kernel; for positions, by the generated analytic reverse sweep (forces and moments over
    subtrees), from the positions and the joint frames the forward pass saved. ``wheel_q`` is
    treated as a constant.
    """

    @staticmethod
    def forward(
        ctx: Any, q: torch.Tensor, wheel_q: torch.Tensor | None, model: KinematicModel, kind: str
    ) -> torch.Tensor:
        c = _ctx(model, q)
        B, L, J = q.shape[0], model.link_count, model.joint_count
        transforms = kind == "transforms"
        out = torch.empty((B, L, 7 if transforms else 3), dtype=q.dtype, device=q.device)  # [B, L, 7 | 3]
        frames = None
        outs = [(out, c.transform if transforms else c.vec3)]
        if transforms:
            kernel = c.module.fk_transforms
        elif ctx.needs_input_grad[0]:
            kernel = c.module.fk_positions_frames
            frames = torch.empty((B, max(J, 1), 4), dtype=q.dtype, device=q.device)  # [B, J, 4]
            outs.append((frames, c.quat))
        else:
            kernel = c.module.fk_positions
        if B:
            wheel, batched = _wheels(c, model, wheel_q, B)
            with on_torch_stream(c.wp_device):
                c.launch_fk(kernel, q, outs, wheel, batched)
        if frames is not None:
            ctx.save_for_backward(q, wheel_q, out, frames)
        else:
            ctx.save_for_backward(q, wheel_q)
        ctx.model, ctx.kind = model, kind
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad_out: torch.Tensor) -> tuple[torch.Tensor | None, None, None, None]:
        saved = ctx.saved_tensors
        q, wheel_q = saved[0], saved[1]
        model: KinematicModel = ctx.model
        if not ctx.needs_input_grad[0]:
            return None, None, None, None
        c = _ctx(model, q)
        B = q.shape[0]
        grad_q = _zeros(q.shape, q)  # [B, C]
        if B:
            grad_out = _cotangent(grad_out)  # [B, L, 7 | 3]
            with on_torch_stream(c.wp_device):
                if ctx.kind == "positions":
                    pos, frames = saved[2], saved[3]  # [B, L, 3], [B, J, 4]
                    launch(
                        c.module.fk_positions_vjp,
                        B,
                        c.wp_device,
                        [_ctype(q, c.scalar), _ctype(pos, c.vec3), _ctype(frames, c.quat), _ctype(grad_out, c.vec3),
                         0],
                        [_ctype(grad_q, c.scalar)],
                    )
                else:
                    wheel, batched = _wheels(c, model, wheel_q, B)
                    adj_out = _ctype(grad_out, c.transform)
                    # The adjoint never reads the forward output: the gradient buffer stands in for it.
                    launch(
                        c.module.fk_transforms,
                        B,
                        c.wp_device,
                        [_ctype(q, c.scalar), wheel, batched, 0],
                        [adj_out],
                        adjoint=True,
                        adj_inputs=[_ctype(grad_q, c.scalar), None, 0, 0],
                        adj_outputs=[adj_out],
                    )
        return grad_q, None, None, None


class EndEffectorFunction(torch.autograd.Function):
    """End-effector points [B, E, 3] and link orientations [B, E, 4] in the world or heading frame.

    Forward runs FK into a saved [B, L, 7] buffer, then the end-effector kernel. Backward runs the
    end-effector adjoint into $\\bar{Ts}$, then the FK adjoint into $\\bar q$.
    """

    @staticmethod
    def forward(
        ctx: Any, q: torch.Tensor, wheel_q: torch.Tensor | None, model: KinematicModel, heading: int
    ) -> tuple[torch.Tensor, torch.Tensor]:
        c = _ctx(model, q)
        B, L, E = q.shape[0], model.link_count, model.ee_count
        Ts = torch.empty((B, L, 7), dtype=q.dtype, device=q.device)  # [B, L, 7]
        pos = torch.empty((B, E, 3), dtype=q.dtype, device=q.device)  # [B, E, 3]
        rot = torch.empty((B, E, 4), dtype=q.dtype, device=q.device)  # [B, E, 4]
        if B:
            wheel, batched = _wheels(c, model, wheel_q, B)
            with on_torch_stream(c.wp_device):
                c.launch_fk(c.module.fk_transforms, q, [(Ts, c.transform)], wheel, batched)
                if E:
                    launch(
                        _ee.end_effector_poses,
                        B,
                        c.wp_device,
                        [_array(Ts, c.transform), c.arrays.ee_link, c.arrays.ee_offset, heading, 0],
                        [_array(pos, c.vec3), _array(rot, c.quat)],
                        dim_tail=(E,),
                    )
        ctx.save_for_backward(q, wheel_q, Ts)
        ctx.model, ctx.heading = model, heading
        ctx.mark_non_differentiable(Ts)
        return pos, rot

    @staticmethod
    @once_differentiable
    def backward(
        ctx: Any, grad_pos: torch.Tensor | None, grad_rot: torch.Tensor | None
    ) -> tuple[torch.Tensor | None, None, None, None]:
        q, wheel_q, Ts = ctx.saved_tensors
        model: KinematicModel = ctx.model
        if not ctx.needs_input_grad[0]:
            return None, None, None, None
        c = _ctx(model, q)
        B, L, E = q.shape[0], model.link_count, model.ee_count
        grad_q = _zeros(q.shape, q)  # [B, C]
        if B and E:
            grad_pos = (
                _zeros((B, E, 3), q) if grad_pos is None else _cotangent(grad_pos)
            )  # [B, E, 3]
            grad_rot = (
                _zeros((B, E, 4), q) if grad_rot is None else _cotangent(grad_rot)
            )  # [B, E, 4]
            adj_Ts = _zeros((B, L, 7), q)  # [B, L, 7]
            wheel, batched = _wheels(c, model, wheel_q, B)
            adj_pos = _array(grad_pos, c.vec3)
            adj_rot = _array(grad_rot, c.quat)
            adj_Ts_wp = _array(adj_Ts, c.transform)
            with on_torch_stream(c.wp_device):
                launch(
                    _ee.end_effector_poses,
                    B,
                    c.wp_device,
                    [_array(Ts, c.transform), c.arrays.ee_link, c.arrays.ee_offset, ctx.heading, 0],
                    [adj_pos, adj_rot],
                    adjoint=True,
                    adj_inputs=[adj_Ts_wp, None, None, 0, 0],
                    adj_outputs=[adj_pos, adj_rot],
                    dim_tail=(E,),
                )
                launch(
                    c.module.fk_transforms,
                    B,
                    c.wp_device,
                    [_ctype(q, c.scalar), wheel, batched, 0],
                    [adj_Ts_wp],
                    adjoint=True,
                    adj_inputs=[_array(grad_q, c.scalar), None, 0, 0],
                    adj_outputs=[adj_Ts_wp],
                )
        return grad_q, None, None, None


# ---- functional API -------------------------------------------------------------------------
def _prepare(
    model: KinematicModel, q: torch.Tensor, wheel_q: torch.Tensor | None, time_series: bool
) -> tuple[torch.Tensor, torch.Tensor | None]:
    _check(model, q)
    if wheel_q is None and time_series and model.wheel_count:
        wheel_q = wheel_angles(model, q)
    if wheel_q is not None and tuple(wheel_q.shape) != (*q.shape[:-1], model.wheel_count):
        raise GraphError(f"wheel_q: expected shape {[*q.shape[:-1], model.wheel_count]}, got {list(wheel_q.shape)}")
    if wheel_q is not None:
        wheel_q = wheel_q.detach().to(q.dtype).reshape(-1, model.wheel_count).contiguous()
    return _flat_q(model, q), wheel_q


def fk(
    model: KinematicModel, q: torch.Tensor, *, wheel_q: torch.Tensor | None = None, time_series: bool = False
) -> torch.Tensor:
    """Link transforms ``Ts_world_link``, shape [..., L, 7] (position [m], xyzw quaternion).

    Args:
        model: The compiled morphology (:func:`morphkit.model.compile_model`).
        q: Coordinates [..., C], float32 or float64, on any device Warp supports; differentiable.
        wheel_q: Wheel angles [..., W] [rad] (constant for autograd). Default: 0, or integrated from the
            base motion when ``time_series``.
        time_series: ``q`` is a motion [..., T, C]: wheel angles follow the base (see
            ``docs/design/q-layout.md``).
    """
    q2, w = _prepare(model, q, wheel_q, time_series)
    return FKFunction.apply(q2, w, model, "transforms").reshape(*q.shape[:-1], model.link_count, 7)


def link_positions(
    model: KinematicModel, q: torch.Tensor, *, wheel_q: torch.Tensor | None = None, time_series: bool = False
) -> torch.Tensor:
    """World positions of every link origin, shape [..., L, 3] [m] (the fast path of :func:`fk`)."""
    q2, w = _prepare(model, q, wheel_q, time_series)
    return FKFunction.apply(q2, w, model, "positions").reshape(*q.shape[:-1], model.link_count, 3)


def end_effectors(
    model: KinematicModel,
    q: torch.Tensor,
    *,
    frame: str = "world",
    wheel_q: torch.Tensor | None = None,
    time_series: bool = False,
) -> tuple[torch.Tensor, torch.Tensor]:
    """End-effector points [..., E, 3] [m] and orientations [..., E, 4] (xyzw, their links').

    ``frame="heading"`` expresses both in the root's heading frame (:mod:`morphkit.conventions`:
    origin at the root, x along its facing direction, z up).
    """
    heading = _ee.frame_code(frame)
    q2, w = _prepare(model, q, wheel_q, time_series)
    pos, rot = EndEffectorFunction.apply(q2, w, model, heading)
    lead = q.shape[:-1]
    return pos.reshape(*lead, model.ee_count, 3), rot.reshape(*lead, model.ee_count, 4)


def end_effector_positions(
    model: KinematicModel,
    q: torch.Tensor,
    *,
    frame: str = "world",
    wheel_q: torch.Tensor | None = None,
    time_series: bool = False,
) -> torch.Tensor:
    """End-effector points, shape [..., E, 3] [m], in the ``"world"`` or ``"heading"`` frame."""
    return end_effectors(model, q, frame=frame, wheel_q=wheel_q, time_series=time_series)[0]


def end_effector_velocities(
    model: KinematicModel, q: torch.Tensor, *, dt: float, frame: str = "world", wheel_q: torch.Tensor | None = None
) -> torch.Tensor:
    """End-effector velocities of motions ``q`` [..., T, C], shape [..., T, E, 3] [m/s].

    Backward differences of the world positions along T (frame 0 copies frame 1, as the
    conventions say); with ``frame="heading"`` each frame's world velocity is expressed in that
    frame's heading frame.
    Differentiable (the differences are plain torch ops over :func:`end_effectors`).
    """
    _ee.frame_code(frame)
    if q.dim() < 2:
        raise GraphError(f"q: expected a motion of shape [..., T, {model.coordinate_count}], got {list(q.shape)}")
    if not dt > 0:
        raise GraphError(f"dt must be > 0, got {dt}")
    p = end_effector_positions(model, q, wheel_q=wheel_q, time_series=True)  # [..., T, E, 3]
    T = q.shape[-2]
    if T < 2:
        v = torch.zeros_like(p)
    else:
        d = (p[..., 1:, :, :] - p[..., :-1, :, :]) / dt
        v = torch.cat((d[..., :1, :, :], d), dim=-3)
    if frame == "heading":
        root = fk(model, q, wheel_q=wheel_q, time_series=True)[..., 0, :]  # [..., T, 7]
        H = heading_frame(root)  # [..., T, 7]
        v = quat_rotate_inverse(H[..., None, 3:], v)
    return v


def wheel_angles(model: KinematicModel, q: torch.Tensor) -> torch.Tensor:
    """Wheel angles [..., T, W] [rad] of motions ``q`` [..., T, C] (no gradient; see ``eval_wheel_angles``)."""
    _check(model, q)
    if q.dim() < 2:
        raise GraphError(f"q: expected a motion of shape [..., T, {model.coordinate_count}], got {list(q.shape)}")
    out = torch.zeros((*q.shape[:-1], model.wheel_count), dtype=q.dtype, device=q.device)
    if model.wheel_count and q.numel():
        qd = q.detach().contiguous()
        c = _ctx(model, qd)
        with on_torch_stream(c.wp_device):
            _fk.eval_wheel_angles(model, _array(qd, c.scalar), out=_array(out, c.scalar), device=c.wp_device)
    return out
