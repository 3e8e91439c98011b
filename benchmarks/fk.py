"""FK throughput: morphkit (raw Warp kernels and through torch) against pytorch-kinematics, Pinocchio,
MuJoCo and a plain batched torch FK, on Spot and the CMU 22-joint human.

Run: ``python benchmarks/fk.py [--json] [--quick] [--batches 1 64 1024 16384 131072]`` (the same as
``morphkit bench fk``; ``--help`` lists every option). The peers come with ``pip install -e ".[bench]"``;
missing ones are skipped and listed. Set ``MORPHKIT_DATA`` to benchmark the CMU skeleton (the
shipped ``human`` otherwise). The report checks the targets in ``fk_targets.yaml`` beside this file.
Results and method: ``benchmarks/README.md``. The implementation lives in :mod:`morphkit.bench`;
this file is only its entry point.
"""

from __future__ import annotations

import sys
from pathlib import Path

from morphkit.cli import main

TARGETS = Path(__file__).with_name("fk_targets.yaml")

if __name__ == "__main__":
    raise SystemExit(main(["bench", "fk", "--targets", str(TARGETS), *sys.argv[1:]]))
