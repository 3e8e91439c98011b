"""The feature function Ψ of ACE (Li et al. 2023, §6.3), shared by the feature loss, the metrics
and the end-effector mapping.

Ψ reads the fields every state has in common (see :mod:`morphkit.motion.states`) and divides
lengths by the creature's body length ``length`` (:func:`morphkit.motion.scale.measured_body_length`: its
standing root height, so a standing creature's root is at 1 and its feet near -1):

===========================  ==========  ===================================================
block                        dims        value
===========================  ==========  ===================================================
``root_height``              1           root height / length
``root_orientation``         4           root orientation in the heading frame (xyzw)
``root_linear_velocity``     3           heading frame, / length [1/s]
``root_angular_velocity``    3           heading frame [rad/s]
``ee_positions``             3k          selected end-effectors, heading frame, / length
===========================  ==========  ===================================================

The same code runs on NumPy arrays and on torch tensors (slicing, division and concatenation
only), so the feature loss stays differentiable. To compare a human and a creature, select the
human's end-effectors in the order the mapping pairs them with the creature's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.errors import ConfigError
from morphkit.motion.scale import measured_body_length
from morphkit.motion.states import (
    StateLayout,
    character_state_from_motion,
    character_state_layout,
    human_state_from_motion,
    human_state_layout,
)

if TYPE_CHECKING:
    from morphkit.motion.motion import Motion

__all__ = ["ACTIVE_HAND", "ACTIVE_HAND_SOFTNESS", "GROUND_MOTION_FEATURES", "ROOT_FEATURE_DIM", "ActiveHand", "Pairing",
           "feature_dim", "features", "motion_features"]

ROOT_FEATURE_DIM = 11
"""Dimensions of Ψ before the end-effector block (height 1, orientation 4, velocities 6)."""
GROUND_MOTION_FEATURES = (5, 6, 10)
"""Ψ's root motion over the ground: heading-frame forward and sideways velocity [body lengths/s] and yaw rate
[rad/s] — where the character goes and where it turns."""


ACTIVE_HAND = "active_hand"
"""A virtual human end-effector (ours): of the human's hands, the one moved furthest from where it usually is.
A creature's lone hand or tool is paired with it (:func:`~morphkit.motion.ee_mapping.map_end_effectors`), so a
one-armed creature follows whichever hand acts — the wave of a left hand as well as the reach of a right one."""
ACTIVE_HAND_SOFTNESS = 0.05
"""[body lengths] Softness of the active hand's choice (ours): each hand's weight is a softmax of its distance from
its own mean position over this, so a hand 0.1 body lengths further out than the other takes 88 % of the weight,
and the choice moves smoothly from hand to hand."""


@dataclass(frozen=True)
class ActiveHand:
    """How Ψ's :data:`ACTIVE_HAND` block is formed from the human's hands.

    Per frame, each hand's heading-frame position / body length minus its mean over the human data (``means``)
    is its displacement $d_i$; the block is $\\sum_i w_i d_i$ with $w = \\mathrm{softmax}(\\|d_i\\| / s)$,
    ``s`` = :attr:`softness`. A hand marked in ``mirror`` has its lateral (y) displacement negated, so that a
    creature's tool on one side moves outward when either hand does.
    """

    hands: tuple[str, ...]
    """The human's hand end-effectors."""
    means: tuple[float, ...] | None = None
    """Each hand's mean Ψ position over the human data [3 h] (``None``: displacements from the root)."""
    mirror: tuple[bool, ...] = ()
    """Per hand, whether its lateral displacement is negated (empty: none)."""
    softness: float = ACTIVE_HAND_SOFTNESS

    def __post_init__(self) -> None:
        object.__setattr__(self, "hands", tuple(self.hands))
        object.__setattr__(self, "mirror", tuple(bool(v) for v in self.mirror) or (False,) * len(self.hands))
        if self.means is not None:
            object.__setattr__(self, "means", tuple(float(v) for v in self.means))
        if len(self.hands) < 2:
            raise ConfigError(f"an active hand needs two or more human hands, got {list(self.hands)}")
        if len(self.mirror) != len(self.hands) or (self.means is not None and len(self.means) != 3 * len(self.hands)):
            raise ConfigError("ActiveHand: mirror needs one flag and means three values per hand")
        if not self.softness > 0:
            raise ConfigError(f"ActiveHand.softness must be > 0, got {self.softness!r}")

    def block(self, state: Any, layout: StateLayout, inv: float) -> Any:
        """The active hand's Ψ block [..., 3] of states [..., layout.dim] (NumPy or torch, not normalised)."""
        d = _centred(state[..., _ee_columns(layout, self.hands)] * inv, self.means)
        sign = np.ones(3 * len(self.hands))
        sign[[3 * i + 1 for i, m in enumerate(self.mirror) if m]] = -1.0
        if isinstance(d, np.ndarray):
            d = (d * sign).reshape(*d.shape[:-1], len(self.hands), 3)
            a = np.linalg.norm(d, axis=-1) / self.softness
            w = np.exp(a - a.max(axis=-1, keepdims=True))
            return (w[..., None] * d).sum(axis=-2) / w.sum(axis=-1)[..., None]
        import torch

        d = (d * torch.as_tensor(sign, dtype=d.dtype, device=d.device)).unflatten(-1, (len(self.hands), 3))
        w = torch.softmax(d.norm(dim=-1) / self.softness, dim=-1)
        return (w.unsqueeze(-1) * d).sum(dim=-2)


def feature_dim(ee_count: int) -> int:
    """Length of Ψ with ``ee_count`` selected end-effectors."""
    return ROOT_FEATURE_DIM + 3 * ee_count


def _ee_columns(layout: StateLayout, ee_names: Sequence[str] | None) -> list[int]:
    start = layout.slice("ee_positions").start
    if ee_names is None:
        idx = range(len(layout.ee_names))
    else:
        idx = []
        for n in ee_names:
            if n not in layout.ee_names:
                raise ConfigError(f"no end-effector {n!r} in the state (end-effectors: {', '.join(layout.ee_names)})")
            idx.append(layout.ee_names.index(n))
    return [start + 3 * i + k for i in idx for k in range(3)]


def _cat(parts: list[Any]) -> Any:
    if isinstance(parts[0], np.ndarray):
        return np.concatenate(parts, axis=-1)
    import torch

    return torch.cat(parts, dim=-1)


def _centred(ee: Any, centre: Sequence[float] | None) -> Any:
    if centre is None:
        return ee
    if isinstance(ee, np.ndarray):
        return ee - np.asarray(centre, dtype=ee.dtype)
    import torch

    return ee - torch.as_tensor(centre, dtype=ee.dtype, device=ee.device)


def features(state: Any, layout: StateLayout, *, length: float, ee_names: Sequence[str] | None = None,
             centre: Sequence[float] | None = None, active_hand: ActiveHand | None = None,
             height_centre: float | None = None) -> Any:
    """Ψ of states (see the module docstring).

    Args:
        state: States [..., layout.dim] (NumPy array or torch tensor, not normalised).
        layout: The states' layout (human or character).
        length: Body length [m] the lengths are divided by.
        ee_names: End-effectors to include, in this order (default: all, in layout order).
        centre: Subtracted from the end-effector block after dividing by ``length`` [3 k] (the side's
            mean over its own data set: :attr:`Pairing.creature_centre`); ``None``: not centred.
        active_hand: How an :data:`ACTIVE_HAND` in ``ee_names`` is formed (needed when one is).
        height_centre: Subtracted from the root height after dividing by ``length`` (the side's mean over its
            own data set: :attr:`Pairing.creature_height_centre`); ``None``: not centred.

    Returns:
        [..., 11 + 3 k] features, same type as ``state``.

    Raises:
        ConfigError: an unknown end-effector name, a non-positive length, or an :data:`ACTIVE_HAND` without
            ``active_hand``.
    """
    if not length > 0:
        raise ConfigError(f"body length must be > 0, got {length!r}")
    inv = 1.0 / float(length)
    if ee_names is not None and ACTIVE_HAND in ee_names:
        if active_hand is None:
            raise ConfigError(f"Ψ of {ACTIVE_HAND!r} needs the human's hands (Pairing.active_hand)")
        ee = _cat([active_hand.block(state, layout, inv) if n == ACTIVE_HAND
                   else state[..., _ee_columns(layout, [n])] * inv for n in ee_names])
    else:
        ee = state[..., _ee_columns(layout, ee_names)] * inv
    height = state[..., layout.slice("root_height")] * inv
    parts = [
        height if height_centre is None else height - float(height_centre),
        state[..., layout.slice("root_orientation")],
        state[..., layout.slice("root_linear_velocity")] * inv,
        state[..., layout.slice("root_angular_velocity")],
        _centred(ee, centre),
    ]
    return _cat(parts)


def motion_features(
    motion: Motion, *, ee_names: Sequence[str] | None = None, length: float | None = None,
    centre: Sequence[float] | None = None,
) -> np.ndarray:
    """Ψ of every frame of a motion, shape [T, 11 + 3 k].

    Args:
        motion: The motion.
        ee_names: End-effectors to include, in this order (default: all).
        length: Body length [m] (default: :func:`~morphkit.motion.scale.measured_body_length` of the
            morphology, measured on this motion; pass one length for every clip of a data set).
        centre: See :func:`features`.
    """
    layout = character_state_layout(motion.morphology)
    state = character_state_from_motion(motion)
    body = measured_body_length(motion.morphology, motion) if length is None else length
    return features(state, layout, length=body, ee_names=ee_names, centre=centre)


@dataclass(frozen=True)
class Pairing:
    """How a creature's Ψ and a human's Ψ are compared: mapped end-effectors, pair by pair, and the
    body length each side divides by (ACE §6.3, Eq. 9–11).

    One value for training (the feature loss), retargeting and evaluation (L_fea, FID, DIV), so the
    three measure the same Ψ.
    """

    creature_ees: tuple[str, ...]
    """Creature end-effectors in Ψ's order."""
    human_ees: tuple[str, ...]
    """The human end-effector paired with each of ``creature_ees`` (same order)."""
    creature_length: float
    """The creature's body length [m] (:func:`~morphkit.motion.scale.measured_body_length` on its data set)."""
    human_length: float
    """The human's body length [m] (on the human data the run was trained on)."""
    creature_centre: tuple[float, ...] | None = None
    """Mean of the creature's Ψ end-effector block over its own data set [3k] (body lengths, heading
    frame), subtracted from it (``None``: Ψ not centred, as the paper and runs before centring)."""
    human_centre: tuple[float, ...] | None = None
    """The same for the human side, over the human data."""
    creature_height_centre: float | None = None
    """Mean of the creature's Ψ root height over its own data set (body lengths), subtracted from it (``None``: not
    centred, as the paper and runs before it)."""
    human_height_centre: float | None = None
    """The same for the human side, over the human data."""
    active_hand: ActiveHand | None = None
    """How the human's :data:`ACTIVE_HAND` is formed, when ``human_ees`` holds it (its hands' means set by
    :meth:`with_centres`)."""

    def __post_init__(self) -> None:
        if len(self.creature_ees) != len(self.human_ees):
            raise ConfigError(f"a pairing needs as many human end-effectors ({len(self.human_ees)}) as creature "
                              f"ones ({len(self.creature_ees)})")
        object.__setattr__(self, "creature_ees", tuple(self.creature_ees))
        object.__setattr__(self, "human_ees", tuple(self.human_ees))
        object.__setattr__(self, "creature_length", float(self.creature_length))
        object.__setattr__(self, "human_length", float(self.human_length))
        for name in ("creature_centre", "human_centre"):
            value = getattr(self, name)
            if value is not None:
                value = tuple(float(v) for v in value)
                if len(value) != 3 * len(self.creature_ees):
                    raise ConfigError(f"Pairing.{name} needs {3 * len(self.creature_ees)} values, got {len(value)}")
                object.__setattr__(self, name, value)
        for name in ("creature_height_centre", "human_height_centre"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, float(value))
        if ACTIVE_HAND in self.human_ees and self.active_hand is None:
            raise ConfigError(f"a pairing with {ACTIVE_HAND!r} needs its ActiveHand (the human's hands)")

    @property
    def centred(self) -> bool:
        """Whether both sides' end-effector blocks are centred."""
        return self.creature_centre is not None and self.human_centre is not None

    @property
    def height_centred(self) -> bool:
        """Whether both sides' root heights are centred."""
        return self.creature_height_centre is not None and self.human_height_centre is not None

    def with_centres(self, creature: Sequence[Motion], human: Sequence[Motion]) -> Pairing:
        """This pairing centred on data sets: each side's mean end-effector block and root height over its own
        motions.

        Centring removes the floor that the two bodies' different stances put under the feature
        loss (a quadruped's feet stand ahead of and behind its root, a human's under it; a wheeled robot's
        root sits on the ground, a human's one body length above it): what is compared is how end-effectors
        move about where they usually are, and how far the body rises or crouches from its usual height.
        """
        plain = dataclasses.replace(self, creature_centre=None, human_centre=None, creature_height_centre=None,
                                    human_height_centre=None)
        states = [(human_state_from_motion(m), human_state_layout(m.morphology)) for m in human]
        if plain.active_hand is not None:  # the hands' own means first: the active hand is chosen by distance from them
            hands = dataclasses.replace(plain.active_hand, means=None)
            means = np.concatenate([features(x, layout, length=self.human_length, ee_names=hands.hands)
                                    for x, layout in states])[:, ROOT_FEATURE_DIM:].mean(axis=0)
            plain = dataclasses.replace(plain, active_hand=dataclasses.replace(hands, means=tuple(means.tolist())))
        c = np.concatenate([plain.creature_psi(m) for m in creature]).mean(axis=0)
        h = np.concatenate([plain.human_psi_of_states(x, layout) for x, layout in states]).mean(axis=0)
        return dataclasses.replace(self, creature_centre=tuple(c[ROOT_FEATURE_DIM:].tolist()),
                                   human_centre=tuple(h[ROOT_FEATURE_DIM:].tolist()),
                                   creature_height_centre=float(c[0]), human_height_centre=float(h[0]),
                                   active_hand=plain.active_hand)

    @staticmethod
    def from_mapping(mapping: Mapping[str, str], creature_length: float, human_length: float,
                     active_hand: ActiveHand | None = None) -> Pairing:
        """The (uncentred) pairing of ``{creature_ee: human_ee}`` (an :attr:`EndEffectorMapping.mapping`, with
        its :attr:`~EndEffectorMapping.active_hand` when it pairs one)."""
        return Pairing(tuple(mapping), tuple(mapping.values()), creature_length, human_length,
                       active_hand=active_hand if ACTIVE_HAND in mapping.values() else None)

    @property
    def mapping(self) -> dict[str, str]:
        """``{creature_ee: human_ee}``."""
        return dict(zip(self.creature_ees, self.human_ees, strict=True))

    def creature_psi(self, motion: Motion) -> np.ndarray:
        """Ψ of a creature motion's frames [T, 11 + 3k] (end-effectors through FK)."""
        return self.creature_psi_of_states(character_state_from_motion(motion),
                                           character_state_layout(motion.morphology))

    def creature_psi_of_states(self, state: Any, layout: StateLayout) -> Any:
        """Ψ of creature states [..., layout.dim] (not normalised; NumPy or torch; end-effectors as the states hold
        them) → [..., 11 + 3k]."""
        return features(state, layout, length=self.creature_length, ee_names=self.creature_ees,
                        centre=self.creature_centre, height_centre=self.creature_height_centre)

    def human_psi(self, motion: Motion) -> np.ndarray:
        """Ψ of a human motion's frames [T, 11 + 3k], its end-effectors in the creature's order."""
        return self.human_psi_of_states(human_state_from_motion(motion), human_state_layout(motion.morphology))

    def human_psi_of_states(self, state: Any, layout: StateLayout) -> Any:
        """Ψ of human states [..., layout.dim] (not normalised; NumPy or torch) → [..., 11 + 3k], end-effectors in
        the creature's order."""
        return features(state, layout, length=self.human_length, ee_names=self.human_ees, centre=self.human_centre,
                        active_hand=self.active_hand, height_centre=self.human_height_centre)
