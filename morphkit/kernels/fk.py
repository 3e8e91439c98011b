"""Forward kinematics kernels, specialised per morphology, and their launchers.

One thread computes one pose: it walks the joints in topological order and writes the world
transform of every link. The joint list is unrolled into straight-line scalar code generated
for each morphology, with its constants (joint origins, axes, mimic coefficients) baked in and
every product with a literal 0 or 1 removed: no loop, no switch on the joint type, every
intermediate in registers (``docs/design/fk-kernels.md`` has the measurements). Per-sample bone
offsets (NKN) go through the pure-torch reference path instead (:mod:`morphkit.torch.reference`).

Generated sources are written to a cache directory (``MORPHKIT_CACHE_DIR``, default
``~/.cache/morphkit/<version>/kernels``) and imported as ordinary modules, so Warp can read
their source and cache their binaries like any other kernel module.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import threading
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import warp as wp

from morphkit._atomic import atomic_write_text
from morphkit._version import __version__
from morphkit.cache import cache_dir
from morphkit.errors import GraphError
from morphkit.kernels._fk_codegen import generate_source
from morphkit.kernels.dtypes import quat_type, transform_type, vec3_type
from morphkit.kernels.launch import as_batch, as_shape, check_device, launch, output_array, resolve_device
from morphkit.model.kinematic_model import KinematicModel, resolve_float_dtype

__all__ = [
    "eval_fk",
    "eval_fk_adjoint",
    "eval_link_positions",
    "eval_link_positions_adjoint",
    "eval_wheel_angles",
    "fk_module",
    "generate_fk_source",
    "kernel_cache_dir",
]

# ---------------------------------------------------------------------------------------------
# code generation
# ---------------------------------------------------------------------------------------------

def kernel_cache_dir() -> Path:
    """Where generated kernel sources go: ``$MORPHKIT_CACHE_DIR/<version>/kernels`` (default ``~/.cache/morphkit``)."""
    return cache_dir(__version__, "kernels")


def generate_fk_source(model: KinematicModel, dtype: Any = None) -> str:
    """Python source of the FK kernels specialised for ``model`` (and ``dtype``: float32 or float64).

    The module defines ``fk_transforms`` (``out[b, l]`` = ``T_world_link``) and
    ``fk_positions`` (``out[b, l]`` = link origin in world), both with the signature
    ``(q, wheel_q, wheel_batched, offset, out)``; thread ``i`` computes pose ``b = i + offset``.
    """
    return generate_source(model, resolve_float_dtype(dtype).__name__)


def _write_source(name: str, source: str) -> Path:
    """Write a generated module into the cache directory (a temporary one if that is not writable)."""
    import tempfile

    fallback = Path(tempfile.gettempdir()) / f"morphkit-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
    for folder in (kernel_cache_dir(), fallback / __version__ / "kernels"):
        path = folder / f"{name}.py"
        try:
            if not path.exists() or path.read_text() != source:
                folder.mkdir(parents=True, exist_ok=True)
                atomic_write_text(path, source)
            return path
        except OSError:
            continue
    raise GraphError(f"cannot write generated kernel module {name}.py to {kernel_cache_dir()} or {fallback}; "
                     "set MORPHKIT_CACHE_DIR to a writable folder")


_module_lock = threading.Lock()
_modules: dict[str, ModuleType] = {}


def fk_module(model: KinematicModel, dtype: Any = None) -> ModuleType:
    """The generated FK module for ``model``'s structure and ``dtype`` (generated, written and imported once).

    Its kernels are ordinary Warp kernels (``module.fk_transforms``, ``module.fk_positions``);
    ``wp.get_module(module.__name__)`` is the Warp module, for ahead-of-time compilation.
    """
    cache = model.kernel_cache()
    dt = resolve_float_dtype(dtype)
    hit = cache.get(("fk_module", dt.__name__))
    if hit is not None:
        return hit
    source = generate_fk_source(model, dt)
    digest = hashlib.sha1(source.encode()).hexdigest()[:16]
    name = f"morphkit_fk_{digest}"
    with _module_lock:
        module = _modules.get(name)
        if module is None:
            path = _write_source(name, source)
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:  # pragma: no cover - importlib always finds a .py file
                raise GraphError(f"cannot import generated kernel module {path}")
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            spec.loader.exec_module(module)
            _modules[name] = module
    cache[("fk_module", dt.__name__)] = module
    return module


# ---------------------------------------------------------------------------------------------
# launchers
# ---------------------------------------------------------------------------------------------


def _wheel_input(model: KinematicModel, wheel_q: Any, B: int, lead: tuple[int, ...], device: Any,
                 dtype: Any) -> tuple[wp.array, int]:
    W = model.wheel_count
    if wheel_q is None:
        key = ("zeros_wheel", str(device), dtype.__name__, W)
        cache = model.kernel_cache()
        z = cache.get(key)
        if z is None:
            z = cache[key] = wp.zeros((1, max(W, 1)), dtype=dtype, device=device)
        return z, 0
    if not isinstance(wheel_q, wp.array):
        wheel_q = wp.array(np.ascontiguousarray(wheel_q, dtype=wp.dtype_to_numpy(dtype)), dtype=dtype, device=device)
    if tuple(wheel_q.shape) != (*lead, W):
        raise GraphError(f"wheel_q: expected shape {[*lead, W]}, got {list(wheel_q.shape)}")
    if wheel_q.dtype != dtype:
        raise GraphError("wheel_q: dtype must match q")
    if W == 0:
        return _wheel_input(model, None, B, lead, device, dtype)
    return wheel_q.contiguous().reshape((B, W)), 1


def _fk_inputs(q: wp.array, wheel: wp.array, wheel_batched: int) -> list:
    return [q, wheel, wheel_batched, 0]


def _eval(model: KinematicModel, q: Any, kernel_name: str, out_dtype_of: Any, *, out: Any, wheel_q: Any,
          device: Any) -> wp.array:
    device = resolve_device(device, q, model, out=out)
    q2, lead, dtype = as_batch(model, q, device)
    B = q2.shape[0]
    wheel, wheel_batched = _wheel_input(model, wheel_q, B, lead, device, dtype)
    L = model.link_count
    out = output_array(out, (*lead, L), out_dtype_of(dtype), device, requires_grad=q2.requires_grad)
    if B == 0:
        return out
    kernel = getattr(fk_module(model, dtype), kernel_name)
    launch(kernel, B, device, _fk_inputs(q2, wheel, wheel_batched), [as_shape(out, (B, L))])
    return out


def eval_fk(model: KinematicModel, q: Any, *, out: wp.array | None = None, wheel_q: Any = None,
            device: Any = None) -> wp.array:
    """World transforms ``T_world_link`` of every link.

    Args:
        model: The compiled morphology.
        q: Coordinates, shape [..., C] (any leading shape), float32 or float64, as a Warp array
            (or anything NumPy accepts, copied to ``device``).
        out: Optional output, shape [..., L], dtype ``wp.transform`` (``wp.transformd`` for
            float64); reused instead of allocating.
        wheel_q: Wheel angles [rad], shape [..., W] (see :func:`~morphkit.kernels.eval_wheel_angles`);
            ``None`` puts every wheel at 0.
        device: Launch device (default: ``q``'s device, else the model's).

    Returns:
        ``Ts_world_link``, shape [..., L] of transforms (``.numpy()`` gives [..., L, 7]: position [m]
        then xyzw quaternion).

    Raises:
        GraphError: on a wrong shape, dtype or device.
    """
    return _eval(model, q, "fk_transforms", transform_type, out=out, wheel_q=wheel_q, device=device)


def eval_link_positions(model: KinematicModel, q: Any, *, out: wp.array | None = None, wheel_q: Any = None,
                        device: Any = None) -> wp.array:
    """World positions of every link origin (the fast path of :func:`eval_fk`).

    Same arguments as :func:`eval_fk`; returns shape [..., L] of ``wp.vec3`` (``.numpy()``:
    [..., L, 3], [m]).
    """
    return _eval(model, q, "fk_positions", vec3_type, out=out, wheel_q=wheel_q, device=device)


def _adjoint_args(model: KinematicModel, q: Any, adj_out: wp.array, out_dtype_of: Any, *, adj_q: wp.array | None,
                  wheel_q: Any, device: Any) -> tuple[Any, wp.array, Any, wp.array, int, wp.array]:
    """Validate the arguments of an FK adjoint; returns device, q as [B, C], dtype, wheel input, whether
    wheels are batched, and ``adj_q`` (allocated zeroed when not given)."""
    device = resolve_device(device, q, model, out=adj_out)
    check_device(adj_out, device, "adj_out")
    q2, lead, dtype = as_batch(model, q, device)
    L, C = model.link_count, model.coordinate_count
    wheel, wheel_batched = _wheel_input(model, wheel_q, q2.shape[0], lead, device, dtype)
    out_type = out_dtype_of(dtype)
    if tuple(adj_out.shape) != (*lead, L) or not wp.types.types_equal(adj_out.dtype, out_type):
        raise GraphError(f"adj_out: expected shape {[*lead, L]} of {wp.types.type_repr(out_type)}, "
                         f"got {list(adj_out.shape)} of {wp.types.type_repr(adj_out.dtype)}")
    adj_q = output_array(adj_q, (*lead, C), dtype, device, "adj_q", zeros=True)
    return device, q2, dtype, wheel, wheel_batched, adj_q


def _eval_adjoint(model: KinematicModel, q: wp.array, adj_out: wp.array, kernel_name: str, out_dtype_of: Any, *,
                  adj_q: wp.array | None, wheel_q: Any, device: Any) -> wp.array:
    device, q2, dtype, wheel, wheel_batched, adj_q = _adjoint_args(
        model, q, adj_out, out_dtype_of, adj_q=adj_q, wheel_q=wheel_q, device=device
    )
    B, L, C = q2.shape[0], model.link_count, model.coordinate_count
    if B == 0:
        return adj_q
    kernel = getattr(fk_module(model, dtype), kernel_name)
    inputs = _fk_inputs(q2, wheel, wheel_batched)
    # ``out`` is not read by the adjoint of a store; a zero-size placeholder avoids allocating it.
    out_placeholder = adj_out.contiguous().reshape((B, L))
    adj_inputs = [adj_q.reshape((B, C)), None, 0, 0]
    launch(kernel, B, device, inputs, [out_placeholder], adjoint=True, adj_inputs=adj_inputs,
           adj_outputs=[out_placeholder])
    return adj_q


def eval_fk_adjoint(model: KinematicModel, q: Any, adj_out: wp.array, *, adj_q: wp.array | None = None,
                    wheel_q: Any = None, device: Any = None) -> wp.array:
    """Accumulate the vector–Jacobian product of :func:`eval_fk` into ``adj_q``.

    Computes $\\bar q \\mathrel{+}= (\\partial T / \\partial q)^\\top \\bar T$ where $\\bar T$ is
    ``adj_out`` (the gradient of a scalar loss with respect to the link transforms, shape [..., L]
    of transforms, read as 7 floats each), by Warp's adjoint of the generated kernel. Wheel angles
    and model parameters get no gradient here (use :mod:`morphkit.torch.reference` for joint-origin
    gradients).

    Returns:
        ``adj_q``, shape [..., C] (allocated zeroed when not given; accumulated into otherwise).
    """
    return _eval_adjoint(model, q, adj_out, "fk_transforms", transform_type, adj_q=adj_q, wheel_q=wheel_q,
                         device=device)


def eval_link_positions_adjoint(model: KinematicModel, q: Any, adj_out: wp.array, *, adj_q: wp.array | None = None,
                                wheel_q: Any = None, device: Any = None) -> wp.array:
    """Vector–Jacobian product of :func:`eval_link_positions` (``adj_out``: [..., L] vec3), added to ``adj_q``.

    Uses the generated analytic reverse sweep (forces and moments accumulated over subtrees, see
    ``_fk_codegen._vjp_body``) instead of Warp's adjoint: it re-runs the forward pass once to
    record the joint frames, then sweeps the tree backwards.
    """
    device, q2, dtype, wheel, wheel_batched, adj_q = _adjoint_args(
        model, q, adj_out, vec3_type, adj_q=adj_q, wheel_q=wheel_q, device=device
    )
    B, L, C = q2.shape[0], model.link_count, model.coordinate_count
    vec3 = vec3_type(dtype)
    if B == 0:
        return adj_q
    module = fk_module(model, dtype)
    pos = wp.empty((B, L), dtype=vec3, device=device)
    frames = wp.empty((B, max(model.joint_count, 1)), dtype=quat_type(dtype), device=device)
    launch(module.fk_positions_frames, B, device, _fk_inputs(q2, wheel, wheel_batched), [pos, frames])
    launch(module.fk_positions_vjp, B, device, [q2, pos, frames, adj_out.contiguous().reshape((B, L)), 0],
           [adj_q.reshape((B, C))])
    return adj_q


# ---------------------------------------------------------------------------------------------
# wheels
# ---------------------------------------------------------------------------------------------


@wp.kernel(enable_backward=False)
def wheel_angles(
    q: wp.array3d[Any],
    lateral: wp.array[Any],
    sign: wp.array[Any],
    inv_radius: Any,
    offset: int,
    out: wp.array3d[Any],
):
    r"""Scan over time for one motion ``b``: wheel angles that roll without slipping along the base path.

    Between frames the root follows a circular arc (constant speed and yaw rate): its arc length
    is the chord along the mid heading times $h / \sin h$, $h = \Delta\psi / 2$. Wheel ``w``
    at lateral offset $y_w$ rolls $s - y_w \Delta\psi$.
    """
    i = wp.tid()
    b = i + offset
    zero = inv_radius - inv_radius
    half = type(inv_radius)(0.5)
    pi = type(inv_radius)(3.14159265358979323846)
    for w in range(out.shape[2]):
        out[b, 0, w] = zero
    for t in range(1, q.shape[1]):
        dx = q[b, t, 0] - q[b, t - 1, 0]
        dy = q[b, t, 1] - q[b, t - 1, 1]
        d = q[b, t, 2] - q[b, t - 1, 2]
        dpsi = d - type(d)(2.0) * pi * wp.floor((d + pi) / (type(d)(2.0) * pi))
        mid = q[b, t - 1, 2] + half * dpsi
        chord = dx * wp.cos(mid) + dy * wp.sin(mid)
        h = half * dpsi
        factor = type(h)(1.0) + h * h / type(h)(6.0)
        if wp.abs(h) > type(h)(1.0e-4):
            factor = h / wp.sin(h)
        s = chord * factor
        for w in range(out.shape[2]):
            out[b, t, w] = out[b, t - 1, w] + sign[w] * (s - lateral[w] * dpsi) * inv_radius


for _s in (wp.float32, wp.float64):
    wp.overload(wheel_angles, {"q": wp.array3d(dtype=_s), "lateral": wp.array(dtype=_s), "sign": wp.array(dtype=_s),
                               "inv_radius": _s, "out": wp.array3d(dtype=_s)})


def eval_wheel_angles(model: KinematicModel, q: Any, *, out: wp.array | None = None, device: Any = None) -> wp.array:
    r"""Wheel angles [rad] of motions of a wheeled base, for :func:`eval_fk`'s ``wheel_q``.

    Wheels roll without slipping along the base's path: for wheel $w$ at lateral offset $y_w$
    (root-frame y of its joint at rest, left positive) and axis sign $\sigma_w$,
    $\theta_w(t) = \sigma_w / r \sum_{k \le t} (s_k - y_w \Delta\psi_k)$ with $s_k$ the root's
    arc length and $\Delta\psi_k$ its yaw change between frames $k - 1$ and $k$; angles start at 0.
    Not differentiable (the wheel angles only turn the wheels).

    Args:
        model: A compiled morphology (wheeled base; otherwise the result has W = 0 columns).
        q: Motions, shape [..., T, C]; the base coordinates ``q[..., 0:3]`` are ``(x, y, yaw)``.
        out: Optional output, shape [..., T, W].

    Returns:
        Wheel angles, shape [..., T, W] (same dtype as ``q``).
    """
    device = resolve_device(device, q, model, out=out)
    q2, lead, dtype = as_batch(model, q, device)
    if len(lead) < 1:
        raise GraphError(f"q: expected a motion of shape [..., T, {model.coordinate_count}], got {list(q.shape)}")
    W = model.wheel_count
    out = output_array(out, (*lead, W), dtype, device, zeros=True)
    T = lead[-1]
    B = q2.shape[0] // T if T else 0
    if W == 0 or B == 0:
        return out
    a = model.arrays(device, dtype)
    launch(wheel_angles, B, device, [q2.reshape((B, T, model.coordinate_count)), a.wheel_lateral, a.wheel_sign,
                                     dtype(1.0 / model.wheel_radius), 0], [out.reshape((B, T, W))])
    return out
