"""Warp launches on torch's current CUDA stream.

Every autograd function of the torch bridge launches its kernels inside :func:`on_torch_stream`,
so they are ordered with the torch work around them (and captured with it in a CUDA graph)
without any synchronisation.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import torch
import warp as wp

__all__ = ["on_torch_stream"]


@contextlib.contextmanager
def on_torch_stream(device: torch.device | wp.Device) -> Iterator[wp.Device]:
    """Run the Warp launches of the block on torch's current stream of ``device``; yields the Warp device.

    Launches that take no stream (``wp.launch``, a recorded launch's ``launch()``) use the device's
    current stream, which is torch's inside the block. On the CPU this only resolves the device.

    Args:
        device: A torch device (e.g. ``tensor.device``) or the Warp device it maps to.
    """
    if isinstance(device, torch.device) and device.type == "cuda" and device.index is None:
        # torch.device("cuda") names no ordinal, which Warp's mapping needs: take torch's current one.
        device = torch.device("cuda", torch.cuda.current_device())
    wp_device = device if isinstance(device, wp.Device) else wp.device_from_torch(device)
    if wp_device.is_cuda:
        with wp.ScopedStream(wp.stream_from_torch(torch.cuda.current_stream(wp_device.ordinal))):
            yield wp_device
    else:
        yield wp_device
