"""Automatic end-effector correspondence between two creatures (ACE, Li et al. 2023, §5.3, Eq. 11).

Each end-effector's positions over a dataset — in the root's heading frame, divided by the
creature's body length, exactly the end-effector block of Ψ (:mod:`morphkit.motion.features`)
— are summarised by a Gaussian ``N(μ, Σ)``. Creature end-effector ``j`` maps to the human
end-effector ``i`` that minimises ``KL(p_r_j ‖ p_h_i)``:

.. math::

    KL(N_0 ‖ N_1) = ½ [ tr(Σ_1⁻¹ Σ_0) + (μ_1 - μ_0)ᵀ Σ_1⁻¹ (μ_1 - μ_0) - 3 + ln(det Σ_1 / det Σ_0) ].

Several creature end-effectors may map to one human end-effector (four feet to two). A manual
override (``{creature_ee: human_ee}``, from a dict or a small YAML file) replaces the automatic
choice for the end-effectors it names; the KL table is still reported for all of them.

Given both creatures' end-effector roles, the mapping respects them (morphkit's default; the
paper's KL-only rule stays available): a foot goes to a human foot, a head to the head, a hand or
tool to a hand, and KL chooses within the role — across all roles only where the human has none
of that role. Within a role the choice is one assignment of least total KL in which no human
end-effector takes two creature end-effectors while another of that role is free (two creature
hands go to both human hands; four feet share two, two each or three and one as KL prefers). Within
a role, KL is taken between distributions centred on their role group's mean, and left goes to left
(:func:`map_end_effectors`; ours, so that a crab's claws, far outside any human wrist, map by how
they move and to their own side).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.errors import ConfigError, SourceLocation
from morphkit.motion.features import ACTIVE_HAND, ROOT_FEATURE_DIM, ActiveHand, motion_features
from morphkit.motion.scale import measured_body_length
from morphkit.yaml_loader import MALFORMED, YamlMapping, load_yaml_file

if TYPE_CHECKING:
    from morphkit.motion.motion import Motion

__all__ = [
    "EndEffectorMapping",
    "Gaussian",
    "ee_distributions",
    "fit_gaussian",
    "kl_divergence",
    "map_end_effectors",
    "read_override",
]

DEFAULT_REGULARIZATION = 1e-4
"""Added to every covariance's diagonal (normalised units², i.e. a 1 % body-length floor on the
standard deviation) so an end-effector that never moves still has a proper density."""


@dataclass(frozen=True, eq=False)
class Gaussian:
    """A 3-D normal distribution of end-effector positions (heading frame, normalised)."""

    mean: np.ndarray
    """[3]."""
    cov: np.ndarray
    """[3, 3], symmetric positive definite."""
    count: int = 0
    """Number of samples it was fitted to."""


def fit_gaussian(samples: np.ndarray, *, regularization: float = DEFAULT_REGULARIZATION) -> Gaussian:
    """Maximum-likelihood Gaussian of samples [N, 3] with ``regularization`` added to the diagonal.

    Raises:
        ConfigError: if there are no samples.
    """
    x = np.asarray(samples, dtype=float).reshape(-1, 3)
    if x.shape[0] == 0:
        raise ConfigError("cannot fit a distribution to zero samples")
    mean = x.mean(axis=0)
    d = x - mean
    cov = d.T @ d / x.shape[0] + regularization * np.eye(3)
    return Gaussian(mean, cov, int(x.shape[0]))


def kl_divergence(p: Gaussian, q: Gaussian) -> float:
    """``KL(p ‖ q)`` of two Gaussians [nats] (see the module docstring)."""
    k = p.mean.shape[0]
    q_inv = np.linalg.inv(q.cov)
    diff = q.mean - p.mean
    _, logdet_p = np.linalg.slogdet(p.cov)
    _, logdet_q = np.linalg.slogdet(q.cov)
    return float(0.5 * (np.trace(q_inv @ p.cov) + diff @ q_inv @ diff - k + logdet_q - logdet_p))


def ee_distributions(
    motions: Iterable[Motion],
    *,
    max_frames_per_clip: int | None = None,
    regularization: float = DEFAULT_REGULARIZATION,
    length: float | None = None,
) -> dict[str, Gaussian]:
    """Fit a :class:`Gaussian` to each end-effector's positions over a dataset.

    Positions are the end-effector block of Ψ: heading frame, relative to the root, divided by
    the morphology's body length. All motions must share the end-effector names of the first.

    Args:
        motions: Clips of one creature.
        max_frames_per_clip: Use at most this many evenly spaced frames of each clip (speed).
        regularization: Diagonal added to each covariance (normalised units²).
        length: Body length [m] to normalise by (default:
            :func:`~morphkit.motion.scale.measured_body_length` of the first clip's morphology, measured on
            all the clips together, so every clip shares it).

    Returns:
        ``{ee_name: Gaussian}`` in the morphology's end-effector order.

    Raises:
        ConfigError: no motion, a morphology without end-effectors, or clips that disagree on
            end-effector names.
    """
    motions = list(motions)
    if length is None and motions:
        length = measured_body_length(motions[0].morphology, motions)
    names: tuple[str, ...] | None = None
    chunks: list[np.ndarray] = []
    for m in motions:
        ee = tuple(e.name for e in m.morphology.end_effectors)
        if not ee:
            raise ConfigError(f"morphology {m.morphology.name!r} has no end-effectors to map")
        if names is None:
            names = ee
        elif ee != names:
            raise ConfigError(f"clip {m.name!r} has end-effectors {list(ee)}, the first clip {list(names)}")
        if max_frames_per_clip is not None and m.frame_count > max_frames_per_clip:
            step = int(np.ceil(m.frame_count / max_frames_per_clip))
            # Keep the original fps for velocities: slice after computing features.
            psi = motion_features(m, length=length)[::step]
        else:
            psi = motion_features(m, length=length)
        chunks.append(psi[:, ROOT_FEATURE_DIM:].reshape(psi.shape[0], len(ee), 3))
    if names is None:
        raise ConfigError("no motions to fit end-effector distributions to")
    data = np.concatenate(chunks, axis=0)
    return {n: fit_gaussian(data[:, i], regularization=regularization) for i, n in enumerate(names)}


@dataclass(frozen=True)
class EndEffectorMapping:
    """Which human end-effector each creature end-effector follows, and the evidence.

    Attributes:
        mapping: ``{creature_ee: human_ee}`` in the creature's end-effector order: the chosen rule's
            mapping, manual overrides applied.
        kl: ``{creature_ee: {human_ee: KL(p_r ‖ p_h)}}`` for every pair.
        overridden: Creature end-effectors whose mapping came from a manual override.
        rule: ``"roles"`` (KL within compatible roles, one human end-effector per creature
            end-effector of a role while another is free) or ``"kl"`` (the paper's rule: KL alone).
        kl_only: The paper's rule, ``argmin_h KL`` per creature end-effector (overrides applied).
        by_role: The role-aware mapping (overrides applied); ``None`` when no roles were given.
        roles: ``{creature_ee: role name}`` when roles were given (``"foot"``, ``"hand"``, ...).
        active_hand: The human hands a lone creature hand or tool follows when it is mapped to
            :data:`~morphkit.motion.features.ACTIVE_HAND` (``None``: none is).
    """

    mapping: dict[str, str]
    kl: dict[str, dict[str, float]]
    overridden: frozenset[str] = field(default_factory=frozenset)
    rule: str = "kl"
    kl_only: dict[str, str] = field(default_factory=dict)
    by_role: dict[str, str] | None = None
    roles: dict[str, str] | None = None
    active_hand: ActiveHand | None = None

    def feature_order(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """``(creature_ees, human_ees)``: the end-effector lists Ψ takes, paired index by index.

        Pass the first as ``ee_names`` to the creature's :func:`~morphkit.motion.features` and the
        second to the human's, so both Ψ vectors put mapped end-effectors in the same slots.
        """
        return tuple(self.mapping), tuple(self.mapping.values())

    def to_json(self) -> dict[str, Any]:
        """``{"mapping", "rule", "kl_only", "kl"}`` plus ``"by_role"`` and ``"roles"`` when roles were
        given and ``"overridden"`` when any, JSON-serialisable."""
        out: dict[str, Any] = {"mapping": dict(self.mapping), "rule": self.rule, "kl_only": dict(self.kl_only)}
        if self.by_role is not None:
            out["by_role"] = dict(self.by_role)
        if self.roles is not None:
            out["roles"] = dict(self.roles)
        out["kl"] = {k: dict(v) for k, v in self.kl.items()}
        if self.overridden:
            out["overridden"] = sorted(self.overridden)
        if self.active_hand is not None:
            out["active_hand"] = {"hands": list(self.active_hand.hands), "mirror": list(self.active_hand.mirror)}
        return out

    def format_table(self) -> str:
        """A text table: one row per creature end-effector, one column per human end-effector.

        With roles, a ``role`` column and the other rule's choice (``KL only`` or ``by role``) come
        after the chosen mapping; ``!`` marks rows where the two rules differ.
        """
        humans = list(next(iter(self.kl.values())).keys()) if self.kl else []
        w0 = max([len("creature ee"), *(len(c) for c in self.kl)])
        w = max([9, *(len(h) for h in humans)])
        other_name, other = ("KL only", self.kl_only) if self.rule == "roles" else ("by role", self.by_role or {})
        roles = self.roles or {}
        with_roles = bool(roles) and bool(other)
        wr = max([4, *(len(r) for r in roles.values())])
        head = f"{'creature ee':<{w0}}  "
        if with_roles:
            head += f"{'role':<{wr}}  "
        head += f"{'-> human ee':<{w + 5}}  "
        if with_roles:
            head += f"{other_name:<{w + 1}}  "
        lines = [head + "  ".join(f"{h:>{w}}" for h in humans)]
        for c, row in self.kl.items():
            mark = " *" if c in self.overridden else "  "
            line = f"{c:<{w0}}  "
            if with_roles:
                line += f"{roles.get(c, ''):<{wr}}  "
            line += f"{'-> ' + self.mapping[c] + mark:<{w + 5}}  "
            if with_roles:
                differs = "!" if other[c] != self.mapping[c] else " "
                line += f"{other[c] + differs:<{w + 1}}  "
            lines.append(line + "  ".join(f"{row[h]:>{w}.3f}" for h in humans))
        if with_roles:
            rule = "KL within roles" if self.rule == "roles" else "KL only (the paper's rule)"
            lines.append(f"mapping: {rule}; {other_name}: the other rule's choice (! where it differs)")
        if self.overridden:
            lines.append("* manual override")
        if self.active_hand is not None:
            hands = ", ".join(self.active_hand.hands)
            lines.append(f"{ACTIVE_HAND}: whichever of {hands} is moved furthest from where it usually is "
                         "(a lone hand or tool follows either hand)")
        return "\n".join(lines)


def map_end_effectors(
    creature: Mapping[str, Gaussian],
    human: Mapping[str, Gaussian],
    *,
    override: Mapping[str, str] | None = None,
    roles: tuple[Mapping[str, Any], Mapping[str, Any]] | None = None,
    kl_only: bool = False,
    active_hand: bool = False,
) -> EndEffectorMapping:
    """Eq. 11: map each creature end-effector to ``argmin_i KL(p_r ‖ p_h_i)``, within roles when given.

    Args:
        creature: Distributions of the creature's end-effectors (:func:`ee_distributions`).
        human: Distributions of the human's (source's) end-effectors.
        override: ``{creature_ee: human_ee}`` pairs that replace the automatic choice.
        roles: ``(creature_roles, human_roles)``, ``{ee: EndEffectorRole}`` each (or role names): KL then
            chooses only among human end-effectors of a compatible role (foot → foot, head → head, hand
            or tool → hand), across roles only where the human has none of that role, and never puts two
            creature end-effectors of one role on one human end-effector while another is free (see the
            module docstring). ``None``: the paper's rule (KL only). KL alone depends on how spread each
            data set is: a narrow human foot distribution loses to a broad hand one even for a
            quadruped's feet.
        kl_only: With ``roles``, still choose by the paper's rule (the role-aware mapping is kept in
            :attr:`EndEffectorMapping.by_role` for comparison).
        active_hand: With ``roles`` (ours): a creature's lone hand or tool (the only end-effector of its role
            group, not overridden) is mapped to :data:`~morphkit.motion.features.ACTIVE_HAND` — whichever of
            the human's two or more hands moves — instead of the one hand KL prefers; a tool on one side of
            the body takes the other side's hand mirrored (its lateral displacement negated).

    Raises:
        ConfigError: empty inputs, or an override naming an unknown end-effector (listing the valid ones).
    """
    if not creature or not human:
        raise ConfigError("both creatures need at least one end-effector to map")
    override = dict(override or {})
    for c, h in override.items():
        if c not in creature:
            raise ConfigError(f"override: no creature end-effector {c!r} (valid: {', '.join(creature)})")
        if h not in human:
            raise ConfigError(f"override: no human end-effector {h!r} (valid: {', '.join(human)})")
    kl = {c: {h: kl_divergence(pc, ph) for h, ph in human.items()} for c, pc in creature.items()}
    paper = {c: override.get(c, min(row, key=row.__getitem__)) for c, row in kl.items()}
    if roles is None:
        return EndEffectorMapping(dict(paper), kl, frozenset(override), "kl", paper)
    by_role = _assign_by_role(kl, roles, override, creature, human)
    lone = _lone_hand(roles, override, creature, human) if active_hand else None
    if lone is not None:
        by_role[lone[0]] = ACTIVE_HAND
    role_names = {c: _role_name(roles[0][c]) for c in kl if c in roles[0]}
    rule, chosen = ("kl", paper) if kl_only else ("roles", by_role)
    return EndEffectorMapping(dict(chosen), kl, frozenset(override), rule, paper, by_role, role_names,
                              None if kl_only or lone is None else lone[1])


def _lone_hand(roles: tuple[Mapping[str, Any], Mapping[str, Any]], override: Mapping[str, str],
               creature: Mapping[str, Gaussian], human: Mapping[str, Gaussian]) -> tuple[str, ActiveHand] | None:
    """The creature's lone hand or tool and the :class:`ActiveHand` it follows (``None``: no lone one, or the human
    has fewer than two hands)."""
    members = [c for c in creature if c in roles[0] and _role_group(roles[0][c]) == "hand"]
    hands = [h for h in human if h in roles[1] and _role_name(roles[1][h]) == "hand"]
    if len(members) != 1 or members[0] in override or len(hands) < 2:
        return None
    side = _side(creature[members[0]])
    return members[0], ActiveHand(tuple(hands), mirror=tuple(side != 0 and _side(human[h]) == -side for h in hands))


def _role_name(role: Any) -> str:
    return str(getattr(role, "name", role)).lower()


def _role_group(role: Any) -> str:
    name = _role_name(role)
    return "hand" if name in ("hand", "tool") else name


SIDE_TOLERANCE = 0.05
"""An end-effector whose mean lateral coordinate (heading frame, body lengths) is beyond ±this is on
the left (+y) or the right (−y); within it, in the middle (ours)."""
SIDE_PENALTY = 1e6
"""Added to the assignment cost of a left end-effector on a right one (or the reverse): chosen only
where no end-effector of its own side or the middle is left."""


def _side(g: Gaussian) -> int:
    y = float(g.mean[1])
    return 0 if abs(y) <= SIDE_TOLERANCE else (1 if y > 0 else -1)


def _shifted(g: Gaussian, offset: np.ndarray) -> Gaussian:
    return Gaussian(g.mean - offset, g.cov, g.count)


def _assign_by_role(
    kl: Mapping[str, Mapping[str, float]],
    roles: tuple[Mapping[str, Any], Mapping[str, Any]],
    override: Mapping[str, str],
    creature: Mapping[str, Gaussian],
    human: Mapping[str, Gaussian],
) -> dict[str, str]:
    """The role-aware mapping (module docstring): one least-total-cost assignment per role group.

    Within a group the cost is KL between the distributions **centred on their group's mean** (each
    side's members' means averaged), so a creature whose claws sit far outside the human's wrists is
    mapped by how its end-effectors spread and move, not by which human one happens to lie nearer;
    and a left end-effector goes to a left one (:data:`SIDE_TOLERANCE`, :data:`SIDE_PENALTY`), so a
    mirror-symmetric creature maps mirror-symmetrically. Overrides always win.
    """
    from scipy.optimize import linear_sum_assignment

    creature_roles, human_roles = roles
    humans = list(next(iter(kl.values())))
    groups: dict[str, list[str]] = {}
    out: dict[str, str] = {}
    for c in kl:
        if c in creature_roles:
            groups.setdefault(_role_group(creature_roles[c]), []).append(c)
        else:  # no role known: KL over all, as the paper
            out[c] = override.get(c, min(kl[c], key=kl[c].__getitem__))
    for group, members in groups.items():
        candidates = [h for h in humans if h in human_roles and _role_group(human_roles[h]) == group] or humans
        taken = {override[c] for c in members if c in override}
        out.update({c: override[c] for c in members if c in override})
        c_mid = np.mean([creature[c].mean for c in members], axis=0)
        h_mid = np.mean([human[h].mean for h in candidates], axis=0)
        members = [c for c in members if c not in override]
        free = [h for h in candidates if h not in taken] or candidates
        if not members:
            continue

        def cost_of(c: str, h: str, c_mid: np.ndarray = c_mid, h_mid: np.ndarray = h_mid) -> float:
            centred = kl_divergence(_shifted(creature[c], c_mid), _shifted(human[h], h_mid))
            return centred + (SIDE_PENALTY if _side(creature[c]) * _side(human[h]) < 0 else 0.0)

        cost = np.array([[cost_of(c, h) for h in free] for c in members])
        extra = len(members) - len(free)
        if extra > 0:
            # Every free end-effector takes one creature end-effector; the rest go wherever the cost
            # is least among the candidates (extra columns costing each row's best).
            best = np.array([min(cost_of(c, h) for h in candidates) for c in members])
            cost = np.concatenate([cost, np.repeat(best[:, None], extra, axis=1)], axis=1)
        rows, cols = linear_sum_assignment(cost)
        for r, k in zip(rows, cols, strict=True):
            c = members[r]
            out[c] = free[k] if k < len(free) else min(candidates, key=lambda h, c=c: cost_of(c, h))
    return {c: out[c] for c in kl}


def read_override(path: str | os.PathLike[str]) -> dict[str, str]:
    """Read a manual mapping from YAML: ``{creature_ee: human_ee}``, optionally under a ``mapping:`` key.

    Example::

        mapping:
          gripper: lwrist

    Raises:
        ConfigError: unreadable file, malformed YAML or a value that is not a name.
    """
    where = SourceLocation(str(path))
    doc = load_yaml_file(path, what="override file", malformed=MALFORMED)
    if isinstance(doc, dict) and set(doc) == {"mapping"}:
        doc = doc["mapping"]
    if not isinstance(doc, dict):
        raise ConfigError("expected a mapping {creature_ee: human_ee}", location=where)
    out = {}
    for k, v in doc.items():
        if not isinstance(k, str) or not isinstance(v, str):
            line = doc.key_lines.get(k) if isinstance(doc, YamlMapping) else None
            raise ConfigError(f"override {k!r}: {v!r} must map a name to a name", location=where.at_line(line))
        out[k] = v
    return out
