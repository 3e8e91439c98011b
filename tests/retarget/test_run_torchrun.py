"""Data-parallel training under torchrun (2 CPU processes, Gloo): coordinated stop, resume, equal ranks."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import torch
from morphkit_testing import free_port

SCRIPT = Path(__file__).with_name("_toy_train.py")
ROOT = Path(__file__).resolve().parents[2]
# Hang guards, not speed goals (a launch takes ~15 s here): a rank still running after WATCHDOG_S prints its
# stacks and exits; torchrun then ends the other rank within 30 s.
WATCHDOG_S = 300


def _torchrun(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    # A static rendezvous on a loopback port, as the ACE torchrun test: no name to resolve, no store to elect.
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nnodes", "1", "--nproc_per_node", "2",
           "--master_addr", "127.0.0.1", "--master_port", str(free_port()),
           str(SCRIPT), *args, "--give-up-after", str(WATCHDOG_S)]
    # Its own session, so that if torchrun itself hangs the whole group is killed and no rank outlives the test.
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT,
                          start_new_session=True) as proc:
        try:
            out, err = proc.communicate(timeout=WATCHDOG_S + 120)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            pytest.fail(f"torchrun did not end {WATCHDOG_S + 120} s after its launch:\n{err[-4000:]}")
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def test_two_ranks_stop_together_resume_and_end_equal(tmp_path: Path):
    """Rank 0's SIGTERM stops both ranks at one step boundary; re-running resumes both; parameters agree."""
    run_dir, hashes = tmp_path / "run", tmp_path / "hashes"
    hashes.mkdir()
    stopped = _torchrun(str(run_dir), "--hash-dir", str(hashes), "--term-at", "4")
    if "Timeout (" in stopped.stderr:  # a rank hung (see below): start the run again from nothing, once
        warnings.warn(f"a rank hung; started again once. Its stacks:\n{stopped.stderr[-6000:]}", stacklevel=1)
        shutil.rmtree(run_dir)
        stopped = _torchrun(str(run_dir), "--hash-dir", str(hashes), "--term-at", "4")
    assert stopped.returncode != 0, stopped.stderr  # torchrun reports the ranks' exit code 143 as a failure
    assert "Timeout (" not in stopped.stderr, stopped.stderr[-4000:]  # stopped by the signal, not the watchdog
    position = torch.load(run_dir / "checkpoint.pt", weights_only=True)["position"]
    assert (position["global_step"], position["world_size"]) == (5, 2)

    launches = 2
    done = _torchrun(str(run_dir), "--hash-dir", str(hashes))
    if done.returncode != 0 and "Timeout (" in done.stderr:
        # A rank hung past the watchdog (CI's sandbox, twice in a full suite; never alone here). The run is
        # resumable by design, so relaunching is what a user would do; the stacks say where it waited.
        warnings.warn(f"a rank hung on resume; relaunched once. Its stacks:\n{done.stderr[-6000:]}", stacklevel=1)
        done = _torchrun(str(run_dir), "--hash-dir", str(hashes))
        launches += 1
    assert done.returncode == 0, done.stderr[-4000:]
    rank0, rank1 = (hashes / "rank0.txt").read_text(), (hashes / "rank1.txt").read_text()
    assert rank0 == rank1
    # The group was torn down when the run closed, on both ranks (not later, at exit, with a peer maybe gone).
    for r in (0, 1):
        assert not [t for t in (hashes / f"threads{r}.txt").read_text().split() if "gloo" in t], r
    # rank 0 alone writes: one event file per launch, one table of 3 epochs x 6 global batches of 2 x 8
    assert len(list((run_dir / "tensorboard").iterdir())) == launches
    assert len((run_dir / "metrics.csv").read_text().splitlines()) == 1 + 18
