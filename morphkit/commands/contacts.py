"""``morphkit contacts IN OUT [--mode replan|lock]``: the contact-aware export applied to any creature motion file."""

from __future__ import annotations

import argparse

from morphkit.commands import _args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "contacts",
        help="plant a legged creature's feet in a motion file: re-step its legs (replan) or lock its stance feet",
        description=(
            "Apply a contact-aware export to a creature motion (.npz or .usd[a|c], which carry their creature; "
            "any retargeter's output or a file you made): replan re-steps the legs with the synthesis' footstep "
            "planner along the motion's root path; lock keeps the motion's own steps and holds each stance foot at its "
            "touchdown point by IK. Both keep the root path, then move the upper body (arms, head, tail) out of the "
            "creature's own shapes and the ground by a short change of its joints, in the frames where it is in "
            "them; nothing else moves."
        ),
    )
    p.add_argument("motion", metavar="IN", help="a creature motion file (.npz, .usda, .usdc, .usd)")
    p.add_argument("out", type=_args.out_path, metavar="OUT",
                   help="output motion file (.npz, .bvh, .usd[a|c]) or robot commands (.csv)")
    p.add_argument("--mode", default="replan", choices=("replan", "lock", "none"), help="the export (default replan)")
    p.set_defaults(run=run)


def _self_collision(motion) -> float:
    """Share of frames with two of the creature's shapes overlapping (the unrealistic-frame metric's check)."""
    from morphkit.metrics import unrealistic_frame_ratio

    return float(unrealistic_frame_ratio(motion).self_collision.mean()) if motion.frame_count else 0.0


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from morphkit.contact_export import apply_contacts
    from morphkit.errors import ConfigError
    from morphkit.metrics import foot_contact_figures
    from morphkit.motion import read_motion, write_motion_files

    if Path(args.out).resolve() == Path(args.motion).resolve():
        raise ConfigError(f"OUT is IN ({args.out}): write the export to another file, the input is kept")
    motion = read_motion(args.motion)
    out = apply_contacts(motion, args.mode)
    target = Path(args.out)
    (written,) = write_motion_files(out, target.with_suffix(""), [target.suffix])
    before, after = foot_contact_figures(motion), foot_contact_figures(out)
    print(f"{written}: {motion.frame_count} frames; foot sliding {100 * before.sliding_rate:.1f} % → "
          f"{100 * after.sliding_rate:.1f} % of foot-frames, penetration {100 * before.penetration_rate:.1f} % → "
          f"{100 * after.penetration_rate:.1f} %, self-collision {100 * _self_collision(motion):.1f} % → "
          f"{100 * _self_collision(out):.1f} % of frames")
    return 0
