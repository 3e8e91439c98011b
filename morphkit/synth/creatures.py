"""Random creatures of a family: a body with 2, 4, 6 or 8 legs, with or without an arm, a tail, a neck and head.

Evaluation needs creatures no one tuned for (issue 48): :func:`random_creature` draws one from a
family — proportions, leg segment lengths, joint limits and where the limbs sit — from a seed, so a
test split of creatures can be generated that the development never saw. Every creature has
primitive shapes (box body, capsule segments, sphere feet) and joint limits a real robot would have
(knees that bend one way).

The end-effectors the generator labels (feet at the sole of each foot ball, the hand at the hand
ball, the head; a tail carries none) are its own ground truth; ``labelled=False`` leaves them out,
so that the readers' body-based guess (:mod:`morphkit.body.anatomy`) can be checked against them.

Beyond the three first families, :data:`FAMILIES` names body plans whose data is unlike a human's (issue 65): a
hopping biped with a heavy tail resting near the ground behind, short arms and long feet (``hopper``); a long-necked
grazer whose head reaches the ground (``grazer``); an eight-legged body (``octopod``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import Limit, Morphology, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.rotations import quat_conjugate, quat_from_rpy, quat_rotate

__all__ = ["FAMILIES", "CreatureFamily", "random_creature"]


@dataclass(frozen=True)
class CreatureFamily:
    """What a generated creature has; its proportions are drawn from the seed."""

    legs: int = 4
    """2, 4, 6 or 8."""
    arm: bool = False
    """A four-joint arm on the front of the body, ending in a hand."""
    tail: bool = False
    """A two-segment tail at the back (no end-effector: nothing of a human's maps to it)."""
    neck: bool = False
    """A neck and a head at the front."""
    size: float = 1.0
    """Scale of every length (1: a body about 0.6 m long)."""
    short_arms: bool = False
    """A pair of short two-joint arms at the front of the body, each ending in a hand."""
    heavy_tail: bool = False
    """A thick three-segment tail whose tip rests 2 cm (× size) above the ground behind at the stance (no
    end-effector; implies ``tail``)."""
    long_neck: bool = False
    """A three-joint neck about as long as the legs, whose head reaches the ground (implies ``neck``)."""
    long_feet: bool = False
    """An ankle and a long flat foot on each leg, the sole's middle its end-effector."""

    def __post_init__(self) -> None:
        if self.legs not in (2, 4, 6, 8):
            raise ConfigError(f"a generated creature has 2, 4 or 6 legs (or 8), not {self.legs}")
        if not (math.isfinite(self.size) and 0.05 <= self.size <= 20.0):
            raise ConfigError(f"creature size must be within [0.05, 20], got {self.size}")

    @property
    def name(self) -> str:
        parts = [f"{self.legs}legs"] + [k for k in ("arm", "short_arms", "tail", "heavy_tail", "neck", "long_neck",
                                                     "long_feet") if getattr(self, k)]
        return "_".join(parts)


FAMILIES: dict[str, CreatureFamily] = {
    "hopper": CreatureFamily(legs=2, short_arms=True, heavy_tail=True, neck=True, long_feet=True),
    "grazer": CreatureFamily(legs=4, long_neck=True, tail=True),
    "octopod": CreatureFamily(legs=8),
}
"""Named body plans (``morphkit generate --family NAME``): a hopping biped with a heavy tail, short arms and long
feet; a long-necked grazer; an eight-legged body."""


def _capsule_along(axis: str, length: float, radius: float) -> Shape:
    """A capsule from the link origin ``length`` along ``axis`` (``"x"`` or ``"-z"``), caps included."""
    core = max(length - 2.0 * radius, 1e-3)
    if axis == "-z":
        return Shape(ShapeType.CAPSULE, Transform((0.0, 0.0, -0.5 * length)), radius=radius, length=core)
    quat = tuple(float(v) for v in quat_from_rpy(np.array([0.0, math.pi / 2, 0.0])))
    return Shape(ShapeType.CAPSULE, Transform((0.5 * length, 0.0, 0.0), quat), radius=radius,  # type: ignore[arg-type]
                 length=core)


def random_creature(family: CreatureFamily, seed: int = 0, *, labelled: bool = True) -> Morphology:
    """A creature of ``family`` with proportions drawn from ``seed`` (same seed, same creature).

    Args:
        family: Leg count, limbs, size.
        seed: Random seed of the proportions.
        labelled: Give the end-effectors (feet, hand, head); False leaves them to the readers' guess
            from the body.

    Returns:
        A floating-base :class:`~morphkit.graph.Morphology` standing at ``q = 0`` with bent knees.
    """
    rng = np.random.default_rng(seed)
    s = family.size
    u = rng.uniform
    length = s * u(0.45, 0.8) * {2: 0.6, 8: 1.3}.get(family.legs, 1.0)
    width, height = s * u(0.18, 0.3), s * u(0.1, 0.18)
    thigh, shin = s * u(0.2, 0.32), s * u(0.2, 0.32)
    foot_r = s * u(0.02, 0.035)
    b = MorphologyBuilder(f"generated_{family.name}_{seed}")
    b.set_base("floating")
    b.add_link("body", shapes=[Shape(ShapeType.BOX, Transform(), size=(length, width, height))])

    stance = _add_legs(b, family, u, (length, width, height, thigh, shin, foot_r), labelled)
    _add_arms(b, family, u, (length, width, height), labelled)
    _add_neck(b, family, u, (length, height), labelled)
    _add_tail(b, family, u, (length, height), stance)
    return b.build()


def _add_legs(b: MorphologyBuilder, family: CreatureFamily, u: Callable[[float, float], float],
              dims: tuple[float, ...], labelled: bool) -> float:
    """The legs (body ``dims``: length, width, height, thigh, shin, foot radius [m]); returns the body centre's
    height above the ground at ``q = 0`` [m]. Draws from ``u`` in a fixed order (same seed, same creature)."""
    s = family.size
    length, width, height, thigh, shin, foot_r = dims
    # legs in pairs along the body, knees bent at q = 0 (front knees back, as most quadrupeds)
    pairs = family.legs // 2
    xs = [0.0] if pairs == 1 else list(np.linspace(0.4 * length, -0.4 * length, pairs))
    knee = u(0.6, 1.0)  # rest bend [rad]
    foot_len = s * u(0.18, 0.26)
    # the body's centre above the ground at q = 0: hip drop, both segments at half the knee bend, the sole
    stance = 0.5 * height + (thigh + shin) * math.cos(0.5 * knee) + foot_r
    for i, x in enumerate(xs):
        for side, y in (("l", 0.5 * width), ("r", -0.5 * width)):
            n = f"leg{i}_{side}"
            b.add_link(f"{n}_hip")
            b.add_link(f"{n}_thigh", shapes=[_capsule_along("-z", thigh, 0.025 * s)])
            ball = [] if family.long_feet else [Shape(ShapeType.SPHERE, Transform((0.0, 0.0, -shin)), radius=foot_r)]
            b.add_link(f"{n}_shin", shapes=[_capsule_along("-z", shin, 0.02 * s), *ball])
            b.add_joint_revolute(f"{n}_abduct", "body", f"{n}_hip", origin=Transform((float(x), y, -0.5 * height)),
                                 axis=(1, 0, 0), limit=Limit(-0.5, 0.5))
            # thigh pitched forward by half the knee bend, the shin back by all of it: the foot under the hip
            b.add_joint_revolute(f"{n}_hip_pitch", f"{n}_hip", f"{n}_thigh",
                                 origin=Transform(quat=_pitch(-0.5 * knee)), axis=(0, 1, 0), limit=Limit(-1.2, 1.2))
            b.add_joint_revolute(f"{n}_knee", f"{n}_thigh", f"{n}_shin",
                                 origin=Transform((0.0, 0.0, -thigh), _pitch(knee)), axis=(0, 1, 0),
                                 limit=Limit(-knee + 0.05, 2.4 - knee))
            if family.long_feet:
                # levelled at q = 0: the ankle undoes the shin's pitch; the foot reaches forward from the heel
                b.add_link(f"{n}_foot", shapes=[Shape(ShapeType.BOX, Transform((0.5 * foot_len - foot_r, 0.0, 0.0)),
                                                      size=(foot_len, 2.0 * foot_r, 2.0 * foot_r))])
                b.add_joint_revolute(f"{n}_ankle", f"{n}_shin", f"{n}_foot",
                                     origin=Transform((0.0, 0.0, -shin), _pitch(-0.5 * knee)), axis=(0, 1, 0),
                                     limit=Limit(-0.8, 0.8))
                if labelled:
                    b.add_end_effector(f"{n}_foot", f"{n}_foot", offset=(0.0, 0.0, -foot_r),
                                       role="foot")
            elif labelled:
                b.add_end_effector(f"{n}_foot", f"{n}_shin", offset=_sole(knee, shin, foot_r), role="foot")

    return stance


def _add_arms(b: MorphologyBuilder, family: CreatureFamily, u: Callable[[float, float], float],
              dims: tuple[float, ...], labelled: bool) -> None:
    """The front arm and the short arms the family has (body ``dims``: length, width, height [m])."""
    s = family.size
    length, width, height = dims
    if family.arm:
        upper, fore = s * u(0.18, 0.3), s * u(0.15, 0.25)
        front = (0.5 * length - 0.05 * s, 0.0, 0.5 * height)
        b.add_link("arm_base")
        b.add_link("arm_upper", shapes=[_capsule_along("x", upper, 0.02 * s)])
        b.add_link("arm_fore", shapes=[_capsule_along("x", fore, 0.018 * s)])
        b.add_link("arm_hand", shapes=[Shape(ShapeType.SPHERE, Transform((0.04 * s, 0.0, 0.0)), radius=0.03 * s)])
        b.add_joint_revolute("arm_yaw", "body", "arm_base", origin=Transform(front), axis=(0, 0, 1),
                             limit=Limit(-1.5, 1.5))
        b.add_joint_revolute("arm_shoulder", "arm_base", "arm_upper", origin=Transform(quat=_pitch(-0.6)),
                             axis=(0, 1, 0), limit=Limit(-1.5, 0.8))
        b.add_joint_revolute("arm_elbow", "arm_upper", "arm_fore", origin=Transform((upper, 0.0, 0.0), _pitch(1.2)),
                             axis=(0, 1, 0), limit=Limit(-1.0, 1.5))
        b.add_joint_revolute("arm_wrist", "arm_fore", "arm_hand", origin=Transform((fore, 0.0, 0.0)), axis=(0, 1, 0),
                             limit=Limit(-1.2, 1.2))
        if labelled:
            b.add_end_effector("hand", "arm_hand", offset=(0.07 * s, 0.0, 0.0), role="hand")

    if family.short_arms:
        arm = s * u(0.08, 0.12)
        for side, y in (("l", 0.35 * width), ("r", -0.35 * width)):
            b.add_link(f"{side}_arm", shapes=[_capsule_along("-z", arm, 0.015 * s)])
            b.add_link(f"{side}_forearm", shapes=[_capsule_along("-z", arm, 0.012 * s)])
            b.add_joint_revolute(f"{side}_shoulder", "body", f"{side}_arm",
                                 origin=Transform((0.5 * length, y, 0.0), _pitch(-0.3)), axis=(0, 1, 0),
                                 limit=Limit(-1.5, 1.0))
            b.add_joint_revolute(f"{side}_elbow", f"{side}_arm", f"{side}_forearm",
                                 origin=Transform((0.0, 0.0, -arm), _pitch(-0.6)), axis=(0, 1, 0),
                                 limit=Limit(-1.2, 0.6))
            if labelled:
                b.add_end_effector(f"{side}_hand", f"{side}_forearm", offset=(0.0, 0.0, -arm), role="hand")


def _add_neck(b: MorphologyBuilder, family: CreatureFamily, u: Callable[[float, float], float],
              dims: tuple[float, ...], labelled: bool) -> None:
    """The neck and head the family has, long or short (body ``dims``: length, height [m])."""
    s = family.size
    length, height = dims
    if family.long_neck:
        seg = s * u(0.16, 0.22)
        head = 0.06 * s
        prev, at = "body", Transform((0.5 * length, 0.0, 0.3 * height), _pitch(-0.9))
        for i in range(3):
            b.add_link(f"neck{i}", shapes=[_capsule_along("x", seg, 0.035 * s)])
            b.add_joint_revolute(f"neck{i}_pitch", prev, f"neck{i}", origin=at, axis=(0, 1, 0),
                                 limit=Limit(-0.5, 0.9) if i == 0 else Limit(-0.6, 0.6))
            prev, at = f"neck{i}", Transform((seg, 0.0, 0.0), _pitch(0.3))
        b.add_link("head", shapes=[Shape(ShapeType.SPHERE, Transform((head, 0.0, 0.0)), radius=head)])
        b.add_joint_revolute("head_pitch", prev, "head", origin=Transform((seg, 0.0, 0.0), _pitch(0.6)),
                             axis=(0, 1, 0), limit=Limit(-0.8, 0.8))
        if labelled:
            b.add_end_effector("head_tip", "head", offset=(2.0 * head, 0.0, 0.0), role="head")
    elif family.neck:
        neck = s * u(0.12, 0.25)
        head = 0.06 * s
        b.add_link("neck", shapes=[_capsule_along("x", neck, 0.03 * s)])
        b.add_link("head", shapes=[Shape(ShapeType.SPHERE, Transform((head, 0.0, 0.0)), radius=head)])
        front_top = (0.5 * length, 0.0, 0.3 * height)
        b.add_joint_revolute("neck_pitch", "body", "neck", origin=Transform(front_top, _pitch(-0.6)), axis=(0, 1, 0),
                             limit=Limit(-0.6, 0.6))
        b.add_joint_revolute("head_pitch", "neck", "head", origin=Transform((neck, 0.0, 0.0), _pitch(0.6)),
                             axis=(0, 1, 0), limit=Limit(-0.8, 0.8))
        if labelled:
            b.add_end_effector("head_tip", "head", offset=(2.0 * head, 0.0, 0.0), role="head")


def _add_tail(b: MorphologyBuilder, family: CreatureFamily, u: Callable[[float, float], float],
              dims: tuple[float, ...], stance: float) -> None:
    """The tail the family has, heavy (its tip just above the ground at the ``stance`` height [m]) or light."""
    s = family.size
    length, height = dims
    if family.heavy_tail:
        # thick, tapering, its tip 2 cm (× size) above the ground behind at the stance
        back = (-0.5 * length, 0.0, 0.0)
        seg = 0.5 * stance
        radii = (0.045 * s, 0.035 * s, 0.025 * s)
        drop = (stance - radii[2] - 0.02 * s) / (3.0 * seg)
        b.add_link("tail_base")
        b.add_joint_revolute("tail_yaw", "body", "tail_base", origin=Transform(back, _yaw(math.pi)), axis=(0, 0, 1),
                             limit=Limit(-0.6, 0.6))
        prev, at = "tail_base", Transform(quat=_pitch(math.asin(min(drop, 0.95))))
        for i, r in enumerate(radii):
            b.add_link(f"tail_{i + 1}", shapes=[_capsule_along("x", seg, r)])
            b.add_joint_revolute(f"tail_pitch{i + 1}", prev, f"tail_{i + 1}", origin=at, axis=(0, 1, 0),
                                 limit=Limit(-0.6, 0.3))
            prev, at = f"tail_{i + 1}", Transform((seg, 0.0, 0.0))
    elif family.tail:
        seg = s * u(0.12, 0.22)
        back = (-0.5 * length, 0.0, 0.2 * height)
        b.add_link("tail_base")
        b.add_link("tail_1", shapes=[_capsule_along("x", seg, 0.02 * s)])
        b.add_link("tail_2", shapes=[_capsule_along("x", seg, 0.015 * s)])
        b.add_joint_revolute("tail_yaw", "body", "tail_base", origin=Transform(back, _yaw(math.pi)), axis=(0, 0, 1),
                             limit=Limit(-0.8, 0.8))
        b.add_joint_revolute("tail_pitch", "tail_base", "tail_1", origin=Transform(quat=_pitch(-0.4)),
                             axis=(0, 1, 0), limit=Limit(-0.8, 0.8))
        b.add_joint_revolute("tail_bend", "tail_1", "tail_2", origin=Transform((seg, 0.0, 0.0)), axis=(0, 1, 0),
                             limit=Limit(-0.8, 0.8))


def _pitch(angle: float) -> tuple[float, float, float, float]:
    return tuple(float(v) for v in quat_from_rpy(np.array([0.0, angle, 0.0])))  # type: ignore[return-value]


def _yaw(angle: float) -> tuple[float, float, float, float]:
    return tuple(float(v) for v in quat_from_rpy(np.array([0.0, 0.0, angle])))  # type: ignore[return-value]


def _sole(knee: float, shin: float, radius: float) -> tuple[float, float, float]:
    """The bottom of the foot ball in the shin frame: the shin is pitched by ``knee / 2`` at q = 0."""
    down = quat_rotate(quat_conjugate(np.asarray(_pitch(0.5 * knee))), np.array([0.0, 0.0, -radius]))
    return float(down[0]), float(down[1]), float(down[2] - shin)
