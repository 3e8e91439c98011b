"""``morphkit train ace CREATURE``: ACE's subcommand of ``train`` (the table and shared flags in :mod:`.train`)."""

from __future__ import annotations

import argparse

from morphkit.commands import _args


def add_arguments(p: argparse.ArgumentParser) -> None:
    """ACE's CREATURE and its own flags."""
    p.add_argument("creature", metavar="CREATURE", nargs="?",
                   help="a shipped name (spot, crab, stretch, human) or a description file")
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


def run(args: argparse.Namespace) -> int:
    """Train ACE for CREATURE: its motion prior, then the retargeter variant the flags ask for."""
    import dataclasses
    from pathlib import Path

    from morphkit.commands.train import hold_for_command
    from morphkit.errors import ConfigError
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.output_names import safe_stem
    from morphkit.retarget.ace.config import preset
    from morphkit.retarget.ace.train import train_ace
    from morphkit.retarget.ace.variants import AceVariant
    from morphkit.retarget.config import replace_config

    if args.creature is None:
        raise ConfigError("train ace needs a CREATURE (a shipped name or a description file)")
    creature = read_morphology(resolve_morphology(args.creature))
    if args.body_length is not None:  # range-checked while parsing (commands._args.body_length)
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
