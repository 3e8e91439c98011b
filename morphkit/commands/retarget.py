"""``morphkit retarget --run RUN --motion CLIP_OR_DIR --out OUT``: retarget human motion with a trained run."""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from morphkit.commands import _args

if TYPE_CHECKING:
    from morphkit.motion import Motion
    from morphkit.retarget.retargeter import Retargeter

FORMATS = (".npz", ".bvh", ".usda", ".usd", ".usdc", ".csv")
DEFAULT_NKN_TARGET = "short_legs"
"""The skeleton an NKN run over human skeletons retargets onto when ``--target`` is not given: the first
unseen bone-length variant of the evaluation."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "retarget",
        help="retarget human clips onto the run's creature; writes .npz/.bvh/.usda motions and .csv robot commands",
        description=(
            "Roll a trained run (ACE, or NKN) over human clips (batched) and write the creature's motions. OUT "
            "ending in a motion suffix names the file for a single clip; otherwise OUT is a folder with one file per "
            "clip and format (--formats). .csv files are robot commands: base velocity, body height and pitch, arm "
            "joints."
        ),
    )
    p.add_argument("--run", required=True, dest="run_dir", metavar="RUN",
                   help="a trained run folder (morphkit train ace|nkn)")
    p.add_argument("--motion", required=True, nargs="+", metavar="CLIP_OR_DIR", help="human motion files or folders")
    p.add_argument("--out", type=_args.out_path, required=True, metavar="OUT",
                   help="output folder, or a file for one clip")
    p.add_argument(
        "--stage", metavar="DIR",
        help="ACE runs: retargeter stage folder or variant (default RUN/retarget; e.g. RUN/retarget_wofea, ace-wofea)",
    )
    p.add_argument("--formats", default="npz,csv", help="folder output: comma-separated suffixes (default npz,csv)")
    p.add_argument("--contacts", choices=("none", "replan", "lock"),
                   help="contact-aware export: replan re-steps a legged creature's legs along the retargeted root "
                        "path (stance feet planted; body and arms kept); lock keeps the retargeter's own steps and "
                        "holds each stance foot at its touchdown point; both then move an arm out of the body "
                        "where it went in; none writes the raw output (default: "
                        "replan onto a creature, none onto a human skeleton)")
    p.add_argument("--target", metavar="SKELETON",
                   help="NKN runs over human skeletons: a training character's name, a bone-length variant "
                        "(short_legs, long_legs, long_arms_short_legs, tall) or a BVH/YAML skeleton (default: the "
                        "first unseen variant, short_legs)")
    p.add_argument("--fps", "--source-fps", dest="fps", type=_args.source_fps, metavar="FPS",
                   help="the clips' true frame rate, replacing their own (a BVH Frame Time that lies, which is "
                        "refused outside 1e-4 to 1 s)")
    p.add_argument("--device", default="cpu", help="torch device (default cpu)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from morphkit._atomic import check_writable
    from morphkit._folder_lock import hold_run_folder
    from morphkit.errors import ConfigError, MotionFormatError, SourceLocation
    from morphkit.motion import load_motions, write_motion_files
    from morphkit.motion.datasets import expand_motion_paths
    from morphkit.retarget import WithContacts, load

    out = Path(args.out)
    single = out.suffix.lower() in FORMATS
    formats = [out.suffix.lower()] if single else ["." + f.strip().lstrip(".").lower() for f in args.formats.split(",")]
    for f in formats:
        if f not in FORMATS:
            raise ConfigError(f"unknown output format {f!r}; supported: {', '.join(FORMATS)}")
    paths = expand_motion_paths(args.motion)
    if single and len(paths) != 1:
        raise ConfigError(f"--out {out} names one file but {len(paths)} clips were given: pass a folder")
    # One clip into a file: OUT's own name and suffix (case kept); a folder: a file per clip and format.
    stems = [out.with_suffix("")] if single else output_stems(paths, out)
    suffixes = [out.suffix] if single else formats
    for stem in stems:  # before any work: a bad output path would waste it
        for suffix in suffixes:
            check_writable(f"{stem}{suffix}")
    rate = {"source_fps": args.fps} if args.fps is not None else {}
    clips = [c.replace(name=p.stem) for p, c in zip(paths, load_motions(paths, **rate), strict=True)]
    model = load(args.run_dir, stage=args.stage, device=args.device, target=args.target)
    if model.creature is None and args.target is None:  # NKN between human skeletons: an unseen skeleton
        model = model.with_target(DEFAULT_NKN_TARGET)
    contacts = args.contacts or ("replan" if model.creature is not None else "none")
    if contacts != "none" or (model.creature is not None and model.creature.wheels is not None):
        model = WithContacts(model, contacts)  # "none" too on wheels: every export drives as the wheels allow
    for path, clip in zip(paths, clips, strict=True):
        try:  # every clip checked before any is retargeted, its error naming its file
            model.intake(clip)
        except MotionFormatError as exc:
            raise MotionFormatError(exc.message, location=exc.location or SourceLocation(str(path))) from None
    results = model.retarget(clips)
    # one writer per output folder (a single file is replaced atomically and needs none)
    with contextlib.nullcontext() if single else hold_run_folder(out):
        for r, stem in zip(results, stems, strict=True):
            for path in write_motion_files(r.motion, stem, suffixes):
                print(path)
            if r.clamp.coordinates:
                print(f"  {r.motion.name}: {r.clamp}")
    warn_off_data(model, [r.motion for r in results])
    return 0


def warn_off_data(model: Retargeter, motions: Sequence[Motion]) -> None:
    """Warn on stderr of each clip whose motion lies outside the creature's data (a per-clip distance above the
    largest the data's own clips reach: :func:`morphkit.evaluation.table.outside_clips`); never silent: a run that
    cannot be checked says so."""
    import sys

    from morphkit.evaluation.table import outside_clips, reference_data
    from morphkit.retarget.training_data import character_motions

    # getattr: a retargeter that lacks them (a test double, a third-party one) is told of, not crashed on
    pairing, creature, data = (getattr(model, k, None) for k in ("pairing", "creature", "data"))
    if creature is None:
        return
    if pairing is None or data is None:
        print("note: this retargeter has no Ψ pairing or data set: its clips were not checked against the "
              "creature's data",
              file=sys.stderr)
        return
    reference = reference_data(character_motions(creature, data, progress=False), pairing)
    outside = outside_clips(motions, reference, pairing)
    threshold = reference.envelope.threshold if reference.envelope is not None else float("nan")
    for name, d in outside:
        print(f"warning: clip {name!r} lies outside {creature.name}'s data: distance {d:.2f} > "
              f"{threshold:.2f} (the largest its own clips reach); look at it before using it", file=sys.stderr)
    print(f"{len(motions) - len(outside)} of {len(motions)} clips inside {creature.name}'s data "
          f"({reference.envelope.describe() if reference.envelope is not None else 'no envelope'})")


def output_stems(paths: list[Path], out: Path) -> list[Path]:
    """``OUT/<input stem>`` per input, each input's own name made safe (:func:`morphkit.output_names.safe_stem`);
    two inputs that would write one file are refused.

    Raises:
        ConfigError: two inputs with one stem (``a/walk.bvh`` and ``b/walk.npz``), naming both, or ``out``
            an existing file.
    """
    from morphkit.errors import ConfigError, SourceLocation
    from morphkit.output_names import safe_stem

    if out.exists() and not out.is_dir():
        raise ConfigError("--out is an existing file, not a folder: name a folder, or a file ending in one of "
                          f"{', '.join(FORMATS)} for one clip", location=SourceLocation(str(out)))
    seen: dict[str, Path] = {}
    stems = [safe_stem(p.stem, default="clip") for p in paths]
    for path, stem in zip(paths, stems, strict=True):
        # Case-folded: on a case-insensitive disk Walk.bvh and walk.bvh would write one file.
        key = stem.casefold()
        if key in seen:
            raise ConfigError(f"two inputs would write the same output {out / stem}.*: {seen[key]} and {path}; "
                              "rename one or retarget them into separate folders", location=SourceLocation(str(path)))
        seen[key] = path
    return [out / s for s in stems]
