"""NKN main job: retarget human motion onto skeletons with other bone lengths, against the copy baseline.

Trains NKN (Villegas et al. 2018: a GRU encoder/decoder through morphkit's FK layer, adversarial
cycle consistency) on skeletons of one topology, then retargets held-out 4-second clips onto seen
skeletons and unseen bone-length variants (short legs, long legs, long arms, tall), prints the
metrics table beside the copy-rotations baseline, writes Fig.-5-style end-effector height plots, a
retargeted clip (.npz/.bvh) and a side-by-side video. With ``--creature`` it trains the
cross-morphology mode (human → that creature, ACE's baseline) instead. Re-running resumes the run.

    python examples/nkn_train.py                                   # embedded default human and variants, quick
    python examples/nkn_train.py --human-data ../shared/data/human/cmu --human-data ../shared/data/human/second_skeleton
    python examples/nkn_train.py --creature spot                   # cross-morphology mode
    python examples/nkn_train.py --smoke                           # seconds: the test suite's mode
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--human-data", metavar="DIR", action="append",
                   help="human BVH folder, repeatable: later folders of another skeleton convention are mapped onto "
                   "the first one's when morphkit ships a map (default: the embedded default human)")
    p.add_argument("--creature", help="cross-morphology mode: a shipped name or description file")
    p.add_argument("--preset", default="quick", help="smoke, quick, default or paper (default quick)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], help="override a config field")
    p.add_argument("--out", metavar="DIR", help="output folder (default runs/nkn_<data>_<preset>)")
    p.add_argument("--clips", type=int, default=8, help="4-second evaluation clips (default 8)")
    p.add_argument("--device", default=None, help="torch device (default: cuda when present, else cpu)")
    p.add_argument("--no-video", action="store_true", help="skip the side-by-side video")
    p.add_argument("--smoke", action="store_true", help="the smoke preset, two clips, a frame sheet for a video")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    from morphkit.motion import write_motion
    from morphkit.retarget.config import replace_config
    from morphkit.retarget.nkn import NknRetargeter, preset, train_nkn
    from morphkit.retarget.nkn.data import evaluation_pieces
    from morphkit.retarget.nkn.evaluate import compare_with_baseline, contact_metrics, write_scores
    from morphkit.retarget.nkn.skeleton import EVALUATION_VARIANTS, scale_limbs

    started = time.perf_counter()
    name = "smoke" if args.smoke else args.preset
    cfg = replace_config(preset(name), args.set) if args.set else preset(name)
    creature = None
    if args.creature:
        from morphkit.io import read_morphology

        creature = read_morphology(args.creature)
    from morphkit.output_names import safe_stem

    # names from inside files never steer where outputs go (morphkit.output_names)
    data = "_".join(safe_stem(Path(d).name, "data") for d in args.human_data) if args.human_data else "default"
    suffix = f"_{safe_stem(creature.name)}" if creature else ""
    out = Path(args.out) if args.out else Path("runs") / safe_stem(f"nkn_{data}{suffix}_{name}")
    train_nkn(out, cfg, human_data=args.human_data, creature=creature, device=args.device)

    model = NknRetargeter(out)
    clips = evaluation_pieces(args.human_data, cfg.data, limit=2 if args.smoke else args.clips)
    (out / "clips").mkdir(parents=True, exist_ok=True)
    if creature is not None:
        motions = [r.motion for r in model.retarget(clips)]
        for m in motions:
            write_motion(m, out / "clips" / f"{m.name}.npz")
        contact = [contact_metrics(m) for m in motions]
        print(f"{len(motions)} clips retargeted onto {creature.name}: foot sliding "
              f"{sum(c['sliding'] for c in contact) / len(contact):.3f} m/s")
        shown = (clips[0], motions[0])
    else:
        seen = [(model.skeletons[c["name"]], True) for c in model.artifact.characters if c["clips"]][:2]
        seen += [(model.skeletons[c["name"]], True) for c in model.artifact.characters if not c["clips"]][:1]
        unseen = [(scale_limbs(model.template, s, name=n), False) for n, s in EVALUATION_VARIANTS.items()]
        if args.smoke:
            seen, unseen = seen[:1], unseen[:1]
        rows, plots = compare_with_baseline(model, clips, seen + unseen, plot_dir=out / "plots")
        print(write_scores(rows, out / "evaluation"))
        print(f"plots: {out / 'plots'} ({len(plots)} PNGs)")
        target = unseen[0][0]
        motion = model.retarget(clips[:1], target)[0].motion
        shown = (clips[0], motion)
    for suffix in (".npz", ".bvh"):
        write_motion(shown[1], out / "clips" / f"{shown[1].name}{suffix}")
    print(f"retargeted clips: {out / 'clips'}")
    if not args.no_video:
        _video(*shown, out / "videos", sheet=args.smoke)
    print(f"done in {time.perf_counter() - started:.0f} s: {out}")
    return 0


def _video(source, motion, folder: Path, *, sheet: bool) -> None:
    try:
        from morphkit.render import ffmpeg_available, render_side_by_side
    except ImportError as exc:  # the render extra is optional
        print(f"no video: {exc} (pip install -e '.[render]')")
        return
    folder.mkdir(parents=True, exist_ok=True)
    suffix = ".png" if sheet else (".mp4" if ffmpeg_available() else ".gif")
    path = render_side_by_side(source, motion, out=folder / f"{motion.name}{suffix}",
                               labels=("source", motion.morphology.name), size=(360, 360), progress=False)
    print(f"video: {path}")


if __name__ == "__main__":
    raise SystemExit(main())
