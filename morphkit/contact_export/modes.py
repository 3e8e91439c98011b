"""Contact-aware exports of a retargetted motion, by name: what ``--contacts`` and Table 1's rows choose from."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from morphkit.contact_export.clearance import clear_upper_body
from morphkit.contact_export.lock import lock_feet
from morphkit.contact_export.replan import replan_legs
from morphkit.errors import ConfigError
from morphkit.motion.motion import Motion
from morphkit.synth.wheeled import drivable

__all__ = ["CONTACT_MODES", "apply_contacts", "as_driven"]

CONTACT_MODES = ("none", "replan", "lock")
"""``none``: the retargeter's raw output (the paper's); ``replan``: legs re-stepped by the synthesis' planner
along the root path (:func:`~morphkit.contact_export.replan.replan_legs`); ``lock``: the retargeter's own steps
with stance feet held at their touchdown points (:func:`~morphkit.contact_export.lock.lock_feet`). Both then move the
upper body out of the creature's own shapes and the ground by a short change of its joints
(:func:`~morphkit.contact_export.clearance.clear_upper_body`). In every mode, ``none`` included, a wheeled base
first drives as its wheels allow (:func:`as_driven`)."""


def as_driven(motion: Motion) -> Motion:
    """``motion`` with a wheeled base's root path made one its wheels can drive and its steering, caster and
    steered-wheel angles set from it (:func:`~morphkit.synth.wheeled.drivable`: no sideways motion on a differential
    or skid-steer base, no turn tighter than an Ackermann's steering allows); other bases' motions, and motions the
    wheels already drive (to 1 nm or nrad: re-integration's rounding), come back as the same object."""
    m = motion.morphology
    if m.wheels is None or motion.frame_count < 2:
        return motion
    q = drivable(m, motion.q, motion.fps)
    return motion if np.allclose(q, motion.q, rtol=0.0, atol=1e-9) else motion.replace(q=q)


def apply_contacts(motion: Motion, mode: str, *, stance: Any = None,
                   swing_hint: Mapping[str, np.ndarray] | None = None) -> Motion:
    """The contact-aware export ``mode`` (one of :data:`CONTACT_MODES`) of a retargeted motion, a wheeled base's
    path first made drivable (:func:`as_driven`).

    ``stance``: the retargeter's stance flags [T, F] (feet in :func:`~morphkit.motion.foot_names` order),
    which ``lock`` holds instead of deciding stance from the feet's height and speed. ``swing_hint``:
    ``{foot end-effector: [T] bool}``, when each of those feet should be in the air, which ``replan``'s
    swings follow (:func:`~morphkit.contact_export.replan.replan_legs`); ``lock`` ignores it.

    Raises:
        ConfigError: an unknown mode.
    """
    if mode not in CONTACT_MODES:
        raise ConfigError(f"unknown contact mode {mode!r}; expected one of: {', '.join(CONTACT_MODES)}")
    # the wheels' path first: replan steps legs along the root path, and every mode's export is driven
    motion = as_driven(motion)
    if mode == "none":
        return motion
    if mode == "replan":
        return clear_upper_body(replan_legs(motion, swing_hint=swing_hint))
    return clear_upper_body(lock_feet(motion, stance=stance))  # "lock"
