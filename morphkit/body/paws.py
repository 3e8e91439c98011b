"""When a limb named like an arm is a leg: one rule for descriptions and BVH skeletons alike.

A dog's front legs end in joints a rig calls ``LeftHand``; a quadruped robot may call its front feet ``hand``.
Names are hints (:mod:`morphkit.body.roles`); the body decides. A hand-, tool- or head-named end is a
**front paw** (a leg) when both hold:

- it is **leg-long**: its limb — bone or joint offsets from its tip up to where it branches off the body —
  is at least :attr:`PawRule.limb_ratio` of the legs' mean (rules out a human's arms, 0.67–0.75 of the legs
  on the CMU, DAZ and Bandai Namco skeletons; a dog's front legs are 1.24);
- it **rests on the ground**: its height above the ground is at most :attr:`PawRule.height_fraction` of the
  body's (the hips' for a skeleton, the root's for a description). A skeleton's height is the median over its
  frames (dogs 0.00–0.21, humans 0.87–2.16 on the shipped data); a description's is at its reference pose.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PAW_RULE", "PawRule"]


@dataclass(frozen=True)
class PawRule:
    """The two thresholds of the front-paw rule (dimensionless ratios)."""

    height_fraction: float = 0.35
    """A resting end's height above the ground, at most this fraction of the body's."""
    limb_ratio: float = 0.9
    """A leg-long end's limb, at least this fraction of the legs' mean length."""

    def leg_long(self, limb: float, legs: float) -> bool:
        """Whether a limb ``limb`` long is long enough to be a leg beside legs ``legs`` long on average (same units)."""
        return limb >= self.limb_ratio * legs

    def rests(self, height: float, body: float) -> bool:
        """Whether an end ``height`` above the ground rests on it under a body ``body`` above it (same units)."""
        return height <= self.height_fraction * body

    def is_paw(self, limb: float, legs: float, height: float, body: float) -> bool:
        """Both: a leg-long limb resting on the ground."""
        return self.leg_long(limb, legs) and self.rests(height, body)


PAW_RULE = PawRule()
"""The rule every reader uses."""
