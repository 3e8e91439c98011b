"""Body length: the length Ψ divides by, so a human and a creature share one scale (ACE §6.3).

ACE normalises every length of its feature function "according to the character's body length".
morphkit takes a creature's **standing root height** — how high its root stands above its feet —
so that in Ψ a standing creature's root sits at 1 and its feet at about -1, whatever its size or
leg count. Two estimates of that one length, each named for its source: the graph gives one from the
description alone (:attr:`~morphkit.graph.Morphology.body_length`: the rest stance, straight legs for
rigs whose rest pose is not upright, hand reach for creatures without feet); :func:`measured_body_length`
measures it on the creature's own motion where one is given, because a rest pose need not be how a creature
stands (Spot's rest pose has straight legs, 0.65 m; it walks at about 0.51 m) and some BVH rigs
are not posed upright at all. See ``docs/concepts/body-length.md``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import EndEffectorRole, Morphology

if TYPE_CHECKING:
    from morphkit.motion.motion import Motion

__all__ = ["STANDING_PERCENTILE", "measured_body_length", "standing_height"]

STANDING_PERCENTILE = 90.0
"""Percentile of the per-frame root height above the lowest foot that counts as standing: high
enough to ignore frames where the creature crouches, sits or lies (a dog clip that lies for two
thirds of its frames), low enough to ignore the odd frame of a jump with legs stretched."""


def _as_list(motion: Motion | Iterable[Motion]) -> list[Motion]:
    from morphkit.motion.motion import Motion

    return [motion] if isinstance(motion, Motion) else list(motion)


def standing_height(motion: Motion | Iterable[Motion]) -> float | None:
    """The root's standing height above its lowest foot [m], measured on motions.

    Per frame, the root's height above the lowest of its ``foot`` end-effectors (so the height of
    the ground does not matter); over all frames of all motions together, the
    :data:`STANDING_PERCENTILE`-th percentile.

    Args:
        motion: A motion, or several of one creature.

    Returns:
        The height, or ``None`` without motions or when their creature has no feet.
    """
    heights = []
    for m in _as_list(motion):
        feet = [i for i, e in enumerate(m.morphology.end_effectors) if e.role == EndEffectorRole.FOOT]
        if not feet:
            continue
        root_z = m.link_positions()[:, 0, 2]
        heights.append(root_z - m.end_effector_positions()[:, feet, 2].min(axis=1))
    if not heights:
        return None
    return float(np.percentile(np.concatenate(heights), STANDING_PERCENTILE))


def measured_body_length(morphology: Morphology, motion: Motion | Iterable[Motion] | None = None) -> float:
    """The body length [m] of a creature, measured on its motion where one is given (what Ψ divides by).

    1. The length the description declares (YAML ``body_length:``), if any.
    2. A creature with feet and a motion: its :func:`standing_height` over the motion (pass a
       whole data set so every clip is normalised by the same length).
    3. Otherwise the graph's rule, :attr:`~morphkit.graph.Morphology.body_length`.

    Args:
        morphology: The creature.
        motion: None, one motion, or several motions of that creature.

    Raises:
        ConfigError: a motion of a creature with other end-effectors.
    """
    motions = [] if motion is None else _as_list(motion)
    names = tuple(e.name for e in morphology.end_effectors)
    for m in motions:
        if tuple(e.name for e in m.morphology.end_effectors) != names:
            raise ConfigError(
                f"motion {m.name!r} is of creature {m.morphology.name!r}, whose end-effectors differ from "
                f"{morphology.name!r}'s ({', '.join(names) or 'none'})"
            )
    if morphology.declared_body_length is not None:
        return float(morphology.declared_body_length)
    height = standing_height(motions)
    if height is not None and height > 1e-6:
        return height
    return morphology.body_length
