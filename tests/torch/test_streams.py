"""Warp launches of the torch bridge follow torch's current stream."""

from __future__ import annotations

import pytest
import torch
import warp as wp
from morphkit_testing import random_q, spot_like

import morphkit.torch as mt
from morphkit.model import compile_model
from morphkit.torch.reference import end_effectors_reference, fk_reference
from morphkit.torch.streams import on_torch_stream


def test_cpu_resolves_the_device_only():
    with on_torch_stream(torch.device("cpu")) as dev:
        assert dev == wp.get_device("cpu")
    with on_torch_stream(wp.get_device("cpu")) as dev:
        assert dev == wp.get_device("cpu")


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_launches_run_on_a_side_stream_torch_is_using():
    """On a side stream, replayed and plain launches (FK, end-effectors, contact) see the inputs torch wrote
    there just before and write outputs torch reads there just after, with no synchronisation."""
    m = compile_model(spot_like())
    q_cpu = torch.tensor(random_q(m, (3, 40), seed=2), dtype=torch.float32)
    side = torch.cuda.Stream()
    with torch.cuda.stream(side):
        with on_torch_stream(torch.device("cuda")) as dev:
            assert wp.get_stream(dev).cuda_stream == side.cuda_stream
        q = q_cpu.cuda() * 1.0  # queued on the side stream
        for B in (1, 3, 2):  # the small-batch path records once, then replays with new sizes
            Ts = mt.fk(m, q[:B])
            p = mt.end_effector_positions(m, q[:B])
            d = mt.penetration_depth(p)
        Ts, p, d = Ts.cpu(), p.cpu(), d.cpu()
    torch.cuda.synchronize()
    ref = fk_reference(m, q_cpu[:2])
    torch.testing.assert_close(Ts, ref, atol=2e-5, rtol=0)
    p_ref = end_effectors_reference(m, ref)[..., :3]
    torch.testing.assert_close(p, p_ref, atol=2e-5, rtol=0)
    torch.testing.assert_close(d, (-p_ref[..., 2]).clamp(min=0), atol=2e-5, rtol=0)
