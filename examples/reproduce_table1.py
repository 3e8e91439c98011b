"""Reproduce ACE's Table 1 for a creature: ACE, NKN, ACEwoFea, ACEwoAdv and ACE+contact, end to end.

Synthesises the creature's motion, pre-trains its motion prior once, trains ACE and its ablations
from it, ACE+contact (--contact-weight) and NKN's cross-morphology mode, for --seeds seeds; then
retargets the held-out clips with each and writes the report (table.md/.csv with mean ± std over
seeds, charts, side-by-side videos, index.html) under OUT/<creature>/report. Every run folder stays
under OUT/<creature>/runs (point `morphkit evaluate` at it for other clips). Re-running the same
command skips every finished stage and resumes an interrupted one.

    python examples/reproduce_table1.py --character spot --human-data ../shared/data/human/cmu --out table1
    python examples/reproduce_table1.py --character crab --character stretch --preset quick --out table1_quick
    python examples/reproduce_table1.py --character my_creature.yaml --smoke --out /tmp/t1   # the test suite's mode
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

# Test-only: the smoke preset shortened further (one short epoch per stage), two clips, one small contact sheet.
SMOKE_ACE = ("prior.epochs=1", "prior.steps_per_epoch=3", "retarget.epochs=1", "retarget.steps_per_epoch=2")
SMOKE_NKN = ("epochs=1", "steps_per_epoch=2")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--character", action="append", metavar="NAME_OR_PATH",
                   help="spot, crab, stretch or a description file (repeatable: one folder per character; "
                        "default spot)")
    p.add_argument("--human-data", metavar="DIR", help="human BVH folder (default: the embedded default human motion)")
    p.add_argument("--preset", default="default", help="smoke, quick, default or paper (default: default)")
    p.add_argument("--seeds", type=int, default=1, help="seeds per method (default 1); the table gives mean ± std")
    p.add_argument("--contact-weight", type=float, default=2.0, metavar="W", help="ACE+contact's weight (default 2)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], help="override an ACE config field")
    p.add_argument("--nkn-set", metavar="KEY=VALUE", action="append", default=[], help="override an NKN config field")
    p.add_argument("--clips", type=int, help="evaluate the first N held-out clips only (default: all)")
    p.add_argument("--videos", type=int, default=3, help="clips with a side-by-side video (default 3)")
    p.add_argument("--video-format", choices=["mp4", "gif", "png"], help="default mp4 (gif without ffmpeg)")
    p.add_argument("--out", metavar="DIR", default="table1", help="output folder (default table1)")
    p.add_argument("--jobs", type=int, default=2,
                   help="lanes trained at once on CPU: NKN beside the prior and ACE (default 2; 1: in turn)")
    p.add_argument("--device", default=None, help="torch device of training (default: cuda when present, else cpu)")
    p.add_argument("--smoke", action="store_true", help="the smoke preset shortened to seconds: the test suite's mode")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    from morphkit.evaluation import ReproduceConfig, reproduce_table1
    from morphkit.io import read_morphology

    cfg = ReproduceConfig(
        preset=args.preset, seeds=args.seeds, contact_weight=args.contact_weight, ace_overrides=tuple(args.set),
        nkn_overrides=tuple(args.nkn_set), clips=args.clips, videos=args.videos,
        video_suffix=f".{args.video_format}" if args.video_format else None, device=args.device,
        jobs=args.jobs)
    if args.smoke:
        cfg = replace(cfg, preset="smoke", ace_overrides=SMOKE_ACE + cfg.ace_overrides,
                      nkn_overrides=SMOKE_NKN + cfg.nkn_overrides, clips=2, videos=min(cfg.videos, 1),
                      video_suffix=".png", video_seconds=0.1, video_size=(96, 96))
    creatures = [read_morphology(c) for c in args.character or ["spot"]]
    times = []
    for creature in creatures:
        started = time.perf_counter()
        table = reproduce_table1(creature, Path(args.out) / creature.name, cfg, human_data=args.human_data)
        times.append((creature.name, time.perf_counter() - started))
        report = Path(args.out) / creature.name / "report"
        print(table, end="")
        if (report / "targets.md").is_file():  # a report finished before reports checked the claims has none
            print((report / "targets.md").read_text(encoding="utf-8"), end="")
        print(f"report: {report / 'index.html'}")
    for name, seconds in times:
        print(f"{name}: {seconds:.0f} s ({seconds / 60:.1f} min)")
    print(f"done in {sum(s for _, s in times):.0f} s: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
