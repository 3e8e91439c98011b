"""Retarget human clips with a trained ACE run: motions for Blender, usdview and a robot, and a video.

Loads a run trained by ``examples/ace_train.py`` or ``morphkit train ace`` (any creature), rolls its
retargeter over human clips in one batch — BVH/NPZ/USD files or folders, or held-out clips of the
embedded default human motion — and writes each retargeted clip as ``.npz`` (morphkit), ``.bvh``
(Blender), ``.usda`` (usdview) and robot commands ``.csv``, prints how far the human and the creature
travelled and which joint values were clamped into their limits, and renders the first clip human |
creature side by side. ``--smoke`` without ``--run`` first trains the ``smoke`` preset on Spot.

    python examples/ace_retarget.py --run runs/ace_spot_quick                     # after examples/ace_train.py
    python examples/ace_retarget.py --run runs/crab --motion ../shared/data/human/cmu --clips 8 --out runs/crab_clips
    python examples/ace_retarget.py --smoke                                       # the test suite's mode
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

FORMATS = (".npz", ".bvh", ".usda", ".csv")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", metavar="RUN", help="an ACE run folder (required unless --smoke)")
    p.add_argument("--stage", metavar="DIR", help="retargeter stage (default RUN/retarget; e.g. RUN/retarget_wofea)")
    p.add_argument("--motion", metavar="CLIP_OR_DIR", nargs="+",
                   help="human motion files or folders (default: held-out clips of the embedded default human)")
    p.add_argument("--clips", type=int, default=4, help="retarget at most this many clips (default 4)")
    p.add_argument("--out", metavar="DIR", help="output folder (default RUN/retargeted)")
    p.add_argument("--device", default="cpu", help="torch device (default cpu)")
    p.add_argument("--smoke", action="store_true", help="two short clips and a frame sheet; trains a smoke run "
                   "first when --run is not given")
    args = p.parse_args(argv)
    if args.run is None and not args.smoke:
        p.error("--run RUN is required (train one with examples/ace_train.py), or pass --smoke")

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from morphkit.motion import load_motions, write_motion_files
    from morphkit.retarget import load
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.training_data import evaluation_clips

    started = time.perf_counter()
    cfg = preset("smoke" if args.smoke else "quick")
    run_dir = Path(args.run) if args.run else _smoke_run(Path(args.out or "runs/ace_retarget_smoke") / "run", cfg)
    out = Path(args.out) if args.out else run_dir / "retargeted"
    limit = 2 if args.smoke else args.clips

    clips = load_motions(args.motion)[:limit] if args.motion else evaluation_clips(None, cfg.data, limit=limit)
    model = load(run_dir, stage=args.stage, device=args.device)
    results = model.retarget(clips)  # one batched rollout over every clip
    out.mkdir(parents=True, exist_ok=True)
    for r in results:
        write_motion_files(r.motion, out / r.motion.name, FORMATS)  # .csv: base velocity, height, pitch, arm joints
        human, creature = (float(np.linalg.norm(np.diff(m.root_pose()[:, :2], axis=0), axis=1).sum())
                           for m in (r.source, r.motion))  # root path length on the ground
        print(f"{r.source.name}: {r.motion.frame_count} frames, the human walks {human:.2f} m, "
              f"{r.motion.morphology.name} {creature:.2f} m; clamped: {r.clamp}")
    print(f"retargeted clips ({', '.join(FORMATS)}): {out}")

    import morphkit.render as render

    first = results[0]
    try:
        path = render.render_side_by_side(
            first.source, first.motion, out=out / f"{first.motion.name}_compare{'.png' if args.smoke else '.gif'}",
            labels=("human", first.motion.morphology.name), size=(200, 200) if args.smoke else (360, 360),
            progress=False)
        print(f"side by side: {path}")
    except render.RenderUnavailableError as exc:  # the render extra or a headless OpenGL is missing
        print(f"no video: {exc}")
    print(f"done in {time.perf_counter() - started:.0f} s: {out}")
    return 0


def _smoke_run(run_dir: Path, cfg) -> Path:
    """Train (or resume) the smoke preset on Spot: a run to retarget with, in about half a minute."""
    from morphkit.io import read_morphology
    from morphkit.retarget.ace.train import train_ace

    print(f"no --run: training the smoke preset on Spot into {run_dir}")
    train_ace(run_dir, read_morphology("spot"), cfg, progress=False)
    return run_dir


if __name__ == "__main__":
    raise SystemExit(main())
