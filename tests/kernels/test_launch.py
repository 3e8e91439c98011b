"""The shared launch helpers: device resolution, batch checks, CPU chunks and the one thread pool."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import torch
import warp as wp
from morphkit_testing import random_q, spot_like

from morphkit.errors import GraphError
from morphkit.kernels import contact as ck
from morphkit.kernels import cpu_thread_count, eval_fk, set_cpu_thread_count
from morphkit.kernels.launch import as_batch, cpu_pool, launch_chunks, output_array, resolve_device
from morphkit.model import compile_model
from morphkit.torch.reference import fk_reference

CUDA = wp.is_cuda_available()


def test_resolve_device_prefers_the_argument_then_the_array_then_the_model():
    m = compile_model(spot_like())
    q = wp.zeros((2, m.coordinate_count), device="cpu")
    assert resolve_device("cpu", q, m) == wp.get_device("cpu")
    assert resolve_device(None, q, m) is q.device
    assert resolve_device(None, np.zeros(3), m) == wp.get_device(m.device)
    assert resolve_device(None, np.zeros(3)) == wp.get_device(None)
    out = wp.zeros(3, device="cpu")
    assert resolve_device(None, np.zeros(3), m, out=out) is out.device
    assert resolve_device(None, q, m, out=out) is q.device


def test_numpy_inputs_run_where_their_output_lives(device):
    """With Warp's default device elsewhere (CUDA on a GPU machine), NumPy inputs written into ``out``
    launch on ``out``'s device: the kernels' results land there, equal to the reference."""
    other = "cpu" if device != "cpu" else ("cuda" if CUDA else "cpu")
    pts = np.zeros((2, 3, 4, 3))
    pts[1, 2, 3, 2] = -0.05
    m = compile_model(spot_like())
    q = random_q(m, (2,), seed=3)
    with wp.ScopedDevice(other):
        depth = wp.zeros((2, 3, 2), dtype=wp.float64, device=device)
        assert ck.eval_penetration_depth(pts, feet=[0, 3], out=depth) is depth
        adj = ck.eval_penetration_depth_adjoint(pts, wp.ones((2, 3, 2), dtype=wp.float64, device=device), feet=[0, 3])
        Ts = wp.empty((2, m.link_count), dtype=wp.transformd, device=device)
        eval_fk(m, q, out=Ts)
    assert depth.numpy()[1, 2, 1] == pytest.approx(0.05) and np.count_nonzero(depth.numpy()) == 1
    assert str(adj.device) == str(wp.get_device(device))  # d depth / d z = -1 where the foot is below
    assert adj.numpy()[1, 2, 3, 2] == -1.0 and np.count_nonzero(adj.numpy()) == 1
    np.testing.assert_allclose(Ts.numpy(), fk_reference(m, torch.tensor(q)).numpy(), atol=1e-12)


def test_output_array_checks_shape_dtype_and_device():
    out = wp.zeros((2, 3), dtype=wp.float32, device="cpu")
    assert output_array(out, (2, 3), wp.float32, wp.get_device("cpu")) is out
    fresh = output_array(None, (4,), wp.float64, wp.get_device("cpu"), zeros=True)
    assert fresh.shape == (4,) and fresh.dtype == wp.float64 and not fresh.numpy().any()
    with pytest.raises(GraphError, match=r"adj_q: expected a contiguous array of shape \[3, 2\]"):
        output_array(out, (3, 2), wp.float32, wp.get_device("cpu"), "adj_q")
    with pytest.raises(GraphError, match="dtype float64"):
        output_array(out, (2, 3), wp.float64, wp.get_device("cpu"))


@pytest.mark.skipif(not CUDA, reason="needs a CUDA device")
def test_an_output_on_another_device_is_refused_before_any_launch():
    """A CUDA kernel writing through a CPU pointer faults and poisons the CUDA context: refused instead."""
    m = compile_model(spot_like())
    q = wp.array(random_q(m, (2,)), dtype=wp.float64, device="cuda")
    with pytest.raises(GraphError, match="out: array is on cpu, expected cuda:0"):
        eval_fk(m, q, out=wp.empty((2, m.link_count), dtype=wp.transformd, device="cpu"))
    Ts = eval_fk(m, q)  # the context is still usable
    np.testing.assert_allclose(Ts.numpy(), fk_reference(m, torch.tensor(q.numpy())).numpy(), atol=1e-12)


def test_as_batch_flattens_leading_dimensions_and_names_bad_input():
    m = compile_model(spot_like())
    C = m.coordinate_count
    q2, lead, dtype = as_batch(m, random_q(m, (2, 3)), wp.get_device("cpu"))
    assert (tuple(q2.shape), lead, dtype) == ((6, C), (2, 3), wp.float64)
    assert as_batch(m, np.zeros(C, np.int64), wp.get_device("cpu"))[2] == wp.float32
    with pytest.raises(GraphError, match=rf"q: expected shape \[\.\.\., {C}\]"):
        as_batch(m, np.zeros((2, C + 1)), wp.get_device("cpu"))
    with pytest.raises(GraphError, match="expected float32 or float64"):
        as_batch(m, wp.zeros((2, C), dtype=wp.int32, device="cpu"), wp.get_device("cpu"))


def test_cpu_chunks_cover_the_batch_once_and_one_thread_pool_is_shared():
    before = cpu_thread_count()
    try:
        set_cpu_thread_count(3)
        cpu = wp.get_device("cpu")
        for batch in (0, 1, 2047, 6144, 10_001):
            chunks = launch_chunks(batch, cpu)
            assert len(chunks) <= 3
            covered = [i for offset, size in chunks for i in range(offset, offset + size)]
            assert covered == list(range(batch))
        assert len(launch_chunks(10_001, cpu)) == 3
        pool = cpu_pool()
        assert pool is not None and cpu_pool() is pool
        names = set(pool.map(lambda _: threading.current_thread().name, range(6)))
        assert all(n.startswith("morphkit-cpu") for n in names)
        set_cpu_thread_count(2)
        assert cpu_pool() is not pool  # a new count makes a new pool
        set_cpu_thread_count(1)
        assert cpu_pool() is None
        assert launch_chunks(10_001, cpu) == [(0, 10_001)]
    finally:
        set_cpu_thread_count(before)


@pytest.mark.skipif(not wp.is_cuda_available(), reason="needs a CUDA device")
def test_cuda_launches_in_one_chunk():
    assert launch_chunks(1_000_000, wp.get_device("cuda")) == [(0, 1_000_000)]


def test_python_api_does_not_print_warps_no_cuda_driver_note():
    """Importing the kernels from Python (not the CLI) keeps Warp's 'no CUDA driver' note off stderr:
    on a CPU machine it reads like an error. Where a driver exists Warp never prints it."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "MORPHKIT_QUIET_WARP"}
    out = subprocess.run([sys.executable, "-c", "import morphkit.kernels, warp; warp.init()"], env=env,
                         capture_output=True, text=True, timeout=300, check=True)
    assert "Could not find or load the NVIDIA CUDA driver" not in out.stderr + out.stdout


def test_a_forked_process_gets_a_working_pool():
    """The pool's threads do not survive a fork: a child given its parent's pool would wait forever on work
    nobody runs (reproduce_table1's lanes fork after the synthesis has used it)."""
    import multiprocessing

    before = cpu_thread_count()
    set_cpu_thread_count(2)
    try:
        assert cpu_pool().submit(lambda: 1).result(timeout=10) == 1  # the parent's threads exist now

        def child() -> None:
            raise SystemExit(0 if cpu_pool().submit(lambda: 2).result(timeout=20) == 2 else 1)

        proc = multiprocessing.get_context("fork").Process(target=child)
        proc.start()
        proc.join(timeout=60)
        if proc.is_alive():
            proc.kill()
        assert proc.exitcode == 0
    finally:
        set_cpu_thread_count(before)
