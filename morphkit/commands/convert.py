"""``morphkit convert IN OUT``: convert a creature description between formats, by extension."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="convert a description between .yaml/.urdf/.usd[a|c] (by extension)")
    p.add_argument("input", metavar="IN", help="description file or shipped creature name")
    p.add_argument("output", metavar="OUT", help="output file; its extension picks the format")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from morphkit.io import read_morphology, write_morphology
    from morphkit.io.shipped import resolve_morphology

    m = read_morphology(resolve_morphology(args.input))
    write_morphology(m, args.output)
    print(f"wrote {args.output} ({m.name}: {m.link_count} links, {m.joint_count} joints)")
    return 0
