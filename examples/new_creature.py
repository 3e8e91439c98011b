"""A new creature, end to end: describe it in YAML, check it, see it, make it move, retarget human motion onto it.

Copies a four-legged creature with a neck, a head and a tail (``examples/critter.yaml``) into the
output folder unless it is already there (edit that copy and re-run: nothing a user wrote is
overwritten), validates it, renders its
turntable, synthesises its motion and measures it, trains ACE on it (the ``quick`` preset; the
``smoke`` preset with ``--smoke``), retargets a human clip and renders human | creature side by side.
No line of morphkit knows this creature: the same steps work for any description file
(``--creature``). Re-running resumes the training. The same steps on the command line:
``docs/guides/new-creature.md``.

    python examples/new_creature.py                               # runs/new_creature/, a few minutes
    python examples/new_creature.py --creature my_robot.urdf --motion clip.bvh --out runs/my_robot
    python examples/new_creature.py --smoke                       # about a minute: the test suite's mode
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

CRITTER = Path(__file__).with_name("critter.yaml")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--creature", metavar="FILE", help="your description (.yaml/.urdf/.usd*) instead of critter.yaml")
    p.add_argument("--motion", metavar="CLIP", help="human clip to retarget (.bvh/.npz/.usd*; default: embedded)")
    p.add_argument("--preset", default="quick", help="ACE preset: smoke, quick, default or paper (default quick)")
    p.add_argument("--out", metavar="DIR", default="runs/new_creature", help="output folder (default %(default)s)")
    p.add_argument("--smoke", action="store_true", help="the smoke preset and small pictures: about a minute")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from morphkit.graph import EndEffectorRole
    from morphkit.io import read_morphology
    from morphkit.motion import load_motions, write_motion
    from morphkit.retarget import load
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.ace.train import train_ace
    from morphkit.retarget.training_data import character_motions, evaluation_clips
    from morphkit.synth.report import format_report, quality_report

    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = preset("smoke" if args.smoke else args.preset)

    # 1. Describe: the YAML file is the whole definition (docs/concepts/yaml-format.md).
    path = Path(args.creature) if args.creature else out / "critter.yaml"
    if not args.creature and not path.exists():
        path.write_text(CRITTER.read_text())
        print(f"wrote {path} (from {CRITTER})")

    # 2. Validate: the reader rejects a malformed file with `FILE:LINE: cause`.
    creature = read_morphology(path)
    feet = [e.name for e in creature.end_effectors if e.role == EndEffectorRole.FOOT]
    print(f"{creature.name}: {creature.link_count} links, {creature.dof} DoF, "
          f"{len(creature.end_effectors)} end-effectors ({len(feet)} feet), body length {creature.body_length:.3f} m")

    # 3. See it: a turntable (a still in smoke mode).
    _render(lambda render: render.turntable(
        creature, out / ("turntable.png" if args.smoke else "turntable.gif"), frames=1 if args.smoke else 36,
        size=(240, 180) if args.smoke else (480, 360), progress=False))

    # 4. Make it move: the synthesised data set ACE trains on (cached; the training below reuses it).
    motions = character_motions(creature, cfg.data, progress=False)
    (out / "motions").mkdir(exist_ok=True)
    for m in motions[:2]:
        write_motion(m, out / "motions" / f"{m.name}.npz")
    print(format_report(quality_report(motions)))
    print(f"synthesised: {sum(m.frame_count for m in motions)} frames, two clips in {out / 'motions'}")

    # 5. Train ACE: the motion prior, then the adversarial retargeter (re-running resumes).
    run_dir = out / "run"
    train_ace(run_dir, creature, cfg, progress=False)

    # 6. Retarget a human clip it never saw, and 7. render the comparison.
    clips = load_motions([args.motion]) if args.motion else evaluation_clips(None, cfg.data, limit=1)
    result = load(run_dir).retarget(clips[:1])[0]
    write_motion(result.motion, out / f"{result.motion.name}.bvh")
    travel = np.linalg.norm(result.motion.root_pose()[-1, :2] - result.motion.root_pose()[0, :2])
    print(f"retargeted {clips[0].name} ({result.motion.frame_count} frames, root ends {travel:.2f} m from its start): "
          f"{out / (result.motion.name + '.bvh')}")
    _render(lambda render: render.render_side_by_side(
        result.source, result.motion, out=out / ("compare.png" if args.smoke else "compare.gif"),
        labels=("human", creature.name), size=(200, 200) if args.smoke else (360, 360), progress=False))
    print(f"done in {time.perf_counter() - started:.0f} s: {out}")
    return 0


def _render(draw) -> None:
    """Call ``draw(morphkit.render)`` and print what it wrote; say why when rendering is unavailable."""
    import morphkit.render as render

    try:
        path = draw(render)
    except render.RenderUnavailableError as exc:  # the render extra or a headless OpenGL is missing
        print(f"no picture: {exc}")
        return
    print(f"picture: {path}")


if __name__ == "__main__":
    raise SystemExit(main())
