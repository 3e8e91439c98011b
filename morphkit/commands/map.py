"""``morphkit map HUMAN_DATA CREATURE_DATA``: pair a creature's end-effectors with a human's (ACE Eq. 11)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "map",
        help="map a creature's end-effectors to a human's by KL divergence of their position distributions",
        description=(
            "Fit a Gaussian to every end-effector's positions (root heading frame, divided by body length) "
            "over each dataset and map each creature end-effector to the human end-effector with the smallest "
            "KL(p_creature || p_human) (ACE, Li et al. 2023, Eq. 11)."
        ),
    )
    p.add_argument("human", metavar="HUMAN_DATA", nargs="+",
                   help="human motion files or folders (.bvh, .npz, .usd*); the last positional is CREATURE_DATA")
    p.add_argument("creature", metavar="CREATURE_DATA", help="creature motion file or folder")
    p.add_argument("--override", metavar="FILE",
                   help="YAML {creature_ee: human_ee} (optionally under 'mapping:') replacing the automatic choice")
    p.add_argument("--set", metavar="C=H", action="append", default=[],
                   help="override one pair on the command line, e.g. --set gripper=lwrist_end (repeatable)")
    p.add_argument("--json", action="store_true", help='print {"mapping": {...}, "kl": {...}} as JSON')
    p.add_argument("--max-frames", type=int, default=300, metavar="N",
                   help="use at most N evenly spaced frames per clip (default 300)")
    p.add_argument("--human-facing", default="auto",
                   help="BVH axis the human skeletons face: +z, -z, +x, -x or auto (default: auto, +z for humans)")
    p.add_argument("--creature-facing", default="auto",
                   help="BVH axis the creature skeletons face (default: auto, detected from the motion)")
    p.add_argument("--human-length", type=float, metavar="M",
                   help="body length [m] to normalise human positions by (default: the skeleton's rest height)")
    p.add_argument("--creature-length", type=float, metavar="M",
                   help="body length [m] for the creature (default: its rest height; set it for BVH rigs whose "
                   "rest pose is not upright)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write the motion cache")
    p.set_defaults(run=run)


def _bvh_options(paths: list[str], facing: str) -> dict[str, str]:
    from morphkit.motion.datasets import expand_motion_paths

    files = expand_motion_paths(paths)
    return {"facing": facing} if all(f.suffix.lower() == ".bvh" for f in files) else {}


def run(args: argparse.Namespace) -> int:
    from morphkit.errors import ConfigError, SourceLocation
    from morphkit.motion import ee_distributions, map_end_effectors, read_override
    from morphkit.motion.datasets import load_motions

    if args.max_frames < 1:
        raise ConfigError(f"--max-frames must be >= 1, got {args.max_frames}")
    for flag, value in (("--human-length", args.human_length), ("--creature-length", args.creature_length)):
        if value is not None and not value > 0:
            raise ConfigError(f"{flag} must be a positive length in metres, got {value}")
    override: dict[str, str] = read_override(args.override) if args.override else {}
    for pair in args.set:
        c, sep, h = pair.partition("=")
        if not sep or not c or not h:
            raise ConfigError(f"--set expects CREATURE_EE=HUMAN_EE, got {pair!r}")
        override[c.strip()] = h.strip()
    cache = None if args.no_cache else True
    # Warp reports kernel loading on stdout: keep stdout for the result (--json must parse).
    with contextlib.redirect_stdout(sys.stderr):
        humans = load_motions(args.human, cache_dir=cache, **_bvh_options(args.human, args.human_facing))
        creatures = load_motions(args.creature, cache_dir=cache, **_bvh_options([args.creature], args.creature_facing))
        human = ee_distributions(humans, max_frames_per_clip=args.max_frames, length=args.human_length)
        creature = ee_distributions(creatures, max_frames_per_clip=args.max_frames, length=args.creature_length)
    try:
        result = map_end_effectors(creature, human, override=override)
    except ConfigError as exc:
        where = SourceLocation(args.override) if args.override and exc.location is None else exc.location
        raise ConfigError(exc.message, location=where) from None
    if args.json:
        json.dump(result.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    c_name, h_name = creatures[0].morphology.name, humans[0].morphology.name
    print(f"{c_name} ({len(creatures)} clips) -> {h_name} ({len(humans)} clips); KL(p_creature || p_human)")
    print(result.format_table())
    return 0
