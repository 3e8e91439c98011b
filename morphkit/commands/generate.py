"""``morphkit generate [--family NAME | --legs N [--arm] [--tail] [--neck] ... | --wheels DRIVE [--arm]] --out FILE``:
a random creature of a family, or a wheeled robot of a drive."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphkit.commands import _args
from morphkit.graph.elements import WHEEL_DRIVES

FAMILY_NAMES = ("grazer", "hopper", "octopod")
"""The named body plans of :data:`morphkit.synth.creatures.FAMILIES`, written out: importing the synthesis to build
the parser would start Warp, whose banner lands on every command's stdout (``info --json`` included)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("generate", help="write a random creature of a family (legs, arm, tail, neck) to try things on")
    p.add_argument("--family", choices=FAMILY_NAMES,
                   help="a named body plan: hopper (a biped with a heavy tail resting behind, short arms, long feet), "
                        "grazer (four legs, a long neck reaching the ground, a tail), octopod (eight legs); "
                        "the flags below add to it")
    p.add_argument("--legs", type=int, choices=(2, 4, 6, 8), help="leg count (default 4, or the family's)")
    p.add_argument("--arm", action="store_true", help="an arm on the front of the body, ending in a hand")
    p.add_argument("--tail", action="store_true", help="a two-segment tail")
    p.add_argument("--neck", action="store_true", help="a neck and a head")
    p.add_argument("--short-arms", action="store_true", help="a pair of short two-joint arms at the front, with hands")
    p.add_argument("--heavy-tail", action="store_true",
                   help="a thick three-segment tail whose tip rests just above the ground behind")
    p.add_argument("--long-neck", action="store_true", help="a three-joint neck whose head reaches the ground")
    p.add_argument("--long-feet", action="store_true", help="an ankle and a long flat foot on each leg")
    p.add_argument("--wheels", choices=WHEEL_DRIVES, metavar="DRIVE",
                   help="a wheeled robot instead of a creature: differential, skid_steer, ackermann or holonomic "
                        "(with --arm: an arm on it; with --unlabelled its wheels and drive are left for the reader to "
                        "find, as in a vendor file)")
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
    from morphkit.synth.creatures import FAMILIES, CreatureFamily, random_creature

    suffix = Path(args.out).suffix.lower()
    if suffix not in WRITE_SUFFIXES:
        raise ConfigError(f"{args.out}: unknown description format {suffix or '(no suffix)'!r}; "
                          f"supported: {', '.join(dict.fromkeys(WRITE_SUFFIXES))}")
    if Path(args.out).exists():
        raise ConfigError(f"{args.out}: exists; generate writes a new file (remove it or name another)")
    if args.wheels is not None:
        creature = ("family", "legs", "tail", "neck", "short_arms", "heavy_tail", "long_neck", "long_feet")
        body_flags = [f for f in creature if getattr(args, f) not in (None, False)]
        if body_flags:
            raise ConfigError(f"--wheels makes a wheeled robot; --{body_flags[0].replace('_', '-')} is a creature's")
        from morphkit.synth.wheeled_bodies import wheeled_body, wheeled_robot

        # the proportions are the generator's defaults times --size (no seed: one body per drive)
        make = wheeled_body if args.unlabelled else wheeled_robot
        m = make(args.wheels, arm=args.arm, radius=0.08 * args.size, track=0.5 * args.size, wheelbase=0.6 * args.size)
        write_morphology(m, args.out)
        print(f"wrote {args.out} ({m.name}: {m.link_count} links, {len(m.end_effectors)} end-effectors, "
              f"{args.wheels} drive)")
        return 0
    base = FAMILIES[args.family] if args.family else CreatureFamily()
    family = CreatureFamily(
        legs=args.legs if args.legs is not None else base.legs, size=args.size,
        **{k: getattr(base, k) or getattr(args, k) for k in ("arm", "tail", "neck", "short_arms", "heavy_tail",
                                                             "long_neck", "long_feet")})
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
