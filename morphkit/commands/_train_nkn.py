"""``morphkit train nkn [CREATURE]``: NKN's subcommand of ``train`` (the table and shared flags in :mod:`.train`)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """NKN's optional CREATURE (NKN has no flags of its own beyond the shared ones)."""
    p.add_argument("creature", metavar="CREATURE", nargs="?",
                   help="a shipped name (spot, crab, stretch, human) or a description file: the cross-morphology "
                   "mode onto it (default: none, the paper's NKN between the human skeletons)")


def run(args: argparse.Namespace) -> int:
    """Train NKN: without CREATURE the paper's same-topology mode over the human skeletons, with one the
    cross-morphology mode (human → CREATURE)."""
    from pathlib import Path

    from morphkit.commands.train import hold_for_command
    from morphkit.output_names import safe_stem
    from morphkit.retarget.config import replace_config
    from morphkit.retarget.nkn import preset, train_nkn

    creature = None
    if args.creature is not None:
        from morphkit.io import read_morphology

        creature = read_morphology(args.creature)
    cfg = preset(args.preset)
    if args.set:
        cfg = replace_config(cfg, args.set)
    # names from the data's folder and the creature never steer the path (morphkit.output_names)
    data = safe_stem(Path(args.human_data).name, default="data") if args.human_data else "default"
    suffix = f"_{safe_stem(creature.name)}" if creature else ""
    out = Path(args.out) if args.out else Path("runs") / safe_stem(f"nkn_{data}{suffix}_{args.preset}")
    with hold_for_command(out):
        train_nkn(out, cfg, human_data=args.human_data, creature=creature, device=args.device,
                  progress=not args.no_progress)
    mode = f"cross-morphology NKN onto {creature.name}" if creature else "NKN over the human skeletons"
    print(f"trained {mode}: {out}")
    print(f"retarget with: python -c \"from morphkit.retarget.nkn import NknRetargeter; NknRetargeter('{out}')\""
          " or examples/nkn_train.py")
    return 0
