"""``morphkit synth CREATURE``: procedural motion for any creature, from its graph alone (ACE §7.1)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time

from morphkit.commands import _args


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
    p.add_argument("--frames", type=_args.int_in(1), default=200_000, metavar="N", help="total frames (default 200000)")
    p.add_argument("--fps", type=_args.fps, default=30.0,
                   help=f"frame rate, {_args.FPS_RANGE[0]:g} to {_args.FPS_RANGE[1]:g} (default 30)")
    p.add_argument("--seed", type=_args.seed, default=0,
                   help="random seed (default 0); the same seed gives the same data")
    p.add_argument("--out", type=_args.out_path, metavar="DIR_OR_FILE",
                   help="folder for one <name>.npz per rollout, or a .npz file for all rollouts end to end")
    p.add_argument("--rollout-seconds", type=_args.float_in(*_args.ROLLOUT_SECONDS_RANGE, unit="s", lo_open=True),
                   default=None, metavar="S", help="length of each rollout / output motion, at most "
                   f"{_args.ROLLOUT_SECONDS_RANGE[1]:g} s (default 20)")
    p.add_argument("--force", action="store_true",
                   help="replace the data set of another creature in the --out folder (a folder holds one data set)")
    p.add_argument("--report", action="store_true",
                   help="measure the result: foot sliding, penetration, self-collision, limits, tracking, frames/s")
    p.add_argument("--json", action="store_true", help="print the report (or the written paths) as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from morphkit._folder_lock import hold_run_folder
    from morphkit.body.anatomy import anatomy_warnings
    from morphkit.errors import ConfigError
    from morphkit.graph import BaseType
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.synth import SynthConfig, SynthResult, analyse, iter_synthesize, prepare
    from morphkit.synth.core import rollout_count
    from morphkit.synth.ground import GroundStats
    from morphkit.synth.output import (
        SynthWriter,
        available_memory,
        check_folder,
        check_output,
        estimate_output_bytes,
        format_bytes,
        output_kind,
    )
    from morphkit.synth.report import REPORT_KEYS, format_report, quality_report

    # --frames, --fps, --seed and --rollout-seconds are range-checked by their argparse types (commands._args)
    if args.out is None and not args.report:
        raise ConfigError("nothing to do: give --out DIR_OR_FILE to save the motions and/or --report")
    kind = output_kind(args.out) if args.out is not None else None
    config = SynthConfig()
    if args.rollout_seconds is not None:
        config = replace(config, rollout_seconds=args.rollout_seconds)
    source = resolve_morphology(args.creature)
    morphology = read_morphology(source)

    # before any work: the output can be written and fits on its disk, what stays in memory fits there
    count = rollout_count(args.frames, args.fps, config)
    legs = len(analyse(morphology).legs) if morphology.base == BaseType.FLOATING else 0
    if args.out is not None:
        check_output(args.out, estimate_output_bytes(morphology, args.frames, count, legs,
                                                     single_file=kind == "file"))
    C, L = morphology.coordinate_count, len(morphology.links)
    E, S = len(morphology.end_effectors), sum(len(lk.shapes) for lk in morphology.links)
    per_frame = 8 * C + 128 + legs  # a rollout's frame in memory: coordinates, commands, flags
    held = per_frame * ((args.report or kind == "file") + (kind == "file"))  # a single file is a joined copy
    if args.report:
        held += 16 * C + 56 * L + 48 * E + 8 * S + 256  # the report's FK, points and distances
    free = available_memory()
    if held and free is not None and held * args.frames > free:
        what = "--report measures every rollout at once" if args.report else "a single .npz file is assembled"
        raise ConfigError(f"--frames {args.frames}: {what} in memory, about {format_bytes(held * args.frames)}, and "
                          f"only {format_bytes(free)} is available: ask for fewer frames"
                          + ("" if args.report else ", or give --out a folder (written as it goes)"))

    def warn(lines: list[str]) -> None:
        for line in lines:
            sys.stderr.write(f"warning: {source}: {line}\n")

    # One writer per folder: held from the folder's first write to its manifest's last (a file output is
    # replaced atomically and needs none).
    lock = hold_run_folder(args.out) if kind == "folder" else contextlib.nullcontext()
    # Warp reports kernel loading on stdout: keep stdout for the result (--json must parse).
    with lock, contextlib.redirect_stdout(sys.stderr):
        if kind == "folder":  # before any work: it may hold another creature's data set (refused without --force)
            check_folder(args.out, morphology.name, force=args.force)
        start = time.perf_counter()
        rig = prepare(morphology, fps=args.fps, config=config)  # calibrated once: iter_synthesize reuses it
        told = anatomy_warnings(morphology) + (list(rig.legs.warnings) if rig.legs is not None else [])
        warn(told)
        batches = iter_synthesize(morphology, frames=args.frames, fps=args.fps, seed=args.seed, config=config,
                                  progress=not args.no_progress)
        writer = (SynthWriter(args.out, force=args.force, creature=morphology.name, frames=args.frames, fps=args.fps,
                              seed=args.seed, rollout_seconds=config.rollout_seconds)
                  if args.out is not None else None)
        kept: list[SynthResult] = []
        ground = GroundStats()
        frames = 0
        for part in batches:
            if writer is not None:
                writer.write(part)
            frames += part.frame_count
            ground = ground.merge(part.ground)
            if args.report:
                kept.append(part)
        written = writer.close() if writer is not None else []
        seconds = time.perf_counter() - start  # calibration included
        report = quality_report(SynthResult.concatenate(kept, seconds=seconds)) if kept else None
    warn([w for w in (report["warnings"] if report is not None else ground.warnings()) if w not in told])
    if args.json:
        if report is not None:
            out = {k: report[k] for k in REPORT_KEYS}
            out.update({k: v for k, v in report.items() if k not in REPORT_KEYS})
            out["files"] = [str(p) for p in written]
        else:
            out = {"frames": frames, "frames_per_s": round(frames / max(seconds, 1e-9), 1),
                   "files": [str(p) for p in written]}
        json.dump(out, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    where = f" -> {args.out} ({len(written)} file{'s' if len(written) != 1 else ''})" if written else ""
    print(f"{morphology.name}: {frames} frames in {count} rollouts at {args.fps:g} fps, "
          f"{seconds:.1f} s ({frames / max(seconds, 1e-9):.0f} frames/s){where}")
    if report is not None:
        print(format_report(report))
    return 0
