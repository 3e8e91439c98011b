"""``morphkit map HUMAN_DATA CREATURE_DATA``: pair a creature's end-effectors with a human's (ACE Eq. 11)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys

from morphkit.commands import _args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "map",
        help="map a creature's end-effectors to a human's by KL divergence of their position distributions",
        description=(
            "Fit a Gaussian to every end-effector's positions (root heading frame, divided by body length) "
            "over each dataset and map each creature end-effector to the human end-effector with the smallest "
            "KL(p_creature || p_human) (ACE, Li et al. 2023, Eq. 11) among those of a compatible role (foot to "
            "foot, head to head, hand or tool to hand; all of them where the human has none of that role), never "
            "two of one role on one human end-effector while another is free. --kl-only keeps the paper's rule "
            "(KL alone); the report shows both."
        ),
    )
    p.add_argument("human", metavar="HUMAN_DATA", nargs="+",
                   help="human motion files or folders (.bvh, .npz, .usd*); the last positional is CREATURE_DATA")
    p.add_argument("creature", metavar="CREATURE_DATA", help="creature motion file or folder")
    p.add_argument("--override", metavar="FILE",
                   help="YAML {creature_ee: human_ee} (optionally under 'mapping:') replacing the automatic choice")
    p.add_argument("--set", metavar="C=H", action="append", default=[],
                   help="override one pair on the command line, e.g. --set gripper=lwrist_end (repeatable)")
    p.add_argument("--kl-only", action="store_true",
                   help="the paper's rule: KL alone, ignoring roles (the role-aware mapping is still reported)")
    p.add_argument("--one-hand", action="store_true",
                   help="map a lone hand or tool to the one human hand KL prefers (default: whichever hand moves, "
                        "as ACE trains)")
    p.add_argument("--json", action="store_true",
                   help='print {"mapping", "rule", "kl_only", "by_role", "roles", "kl", "data", "body_length"} as JSON')
    p.add_argument("--max-frames", type=_args.int_in(1, 1_000_000), default=300, metavar="N",
                   help="use at most N evenly spaced frames per clip (default 300)")
    p.add_argument("--human-facing", default="auto",
                   help="BVH axis the human skeletons face: +z, -z, +x, -x or auto (default: auto, +z for humans)")
    p.add_argument("--creature-facing", default="auto",
                   help="BVH axis the creature skeletons face (default: auto, detected from the motion)")
    p.add_argument("--body-length", "--creature-length", dest="creature_length", type=_args.body_length, metavar="M",
                   help="the creature's body length [m], which positions are divided by (default: its description's "
                   "body_length, else its standing root height measured on CREATURE_DATA; footless creatures: "
                   "their hand reach; see docs/concepts/body-length.md)")
    p.add_argument("--human-body-length", "--human-length", dest="human_length", type=_args.body_length, metavar="M",
                   help="the human's body length [m] (default: its standing root height measured on HUMAN_DATA)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write the motion cache")
    p.set_defaults(run=run)


def _bvh_options(paths: list[str], facing: str) -> dict[str, str]:
    from morphkit.motion.datasets import expand_motion_paths

    files = expand_motion_paths(paths)
    return {"facing": facing} if all(f.suffix.lower() == ".bvh" for f in files) else {}


def _label(paths: list[str], clips: list) -> str:
    """What to call a data set: its morphology's name, unless it is read from BVH files, whose skeletons
    have no name of their own (the first file's stem, or a shared skeleton's), then the folders or files
    given (``cmu``, not ``01_01``)."""
    from pathlib import Path

    from morphkit.motion.datasets import expand_motion_paths

    files = [p for p in paths if Path(p).exists()]
    if not files or not all(f.suffix.lower() == ".bvh" for f in expand_motion_paths(files)):
        return clips[0].morphology.name
    return " + ".join(Path(p).name if Path(p).is_dir() else Path(p).stem for p in paths)


def _clips(clips: list) -> str:
    return f"{len(clips)} clip{'s' * (len(clips) != 1)}"


def run(args: argparse.Namespace) -> int:
    from morphkit.errors import ConfigError, SourceLocation
    from morphkit.motion import ee_distributions, map_end_effectors, measured_body_length, read_override
    from morphkit.motion.datasets import load_motions

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
        # One length per data set, measured on all its clips unless given.
        lengths = {
            "creature": args.creature_length or measured_body_length(creatures[0].morphology, creatures),
            "human": args.human_length or measured_body_length(humans[0].morphology, humans),
        }
        human = ee_distributions(humans, max_frames_per_clip=args.max_frames, length=lengths["human"])
        creature = ee_distributions(creatures, max_frames_per_clip=args.max_frames, length=lengths["creature"])
    roles = tuple({e.name: e.role for e in clips[0].morphology.end_effectors} for clips in (creatures, humans))
    try:
        result = map_end_effectors(creature, human, override=override, roles=roles, kl_only=args.kl_only,
                                   active_hand=not args.one_hand)
    except ConfigError as exc:
        where = SourceLocation(args.override) if args.override and exc.location is None else exc.location
        raise ConfigError(exc.message, location=where) from None
    c_name, h_name = _label([args.creature], creatures), _label(args.human, humans)
    if args.json:
        doc = result.to_json()
        doc["data"] = {"creature": {"label": c_name, "clips": len(creatures)},
                       "human": {"label": h_name, "clips": len(humans)}}
        doc["body_length"] = {k: round(v, 6) for k, v in lengths.items()}
        json.dump(doc, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    print(f"{c_name} ({_clips(creatures)}) -> {h_name} ({_clips(humans)}); KL(p_creature || p_human)")
    print(f"body lengths: {c_name} {lengths['creature']:.3f} m, {h_name} {lengths['human']:.3f} m")
    print(result.format_table())
    return 0
