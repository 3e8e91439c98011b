"""Data-parallel training under torchrun (2 CPU processes, Gloo): coordinated stop, resume, equal ranks."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import torch

SCRIPT = Path(__file__).with_name("_toy_train.py")
ROOT = Path(__file__).resolve().parents[2]


def _torchrun(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, timeout=900, check=False)


def test_two_ranks_stop_together_resume_and_end_equal(tmp_path: Path):
    """Rank 0's SIGTERM stops both ranks at one step boundary; re-running resumes both; parameters agree."""
    run_dir, hashes = tmp_path / "run", tmp_path / "hashes"
    hashes.mkdir()
    stopped = _torchrun(str(run_dir), "--hash-dir", str(hashes), "--term-at", "4")
    assert stopped.returncode != 0, stopped.stderr  # torchrun reports the ranks' exit code 143 as a failure
    position = torch.load(run_dir / "checkpoint.pt", weights_only=True)["position"]
    assert (position["global_step"], position["world_size"]) == (5, 2)

    done = _torchrun(str(run_dir), "--hash-dir", str(hashes))
    assert done.returncode == 0, done.stderr
    rank0, rank1 = (hashes / "rank0.txt").read_text(), (hashes / "rank1.txt").read_text()
    assert rank0 == rank1
    # rank 0 alone writes: one event file per launch, one table of 3 epochs x 6 global batches of 2 x 8
    assert len(list((run_dir / "tensorboard").iterdir())) == 2
    assert len((run_dir / "metrics.csv").read_text().splitlines()) == 1 + 18
