"""When a foot is on the ground: one rule, with named presets.

**The rule.** A foot is in contact at frame t when its height above its ground is below the preset's
``height`` and, where the preset sets a ``speed``, its horizontal speed is below it. The speed is the
foot's horizontal displacement by :func:`morphkit.conventions.backward_difference` times the frame rate
(:data:`morphkit.conventions.VELOCITY_DIFFERENCE`: frame 0 copies frame 1), except for a ``causal``
preset, whose frame 0 has no past and moves at speed 0. Speeds are always horizontal: a foot coming
down vertically onto the ground is landing, not sliding, and its height already decides it.

**The presets** (every caller names one; ``docs/concepts/contact.md`` says who uses each and why):

- :data:`UFR`: the unrealistic frame ratio of ACE (Li et al. 2023, §7): 2 cm, 0.2 m/s. Also the default
  of the contact kernels, of ``morphkit synth --report`` and of NKN's contact figures.
- :data:`STANCE_FLAGS`: the stance flags of the ACE states and of the retargeter's feet: 5 cm above the
  clip's own ground, 0.3 m/s.
- :data:`LOCK`: the contact-aware export by locking: 5 cm, 1 m/s, causal.
- :data:`PRIOR_PLANTED`: the feet ACE's motion prior holds planted: 2 cm, 2 mm per transition.
- :data:`GMD_SKATING` and :data:`PHYSDIFF`: the published metrics' own thresholds (GMD's skating ratio,
  PhysDiff's skate), kept as those papers set them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morphkit.conventions import backward_difference

__all__ = [
    "GMD_SKATING",
    "LOCK",
    "PHYSDIFF",
    "PRESETS",
    "PRIOR_PLANTED",
    "PRIOR_PLANTED_STEP",
    "STANCE_FLAGS",
    "UFR",
    "ContactRule",
    "contact_flags",
    "horizontal_speed",
]


@dataclass(frozen=True)
class ContactRule:
    """A named threshold pair of the one contact rule (see the module docstring)."""

    name: str
    """How callers and the docs name the preset."""
    height: float
    """A foot lower than this above its ground can be in contact [m]."""
    speed: float | None
    """A foot horizontally faster than this is not in contact [m/s]; None: height alone decides."""
    causal: bool = False
    """Frame t decided from frames 0..t only: frame 0's speed is 0 instead of frame 1's."""
    why: str = ""
    """Where the numbers come from."""


UFR = ContactRule(
    "ufr", 0.02, 0.2,
    why="ACE gives no thresholds; 2 cm is above mocap noise, 0.2 m/s is below 1 cm per frame at 30 fps and "
        "above stance feet of CMU walking (metrics.UnrealisticFrameThresholds)")
STANCE_FLAGS = ContactRule(
    "stance flags", 0.05, 0.3,
    why="GMD's contact height; 1 cm per frame at 30 fps, a tenth of a walk's swing speed (a human's toe "
        "joint rests a few centimetres up: the ground is the clip's own)")
LOCK = ContactRule(
    "lock", 0.05, 1.0, causal=True,
    why="GMD's contact height; twice GMD's skating speed, so a foot a retargeter drags along the ground is "
        "still taken as planted; causal so a streaming retargeter can lock frame by frame")
PRIOR_PLANTED = ContactRule(
    "prior planted", 0.02, None,
    why="UFR's height; the step limit is per transition (ACE's prior sees state pairs, not a frame rate): "
        "2 mm, 6 cm/s at 30 fps")
GMD_SKATING = ContactRule(
    "gmd skating", 0.05, 0.5, why="Karunratanakul et al. 2023 (guided motion diffusion), as published")
PHYSDIFF = ContactRule("physdiff", 0.05, None, why="Yuan et al. 2023 (PhysDiff), as published")

PRESETS: dict[str, ContactRule] = {r.name: r for r in (UFR, STANCE_FLAGS, LOCK, PRIOR_PLANTED, GMD_SKATING,
                                                       PHYSDIFF)}
"""Every preset by name."""

PRIOR_PLANTED_STEP = 0.002
"""[m] per transition: :data:`PRIOR_PLANTED`'s step limit (see its ``why``)."""


def horizontal_speed(points: np.ndarray, fps: float, *, causal: bool = False) -> np.ndarray:
    """Horizontal speed [T, ...] [m/s] of points [T, ..., 3] [m] by the one difference convention."""
    p = np.asarray(points, dtype=float)
    return np.linalg.norm(backward_difference(p[..., :2], 0, causal=causal), axis=-1) * fps


def contact_flags(points: np.ndarray, fps: float, rule: ContactRule, ground: float | np.ndarray = 0.0) -> np.ndarray:
    """Contact flags [T, F] (bool) of feet at points [T, F, 3] [m] above ``ground`` (scalar or [F]) [m]."""
    p = np.asarray(points, dtype=float)
    low = p[..., 2] - np.asarray(ground, dtype=float) < rule.height
    if rule.speed is None:
        return low
    return low & (horizontal_speed(p, fps, causal=rule.causal) < rule.speed)
