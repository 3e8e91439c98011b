"""``morphkit evaluate RUN... [--human-data DIR] [--split dev|test|all] [--out DIR]``: ACE's Table 1 for trained runs,
and with ``--split`` the evaluation protocol (a subject split, figures per clip type and clip length)."""

from __future__ import annotations

import argparse

from morphkit.commands import _args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "evaluate",
        help="compare trained retargeters (ACE, its ablations, NKN) on held-out clips: Table 1, charts, videos",
        description=(
            "Retarget every clip of the evaluation split with every finished retargeter of the given runs (ACE run "
            "folders give ACE, ACEwoFea, ACEwoAdv, ACE+contact; NKN cross-morphology runs give NKN), score DIV, FID, "
            "L_fea and UFR against the creature's synthesised data set, and write OUT/table.md/.csv (mean ± std over "
            "seeds), runs.csv, bar charts, side-by-side videos and index.html."
        ),
    )
    p.add_argument("run_folders", nargs="*", metavar="RUN",
                   help="run folders (morphkit train ace/nkn), ACE stage folders, or folders holding run folders")
    p.add_argument("--runs", nargs="+", default=[], metavar="RUN", help="the same, after a flag")
    p.add_argument("--split", metavar="dev|test|all",
                   help="the protocol: evaluate the human data's development or test split by subject (or all of it), "
                        "whole clips, and report follow per clip type and for long (>= 30 s) vs short clips")
    p.add_argument("--human-data", metavar="DIR",
                   help="human motion folder whose evaluation split is retargeted (default: the runs' own human data)")
    p.add_argument("--out", type=_args.out_path, metavar="DIR", help="report folder (default: evaluation_<creature>)")
    p.add_argument("--clips", type=_args.int_in(1), metavar="N",
                   help="evaluate on the first N clips only (default: all)")
    p.add_argument("--videos", type=_args.int_in(0, 1000), default=3, metavar="N",
                   help="clips with a side-by-side video, 0 to 1000 (default 3)")
    p.add_argument("--video-format", choices=["mp4", "gif", "png"],
                   help="video format (default mp4 when ffmpeg is there, else gif; png: a contact sheet)")
    p.add_argument("--video-seconds", type=_args.float_in(0.0, 600.0, unit="s", lo_open=True), default=8.0, metavar="S",
                   help="longest video, at most 600 s (default 8 s)")
    p.add_argument("--device", default="cpu", help="torch device of the retargeters (default cpu)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from morphkit.errors import ConfigError
    from morphkit.evaluation import evaluate_runs

    runs = [*args.run_folders, *args.runs]
    if not runs:
        raise ConfigError("no runs to evaluate: give run folders (morphkit evaluate RUN... or --runs RUN...)")
    out = evaluate_runs(runs, args.out, split=args.split, human_data=args.human_data, clips=args.clips,
                        videos=args.videos, video_suffix=f".{args.video_format}" if args.video_format else None,
                        video_seconds=args.video_seconds, device=args.device)
    print((out / "table.md").read_text(encoding="utf-8"), end="")
    return 0
