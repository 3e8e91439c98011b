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
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.errors import ConfigError, SourceLocation
from morphkit.motion.features import ROOT_FEATURE_DIM, motion_features
from morphkit.motion.scale import body_length

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
            :func:`~morphkit.motion.scale.body_length` of the first clip's morphology, measured on
            all the clips together, so every clip shares it).

    Returns:
        ``{ee_name: Gaussian}`` in the morphology's end-effector order.

    Raises:
        ConfigError: no motion, a morphology without end-effectors, or clips that disagree on
            end-effector names.
    """
    motions = list(motions)
    if length is None and motions:
        length = body_length(motions[0].morphology, motions)
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
        mapping: ``{creature_ee: human_ee}`` in the creature's end-effector order.
        kl: ``{creature_ee: {human_ee: KL(p_r ‖ p_h)}}`` for every pair.
        overridden: Creature end-effectors whose mapping came from a manual override.
    """

    mapping: dict[str, str]
    kl: dict[str, dict[str, float]]
    overridden: frozenset[str] = field(default_factory=frozenset)

    def feature_order(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """``(creature_ees, human_ees)``: the end-effector lists Ψ takes, paired index by index.

        Pass the first as ``ee_names`` to the creature's :func:`~morphkit.motion.features` and the
        second to the human's, so both Ψ vectors put mapped end-effectors in the same slots.
        """
        return tuple(self.mapping), tuple(self.mapping.values())

    def to_json(self) -> dict[str, Any]:
        """``{"mapping": {...}, "kl": {...}}`` (plus ``"overridden"`` when any), JSON-serialisable."""
        out: dict[str, Any] = {"mapping": dict(self.mapping), "kl": {k: dict(v) for k, v in self.kl.items()}}
        if self.overridden:
            out["overridden"] = sorted(self.overridden)
        return out

    def format_table(self) -> str:
        """A text table: one row per creature end-effector, one column per human end-effector."""
        humans = list(next(iter(self.kl.values())).keys()) if self.kl else []
        w0 = max([len("creature ee"), *(len(c) for c in self.kl)])
        w = max([9, *(len(h) for h in humans)])
        lines = [
            f"{'creature ee':<{w0}}  {'-> human ee':<{w + 3}}  " + "  ".join(f"{h:>{w}}" for h in humans),
        ]
        for c, row in self.kl.items():
            mark = " *" if c in self.overridden else "  "
            target = self.mapping[c] + mark
            lines.append(
                f"{c:<{w0}}  {'-> ' + target:<{w + 3}}  " + "  ".join(f"{row[h]:>{w}.3f}" for h in humans)
            )
        if self.overridden:
            lines.append("* manual override")
        return "\n".join(lines)


def map_end_effectors(
    creature: Mapping[str, Gaussian],
    human: Mapping[str, Gaussian],
    *,
    override: Mapping[str, str] | None = None,
    roles: tuple[Mapping[str, Any], Mapping[str, Any]] | None = None,
) -> EndEffectorMapping:
    """Eq. 11: map each creature end-effector to ``argmin_i KL(p_r ‖ p_h_i)``.

    Args:
        creature: Distributions of the creature's end-effectors (:func:`ee_distributions`).
        human: Distributions of the human's (source's) end-effectors.
        override: ``{creature_ee: human_ee}`` pairs that replace the automatic choice.
        roles: ``(creature_roles, human_roles)``, ``{ee: EndEffectorRole}`` each: KL then chooses only
            among human end-effectors of a compatible role (foot → foot, head → head, hand or tool →
            hand), across roles only where the human has none of that role. ``None``: the paper's rule
            (KL only). KL alone depends on how spread each data set is: a narrow human foot
            distribution loses to a broad hand one even for a quadruped's feet.

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
    mapping = {c: override.get(c, min(_candidates(c, row, roles), key=row.__getitem__)) for c, row in kl.items()}
    return EndEffectorMapping(mapping, kl, frozenset(override))


def _role_group(role: Any) -> str:
    name = str(getattr(role, "name", role)).lower()
    return "hand" if name in ("hand", "tool") else name


def _candidates(
    c: str, row: Mapping[str, float], roles: tuple[Mapping[str, Any], Mapping[str, Any]] | None
) -> list[str]:
    if roles is None or c not in roles[0]:
        return list(row)
    want = _role_group(roles[0][c])
    same = [h for h in row if h in roles[1] and _role_group(roles[1][h]) == want]
    return same or list(row)


def read_override(path: str | os.PathLike[str]) -> dict[str, str]:
    """Read a manual mapping from YAML: ``{creature_ee: human_ee}``, optionally under a ``mapping:`` key.

    Example::

        mapping:
          gripper: lwrist

    Raises:
        ConfigError: unreadable file, malformed YAML or a value that is not a name.
    """
    import yaml

    where = SourceLocation(str(path))
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read override file: {exc.strerror or exc}", location=where) from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        raise ConfigError(f"malformed YAML: {getattr(exc, 'problem', exc)}", location=where.at_line(line)) from None
    if isinstance(doc, dict) and set(doc) == {"mapping"}:
        doc = doc["mapping"]
    if not isinstance(doc, dict):
        raise ConfigError("expected a mapping {creature_ee: human_ee}", location=where)
    out = {}
    for k, v in doc.items():
        if not isinstance(k, str) or not isinstance(v, str):
            line = _line_of(text, str(k))
            raise ConfigError(f"override {k!r}: {v!r} must map a name to a name", location=where.at_line(line))
        out[k] = v
    return out


def _line_of(text: str, key: str) -> int | None:
    for i, line in enumerate(text.splitlines(), start=1):
        if line.strip().startswith(f"{key}:"):
            return i
    return None
