"""Data-parallel training under ``torchrun``, detected from the environment.

``torchrun --nproc_per_node N script.py`` sets ``WORLD_SIZE``, ``RANK`` and ``LOCAL_RANK``;
:func:`init_distributed` reads them, joins the process group (NCCL on CUDA, Gloo on CPU) and
says which device this rank trains on. Without those variables everything is a one-process
no-op, so the same script runs either way. Rank 0 is the one that writes files.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import torch
import torch.distributed as dist
from torch import nn

from morphkit.errors import ConfigError

__all__ = [
    "DistributedContext",
    "all_gather_objects",
    "all_reduce_max",
    "all_reduce_mean",
    "init_distributed",
    "is_main_process",
    "joined_group",
    "leave_group",
    "release_group",
    "unwrap",
    "wrap_ddp",
]


@dataclass(frozen=True)
class DistributedContext:
    """Where this process stands in a (possibly one-process) data-parallel job."""

    rank: int
    """Global rank, 0 … world_size − 1."""
    local_rank: int
    """Rank on this node; picks the CUDA device."""
    world_size: int
    """Number of processes."""
    device: torch.device
    """Device this rank trains on."""
    backend: str | None
    """``"nccl"``, ``"gloo"``, or ``None`` when not distributed."""

    @property
    def is_main(self) -> bool:
        """Rank 0: the one process that writes files and shows progress."""
        return self.rank == 0

    @property
    def is_distributed(self) -> bool:
        """More than one process."""
        return self.world_size > 1

    def barrier(self) -> None:
        """Wait for every rank (no-op in one process)."""
        if self.is_distributed:
            dist.barrier()


def is_main_process() -> bool:
    """Rank 0 of a ``torchrun`` job, or the one process without one: the process that writes a run's files
    (read from ``RANK``, before or without :func:`init_distributed`)."""
    return int(os.environ.get("RANK", "0")) == 0


def init_distributed(device: str | torch.device | None = None) -> DistributedContext:
    """Join the ``torchrun`` process group if the environment names one; pick this rank's device.

    Args:
        device: ``"cpu"``, ``"cuda"`` (this rank's GPU under torchrun), an explicit device, or
            ``None`` for CUDA when available, else CPU.
    """
    world_size = int(os.environ.get("WORLD_SIZE", "1"))
    rank = int(os.environ.get("RANK", "0"))
    local_rank = int(os.environ.get("LOCAL_RANK", "0"))
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    dev = torch.device(device)
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise ConfigError("device 'cuda' asked for, but torch sees no CUDA device")
        dev = torch.device("cuda", local_rank if dev.index is None else dev.index)
        torch.cuda.set_device(dev)
    backend = None
    if world_size > 1:
        backend = "nccl" if dev.type == "cuda" else "gloo"
        if not dist.is_initialized():
            # DDP imports torch._dynamo at its first construction; imported while a group exists, it keeps
            # references to the group that destroy_process_group cannot drop (torch 2.13), so Gloo's threads
            # outlived the group until exit, where a rank aborted with a peer gone. Imported first, nothing holds it.
            importlib.import_module("torch._dynamo")

            dist.init_process_group(backend=backend, device_id=dev if dev.type == "cuda" else None)
        else:
            backend = dist.get_backend()
    return DistributedContext(rank, local_rank, world_size, dev, backend)


@contextmanager
def joined_group(device: str | torch.device | None = None) -> Iterator[DistributedContext]:
    """:func:`init_distributed` for a block; a process group it created is left at the block's end.

    For a trainer that runs several stages in one group. On a normal exit every rank waits for the
    others, then tears the group down at the same point; left to the interpreter's exit, Gloo's
    threads outlived a peer that had already gone and a rank aborted ("terminate called without an
    active exception"). On an error the barrier is skipped: the other ranks may never reach it.
    """
    joined = dist.is_available() and dist.is_initialized()
    context = init_distributed(device)
    ok = False
    try:
        yield context
        ok = True
    finally:
        if not joined:
            leave_group(context, wait_for_ranks=ok)


def leave_group(context: DistributedContext, *, wait_for_ranks: bool = True) -> None:
    """Tear the process group down on this rank, after waiting for the others (``wait_for_ranks``; skip it
    on an error, which the other ranks may never reach); a no-op in one process. Modules wrapped in DDP must
    have let go of the group first (:func:`release_group`)."""
    if context.is_distributed and dist.is_initialized():
        if wait_for_ranks:
            context.barrier()
        dist.destroy_process_group()


def wrap_ddp(module: nn.Module, context: DistributedContext) -> nn.Module:
    """``module`` on the context's device, inside ``DistributedDataParallel`` when distributed.

    DDP broadcasts rank 0's parameters on construction and averages gradients in ``backward``.
    """
    module = module.to(context.device)
    if not context.is_distributed:
        return module
    ids = [context.device.index] if context.device.type == "cuda" else None
    return nn.parallel.DistributedDataParallel(module, device_ids=ids)


def release_group(module: nn.Module) -> None:
    """Make a DDP wrapper let go of its process group (its reducer and logger hold it too); else a no-op.

    ``destroy_process_group`` only forgets the group: a DDP wrapper still holding it keeps Gloo's
    threads and sockets until the wrapper is collected, at the trainer's return or at exit, when a
    peer may have gone. A rank tearing its group down then hung for good on CI (its peer had
    exited). Released first, the group is torn down inside ``destroy_process_group``, on every rank
    at the same point. The wrapper cannot train afterwards; ``unwrap`` still gives the module.
    """
    if not isinstance(module, nn.parallel.DistributedDataParallel):
        return
    for name in ("reducer", "logger"):
        if hasattr(module, name):
            delattr(module, name)
    module.process_group = None


def unwrap(module: nn.Module) -> nn.Module:
    """The module inside a DDP wrapper (or ``module`` itself)."""
    return module.module if isinstance(module, nn.parallel.DistributedDataParallel) else module


def all_reduce_max(value: float, context: DistributedContext) -> float:
    """The largest ``value`` over all ranks, on every rank (a collective: call it on all ranks)."""
    if not context.is_distributed:
        return value
    tensor = torch.tensor([float(value)], dtype=torch.float64, device=_collective_device(context))
    dist.all_reduce(tensor, op=dist.ReduceOp.MAX)
    return float(tensor.item())


def all_reduce_mean(value: torch.Tensor | float, context: DistributedContext) -> torch.Tensor:
    """The mean of ``value`` over all ranks, on every rank (detached; a collective)."""
    tensor = torch.as_tensor(value).detach().to(_collective_device(context), torch.float64).clone()
    if context.is_distributed:
        dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
        tensor /= context.world_size
    return tensor


def _collective_device(context: DistributedContext) -> torch.device:
    return context.device if context.backend == "nccl" else torch.device("cpu")


def all_gather_objects(obj: Any, context: DistributedContext) -> list[Any]:
    """``obj`` from every rank, in rank order (a collective; ``[obj]`` in one process)."""
    if not context.is_distributed:
        return [obj]
    out: list[Any] = [None] * context.world_size
    dist.all_gather_object(out, obj)
    return out


def broadcast_parameters(module: nn.Module, context: DistributedContext) -> None:
    """Copy rank 0's parameters and buffers to every rank (what DDP does when it wraps a module)."""
    if not context.is_distributed:
        return
    for t in [*module.parameters(), *module.buffers()]:
        dist.broadcast(t.data, src=0)


def average_gradients(module: nn.Module, context: DistributedContext) -> None:
    """Average every parameter's gradient over the ranks, in place (a collective).

    For modules DDP cannot wrap: its hooks do not cover a gradient penalty's double backward
    through the discriminator, nor a network whose parameters are frozen for part of a step.
    """
    if not context.is_distributed:
        return
    for p in module.parameters():
        if p.grad is None:
            p.grad = torch.zeros_like(p)
        dist.all_reduce(p.grad, op=dist.ReduceOp.SUM)
        p.grad /= context.world_size
