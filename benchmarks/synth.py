"""Synthesis throughput: frames per second of ``morphkit synth`` for Spot (target >= 10,000 frames/s on
2 CPU cores, i.e. 200k frames in <= 20 s).

Run: ``python benchmarks/synth.py [--creature spot] [--frames 200000] [--json]``. Calibration (stance,
step region, pose pool; once per creature) is timed separately from generation; the quality report of
what was generated is printed with it.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--creature", default="spot", help="shipped name or description file (default spot)")
    parser.add_argument("--frames", type=int, default=200_000)
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)

    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.synth import prepare, synthesize
    from morphkit.synth.report import format_report, quality_report

    with contextlib.redirect_stdout(sys.stderr):  # Warp's module-load messages
        m = read_morphology(resolve_morphology(args.creature))
        t0 = time.perf_counter()
        prepare(m, fps=args.fps)
        calibration_s = time.perf_counter() - t0
        result = synthesize(m, frames=args.frames, fps=args.fps, seed=args.seed, progress=not args.json)
        report = quality_report(result)
    out = {
        "creature": m.name,
        "frames": result.frame_count,
        "generation_s": round(result.seconds, 3),
        "frames_per_s": round(result.frames_per_s, 1),
        "calibration_s": round(calibration_s, 3),
        "frames_per_s_with_calibration": round(result.frame_count / (result.seconds + calibration_s), 1),
        "cpu_count": os.cpu_count(),
        "report": report,
    }
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(f"{m.name}: {out['frames']} frames in {out['generation_s']} s -> {out['frames_per_s']:.0f} frames/s "
              f"(calibration {out['calibration_s']} s once; {out['frames_per_s_with_calibration']:.0f} frames/s "
              f"with it; {out['cpu_count']} CPUs)")
        print(format_report(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
