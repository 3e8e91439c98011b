"""Issue 66: stances their makers would recognise, and bases and hands found by body.

Truths: the closed-form geometry of a two-link leg (the knee angle that puts a sole a given height under its hip),
the mirror's algebra (a hip's roll flips sign across the sagittal plane, a pitch does not), and the parts a
generated body is built with (two arms on a pedestal, a gripper with a jaw, a head on a neck).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from morphkit.body import ANATOMY
from morphkit.graph import BaseType, EndEffectorRole
from morphkit.io.yaml_format import parse_yaml

FOOT, HAND, TOOL, HEAD = EndEffectorRole.FOOT, EndEffectorRole.HAND, EndEffectorRole.TOOL, EndEffectorRole.HEAD
THIGH, SHANK, TOE = 0.2, 0.2, 0.02  # [m] a leg's two links and its foot sphere's radius
TURNS = 3 * math.pi  # limits as ANYmal's: three turns either way


def _quadruped(limit: float = TURNS) -> str:
    """A level box on four legs of three hinges (roll, pitch, pitch) hanging straight down at q = 0, left and right
    mirror images: no end-effectors, so the reader finds feet and searches a stance."""
    lines = ["name: quad", "base: floating", "root: body", "links:",
             "  body: {shapes: [{type: box, size: [0.5, 0.2, 0.06]}]}"]
    joints = ["joints:"]
    for leg, (x, y) in {"fl": (0.2, 0.1), "fr": (0.2, -0.1), "hl": (-0.2, 0.1), "hr": (-0.2, -0.1)}.items():
        lines += [f"  {leg}_hip: {{}}",
                  f"  {leg}_thigh: {{shapes: [{{type: capsule, radius: 0.015, length: {THIGH}, "
                  f"origin: {{xyz: [0, 0, {-THIGH / 2}]}}}}]}}",
                  f"  {leg}_shank: {{shapes: [{{type: capsule, radius: 0.01, length: {SHANK}, "
                  f"origin: {{xyz: [0, 0, {-SHANK / 2}]}}}}, {{type: sphere, radius: {TOE}, "
                  f"origin: {{xyz: [0, 0, {-SHANK}]}}}}]}}"]
        lim = f"limit: {{lower: {-limit!r}, upper: {limit!r}}}"
        joints += [f"  {leg}_roll: {{type: revolute, parent: body, child: {leg}_hip, origin: {{xyz: [{x}, {y}, 0]}}, "
                   f"axis: [1, 0, 0], {lim}}}",
                   f"  {leg}_pitch: {{type: revolute, parent: {leg}_hip, child: {leg}_thigh, axis: [0, 1, 0], {lim}}}",
                   f"  {leg}_knee: {{type: revolute, parent: {leg}_thigh, child: {leg}_shank, "
                   f"origin: {{xyz: [0, 0, {-THIGH}]}}, axis: [0, 1, 0], {lim}}}"]
    return "\n".join(lines + joints) + "\n"


def _feet(m, q: np.ndarray) -> np.ndarray:
    from morphkit.motion import Motion

    feet = [i for i, e in enumerate(m.end_effectors) if e.role == FOOT]
    return Motion(m, 30.0, q[None]).end_effector_positions()[0, feet]


def test_a_quadruped_allowed_three_turns_stands_within_one_mirrored_as_the_two_link_geometry_says():
    m = parse_yaml(_quadruped())
    assert [e.role for e in m.end_effectors].count(FOOT) == 4
    rest = dict(m.rest_pose)
    assert rest and all(abs(v) <= math.pi for v in rest.values()), rest  # no multi-turn solution
    for front_back in "fh":  # left and right mirror images: roll opposite, pitches equal (to rounding)
        left, right = (lambda name, s=f"{front_back}{side}": rest.get(f"{s}_{name}", 0.0) for side in "lr")
        assert left("roll") == pytest.approx(-right("roll"), abs=1e-9)
        assert left("pitch") == pytest.approx(right("pitch"), abs=1e-9)
        assert left("knee") == pytest.approx(right("knee"), abs=1e-9)
    # The soles level, each under its hip, as high under the body as the rule says (of the sampled reach, which is
    # at most the straight leg's THIGH + SHANK + TOE and near it)
    feet = _feet(m, m.rest_q())
    height = -float(feet[:, 2].min())
    assert np.ptp(feet[:, 2]) < 1e-3
    np.testing.assert_allclose(np.abs(feet[:, :2]), [[0.2, 0.1]] * 4, atol=2e-3)
    assert 0.97 * ANATOMY.stance_extension <= height / (THIGH + SHANK + TOE) <= ANATOMY.stance_extension + 1e-3
    # Closed form: the foot sphere's centre sits height - TOE straight under the hip; the knee then bends by the
    # angle the law of cosines gives, the thigh by half of it the other way (equal links), knees backward.
    c = height - TOE
    knee = math.pi - math.acos((THIGH**2 + SHANK**2 - c**2) / (2 * THIGH * SHANK))
    for leg in ("fl", "fr", "hl", "hr"):
        assert abs(rest[f"{leg}_knee"]) == pytest.approx(knee, abs=2e-3)
        assert rest[f"{leg}_pitch"] == pytest.approx(-rest[f"{leg}_knee"] / 2, abs=2e-3)
        # a positive pitch about +y swings the knee backward (-x): every knee behind its hip
        assert rest[f"{leg}_pitch"] > 0


def test_the_height_rule_follows_the_joints_per_leg():
    """Point feet (three joints) stand knees well bent; two legs with ankles near straight; more legs with ankles
    between."""
    assert ANATOMY.extension([3, 3, 3, 3]) == ANATOMY.extension([3, 3]) == ANATOMY.stance_extension
    assert ANATOMY.extension([6, 6]) == ANATOMY.biped_stance_extension
    assert ANATOMY.extension([6, 6, 8, 8]) == ANATOMY.ankle_stance_extension
    assert ANATOMY.stance_extension < ANATOMY.ankle_stance_extension < ANATOMY.biped_stance_extension


def _torso(*, pedestal: bool, arm: str, tip: str = "hand") -> str:
    """A torso without a declared base, two arms of three hinges hanging 0.8 m from shoulders 0.3 m above the root,
    a head on a two-hinge neck, and maybe a pedestal reaching 1 m under the root."""
    body = "[{type: box, size: [0.3, 0.4, 0.6], origin: {xyz: [0, 0, 0.3]}}"
    body += ", {type: box, size: [0.3, 0.3, 1.0], origin: {xyz: [0, 0, -0.5]}}]" if pedestal else "]"
    lines = ["name: torso", "root: base", "links:", f"  base: {{shapes: {body}}}",
             "  neck: {}", "  head: {shapes: [{type: sphere, radius: 0.1, origin: {xyz: [0, 0, 0.1]}}]}"]
    joints = ["joints:",
              "  neck_yaw: {type: revolute, parent: base, child: neck, origin: {xyz: [0, 0, 0.6]}, axis: [0, 0, 1], "
              "limit: {lower: -1, upper: 1}}",
              "  neck_pitch: {type: revolute, parent: neck, child: head, axis: [0, 1, 0], "
              "limit: {lower: -1, upper: 1}}"]
    for side, y in (("left", 0.25), ("right", -0.25)):
        lines += [f"  {side}_shoulder: {{}}",
                  f"  {side}_upper_{arm}: {{shapes: [{{type: capsule, radius: 0.03, length: 0.4, "
                  "origin: {xyz: [0, 0, -0.2]}}]}",
                  f"  {side}_{tip}: {{shapes: [{{type: capsule, radius: 0.03, length: 0.4, "
                  "origin: {xyz: [0, 0, -0.2]}}]}"]
        lim = "limit: {lower: -2, upper: 2}"
        joints += [f"  {side}_sh_pitch: {{type: revolute, parent: base, child: {side}_shoulder, "
                   f"origin: {{xyz: [0, {y}, 0.3]}}, axis: [0, 1, 0], {lim}}}",
                   f"  {side}_sh_roll: {{type: revolute, parent: {side}_shoulder, child: {side}_upper_{arm}, "
                   f"axis: [1, 0, 0], {lim}}}",
                   f"  {side}_elbow: {{type: revolute, parent: {side}_upper_{arm}, child: {side}_{tip}, "
                   f"origin: {{xyz: [0, 0, -0.4]}}, axis: [0, 1, 0], {lim}}}"]
    return "\n".join(lines + joints) + "\n"


@pytest.mark.parametrize(("pedestal", "arm"), [(True, "link"), (False, "arm")])
def test_a_torso_whose_arms_carry_nothing_is_bolted_down_with_two_hands_and_its_head(pedestal, arm):
    """Baxter: the pedestal reaches 1 m under the root, deeper than the 0.8 m arms from 0.3 m above it can (the arms
    unnamed: the body decides). Alex: no pedestal, the arms hang lowest, but every end reaching down is named like
    an arm: no leg is beside them."""
    m = parse_yaml(_torso(pedestal=pedestal, arm=arm))
    roles = sorted(e.role.name for e in m.end_effectors)
    assert m.base == BaseType.FIXED, m.notes
    assert roles == ["HAND", "HAND", "HEAD"], [(e.name, e.role.name, e.reason) for e in m.end_effectors]
    assert {e.link for e in m.end_effectors if e.role == HAND} == {"left_hand", "right_hand"}


def test_without_the_pedestal_and_the_names_the_arms_are_legs():
    """The counter-case of both rules: the same torso with unnamed limbs and no pedestal hangs on its two chains, so
    they are its legs (what the rules above change is the pedestal and the names, nothing else)."""
    m = parse_yaml(_torso(pedestal=False, arm="link", tip="link"))
    assert m.base == BaseType.FLOATING
    assert [e.role for e in m.end_effectors].count(FOOT) == 2


def test_a_jaw_at_the_end_of_an_arm_is_its_gripper_and_not_a_head():
    """SO-100: five hinges to a ``gripper`` link whose ``jaw`` turns on a sixth; no world link, so the base is
    decided (fixed: nothing carries it) and the jaw's end is a tool, not a head."""
    links = ["base", "shoulder", "upper_arm", "lower_arm", "wrist", "gripper", "jaw"]
    lines = ["name: so", "root: base", "links:"]
    lines += [f"  {n}: {{shapes: [{{type: capsule, radius: 0.02, length: 0.1, origin: {{xyz: [0, 0, 0.05]}}}}]}}"
              for n in links]
    lines.append("joints:")
    for k, (a, b) in enumerate(itertools.pairwise(links)):
        axis = [0, 0, 1] if k % 2 == 0 else [0, 1, 0]
        lines.append(f"  j{k}: {{type: revolute, parent: {a}, child: {b}, origin: {{xyz: [0, 0, 0.1]}}, "
                     f"axis: {axis}, limit: {{lower: -2, upper: 2}}}}")
    m = parse_yaml("\n".join(lines) + "\n")
    assert m.base == BaseType.FIXED
    assert [(e.link, e.role) for e in m.end_effectors] == [("jaw", TOOL)], [e.reason for e in m.end_effectors]
