"""Morphology.body_length: the rule per kind of creature, the declared override, the shipped creatures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from morphkit_testing import TEST_CREATURES, shipped_morphology

from morphkit.errors import GraphError
from morphkit.graph import HUMAN_HAND_REACH, BodyLengthRule, Limit, MorphologyBuilder, Transform


def _biped(*, hip_pitch: float = 0.0, declared: float | None = None) -> MorphologyBuilder:
    """Pelvis root, two 0.4 + 0.4 m legs hanging from hips 0.1 m below and 0.1 m aside, a 0.5 m arm."""
    b = MorphologyBuilder("biped")
    b.add_link("pelvis")
    for side, y in (("l", 0.1), ("r", -0.1)):
        b.add_link(f"{side}_thigh")
        b.add_link(f"{side}_shin")
        # hip_pitch about y swings the leg forward (pi/2: horizontal, a rest pose that is not upright)
        b.add_joint_revolute(f"{side}_hip", "pelvis", f"{side}_thigh", axis=(0, 1, 0), limit=Limit(-2, 2),
                             origin=Transform((0, y, -0.1), (0, math.sin(-hip_pitch / 2), 0, math.cos(hip_pitch / 2))))
        b.add_joint_revolute(f"{side}_knee", f"{side}_thigh", f"{side}_shin", axis=(0, 1, 0), limit=Limit(0, 2),
                             origin=Transform((0, 0, -0.4)))
        b.add_end_effector(f"{side}_foot", f"{side}_shin", offset=(0, 0, -0.4), role="foot")
    b.add_link("arm")
    b.add_joint_revolute("shoulder", "pelvis", "arm", axis=(0, 1, 0), limit=Limit(-math.pi, math.pi),
                         origin=Transform((0, 0, 0.5)))
    b.add_end_effector("hand", "arm", offset=(0, 0, -0.5), role="hand")
    if declared is not None:
        b.set_body_length(declared)
    return b


def test_upright_feet_give_the_rest_stance_height():
    m = _biped().build()
    assert m.body_length_rule == BodyLengthRule.STANCE
    assert m.body_length == pytest.approx(0.9) == m.rest_stance_height
    assert m.leg_length == pytest.approx(0.8)  # hip to foot along the bones
    # The hand: shoulder 0.5 m above the root, 0.5 m arm, ground 0.9 m below the root.
    assert m.hand_height_range == pytest.approx((0.9, 1.9))


def test_rest_pose_not_upright_gives_the_straight_leg_length():
    m = _biped(hip_pitch=math.pi / 2).build()  # legs stick out forward at rest
    assert m.rest_stance_height is None
    assert m.body_length_rule == BodyLengthRule.STRAIGHT_LEGS
    assert m.body_length == pytest.approx(0.8)


def test_declared_length_wins_and_is_validated():
    m = _biped(declared=0.55).build()
    assert (m.body_length, m.body_length_rule, m.declared_body_length) == (0.55, BodyLengthRule.DECLARED, 0.55)
    for bad, message in ((0.0, "must be > 0"), (-1.0, "must be > 0"), (math.nan, "non-finite"),
                         (math.inf, "non-finite"), ("1", "expected a number"), (True, "expected a number")):
        with pytest.raises(GraphError, match=message):
            MorphologyBuilder("x").set_body_length(bad)  # type: ignore[arg-type]


def test_wheeled_robot_without_feet_uses_its_hand_reach():
    """A lift (prismatic, 0 … 1 m) on a wheeled base, a wrist and a gripper 0.2 m up at rest."""
    b = MorphologyBuilder("lifter")
    b.set_base("wheeled")
    for link in ("base", "carriage", "wrist"):
        b.add_link(link)
    b.add_joint_prismatic("lift", "base", "carriage", axis=(0, 0, 1), limit=Limit(0.0, 1.0),
                          origin=Transform((0.1, 0, 0.2)))
    b.add_joint_revolute("wrist", "carriage", "wrist", axis=(0, 1, 0), limit=Limit(-1.0, 1.0))
    b.add_end_effector("gripper", "wrist", offset=(0.1, 0, 0), role="hand")
    m = b.build()
    lo, hi = m.hand_height_range
    # Lowest: lift down, wrist pitched down by 1 rad; highest: lift up, wrist pitched up.
    assert lo == pytest.approx(0.2 - 0.1 * math.sin(1.0))
    assert hi == pytest.approx(1.2 + 0.1 * math.sin(1.0))
    assert m.body_length_rule == BodyLengthRule.HAND_REACH
    assert m.body_length == pytest.approx(hi / HUMAN_HAND_REACH)


def test_creatures_without_feet_or_hands_fall_back_to_the_rest_extent():
    b = MorphologyBuilder("stick")
    b.add_link("a")
    b.add_link("b")
    b.add_joint_fixed("j", "a", "b", origin=Transform((0, 0, 0.7)))
    m = b.build()
    assert m.hand_height_range is None
    assert m.body_length_rule == BodyLengthRule.REST_EXTENT
    assert m.body_length == pytest.approx(m.characteristic_length) == pytest.approx(0.7)


@pytest.mark.parametrize("name", sorted(TEST_CREATURES))
def test_every_test_creature_has_a_finite_positive_body_length(name):
    m = TEST_CREATURES[name]()
    assert np.isfinite(m.body_length) and m.body_length > 0, (name, m.body_length_rule)


@pytest.mark.parametrize(
    ("name", "rule", "length"),
    [
        ("spot", BodyLengthRule.STANCE, 0.6467),  # feet 0.646 m below the body on straight legs (README)
        ("crab", BodyLengthRule.STANCE, 0.1858),  # feet 0.186 m below the body frame (README)
        ("human", BodyLengthRule.STANCE, 0.98),  # root 0.98 m above the soles (README)
        ("stretch", BodyLengthRule.HAND_REACH, 1.2192 / HUMAN_HAND_REACH),  # gripper 0.1192 + 1.1 m lift
    ],
)
def test_shipped_creatures(name, rule, length):
    m = shipped_morphology(name)
    assert m.body_length_rule == rule
    assert m.body_length == pytest.approx(length, abs=1e-3)


def test_stretch_reach_is_its_lift_travel():
    lo, hi = shipped_morphology("stretch").hand_height_range
    assert (lo, hi) == pytest.approx((0.1192, 1.2192), abs=1e-6)  # README: gripper point z + lift 0 … 1.1 m
