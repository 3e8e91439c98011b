"""``morphkit bench fk``: forward-kinematics throughput of morphkit against its peers, in one run.

A thin command over :mod:`morphkit.bench` (what is measured and how: :mod:`morphkit.bench.fk` and
``benchmarks/README.md``). The report ends with the check against the project's speed targets,
``benchmarks/fk_targets.yaml`` of the checkout morphkit runs from, or ``--targets FILE``. The
command sets ``OMP_WAIT_POLICY=PASSIVE`` unless it is set (see ``benchmarks/README.md``).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
from pathlib import Path

from morphkit.bench.fk import BATCHES, IMPLS, MODES, QUICK_BATCHES, BenchConfig
from morphkit.commands import _args
from morphkit.errors import ConfigError

__all__ = ["add_parser", "config_from_args", "run"]


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="benchmarks (fk: forward-kinematics throughput against the peers)")
    bench_sub = p.add_subparsers(dest="bench_command", metavar="BENCH", parser_class=type(p))
    bench_sub.required = True
    fk = bench_sub.add_parser("fk", help="FK poses/s for morphkit, pytorch-kinematics, Pinocchio, MuJoCo, torch")
    fk.add_argument("--json", action="store_true", help="print the records as a JSON list (the report goes to stderr)")
    fk.add_argument("--quick", action="store_true", help="small batches, short timings, no compile probe (< 30 s)")
    fk.add_argument(
        "--batches", type=_args.int_in(1, 2**20), nargs="+", metavar="B",
        help=f"batch sizes, 1 to 2**20 (default {' '.join(map(str, BATCHES))})"
    )
    fk.add_argument(
        "--creatures", nargs="+", metavar="NAME", help="spot, human, or description paths (default spot human)"
    )
    fk.add_argument("--impls", nargs="+", metavar="IMPL", choices=IMPLS, help="implementations (default all)")
    fk.add_argument("--modes", nargs="+", choices=MODES, help="fwd, fwd_bwd (default both)")
    fk.add_argument("--loop-poses", type=_args.int_in(1, 1_000_000), default=2000,
                    help="poses per timed call for Python-loop peers")
    fk.add_argument("--threads", type=_args.int_in(1, 1024), default=2, help="CPU threads for torch and morphkit")
    fk.add_argument("--no-compile-probe", action="store_true", help="skip the first-call compile measurement")
    fk.add_argument("--targets", type=Path, metavar="FILE",
                    help="speed targets to check (default: the checkout's benchmarks/fk_targets.yaml, if any)")
    fk.set_defaults(run=run)


def config_from_args(args: argparse.Namespace) -> BenchConfig:
    """The :class:`BenchConfig` of parsed ``bench fk`` arguments (``--quick`` first, explicit flags win)."""
    cfg = BenchConfig()
    if args.quick:
        cfg = BenchConfig(
            batches=QUICK_BATCHES, loop_poses=200, repeats=2, min_time=0.01, bridge_calls=50, compile_probe=False
        )
    batches = tuple(args.batches) if args.batches else cfg.batches
    if any(b < 1 for b in batches):
        raise ConfigError(f"--batches: batch sizes must be >= 1, got {list(batches)}")
    loop_poses = args.loop_poses if args.loop_poses != 2000 or not args.quick else cfg.loop_poses
    return BenchConfig(
        creatures=tuple(args.creatures) if args.creatures else cfg.creatures,
        impls=tuple(args.impls) if args.impls else cfg.impls,
        modes=tuple(args.modes) if args.modes else cfg.modes,
        batches=batches,
        loop_poses=max(1, loop_poses),
        repeats=cfg.repeats,
        min_time=cfg.min_time,
        bridge_calls=cfg.bridge_calls,
        threads=max(1, args.threads),
        compile_probe=cfg.compile_probe and not args.no_compile_probe,
    )


def run(args: argparse.Namespace) -> int:
    """Run ``morphkit bench fk``: the markdown report on stdout (or records as JSON, report on stderr)."""
    from morphkit.bench.fk import run_fk_benchmark
    from morphkit.bench.report import checkout_targets, load_targets, markdown_report

    config = config_from_args(args)
    targets_path = args.targets or checkout_targets()
    targets = load_targets(targets_path) if targets_path is not None else None
    if "torch" not in sys.modules:
        # GNU OpenMP's default busy-wait keeps torch's idle worker threads spinning after every op; on a
        # machine with other work on its 2 cores that stole the CPU from whatever ran next (small torch
        # ops took milliseconds, and morphkit's launches slowed 3×). Passive waiting keeps the timings
        # honest on a shared machine; export OMP_WAIT_POLICY=ACTIVE to measure the default instead.
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

    def log(line: str) -> None:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()

    import warp as wp

    # The command owns stdout: Warp's initialisation banner and module-load lines would break --json.
    level, wp.config.log_level = wp.config.log_level, wp.LOG_WARNING
    try:
        with contextlib.redirect_stdout(sys.stderr):
            result = run_fk_benchmark(config, log=log)
    finally:
        wp.config.log_level = level
    report = markdown_report(result, targets)
    if args.json:
        sys.stderr.write(report)
        sys.stdout.write(json.dumps(result.records, indent=1) + "\n")
    else:
        sys.stdout.write(report)
    return 0
