"""The front-paw rule is one rule: the same four-legged body, as a description and as a BVH skeleton, gets the same
feet and hands from :mod:`morphkit.body.paws` — front limbs named ``hand`` are legs when leg-long and resting on the
ground, hands when short, whatever the file kind."""

from __future__ import annotations

import pytest

from morphkit.body import complete_anatomy
from morphkit.body.paws import PAW_RULE
from morphkit.graph import EndEffectorRole, Limit, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.io.bvh.analysis import plan_end_effectors
from morphkit.io.bvh.parser import parse_bvh

LEG = 0.4
"""Hind leg length below the hip [m] (two 0.2 m segments)."""
TOE = 0.02


def _description(front: float, drop: float):
    """A quadruped with its body at the origin (x forward, z up): hind legs ``left_foot``/``right_foot`` LEG long,
    front limbs ``left_hand``/``right_hand`` ``front`` long hung ``drop`` below the body's front; a sphere of
    radius TOE at every tip."""
    b = MorphologyBuilder("quad")
    b.add_link("body", shapes=[Shape(ShapeType.BOX, size=(0.6, 0.25, 0.08))])
    for side, y in (("left", 0.1), ("right", -0.1)):
        for end, x, top, length in (("foot", -0.25, 0.0, LEG), ("hand", 0.25, -drop, front)):
            names = [f"{side}_{end}_upper", f"{side}_{end}_lower", f"{side}_{end}"]
            b.add_link(names[0])
            b.add_link(names[1])
            b.add_link(names[2], shapes=[Shape(ShapeType.SPHERE, radius=TOE)])
            hinge = {"axis": (0, 1, 0), "limit": Limit(-1.5, 1.5)}
            b.add_joint_revolute(f"{names[0]}_j", "body", names[0], origin=Transform((x, y, top)), **hinge)
            b.add_joint_revolute(f"{names[1]}_j", names[0], names[1], origin=Transform((0, 0, -length / 2)), **hinge)
            b.add_joint_revolute(f"{names[2]}_j", names[1], names[2], origin=Transform((0, 0, -length / 2)), **hinge)
    return complete_anatomy(b.build(), base_declared=False)


def _bvh(front: float, drop: float) -> str:
    """The same body as a Y-up BVH skeleton (z forward), two frames standing with its toes on the ground."""

    def limb(name: str, x: float, y: float, z: float, length: float) -> str:
        return f"""  JOINT {name}Upper
  {{
    OFFSET {x} {y} {z}
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT {name}Lower
    {{
      OFFSET 0 {-length / 2} 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT {name}
      {{
        OFFSET 0 {-length / 2} 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {{
          OFFSET 0 {-TOE} 0
        }}
      }}
    }}
  }}
"""
    limbs = (limb("LeftFoot", 0.1, 0, -0.25, LEG) + limb("RightFoot", -0.1, 0, -0.25, LEG)
             + limb("LeftHand", 0.1, -drop, 0.25, front) + limb("RightHand", -0.1, -drop, 0.25, front))
    channels = 6 + 3 * 12
    frame = " ".join(["0", str(LEG + TOE), "0"] + ["0"] * (channels - 3))
    return (f"HIERARCHY\nROOT Hips\n{{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation "
            f"Xrotation Yrotation\n{limbs}}}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n{frame}\n{frame}\n")


@pytest.mark.parametrize(("front", "drop", "paws"), [
    (LEG, 0.0, True),  # front legs as long as the hind ones, toes on the ground: front paws
    (0.5 * LEG, 0.5 * LEG, False),  # short arms hung low enough to touch the ground: still hands (not leg-long)
])
def test_a_body_and_its_skeleton_get_the_same_feet(front: float, drop: float, paws: bool):
    assert PAW_RULE.leg_long(front + 0.1, LEG + 0.1) == paws  # the limb path includes the shoulder's offset
    m = _description(front, drop)
    plan = plan_end_effectors(parse_bvh(_bvh(front, drop)), True)
    description = sorted(e.role.name for e in m.end_effectors if "hand" in e.link)
    skeleton = sorted(p.role.name for p in plan if "Hand" in p.name)
    want = ["FOOT", "FOOT"] if paws else ["HAND", "HAND"]
    assert description == want, [(e.name, e.role, e.reason) for e in m.end_effectors]
    assert skeleton == want
    assert sum(e.role == EndEffectorRole.FOOT for e in m.end_effectors) == (4 if paws else 2)
