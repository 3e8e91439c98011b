"""Evaluate trained retargeters as ACE's Table 1: metrics, bar charts, side-by-side videos, one page.

Retargets every held-out clip (the CMU evaluation split, or the embedded default human's evaluation
clips) with every finished retargeter of the given runs — ACE run folders give ACE, ACEwoFea,
ACEwoAdv and ACE+contact, NKN cross-morphology runs give NKN — scores DIV, FID, L_fea and UFR
against the creature's synthesised data set, and writes table.md/.csv (mean ± std over seeds),
bar charts, side-by-side videos (human | each method) and index.html into --out.

    python examples/ace_eval.py --runs runs/ace_spot_quick                # the main job's run
    python examples/ace_eval.py --runs table1/spot/runs --human-data ../shared/data/human/cmu --out table1/spot/eval
    python examples/ace_eval.py --smoke                                   # trains a smoke run, then: seconds
"""

from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", nargs="+", metavar="RUN",
                   help="ACE or NKN (cross-morphology) run folders, ACE stage folders, folders of run folders "
                        "(default: the main job's runs/ace_spot_quick; with --smoke and no runs, a smoke run of "
                        "Spot is trained first)")
    p.add_argument("--human-data", metavar="DIR", help="human BVH folder (default: the runs' own human data)")
    p.add_argument("--out", metavar="DIR", help="report folder (default evaluation_<creature>)")
    p.add_argument("--clips", type=int, help="evaluate the first N clips only (default: all)")
    p.add_argument("--videos", type=int, default=3, help="clips with a side-by-side video (default 3)")
    p.add_argument("--video-format", choices=["mp4", "gif", "png"], help="default mp4 (gif without ffmpeg)")
    p.add_argument("--device", default="cpu", help="torch device (default cpu)")
    p.add_argument("--smoke", action="store_true", help="two clips, one small contact sheet instead of videos")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from morphkit.evaluation import evaluate_runs

    if not args.runs and args.smoke:
        from morphkit.io import read_morphology
        from morphkit.retarget.ace.config import preset
        from morphkit.retarget.ace.train import train_ace

        args.runs = [Path("runs") / "ace_spot_smoke"]
        train_ace(args.runs[0], read_morphology("spot"), preset("smoke"), progress=False)
    elif not args.runs:
        args.runs = [Path("runs") / "ace_spot_quick"]  # the main job's run (python examples/ace_train.py)

    options = {"clips": args.clips, "videos": args.videos,
               "video_suffix": f".{args.video_format}" if args.video_format else None}
    if args.smoke:  # seconds: two clips, one small contact sheet
        options = {"clips": 2, "videos": min(args.videos, 1), "video_suffix": ".png", "video_seconds": 0.1,
                   "video_size": (96, 96)}
    out = evaluate_runs(args.runs, args.out, human_data=args.human_data, device=args.device, **options)
    print((out / "table.md").read_text(encoding="utf-8"), end="")
    print(f"done: {out / 'index.html'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
