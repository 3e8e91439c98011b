"""``morphkit generate --legs N [--arm] [--tail] [--neck] --out FILE``: a random creature of a family."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphkit.commands import _args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("generate", help="write a random creature of a family (legs, arm, tail, neck) to try things on")
    p.add_argument("--legs", type=int, default=4, choices=(2, 4, 6), help="leg count (default 4)")
    p.add_argument("--arm", action="store_true", help="an arm on the front of the body, ending in a hand")
    p.add_argument("--tail", action="store_true", help="a two-segment tail")
    p.add_argument("--neck", action="store_true", help="a neck and a head")
    p.add_argument("--size", type=_args.float_in(0.01, 100.0), default=1.0,
                   help="scale of every length, 0.01 to 100 (1: a body about 0.6 m long)")
    p.add_argument("--seed", type=_args.seed, default=0, help="seed of the proportions (same seed, same creature)")
    p.add_argument("--unlabelled", action="store_true",
                   help="leave the end-effectors out: the readers then decide them from the body")
    p.add_argument("--out", type=_args.out_path, required=True, metavar="FILE",
                   help="description to write (.yaml, .urdf, .usda, .xml)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from morphkit.errors import ConfigError
    from morphkit.io import WRITE_SUFFIXES, write_morphology
    from morphkit.synth.creatures import CreatureFamily, random_creature

    suffix = Path(args.out).suffix.lower()
    if suffix not in WRITE_SUFFIXES:
        raise ConfigError(f"{args.out}: unknown description format {suffix or '(no suffix)'!r}; "
                          f"supported: {', '.join(dict.fromkeys(WRITE_SUFFIXES))}")
    if Path(args.out).exists():
        raise ConfigError(f"{args.out}: exists; generate writes a new file (remove it or name another)")
    family = CreatureFamily(legs=args.legs, arm=args.arm, tail=args.tail, neck=args.neck, size=args.size)
    m = random_creature(family, args.seed, labelled=not args.unlabelled)
    if args.unlabelled and suffix in (".yaml", ".yml"):
        # YAML writes `end_effectors: {}` for "none, decided"; unlabelled means "left to the reader's guess"
        from morphkit._atomic import atomic_write_text
        from morphkit.io.yaml_format import dump_yaml

        text = dump_yaml(m, target=args.out).replace("end_effectors: {}\n", "")
        atomic_write_text(args.out, text)
    else:
        write_morphology(m, args.out)
    print(f"wrote {args.out} ({m.name}: {m.link_count} links, {len(m.end_effectors)} end-effectors)")
    return 0
