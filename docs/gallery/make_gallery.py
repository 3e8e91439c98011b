"""Make the gallery's pictures: turntable sheets of every shipped creature and the guide's critter, synthesised
motion sheets, and (with ``--run``) a retargeted clip side by side with its human source.

Every picture in ``docs/gallery/`` comes from this script, never by hand; only small PNGs are committed
(videos stay out of the repository). Re-run it after a change to the renderer or a creature:

    python docs/gallery/make_gallery.py                                  # turntables and synthesised motion
    python docs/gallery/make_gallery.py --run runs/ace_spot_quick        # + a retargeted clip from that run
    python docs/gallery/make_gallery.py --out /tmp/gallery --smoke       # one creature, small: a quick check
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CREATURES = ("spot", "crab", "stretch", "human", str(ROOT / "examples" / "critter.yaml"))
VIEWS = 4  # turntable views per sheet
PANEL = (240, 180)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", metavar="DIR", default=str(HERE), help="folder for the PNGs (default docs/gallery)")
    p.add_argument("--run", metavar="RUN", help="an ACE run: add its retargeting of a held-out embedded human clip")
    p.add_argument("--smoke", action="store_true", help="one creature, one turntable sheet")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    from morphkit.io import read_morphology
    from morphkit.render import contact_sheet, iter_turntable_frames, write_image

    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in CREATURES[:1] if args.smoke else CREATURES:
        creature = read_morphology(name)
        frames = list(iter_turntable_frames(creature, frames=VIEWS, size=PANEL, progress=False))
        labels = [f"{i * 360 // VIEWS}°" for i in range(VIEWS)]
        print(write_image(contact_sheet(frames, columns=VIEWS, labels=labels), out / f"{creature.name}_turntable.png"))
        if not args.smoke:
            _motion_sheet(creature, out / f"{creature.name}_motion.png")
    if args.run:
        _retargeted(Path(args.run), out)
    print(f"done in {time.perf_counter() - started:.0f} s: {out}")
    return 0


def _motion_sheet(creature, path: Path) -> None:
    """Six frames of four seconds of the creature's synthesised motion."""
    from morphkit.render import contact_sheet, iter_motion_frames, write_image
    from morphkit.synth import default_human_motion, synthesize

    if creature.name == "human":
        motion = next(iter(default_human_motion(frames=120, seed=3)))
    else:
        motion = synthesize(creature, frames=120, seed=3, progress=False).motions[0]
    idx = [round(i * (motion.frame_count - 1) / 5) for i in range(6)]
    frames = list(iter_motion_frames(motion, frame_indices=idx, size=PANEL, progress=False))
    print(write_image(contact_sheet(frames, columns=6, labels=[f"t = {i / motion.fps:.1f} s" for i in idx]), path))


def _retargeted(run_dir: Path, out: Path) -> None:
    """A held-out embedded human clip and its retargeting by the run, six synced frames side by side."""
    from morphkit.render import contact_sheet, iter_side_by_side_frames, write_image
    from morphkit.retarget import load
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.training_data import evaluation_clips

    clip = evaluation_clips(None, preset("quick").data, limit=1)[0]
    result = load(run_dir).retarget([clip])[0]
    idx = [round(i * (clip.frame_count - 1) / 5) for i in range(6)]
    frames = list(iter_side_by_side_frames([result.source, result.motion], frame_indices=idx, size=PANEL,
                                           labels=("human", result.motion.morphology.name), progress=False))
    captions = [f"t = {i / clip.fps:.1f} s" for i in idx]
    path = out / f"retargeted_{result.motion.morphology.name}.png"
    print(write_image(contact_sheet(frames, columns=3, labels=captions), path))


if __name__ == "__main__":
    raise SystemExit(main())
