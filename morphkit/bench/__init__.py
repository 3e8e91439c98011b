"""Benchmark harness: what ``morphkit bench`` and ``benchmarks/*.py`` measure (never run by the unit tests).

* :mod:`~morphkit.bench.fk`: FK throughput of morphkit against pytorch-kinematics, Pinocchio, MuJoCo
  and plain torch, every implementation built from one morphology (:mod:`~morphkit.bench.peers`).
* :mod:`~morphkit.bench.report`: the markdown report and the check against the project's speed
  targets, which live with the benchmarks (``benchmarks/fk_targets.yaml``), not here.
* :mod:`~morphkit.bench.compile_probe`: first-call compile time, in fresh subprocesses.

The package sits at the top of the layers beside ``morphkit.render``; it imports torch, Warp and the
peer libraries inside functions only.
"""

from morphkit.bench.fk import BATCHES as BATCHES
from morphkit.bench.fk import IMPLS as IMPLS
from morphkit.bench.fk import MODES as MODES
from morphkit.bench.fk import QUICK_BATCHES as QUICK_BATCHES
from morphkit.bench.fk import BenchConfig as BenchConfig
from morphkit.bench.fk import BenchResult as BenchResult
from morphkit.bench.fk import Creature as Creature
from morphkit.bench.fk import load_creature as load_creature
from morphkit.bench.fk import make_impl as make_impl
from morphkit.bench.fk import random_q as random_q
from morphkit.bench.fk import run_fk_benchmark as run_fk_benchmark
from morphkit.bench.fk import time_calls as time_calls
from morphkit.bench.report import FKTargets as FKTargets
from morphkit.bench.report import TargetCheck as TargetCheck
from morphkit.bench.report import check_targets as check_targets
from morphkit.bench.report import checkout_targets as checkout_targets
from morphkit.bench.report import load_targets as load_targets
from morphkit.bench.report import markdown_report as markdown_report

__all__ = [
    "BATCHES",
    "IMPLS",
    "MODES",
    "QUICK_BATCHES",
    "BenchConfig",
    "BenchResult",
    "Creature",
    "FKTargets",
    "TargetCheck",
    "check_targets",
    "checkout_targets",
    "load_creature",
    "load_targets",
    "make_impl",
    "markdown_report",
    "random_q",
    "run_fk_benchmark",
    "time_calls",
]
