"""``morphkit train ace CREATURE``: train ACE (motion prior, then a retargeter) into a run folder;
``morphkit train nkn [CREATURE]``: train NKN (:mod:`._train_nkn`)."""

from __future__ import annotations

import argparse
import contextlib
import os
from pathlib import Path

from morphkit.commands import _args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "train",
        help="train a retargeter (ACE) for a creature; re-running the same command resumes it",
        description=(
            "Train ACE (Li et al. 2023) for CREATURE: synthesise its motion, pre-train its motion prior, then the "
            "adversarial retargeter from human motion. The run folder holds configs, checkpoints (resumed "
            "automatically), metrics.csv and TensorBoard logs. Under torchrun it trains with DDP."
        ),
    )
    p.add_argument("trainer", choices=["ace", "nkn"],
                   help="the method: ace (needs CREATURE), or nkn (without CREATURE: the paper's NKN between the "
                   "human skeletons and bone-length variants; with one: its cross-morphology mode)")
    p.add_argument("creature", metavar="CREATURE", nargs="?",
                   help="a shipped name (spot, crab, stretch, human) or a description file")
    p.add_argument("--human-data", metavar="DIR",
                   help="human motion folder or file (BVH, NPZ, USD); default: the embedded default human motion; "
                   "CMU evaluation clips are left out")
    p.add_argument("--preset", default="quick", help="smoke, quick, default or paper (default: quick)")
    p.add_argument("--out", type=_args.out_path, metavar="RUN",
                   help="run folder (default: runs/ace_<creature>_<preset>)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                   help="override a config field, e.g. --set prior.epochs=10 --set retarget.w_fea=2 (repeatable)")
    p.add_argument("--no-feature-loss", action="store_true", help="ablation ACEwoFea: drop w_fea·L_fea")
    p.add_argument("--no-adversarial", action="store_true", help="ablation ACEwoAdv: drop w_adv·L_adv and D")
    p.add_argument("--contact-weight", type=_args.float_in(0.0, 1000.0), default=0.0, metavar="W",
                   help="beyond the paper: add W × (foot sliding + penetration) of the FK'd motion (ACE+contact)")
    p.add_argument("--map", metavar="C=H", action="append", default=[],
                   help="override one end-effector pair, e.g. --map gripper=lwrist_end (repeatable)")
    p.add_argument("--map-file", metavar="FILE", help="YAML {creature_ee: human_ee} overriding the KL mapping")
    p.add_argument("--body-length", type=_args.body_length, metavar="M",
                   help="the creature's body length [m], which Ψ divides its lengths by (default: its description's "
                   "body_length, else its standing root height measured on its synthesised motion; "
                   "see docs/concepts/body-length.md)")
    p.add_argument("--prior", metavar="DIR", help="reuse the prior stage of another run (e.g. RUN/prior)")
    p.add_argument("--device", default=None, help="torch device (default: cuda when present, else cpu)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(run=run)


def parse_pairs(items: list[str], file: str | None) -> dict[str, str] | None:
    """``--map`` pairs (and a ``--map-file``) as one override mapping, or ``None``."""
    from morphkit.errors import ConfigError
    from morphkit.motion import read_override

    out = dict(read_override(file)) if file else {}
    for item in items:
        c, sep, h = item.partition("=")
        if not sep or not c.strip() or not h.strip():
            raise ConfigError(f"--map {item!r} is not of the form creature_ee=human_ee")
        out[c.strip()] = h.strip()
    return out or None


def hold_for_command(out: Path) -> contextlib.AbstractContextManager[None]:
    """The run folder's lock (:mod:`morphkit._folder_lock`) for the whole command; under torchrun rank 0
    takes it alone (the other ranks of the job share the folder by design)."""
    from morphkit._folder_lock import hold_run_folder

    return hold_run_folder(out) if os.environ.get("RANK", "0") == "0" else contextlib.nullcontext()


def run(args: argparse.Namespace) -> int:
    import dataclasses
    import math

    from morphkit.errors import ConfigError
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.output_names import safe_stem
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.ace.train import train_ace
    from morphkit.retarget.ace.variants import AceVariant
    from morphkit.retarget.config import replace_config

    if args.trainer == "nkn":
        from morphkit.commands._train_nkn import run_nkn

        return run_nkn(args)
    if args.creature is None:
        raise ConfigError("train ace needs a CREATURE (a shipped name or a description file)")
    creature = read_morphology(resolve_morphology(args.creature))
    if args.body_length is not None:
        if not (math.isfinite(args.body_length) and args.body_length > 0):
            raise ConfigError(f"--body-length must be a finite length > 0 in metres, got {args.body_length}")
        creature = dataclasses.replace(creature, declared_body_length=args.body_length)
    cfg = preset(args.preset)
    sets = list(args.set)
    if args.contact_weight > 0:
        sets.append(f"retarget.w_contact={args.contact_weight}")
    if sets:
        cfg = replace_config(cfg, sets)
    # --set retarget.w_contact=W asks for ACE+contact as --contact-weight W does
    variant = AceVariant.of_flags(feature_loss=not args.no_feature_loss, adversarial=not args.no_adversarial,
                                  contact_weight=cfg.retarget.w_contact)
    # the creature's name never steers the path (morphkit.output_names); it stays in the run's config
    out = Path(args.out) if args.out else Path("runs") / safe_stem(f"ace_{safe_stem(creature.name)}_{args.preset}")
    with hold_for_command(out):
        stage = train_ace(out, creature, cfg, variant=variant, human_data=args.human_data,
                          mapping_override=parse_pairs(args.map, args.map_file), prior_dir=args.prior,
                          device=args.device, progress=not args.no_progress)
    print(f"trained {variant.value} for {creature.name}: {stage}")
    print(f"retarget with: morphkit retarget --run {out} --motion CLIP_OR_DIR --out OUT")
    return 0
