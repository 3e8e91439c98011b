"""``morphkit synth CREATURE``: procedural motion for any creature, from its graph alone (ACE §7.1)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "synth",
        help="generate a motion dataset for a creature (gaits, arm reaching, wheeled driving) from its graph",
        description=(
            "Roll out a kinematic controller under random smoothed commands (forward/lateral speed, yaw rate, "
            "body height, pitch, roll): legged creatures step with gaits chosen by leg count and speed, feet "
            "planted while in stance; arms reach and wave; wheeled bases drive. Writes one NPZ motion per rollout "
            "(or one .npz with every rollout end to end), readable by morphkit's motion data layer."
        ),
    )
    p.add_argument("creature", metavar="CREATURE", help="description file (.yaml/.urdf/.usd*/.bvh) or shipped name")
    p.add_argument("--frames", type=int, default=200_000, metavar="N", help="total frames (default 200000)")
    p.add_argument("--fps", type=float, default=30.0, help="frame rate (default 30)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0); the same seed gives the same data")
    p.add_argument("--out", metavar="DIR_OR_FILE",
                   help="folder for one <name>.npz per rollout, or a .npz file for all rollouts end to end")
    p.add_argument("--rollout-seconds", type=float, default=None, metavar="S",
                   help="length of each rollout / output motion (default 20)")
    p.add_argument("--report", action="store_true",
                   help="measure the result: foot sliding, penetration, self-collision, limits, tracking, frames/s")
    p.add_argument("--json", action="store_true", help="print the report (or the written paths) as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from morphkit.errors import ConfigError
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.synth import SynthConfig, synthesize
    from morphkit.synth.report import REPORT_KEYS, format_report, quality_report

    if args.frames < 1:
        raise ConfigError(f"--frames must be >= 1, got {args.frames}")
    if not args.fps > 0:
        raise ConfigError(f"--fps must be positive, got {args.fps}")
    if args.rollout_seconds is not None and not args.rollout_seconds > 0:
        raise ConfigError(f"--rollout-seconds must be positive, got {args.rollout_seconds}")
    if args.out is None and not args.report:
        raise ConfigError("nothing to do: give --out DIR_OR_FILE to save the motions and/or --report")
    config = SynthConfig()
    if args.rollout_seconds is not None:
        config = replace(config, rollout_seconds=args.rollout_seconds)
    morphology = read_morphology(resolve_morphology(args.creature))
    # Warp reports kernel loading on stdout: keep stdout for the result (--json must parse).
    with contextlib.redirect_stdout(sys.stderr):
        result = synthesize(morphology, frames=args.frames, fps=args.fps, seed=args.seed, config=config,
                            progress=not args.no_progress)
        written = result.save(args.out) if args.out is not None else []
        report = quality_report(result) if args.report else None
    if args.json:
        if report is not None:
            out = {k: report[k] for k in REPORT_KEYS}
            out.update({k: v for k, v in report.items() if k not in REPORT_KEYS})
            out["files"] = [str(p) for p in written]
        else:
            out = {"frames": result.frame_count, "frames_per_s": round(result.frames_per_s, 1),
                   "files": [str(p) for p in written]}
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    where = f" -> {args.out} ({len(written)} file{'s' if len(written) != 1 else ''})" if written else ""
    print(f"{morphology.name}: {result.frame_count} frames in {len(result)} rollouts at {args.fps:g} fps, "
          f"{result.seconds:.1f} s ({result.frames_per_s:.0f} frames/s){where}")
    if report is not None:
        print(format_report(report))
    return 0
