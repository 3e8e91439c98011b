"""``morphkit info PATH...``: summarise creatures (links, joints, DoF, end-effectors, base, size, body length)."""

from __future__ import annotations

import argparse
import json
from collections import Counter
from typing import Any

from morphkit.body.anatomy import anatomy_warnings
from morphkit.graph import HUMAN_HAND_REACH, BodyLengthRule, JointType, Morphology

_RULE_TEXT = {
    BodyLengthRule.DECLARED: "declared by the description",
    BodyLengthRule.STANCE: "root above the lowest foot at rest; measured on motion where one is given",
    BodyLengthRule.STRAIGHT_LEGS: "leg length, the rest pose is not upright; measured on motion where one is given",
    BodyLengthRule.MEASURED: "measured on motion",
    BodyLengthRule.HAND_REACH: f"highest hand reach above the ground / {HUMAN_HAND_REACH:g}",
    BodyLengthRule.REST_EXTENT: "rest-pose height, no feet or hands",
}


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="summarise a creature description (.yaml/.urdf/.usd[a|c]/.bvh or a shipped name)")
    p.add_argument("paths", nargs="+", metavar="PATH", help="description file or shipped creature name")
    p.add_argument("--json", action="store_true", help="print JSON (a list when several paths are given)")
    p.set_defaults(run=run)


def summary(m: Morphology) -> dict[str, Any]:
    """The ``info --json`` record of a morphology."""
    counts = Counter(j.type.name.lower() for j in m.joints)
    return {
        "name": m.name,
        "source": m.source,
        "base": m.base.name.lower(),
        "root": m.root,
        "link_count": m.link_count,
        "joint_count": m.joint_count,
        "joint_counts": {t.name.lower(): counts.get(t.name.lower(), 0) for t in JointType},
        "dof": m.dof,
        "coordinate_count": m.coordinate_count,
        "base_dof": m.base_dof,
        "driven_joints": [j.name for j in m.joints if m.is_driven(j)],
        "end_effectors": [
            {"name": e.name, "link": e.link, "role": e.role.name.lower(), "offset": [round(v, 6) for v in e.offset],
             "guessed": bool(e.reason), "reason": e.reason or "declared by the description"}
            for e in m.end_effectors
        ],
        "rest_pose": {k: round(v, 6) for k, v in m.rest_pose},
        "wheels": _wheels(m),
        "notes": list(m.notes),
        "warnings": anatomy_warnings(m),
        "characteristic_length": round(m.characteristic_length, 6),
        "body_length": round(m.body_length, 6),
        "body_length_rule": m.body_length_rule.name.lower(),
    }


def _wheels(m: Morphology) -> dict[str, Any] | None:
    """The wheels, their drive and what it allows (None: no wheels named or found)."""
    from morphkit.body.wheels import drive_of

    wl, d = m.wheels, drive_of(m)
    if wl is None or d is None:
        return None
    return {"drive": wl.drive, "joints": list(wl.joints), "steering": list(wl.steering), "steered": list(wl.steered),
            "radius": round(wl.radius, 6), "track": round(d.track, 6), "max_steer": wl.max_steer,
            "top_speed": round(d.top_speed, 4), "top_speed_rule": d.rule,
            "min_turn_radius": round(d.min_turn_radius, 4), "sideways": wl.drive == "holonomic",
            "reason": wl.reason or "declared by the description"}


def _text(s: dict[str, Any]) -> str:
    joints = ", ".join(f"{n} {t}" for t, n in s["joint_counts"].items() if n)
    ees = ", ".join(f"{e['name']} ({e['role']}, on {e['link']})" for e in s["end_effectors"]) or "none"
    rule = s["body_length_rule"]
    lines = [
        f"{s['name']}  ({s['source']})" if s["source"] else s["name"],
        f"  base                  {s['base']} ({s['base_dof']} DoF), root link {s['root']}",
        f"  links                 {s['link_count']}",
        f"  joints                {s['joint_count']}: {joints or 'none'}",
        f"  DoF                   {s['dof']} (without base and driven joints)",
        f"  coordinates           {s['coordinate_count']} (base included)",
    ]
    if s["driven_joints"]:
        lines.append(f"  driven joints         {', '.join(s['driven_joints'])}")
    if (w := s["wheels"]) is not None:
        turn = (f"turns no tighter than {w['min_turn_radius']:.3g} m" if w["min_turn_radius"] > 0
                else "turns on the spot")
        lines += [
            f"  drive                 {w['drive']}: {'moves sideways' if w['sideways'] else 'no sideways motion'}, "
            f"{turn}, top speed {w['top_speed']:.3g} m/s ({w['top_speed_rule']})",
            f"  wheels                {', '.join(w['joints'] + w['steered']) or 'none'}; radius {w['radius']:.4g} m, "
            f"track {w['track']:.3g} m" + (f"; steering {', '.join(w['steering'])}" if w["steering"] else ""),
            f"    why: {w['reason']}",
        ]
    lines += [f"  end-effectors         {len(s['end_effectors'])}: {ees}"]
    lines += [f"    {e['name']}: {e['reason']}" for e in s["end_effectors"] if e["guessed"]]
    lines += [f"  {n}" for n in s["notes"]]
    if s["rest_pose"]:
        lines.append("  rest pose             " + ", ".join(f"{k} {v:+.2f}" for k, v in s["rest_pose"].items()))
    lines += [f"  warning: {w}" for w in s["warnings"]]
    lines += [
        f"  characteristic length {s['characteristic_length']:.3f} m (rest-pose height)",
        f"  body length           {s['body_length']:.3f} m ({_RULE_TEXT[BodyLengthRule[rule.upper()]]})",
    ]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from morphkit.io import read_morphology

    records = [summary(read_morphology(p)) for p in args.paths]
    if args.json:
        print(json.dumps(records[0] if len(records) == 1 else records, indent=2))
    else:
        print("\n\n".join(_text(r) for r in records))
    return 0
