"""What every trained retargeter offers: the :class:`Retargeter` protocol and its :class:`RetargetedClip`.

ACE (:class:`~morphkit.retarget.ace.retarget.AceRetargeter`) and NKN
(:class:`~morphkit.retarget.nkn.retarget.NknRetargeter`) implement it; the evaluation, the CLI and
the ACE examples use only it, through :func:`morphkit.retarget.run_loader.load`.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion import ClampReport, Motion, Pairing, foot_contact_flags, foot_names
from morphkit.retarget.training_data import DataConfig

__all__ = ["RetargetedClip", "Retargeter", "WithContacts", "check_finite", "contact_export", "paired_swings",
           "swing_hint"]


@dataclass(frozen=True)
class RetargetedClip:
    """One retargeted clip: the creature's motion, the clip it came from, and what decoding clamped."""

    source: Motion
    """The human clip, at the retargeter's frame rate."""
    motion: Motion
    """The creature's motion, placed where the source starts (its root's ground position and heading)."""
    states: np.ndarray | None = None
    """[T, Sr] the method's own denormalised output states, where it has them (ACE)."""
    clamp: ClampReport = field(default_factory=lambda: ClampReport(0.0, 0.0, ()))
    """Joint coordinates decoding had to clamp into their limits (nothing, for methods that do not clamp)."""
    stance: np.ndarray | None = None
    """[T, F] the method's own stance flags of the creature's feet (:func:`~morphkit.motion.foot_names` order),
    where a method predicts them (none shipped does since ACE's stance flags were deleted); the ``lock`` export holds
    them."""


def check_finite(motion: Motion, *, run: str | os.PathLike[str], clip: str) -> Motion:
    """``motion`` when every coordinate is finite; else one error naming the run, the clip and the frame
    (a retargeter never hands a NaN on, let alone writes one to disk).

    Raises:
        RunError: the first frame with a non-finite coordinate.
    """
    bad = ~np.isfinite(motion.q).all(axis=1)
    if bad.any():
        frame = int(np.argmax(bad))
        coords = [n for n, ok in zip(motion.morphology.coordinate_names, np.isfinite(motion.q[frame]), strict=True)
                  if not ok]
        raise RunError(f"clip {clip!r}: non-finite output at frame {frame} of {motion.frame_count} "
                       f"({', '.join(coords[:4])})", location=SourceLocation(os.fspath(run)))
    return motion


def paired_swings(source: Motion, creature: Morphology, pairing: Pairing) -> dict[str, np.ndarray]:
    """``{creature foot: [T] bool}``, True where the human foot it is paired with is off the ground in
    ``source`` (:func:`~morphkit.motion.foot_contact_flags`: 5 cm, 0.3 m/s), for each creature foot that
    is the only creature foot paired with its human foot (a biped's; not a quadruped's two left feet, whose
    steps cannot both follow one human foot). Empty where none is, or the human has no feet."""
    human_feet = foot_names(source.morphology)
    creature_feet = set(foot_names(creature))
    pairs = [(c, h) for c, h in zip(pairing.creature_ees, pairing.human_ees, strict=True)
             if c in creature_feet and h in human_feet]
    alone = [(c, h) for c, h in pairs if sum(hh == h for _, hh in pairs) == 1]
    if not alone:
        return {}
    contact = foot_contact_flags(source)
    return {c: contact[:, human_feet.index(h)] < 0.5 for c, h in alone}


def swing_hint(clip: RetargetedClip, pairing: Pairing | None) -> dict[str, np.ndarray] | None:
    """The ``replan`` export's ``swing_hint`` of ``clip`` (:func:`~morphkit.contact_export.apply_contacts`): its
    source's :func:`paired_swings` where the source and the motion share frames (length and rate); None where there
    is no pairing, no one-to-one paired foot or no common timeline."""
    src, motion = clip.source, clip.motion
    if pairing is None or src.frame_count != motion.frame_count or src.fps != motion.fps:
        return None
    return paired_swings(src, motion.morphology, pairing) or None


def contact_export(clip: RetargetedClip, mode: str, pairing: Pairing | None) -> Motion:
    """``clip``'s motion through the contact-aware export ``mode`` (:func:`morphkit.contact_export.apply_contacts`,
    with the clip's stance flags). ``replan``'s one-to-one paired feet follow the source human's swings
    (:func:`swing_hint`) where that costs no realism: the clip is re-planned without them too, and the plan with
    fewer unrealistic frames (:func:`~morphkit.metrics.unrealistic_frame_ratio`) is kept, the human's timing on a
    tie. A timing the creature's legs cannot keep (a touchdown out of reach, a stance foot held at its ellipse's
    edge) then falls back to the planner's own steps for that clip."""
    from morphkit.contact_export import apply_contacts
    from morphkit.metrics import unrealistic_frame_ratio

    plain = apply_contacts(clip.motion, mode, stance=clip.stance)
    hint = swing_hint(clip, pairing) if mode == "replan" else None
    if hint is None:
        return plain
    hinted = apply_contacts(clip.motion, mode, stance=clip.stance, swing_hint=hint)
    worse = unrealistic_frame_ratio(hinted).unrealistic_count > unrealistic_frame_ratio(plain).unrealistic_count
    return plain if worse else hinted


@runtime_checkable
class Retargeter(Protocol):
    """A trained retargeter, ready to use (eval mode, no gradients)."""

    label: str
    """Its name in a comparison (Table 1: ``ACE``, ``ACEwoFea``, ``NKN``, ...)."""
    creature: Morphology | None
    """The creature it retargets onto (``None``: NKN between human skeletons)."""
    pairing: Pairing | None
    """Ψ's end-effector pairs and body lengths it was trained with (``None`` where the method has none)."""
    fps: float
    """Frame rate of its output [1/s]; clips at other rates are resampled."""
    data: DataConfig
    """The creature's synthesised data set it was trained with (frames, frame rate, seed)."""
    human_data: str | None
    """The human data folder it was trained on (``None``: the embedded default human motion)."""

    def intake(self, clip: Motion) -> Motion:
        """``clip`` as the retargeter reads it (e.g. on the canonical human); :meth:`retarget` takes every
        clip through it before retargeting any.

        Raises:
            MotionFormatError: a clip it cannot read (naming the clip and why; the caller adds the file).
        """
        ...

    def retarget(self, clips: Sequence[Motion]) -> list[RetargetedClip]:
        """Retarget human clips, batched; one result per clip, in order."""
        ...

    def with_target(self, target: Morphology | str) -> Retargeter:
        """This retargeter, retargeting onto ``target`` (a skeleton, or what names one: the method says which);
        its own creature gives it back unchanged.

        Raises:
            MorphkitError: a target it cannot retarget onto (e.g. another creature than an ACE run's).
        """
        ...


class WithContacts:
    """A :class:`Retargeter` whose motions go through a contact-aware export
    (:func:`morphkit.contact_export.apply_contacts`: ``replan`` re-steps the legs along the retargeted root
    path, a biped's feet lifting as the human's do); its label gains ``+mode``."""

    def __init__(self, retargeter: Retargeter, mode: str) -> None:
        from morphkit.contact_export import CONTACT_MODES

        if mode not in CONTACT_MODES:
            raise ConfigError(f"unknown contact mode {mode!r}; expected one of: {', '.join(CONTACT_MODES)}")
        self.inner, self.mode = retargeter, mode
        self.label = retargeter.label if mode == "none" else f"{retargeter.label}+{mode}"
        self.creature, self.pairing, self.fps = retargeter.creature, retargeter.pairing, retargeter.fps
        self.data, self.human_data = retargeter.data, retargeter.human_data

    def intake(self, clip: Motion) -> Motion:
        """The inner retargeter's reading of ``clip``."""
        return self.inner.intake(clip)

    def retarget(self, clips: Sequence[Motion]) -> list[RetargetedClip]:
        """The inner retargeter's clips, each motion through the export."""
        return [self.export(r) for r in self.inner.retarget(clips)]

    def with_target(self, target: Morphology | str) -> WithContacts:
        """The inner retargeter onto ``target``, through the same export."""
        return WithContacts(self.inner.with_target(target), self.mode)

    def export(self, clip: RetargetedClip) -> RetargetedClip:
        """One raw clip through the export (:func:`contact_export`; its states and clamp report are the raw
        output's)."""
        return dataclasses.replace(clip, motion=contact_export(clip, self.mode, self.pairing))
