"""Exact resume across processes: SIGKILL and SIGTERM mid-epoch, then the same command again, equals one run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import torch

SCRIPT = Path(__file__).with_name("_toy_train.py")
ROOT = Path(__file__).resolve().parents[2]


def _toy(run_dir: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, str(SCRIPT), str(run_dir), *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, timeout=900, check=False)


def test_killed_and_terminated_run_resumes_bit_identically(tmp_path: Path):
    """SIGKILL at step 17 (last checkpoint: step 15), SIGTERM at step 26, resume: parameters and metrics rows match."""
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    done = _toy(ref)
    assert done.returncode == 0, done.stderr

    killed = _toy(cut, "--kill-at", "17", "--checkpoint-every", "5")
    assert killed.returncode == -signal.SIGKILL
    assert torch.load(cut / "checkpoint.pt", weights_only=True)["position"]["global_step"] == 15

    termed = _toy(cut, "--term-at", "26", "--checkpoint-every", "5")
    assert termed.returncode == 128 + signal.SIGTERM, termed.stderr
    position = torch.load(cut / "checkpoint.pt", weights_only=True)["position"]
    assert (position["epoch"], position["step"], position["global_step"]) == (2, 3, 27)

    resumed = _toy(cut)
    assert resumed.returncode == 0, resumed.stderr
    assert torch.equal(torch.load(ref / "final.pt"), torch.load(cut / "final.pt"))
    # rows logged after a checkpoint were dropped on resume: the two tables are the same, row for row
    assert (ref / "metrics.csv").read_text() == (cut / "metrics.csv").read_text()
    assert len((cut / "metrics.csv").read_text().splitlines()) == 1 + 36
