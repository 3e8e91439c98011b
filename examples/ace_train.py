"""ACE main job: retarget human motion onto a creature, with metrics and a side-by-side video.

Trains ACE (Li et al. 2023) for a creature — synthesises its motion, pre-trains its motion prior,
trains the adversarial retargeter — then retargets clips it never saw, writes them as .npz/.bvh
and robot-command .csv through the contact-aware export (``--contacts replan``: the legs re-stepped
along the retargeted root path), prints Table-1-style rows (DIV, FID, L_fea, UFR and the contact and
follow figures; the data set's own row, the raw output's and both exports', replan and lock), and renders
human | creature side by side. Re-running the same command resumes the run.

    python examples/ace_train.py                                   # Spot, embedded default human motion
    python examples/ace_train.py --creature crab --human-data ../shared/data/human/cmu --preset default
    python examples/ace_train.py --smoke                           # seconds: the test suite's mode
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--creature", default="spot", help="shipped name or description file (default spot)")
    p.add_argument("--human-data", metavar="DIR", help="human BVH folder (default: the embedded default human motion)")
    p.add_argument("--preset", default="quick", help="smoke, quick, default or paper (default quick)")
    p.add_argument("--out", metavar="DIR", help="output folder (default runs/ace_<creature>_<preset>)")
    p.add_argument("--clips", type=int, default=6, help="evaluation clips to retarget (default 6)")
    p.add_argument("--videos", type=int, default=2, help="side-by-side videos to render (default 2)")
    p.add_argument("--contacts", default="replan", choices=("none", "replan", "lock"),
                   help="contact-aware export of the clips and videos (default replan; the table shows all three)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                   help="override a config field, as morphkit train --set (e.g. --set seed=1; repeatable)")
    p.add_argument("--smoke", action="store_true", help="the smoke preset and one short video frame sheet")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    from morphkit.body.anatomy import anatomy_warnings
    from morphkit.evaluation.table import dataset_row, evaluate_clips, pooled_skating, reference_data, write_table
    from morphkit.io import read_morphology
    from morphkit.motion import write_motion_files
    from morphkit.output_names import safe_stem
    from morphkit.retarget import WithContacts, load
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.ace.train import train_ace
    from morphkit.retarget.config import replace_config
    from morphkit.retarget.training_data import character_motions, evaluation_clips

    started = time.perf_counter()
    name = "smoke" if args.smoke else args.preset
    cfg = replace_config(preset(name), args.set) if args.set else preset(name)
    creature = read_morphology(args.creature)
    for line in creature.notes:  # first, before minutes of training
        print(f"note: {line}", file=sys.stderr)
    for line in anatomy_warnings(creature):
        print(f"warning: {line}", file=sys.stderr)
    if not creature.end_effectors:
        print(f"error: {args.creature}: no end-effectors found; name them in the description (YAML end_effectors, "
              "URDF <end_effector>, MJCF side file <model>.morphkit.yaml)", file=sys.stderr)
        return 2
    _warn_unrealistic_data(creature, cfg)
    # the creature's name is inside its file: it never steers where outputs go (morphkit.output_names)
    out = Path(args.out) if args.out else Path("runs") / safe_stem(f"ace_{safe_stem(creature.name)}_{name}")
    train_ace(out, creature, cfg, human_data=args.human_data)

    model = load(out)
    clips = evaluation_clips(args.human_data, cfg.data, limit=2 if args.smoke else args.clips)
    raw = model.retarget(clips)
    shipped = WithContacts(model, args.contacts)
    results = [shipped.export(r) for r in raw]
    (out / "clips").mkdir(parents=True, exist_ok=True)
    for r in results:
        write_motion_files(r.motion, out / "clips" / r.motion.name, (".npz", ".bvh", ".csv"))
    character = character_motions(creature, cfg.data, progress=False)
    reference = reference_data(character, model.pairing)
    humans = [r.source for r in raw]
    rows = [dataset_row(character, model.pairing, seed=cfg.seed, humans=humans, reference=reference)]
    rows.append(evaluate_clips(model.label, humans, [r.motion for r in raw], reference, model.pairing, seed=cfg.seed))
    for mode in ("replan", "lock"):  # both exports side by side, whichever the clips were written with
        exported = results if mode == args.contacts else [WithContacts(model, mode).export(r) for r in raw]
        rows.append(evaluate_clips(f"{model.label}+{mode}", humans, [r.motion for r in exported], reference,
                                   model.pairing, seed=cfg.seed))
    table = write_table(rows, out / "metrics")
    print(table)
    _shipped_beside_data(rows, f"{model.label}+{args.contacts}" if args.contacts != "none" else model.label)
    print(f"the source humans' own skating ratio on these clips: {100 * pooled_skating(humans):.2f} %")
    print(f"retargeted clips: {out / 'clips'}")
    _videos(results[: 1 if args.smoke else args.videos], out / "videos", sheet=args.smoke)
    print(f"done in {time.perf_counter() - started:.0f} s: {out}")
    return 0


def _shipped_beside_data(rows, shipped: str) -> None:
    """The shipped row's FID and DIV beside the data's own spread, and a warning for each clip outside the data."""
    from morphkit.evaluation.table import off_data_warnings

    data = rows[0]
    row = next(r for r in rows if r.name == shipped)
    ratio = row.div / data.div if data.div else float("nan")
    print(f"shipped ({shipped}): matched FID {row.fid:.3f} (the data against itself: 0), DIV {row.div:.3f} against "
          f"the data's {data.div:.3f} ({ratio:.2f}x); {100 * (row.off_data or 0.0):.0f} % of its clips outside "
          "the data")
    for r in rows[1:]:
        for line in off_data_warnings(r):
            print(f"warning: {line}", file=sys.stderr)


def _warn_unrealistic_data(creature, cfg) -> None:
    """Warn before training when the synthesised data ACE learns from are unrealistic (UFR above 5 %)."""
    from morphkit.metrics import UnrealisticFrames, unrealistic_frame_ratio
    from morphkit.retarget.training_data import character_motions

    character = character_motions(creature, cfg.data)  # cached: training reads the same motions
    ufr = UnrealisticFrames.concatenate([unrealistic_frame_ratio(m) for m in character])
    if ufr.ratio > 0.05:
        causes = ", ".join(f"{k.replace('_', ' ')} {100 * v:.1f} %" for k, v in ufr.cause_ratios().items() if v)
        print(f"warning: {creature.name}: {100 * ufr.ratio:.1f} % of the synthesised training frames are unrealistic "
              f"({causes}); ACE learns what it is shown. Check the stance and feet with `morphkit info` and "
              "`morphkit synth --report`, then give a rest pose or name the feet in the description", file=sys.stderr)


def _videos(results: list, folder: Path, *, sheet: bool) -> None:
    try:
        from morphkit.render import ffmpeg_available, render_side_by_side
    except ImportError as exc:  # the render extra is optional
        print(f"no videos: {exc} (pip install -e '.[render]')")
        return
    folder.mkdir(parents=True, exist_ok=True)
    suffix = ".png" if sheet else (".mp4" if ffmpeg_available() else ".gif")
    for r in results:
        path = render_side_by_side(r.source, r.motion, out=folder / f"{r.motion.name}{suffix}",
                                   labels=("human", r.motion.morphology.name), size=(360, 360), fps=15.0,
                                   progress=False)  # 15 fps: rendering, not training, set the main job's time
        print(f"video: {path}")


if __name__ == "__main__":
    raise SystemExit(main())
