"""Creatures written in YAML only for the synth tests: a three-legged one with one telescoping arm and an
eight-legged one, plus readers for them and the shipped creatures."""

from __future__ import annotations

import math
from pathlib import Path

from morphkit.graph import Morphology

SYNTH_FRAMES = 1200
"""Frames per creature in the shared datasets (four 10-second rollouts at 30 fps)."""


def _sprawled_leg(n: str, x: float, y: float, yaw: float, femur: float, tibia: float, swing: float) -> tuple:
    links = [
        f"  {n}_coxa: {{shapes: [{{type: capsule, radius: 0.02, length: 0.04, "
        f"origin: {{xyz: [0.02, 0, 0], rpy: [0, 1.5708, 0]}}}}]}}",
        f"  {n}_femur: {{shapes: [{{type: capsule, radius: 0.018, length: {femur}, "
        f"origin: {{xyz: [{femur / 2}, 0, 0], rpy: [0, 1.5708, 0]}}}}]}}",
        f"  {n}_tibia: {{shapes: [{{type: capsule, radius: 0.015, length: {tibia}, "
        f"origin: {{xyz: [{tibia / 2}, 0, 0], rpy: [0, 1.5708, 0]}}}}]}}",
    ]
    joints = [
        f"  {n}_swing: {{type: revolute, parent: body, child: {n}_coxa, axis: [0, 0, 1], "
        f"origin: {{xyz: [{x}, {y}, 0], rpy: [0, 0, {yaw:.5f}]}}, limit: {{lower: {-swing}, upper: {swing}}}}}",
        f"  {n}_lift: {{type: revolute, parent: {n}_coxa, child: {n}_femur, axis: [0, -1, 0], "
        f"origin: {{xyz: [0.04, 0, 0], rpy: [0, -0.5, 0]}}, limit: {{lower: -0.8, upper: 1.0}}}}",
        f"  {n}_knee: {{type: revolute, parent: {n}_femur, child: {n}_tibia, axis: [0, -1, 0], "
        f"origin: {{xyz: [{femur}, 0, 0], rpy: [0, 1.72, 0]}}, limit: {{lower: -0.9, upper: 0.9}}}}",
    ]
    ee = [f"  {n}_foot: {{link: {n}_tibia, offset: [{tibia}, 0, 0], role: foot}}"]
    return links, joints, ee


def tripod_yaml() -> str:
    """Three legs (front left, front right, back) and one arm with a telescoping (prismatic) forearm."""
    links = ["  body: {shapes: [{type: sphere, radius: 0.14}]}"]
    joints: list[str] = []
    ees: list[str] = []
    for n, x, y, yaw in (("a", 0.12, 0.1, math.pi / 3), ("b", 0.12, -0.1, -math.pi / 3), ("c", -0.16, 0.0, math.pi)):
        lk, jt, ee = _sprawled_leg(n, x, y, yaw, 0.2, 0.3, 0.7)
        links += lk
        joints += jt
        ees += ee
    links += [
        "  arm_base: {shapes: [{type: cylinder, radius: 0.03, length: 0.06, origin: {xyz: [0, 0, 0.03]}}]}",
        "  arm_upper: {shapes: [{type: capsule, radius: 0.02, length: 0.2, "
        "origin: {xyz: [0.1, 0, 0], rpy: [0, 1.5708, 0]}}]}",
        "  arm_slide: {shapes: [{type: capsule, radius: 0.015, length: 0.15, "
        "origin: {xyz: [0.075, 0, 0], rpy: [0, 1.5708, 0]}}]}",
    ]
    joints += [
        "  arm_yaw: {type: revolute, parent: body, child: arm_base, origin: {xyz: [0, 0, 0.14]}, axis: [0, 0, 1], "
        "limit: {lower: -2.5, upper: 2.5}}",
        "  arm_pitch: {type: revolute, parent: arm_base, child: arm_upper, origin: {xyz: [0, 0, 0.06]}, "
        "axis: [0, -1, 0], limit: {lower: -0.3, upper: 1.3}}",
        "  arm_extend: {type: prismatic, parent: arm_upper, child: arm_slide, origin: {xyz: [0.2, 0, 0]}, "
        "axis: [1, 0, 0], limit: {lower: 0.0, upper: 0.12}}",
    ]
    ees.append("  claw: {link: arm_slide, offset: [0.15, 0, 0], role: hand}")
    return _yaml("tripod", links, joints, ees)


def spider_yaml() -> str:
    """Eight sprawled legs, four a side, and a head point on the body."""
    links = ["  body: {shapes: [{type: box, size: [0.5, 0.26, 0.1]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    for side, sgn in (("l", 1.0), ("r", -1.0)):
        for i, (x, spread) in enumerate(zip((0.18, 0.06, -0.06, -0.18), (0.7, 0.25, -0.25, -0.7), strict=True), 1):
            lk, jt, ee = _sprawled_leg(f"{side}{i}", x, sgn * 0.13, sgn * (math.pi / 2 - spread), 0.16, 0.2, 0.4)
            links += lk
            joints += jt
            ees += ee
    ees.append("  head: {link: body, offset: [0.25, 0, 0.03], role: head}")
    return _yaml("spider", links, joints, ees)


def _yaml(name: str, links: list[str], joints: list[str], ees: list[str]) -> str:
    return (f"name: {name}\nbase: floating\nroot: body\nlinks:\n" + "\n".join(links) + "\njoints:\n"
            + "\n".join(joints) + "\nend_effectors:\n" + "\n".join(ees) + "\n")


def _upright_leg(side: str, thigh: float) -> tuple[list[str], str]:
    """Thigh and shin links hanging straight down, and the pitch knee between them (0.4 m below the hip)."""
    down = "origin: {xyz: [0, 0, -0.2]}"
    links = [f"  {side}_thigh: {{shapes: [{{type: capsule, radius: 0.04, length: {thigh}, {down}}}]}}",
             f"  {side}_shin: {{shapes: [{{type: capsule, radius: 0.035, length: 0.32, {down}}}]}}"]
    knee = (f"  {side}_knee: {{type: revolute, parent: {side}_thigh, child: {side}_shin, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, 0, -0.4]}}, limit: {{lower: 0.0, upper: 2.3}}}}")
    return links, knee


def strider_yaml() -> str:
    """A biped whose legs only pitch: hip, knee and ankle all turn about y, no joint turns a foot sideways."""
    links = ["  body: {shapes: [{type: box, size: [0.24, 0.3, 0.3]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    for side, y in (("l", 0.1), ("r", -0.1)):
        leg, knee = _upright_leg(side, 0.32)
        links += [*leg, f"  {side}_foot: {{shapes: [{{type: box, size: [0.18, 0.08, 0.04], "
                        f"origin: {{xyz: [0.03, 0, -0.03]}}}}]}}"]
        joints += [
            f"  {side}_hip: {{type: revolute, parent: body, child: {side}_thigh, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, {y}, -0.15]}}, limit: {{lower: -1.3, upper: 1.3}}}}",
            knee,
            f"  {side}_ankle: {{type: revolute, parent: {side}_shin, child: {side}_foot, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, 0, -0.4]}}, limit: {{lower: -0.9, upper: 0.9}}}}",
        ]
        ees.append(f"  {side}_sole: {{link: {side}_foot, offset: [0, 0, -0.05], role: foot}}")
    ees.append("  head: {link: body, offset: [0.12, 0, 0.1], role: head}")
    return _yaml("strider", links, joints, ees)


def walker_yaml() -> str:
    """A humanoid's legs as robots build them: six hinges each (hip yaw, roll, pitch; knee; ankle pitch, roll),
    flat box feet, an ankle pitch of -0.8..0.6 rad, knees bent in the rest pose."""
    links = ["  body: {shapes: [{type: box, size: [0.2, 0.3, 0.3], origin: {xyz: [0, 0, 0.1]}}]}"]
    joints: list[str] = []
    ees: list[str] = []
    rest: list[str] = []
    for side, y in (("l", 0.1), ("r", -0.1)):
        leg, knee = _upright_leg(side, 0.32)
        foot = "{type: box, size: [0.2, 0.09, 0.03], origin: {xyz: [0.03, 0, -0.05]}}"
        links += [f"  {side}_hip_a: {{}}", f"  {side}_hip_b: {{}}", *leg, f"  {side}_ankle_a: {{}}",
                  f"  {side}_foot: {{shapes: [{foot}]}}"]
        joints += [
            f"  {side}_hip_yaw: {{type: revolute, parent: body, child: {side}_hip_a, axis: [0, 0, 1], "
            f"origin: {{xyz: [0, {y}, -0.1]}}, limit: {{lower: -0.6, upper: 0.6}}}}",
            f"  {side}_hip_roll: {{type: revolute, parent: {side}_hip_a, child: {side}_hip_b, axis: [1, 0, 0], "
            "limit: {lower: -0.5, upper: 0.5}}",
            f"  {side}_hip_pitch: {{type: revolute, parent: {side}_hip_b, child: {side}_thigh, axis: [0, 1, 0], "
            "limit: {lower: -1.6, upper: 0.6}}",
            knee,
            f"  {side}_ankle_pitch: {{type: revolute, parent: {side}_shin, child: {side}_ankle_a, axis: [0, 1, 0], "
            "origin: {xyz: [0, 0, -0.4]}, limit: {lower: -0.8, upper: 0.6}}",
            f"  {side}_ankle_roll: {{type: revolute, parent: {side}_ankle_a, child: {side}_foot, axis: [1, 0, 0], "
            "limit: {lower: -0.4, upper: 0.4}}",
        ]
        ees.append(f"  {side}_sole: {{link: {side}_foot, offset: [0.03, 0, -0.065], role: foot}}")
        rest += [f"  {side}_hip_pitch: -0.35", f"  {side}_knee: 0.7", f"  {side}_ankle_pitch: -0.35"]
    ees.append("  head: {link: body, offset: [0.1, 0, 0.3], role: head}")
    return _yaml("walker", links, joints, ees) + "rest_pose:\n" + "\n".join(rest) + "\n"


def swivel_yaml() -> str:
    """A quadruped whose hips turn three ways (yaw, roll, pitch; then a knee): one hinge more than its round feet
    need. Its yaws rest at 0.1 rad, its legs bent with the feet under the hips."""
    links = ["  body: {shapes: [{type: box, size: [0.6, 0.3, 0.12]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    rest: list[str] = []
    down = "origin: {xyz: [0, 0, -0.125]}"
    for n, x, y in (("fl", 0.25, 0.12), ("fr", 0.25, -0.12), ("hl", -0.25, 0.12), ("hr", -0.25, -0.12)):
        links += [f"  {n}_hip_a: {{}}", f"  {n}_hip_b: {{}}",
                  f"  {n}_thigh: {{shapes: [{{type: capsule, radius: 0.03, length: 0.19, {down}}}]}}",
                  f"  {n}_shin: {{shapes: [{{type: capsule, radius: 0.025, length: 0.2, {down}}}, "
                  "{type: sphere, radius: 0.03, origin: {xyz: [0, 0, -0.25]}}]}"]
        joints += [
            f"  {n}_yaw: {{type: revolute, parent: body, child: {n}_hip_a, axis: [0, 0, 1], "
            f"origin: {{xyz: [{x}, {y}, -0.06]}}, limit: {{lower: -0.5, upper: 0.5}}}}",
            f"  {n}_roll: {{type: revolute, parent: {n}_hip_a, child: {n}_hip_b, axis: [1, 0, 0], "
            "limit: {lower: -0.5, upper: 0.5}}",
            f"  {n}_pitch: {{type: revolute, parent: {n}_hip_b, child: {n}_thigh, axis: [0, 1, 0], "
            "limit: {lower: -1.5, upper: 1.5}}",
            f"  {n}_knee: {{type: revolute, parent: {n}_thigh, child: {n}_shin, axis: [0, 1, 0], "
            "origin: {xyz: [0, 0, -0.25]}, limit: {lower: 0.0, upper: 2.3}}",
        ]
        ees.append(f"  {n}_foot: {{link: {n}_shin, offset: [0, 0, -0.28], role: foot}}")
        rest += [f"  {n}_yaw: 0.1", f"  {n}_pitch: -0.5", f"  {n}_knee: 1.0"]
    return _yaml("swivel", links, joints, ees) + "rest_pose:\n" + "\n".join(rest) + "\n"


def tailed_yaml() -> str:
    """A kangaroo-like biped (hip roll, hip and knee pitch) with a three-segment tail hanging to 3 cm above the
    ground at rest, ending in an end-effector without a role (so a ``tool``, moved like an arm)."""
    links = [
        "  body: {shapes: [{type: capsule, radius: 0.12, length: 0.3, origin: {rpy: [0, 1.5708, 0]}}]}",
        *(f"  tail{i}: {{shapes: [{{type: capsule, radius: {r}, length: 0.25, "
          f"origin: {{xyz: [-0.15, 0, 0], rpy: [0, 1.5708, 0]}}}}]}}" for i, r in ((1, 0.05), (2, 0.04), (3, 0.03))),
    ]
    joints: list[str] = []
    ees: list[str] = []
    for side, y in (("l", 0.1), ("r", -0.1)):
        leg, knee = _upright_leg(side, 0.3)
        links += [f"  {side}_hip: {{}}", *leg]
        joints += [
            f"  {side}_hip_roll: {{type: revolute, parent: body, child: {side}_hip, axis: [1, 0, 0], "
            f"origin: {{xyz: [0.05, {y}, -0.12]}}, limit: {{lower: -0.5, upper: 0.5}}}}",
            f"  {side}_hip_pitch: {{type: revolute, parent: {side}_hip, child: {side}_thigh, axis: [0, 1, 0], "
            f"limit: {{lower: -1.3, upper: 1.3}}}}",
            knee,
        ]
        ees.append(f"  {side}_foot: {{link: {side}_shin, offset: [0, 0, -0.4], role: foot}}")
    joints += [
        "  tail1: {type: revolute, parent: body, child: tail1, axis: [0, 1, 0], "
        "origin: {xyz: [-0.25, 0, -0.05], rpy: [0, -1.2, 0]}, limit: {lower: -1.6, upper: 0.6}}",
        "  tail2: {type: revolute, parent: tail1, child: tail2, axis: [0, 1, 0], origin: {xyz: [-0.3, 0, 0]}, "
        "limit: {lower: -0.6, upper: 1.2}}",
        "  tail3: {type: revolute, parent: tail2, child: tail3, axis: [0, 0, 1], origin: {xyz: [-0.3, 0, 0]}, "
        "limit: {lower: -0.8, upper: 0.8}}",
    ]
    ees += ["  tail_tip: {link: tail3, offset: [-0.3, 0, 0]}",
            "  head: {link: body, offset: [0.3, 0, 0.1], role: head}"]
    return _yaml("roo", links, joints, ees)


def grazer_yaml(*, low_tail: bool = False, bent_legs: bool = False, stuck_tail: bool = False) -> str:
    """A long-necked grazer, written as a new user would: four legs (hip roll, hip and knee pitch; straight at
    rest unless ``bent_legs``: thigh 0.5 rad forward, shin 0.5 rad back), a three-joint neck and a nodding head
    (the muzzle can reach the ground), a two-segment tail. ``low_tail``: instead a three-segment tail whose tip
    hangs about 6 cm above the ground at the stance, whose joints lift it 0.03 rad at most; ``stuck_tail``:
    that tail 1.2 m long, below the ground whatever its joints do."""
    lines = ["  body: {shapes: [{type: box, size: [1.2, 0.4, 0.35]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    lean = 0.5 if bent_legs else 0.0
    for n, x, y in (("fl", 0.5, 0.15), ("fr", 0.5, -0.15), ("hl", -0.4, 0.15), ("hr", -0.4, -0.15)):
        lines += [f"  {n}_hip: {{}}",
                  f"  {n}_thigh: {{shapes: [{{type: capsule, radius: 0.05, length: 0.45, "
                  "origin: {xyz: [0, 0, -0.25]}}]}",
                  f"  {n}_shin: {{shapes: [{{type: capsule, radius: 0.035, length: 0.4, "
                  "origin: {xyz: [0, 0, -0.22]}}]}"]
        if bent_legs:
            knee = "{lower: -1.2, upper: 1.0}"
        else:
            knee = "{lower: -2.2, upper: 0.0}" if n[0] == "f" else "{lower: 0.0, upper: 2.2}"
        joints += [
            f"  {n}_abd: {{type: revolute, parent: body, child: {n}_hip, axis: [1, 0, 0], origin: {{xyz: [{x}, {y}, "
            "-0.1]}, limit: {lower: -0.4, upper: 0.4}}",
            f"  {n}_pitch: {{type: revolute, parent: {n}_hip, child: {n}_thigh, axis: [0, 1, 0], origin: {{rpy: [0, "
            f"{-lean}, 0]}}, limit: {{lower: -1.2, upper: 1.2}}}}",
            f"  {n}_knee: {{type: revolute, parent: {n}_thigh, child: {n}_shin, axis: [0, 1, 0], origin: {{xyz: [0, 0, "
            f"-0.5], rpy: [0, {2 * lean}, 0]}}, limit: {knee}}}",
        ]
        ees.append(f"  {n}_hoof: {{link: {n}_shin, offset: [0, 0, -0.5], role: foot}}")
    for i in (1, 2, 3):
        lines.append(f"  neck{i}: {{shapes: [{{type: capsule, radius: 0.06, length: 0.3, "
                     "origin: {xyz: [0.17, 0, 0], rpy: [0, 1.5708, 0]}}]}")
    lines.append("  head: {shapes: [{type: box, size: [0.35, 0.15, 0.15], origin: {xyz: [0.17, 0, 0]}}]}")
    joints += [
        "  neck1: {type: revolute, parent: body, child: neck1, axis: [0, 1, 0], origin: {xyz: [0.6, 0, 0.1], "
        "rpy: [0, -0.7, 0]}, limit: {lower: -0.6, upper: 1.4}}",
        "  neck2: {type: revolute, parent: neck1, child: neck2, axis: [0, 1, 0], origin: {xyz: [0.34, 0, 0]}, "
        "limit: {lower: -0.5, upper: 0.9}}",
        "  neck3: {type: revolute, parent: neck2, child: neck3, axis: [0, 1, 0], origin: {xyz: [0.34, 0, 0]}, "
        "limit: {lower: -0.5, upper: 0.9}}",
        "  nod: {type: revolute, parent: neck3, child: head, axis: [0, 1, 0], origin: {xyz: [0.34, 0, 0], "
        "rpy: [0, 0.7, 0]}, limit: {lower: -0.8, upper: 1.2}}",
    ]
    ees.append("  muzzle: {link: head, offset: [0.35, 0, 0], role: head}")
    if low_tail or stuck_tail:
        seg = 0.56 if stuck_tail else 0.36
        for i in (1, 2, 3):
            lines.append(f"  tail{i}: {{shapes: [{{type: capsule, radius: 0.03, length: {seg - 0.04}, "
                         f"origin: {{xyz: [{-seg / 2}, 0, 0], rpy: [0, 1.5708, 0]}}}}]}}")
        joints.append("  tail1: {type: revolute, parent: body, child: tail1, axis: [0, 1, 0], origin: {xyz: [-0.6, 0, "
                      "0.1], rpy: [0, -1.1, 0]}, limit: {lower: -0.5, upper: 0.03}}")
        joints += [f"  tail{i}: {{type: revolute, parent: tail{i - 1}, child: tail{i}, axis: [0, 1, 0], "
                   f"origin: {{xyz: [{-seg}, 0, 0]}}, limit: {{lower: -0.5, upper: 0.03}}}}" for i in (2, 3)]
        ees.append(f"  tail_tip: {{link: tail3, offset: [{-seg}, 0, 0], role: tool}}")
    else:
        for i in (1, 2):
            lines.append(f"  tail{i}: {{shapes: [{{type: capsule, radius: 0.03, length: 0.25, "
                         "origin: {xyz: [-0.14, 0, 0], rpy: [0, 1.5708, 0]}}]}")
        joints += ["  tail1: {type: revolute, parent: body, child: tail1, axis: [0, 1, 0], origin: {xyz: [-0.6, 0, "
                   "0.1], rpy: [0, -0.6, 0]}, limit: {lower: -0.7, upper: 0.7}}",
                   "  tail2: {type: revolute, parent: tail1, child: tail2, axis: [0, 1, 0], origin: {xyz: [-0.28, 0, "
                   "0]}, limit: {lower: -0.8, upper: 0.8}}"]
        ees.append("  tail_tip: {link: tail2, offset: [-0.28, 0, 0], role: tool}")
    return _yaml("grazer", lines, joints, ees)


def hopper_yaml() -> str:
    """A planar-legged hopper (hip, knee, ankle all pitching) whose three-segment tail hangs to about 5 cm above
    the ground at rest, its joints able to lift it by 0.02-0.03 rad at most (the issue's case)."""
    links = ["  body: {shapes: [{type: box, size: [0.4, 0.3, 0.2]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    for side, y in (("l", 0.12), ("r", -0.12)):
        links += [f"  {side}_thigh: {{shapes: [{{type: capsule, radius: 0.04, length: 0.3, "
                  "origin: {xyz: [0, 0, -0.2]}}]}",
                  f"  {side}_shin: {{shapes: [{{type: capsule, radius: 0.035, length: 0.3, "
                  "origin: {xyz: [0, 0, -0.2]}}]}",
                  f"  {side}_foot: {{shapes: [{{type: box, size: [0.16, 0.07, 0.03], "
                  "origin: {xyz: [0.03, 0, -0.015]}}]}"]
        joints += [
            f"  {side}_hip: {{type: revolute, parent: body, child: {side}_thigh, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, {y}, -0.1]}}, limit: {{lower: -1.2, upper: 1.2}}}}",
            f"  {side}_knee: {{type: revolute, parent: {side}_thigh, child: {side}_shin, axis: [0, 1, 0], "
            "origin: {xyz: [0, 0, -0.4]}, limit: {lower: 0.0, upper: 2.3}}",
            f"  {side}_ankle: {{type: revolute, parent: {side}_shin, child: {side}_foot, axis: [0, 1, 0], "
            "origin: {xyz: [0, 0, -0.4]}, limit: {lower: -0.9, upper: 0.9}}",
        ]
        ees.append(f"  {side}_sole: {{link: {side}_foot, offset: [0, 0, -0.03], role: foot}}")
    for i, r in ((1, 0.04), (2, 0.03), (3, 0.025)):
        links.append(f"  tail{i}: {{shapes: [{{type: capsule, radius: {r}, length: 0.26, "
                     "origin: {xyz: [-0.15, 0, 0], rpy: [0, 1.5708, 0]}}]}")
    joints += [
        "  tail1: {type: revolute, parent: body, child: tail1, axis: [0, 1, 0], origin: {xyz: [-0.2, 0, -0.05], "
        "rpy: [0, -0.95, 0]}, limit: {lower: -0.4, upper: 0.03}}",
        "  tail2: {type: revolute, parent: tail1, child: tail2, axis: [0, 1, 0], origin: {xyz: [-0.3, 0, 0]}, "
        "limit: {lower: -0.4, upper: 0.02}}",
        "  tail3: {type: revolute, parent: tail2, child: tail3, axis: [0, 1, 0], origin: {xyz: [-0.3, 0, 0]}, "
        "limit: {lower: -0.4, upper: 0.02}}",
    ]
    ees += ["  tail_tip: {link: tail3, offset: [-0.3, 0, 0], role: tool}",
            "  head: {link: body, offset: [0.2, 0, 0.1], role: head}"]
    return _yaml("hopper", links, joints, ees)


_YAML = {"tripod": tripod_yaml, "hopper": hopper_yaml, "spider": spider_yaml, "strider": strider_yaml,
         "roo": tailed_yaml, "walker": walker_yaml, "swivel": swivel_yaml,
         "grazer": grazer_yaml, "grazer_bent": lambda: grazer_yaml(bent_legs=True),
         "grazer_low_tail": lambda: grazer_yaml(low_tail=True),
         "grazer_stuck_tail": lambda: grazer_yaml(stuck_tail=True)}


def read_creature(name: str, tmp_dir: Path) -> Morphology:
    """A shipped creature by name, or one of the YAML-only creatures here (``tripod``, ``spider``, ``strider``,
    ``roo``, ``hopper``, ``walker``, ``swivel``, ``grazer`` and its variants) written to ``tmp_dir`` and read back."""
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology

    if name in _YAML:
        p = tmp_dir / f"{name}.yaml"
        p.write_text(_YAML[name]())
        return read_morphology(p)
    return read_morphology(resolve_morphology(name))


CREATURES = ("spot", "crab", "stretch", "human", "tripod", "spider")


