"""Launching kernels over batches of poses: devices, batch checks, and one CPU thread pool.

Every launcher of :mod:`morphkit.kernels` and the torch bridge goes through :func:`launch`, for a
kernel whose first ``wp.tid()`` index runs over the batch and whose last input is the batch
``offset`` of the launch. Warp runs a CPU launch on one thread; :func:`launch` splits large CPU
batches into chunks launched from one shared thread pool (ctypes releases the GIL during the
kernel call). Other CPU work that launches in parallel (the synthesis IK) takes its threads from
the same pool, :func:`cpu_pool`, so morphkit never runs more kernel threads than
:func:`cpu_thread_count`.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import warp as wp

from morphkit.errors import GraphError
from morphkit.model.kinematic_model import KinematicModel

__all__ = [
    "as_batch",
    "as_shape",
    "check_device",
    "cpu_pool",
    "cpu_thread_count",
    "init_warp_quietly",
    "launch",
    "launch_chunks",
    "output_array",
    "resolve_device",
    "set_cpu_thread_count",
    "tape_active",
]

_NO_CUDA_DRIVER = "Could not find or load the NVIDIA CUDA driver"
"""Warp's note on a machine without a CUDA driver: expected on CPU-only machines, so dropped."""

_MIN_CHUNK = 2048
"""Smallest CPU chunk worth a thread of its own [poses]."""


class _CpuThreads:
    """Thread count and the lazily created pool CPU launches are split over."""

    def __init__(self) -> None:
        self.count = max(1, int(os.environ.get("MORPHKIT_CPU_THREADS", "0")) or (os.cpu_count() or 1))
        self.pool: ThreadPoolExecutor | None = None
        self.lock = threading.Lock()
        self.loaded: set[tuple[int, str]] = set()
        """Modules launched once on a device (safe to launch from several threads)."""


_cpu = _CpuThreads()


def _forget_pool_in_child() -> None:
    # a forked process has none of its parent's threads: a pool it inherited would queue work that never runs
    # (a lane of reproduce_table1 forked after the synthesis used the pool hung), and the lock may be held
    _cpu.lock = threading.Lock()
    _cpu.pool = None


os.register_at_fork(after_in_child=_forget_pool_in_child)


def init_warp_quietly() -> None:
    """Initialise Warp without its note that no CUDA driver was found (CPU-only machines run fine).

    Warp's native library prints that note straight to file descriptor 2 (below Python's
    ``sys.stderr``) while it initialises; the descriptor is pointed at a temporary file for that
    call and whatever else Warp printed there is passed on. A no-op once Warp is initialised.
    """
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real stderr (embedded interpreters): initialise as is
        wp.init()
        return
    with tempfile.TemporaryFile() as caught:
        os.dup2(caught.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        caught.seek(0)
        text = caught.read().decode("utf-8", "replace")
    kept = [line for line in text.splitlines() if line.strip() and _NO_CUDA_DRIVER not in line]
    if kept:
        sys.stderr.write("\n".join(kept) + "\n")


def cpu_thread_count() -> int:
    """Number of threads CPU launches of large batches are split over (``MORPHKIT_CPU_THREADS``, default all cores)."""
    return _cpu.count


def set_cpu_thread_count(n: int) -> None:
    """Set how many threads CPU launches may use (1 disables threading).

    Raises:
        ValueError: when ``n`` < 1.
    """
    if n < 1:
        raise ValueError(f"thread count must be >= 1, got {n}")
    with _cpu.lock:
        _cpu.count = int(n)
        if _cpu.pool is not None:
            _cpu.pool.shutdown(wait=True)
            _cpu.pool = None


def cpu_pool() -> ThreadPoolExecutor | None:
    """The shared pool of :func:`cpu_thread_count` threads (created on first use); ``None`` with one thread.

    Work submitted to it must not wait on other work in the pool (a launch, not a launcher).
    """
    with _cpu.lock:
        if _cpu.count <= 1:
            return None
        if _cpu.pool is None:
            _cpu.pool = ThreadPoolExecutor(max_workers=_cpu.count, thread_name_prefix="morphkit-cpu")
        return _cpu.pool


def launch_chunks(batch: int, device: Any) -> list[tuple[int, int]]:
    """``(offset, size)`` of each launch :func:`launch` makes: one on CUDA, several for large CPU batches."""
    n = 1
    if device.is_cpu and _cpu.count > 1:
        n = min(_cpu.count, max(1, batch // _MIN_CHUNK))
    if n <= 1:
        return [(0, batch)]
    size = math.ceil(batch / n)
    return [(s, min(size, batch - s)) for s in range(0, batch, size)]


def tape_active() -> bool:
    """Whether a ``wp.Tape`` is recording (launches must then not be split)."""
    import warp._src.context as context  # the runtime object appears once Warp is initialised

    return context.runtime is not None and context.runtime.tape is not None


def launch(kernel: Any, batch: int, device: Any, inputs: list, outputs: list, *, adjoint: bool = False,
           adj_inputs: list | None = None, adj_outputs: list | None = None, dim_tail: tuple[int, ...] = ()) -> None:
    """Launch ``kernel`` over ``batch`` poses, split into chunks on the CPU.

    The kernel's first ``wp.tid()`` index runs over a chunk of the batch and its last input is
    the chunk's ``offset`` (its value in ``inputs`` is replaced); ``dim_tail`` gives the remaining
    launch dimensions. Under a ``wp.Tape`` the launch is not split, so the tape records exactly
    one launch.
    """
    chunks = launch_chunks(batch, device)
    if len(chunks) > 1 and tape_active():
        chunks = [(0, batch)]
    last = len(inputs) - 1

    def run(chunk: tuple[int, int]) -> None:
        ins = list(inputs)
        ins[last] = chunk[0]
        wp.launch(kernel, dim=(chunk[1], *dim_tail), inputs=ins, outputs=outputs, device=device, adjoint=adjoint,
                  adj_inputs=adj_inputs or [], adj_outputs=adj_outputs or [])

    pool = cpu_pool() if len(chunks) > 1 else None
    if pool is None:
        for c in chunks:
            run(c)
        return
    key = (id(kernel.module), str(device))
    if key not in _cpu.loaded:
        # The first launch may compile the module: run one chunk alone so threads never race to load it.
        run(chunks[0])
        _cpu.loaded.add(key)
        chunks = chunks[1:]
    for f in [pool.submit(run, c) for c in chunks]:
        f.result()


def resolve_device(device: Any, x: Any = None, model: KinematicModel | None = None, out: Any = None) -> Any:
    """The Warp device to launch on: ``device`` if given, else ``x``'s when it is a Warp array, else
    ``out``'s when it is one (NumPy inputs follow the output they are written into), else the model's
    (Warp's default device without a model)."""
    if device is not None:
        return wp.get_device(device)
    if isinstance(x, wp.array):
        return x.device
    if isinstance(out, wp.array):
        return out.device
    return wp.get_device(model.device if model is not None else None)


def output_array(out: wp.array | None, shape: tuple[int, ...], dtype: Any, device: Any, what: str = "out", *,
                 zeros: bool = False, requires_grad: bool = False) -> wp.array:
    """A launch's output: ``out`` checked against ``shape``, ``dtype`` and ``device``, or a new array.

    Args:
        zeros: A new array starts at zero (adjoints accumulate into it); else it is left uninitialised.

    Raises:
        GraphError: ``out`` has another shape or dtype, is not contiguous, or lives on another device.
    """
    if out is None:
        make = wp.zeros if zeros else wp.empty
        return make(shape, dtype=dtype, device=device, requires_grad=requires_grad)
    if tuple(out.shape) != tuple(shape) or not wp.types.types_equal(out.dtype, dtype) or not out.is_contiguous:
        raise GraphError(f"{what}: expected a contiguous array of shape {list(shape)} and dtype "
                         f"{wp.types.type_repr(dtype)}, got shape {list(out.shape)} and dtype "
                         f"{wp.types.type_repr(out.dtype)}")
    check_device(out, device, what)
    return out


def check_device(a: Any, device: Any, what: str) -> None:
    """Refuse a Warp array ``a`` that lives on another device than the launch's (a CUDA kernel reading or
    writing through a CPU pointer would fault and poison the CUDA context)."""
    if isinstance(a, wp.array) and str(a.device) != str(device):
        raise GraphError(f"{what}: array is on {a.device}, expected {device} (where the inputs are)")


def as_shape(a: wp.array, shape: tuple[int, ...]) -> wp.array:
    """``a`` viewed with ``shape`` (no new array object when it already has it)."""
    return a if tuple(a.shape) == shape else a.reshape(shape)


def as_batch(model: KinematicModel, q: Any, device: Any, what: str = "q") -> tuple[wp.array, tuple[int, ...], Any]:
    """Coordinates ``q`` [..., C] as a contiguous [B, C] Warp array on ``device``.

    Anything that is not a Warp array is copied through NumPy (float32 unless it is float64).

    Returns:
        The [B, C] array, the leading shape ``...`` and the Warp scalar type.

    Raises:
        GraphError: on a dtype other than float32/float64, a last dimension other than the model's
            coordinate count, or a Warp array on another device.
    """
    if not isinstance(q, wp.array):
        arr = np.asarray(q)
        if arr.dtype not in (np.float32, np.float64):
            arr = arr.astype(np.float32)
        q = wp.array(np.ascontiguousarray(arr), dtype=wp.dtype_from_numpy(arr.dtype), device=device)
    if q.dtype not in (wp.float32, wp.float64):
        raise GraphError(f"{what}: expected float32 or float64 coordinates, got {wp.types.type_repr(q.dtype)}")
    C = model.coordinate_count
    if q.ndim < 1 or q.shape[-1] != C:
        raise GraphError(
            f"{what}: expected shape [..., {C}] for {model.name!r} ({C} coordinates), got {list(q.shape)}"
        )
    check_device(q, device, what)
    lead = tuple(q.shape[:-1])
    B = int(np.prod(lead)) if lead else 1
    if not q.is_contiguous:
        q = q.contiguous()
    return as_shape(q, (B, C)), lead, q.dtype
