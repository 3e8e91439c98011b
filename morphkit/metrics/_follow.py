"""How well a creature's motion follows a human's: Pearson correlations of paired 1-D series.

The series are whatever the caller pairs (e.g. the human's pelvis height and the creature's body
height, per frame); each pair must have the same length (the same frames).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from morphkit.errors import ConfigError

__all__ = ["CONSTANT_SERIES_RTOL", "FollowScore", "follow_gain", "follow_score", "pearson_follow", "reachable_gain"]

CONSTANT_SERIES_RTOL = 1e-9
"""A series is constant when its standard deviation is at most this times its largest magnitude."""


def _series(x: object, who: str, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1 or a.size == 0:
        raise ConfigError(f"{who}: {name} must be a non-empty 1-D series, got shape {list(a.shape)}")
    if not np.isfinite(a).all():
        raise ConfigError(f"{who}: {name} has a non-finite value")
    return a


def _pair(a: object, b: object, who: str) -> tuple[np.ndarray, np.ndarray]:
    x, y = _series(a, who, "a"), _series(b, who, "b")
    if x.shape != y.shape:
        raise ConfigError(f"{who}: series of different lengths {x.size} and {y.size}")
    return x, y


def _is_constant(a: np.ndarray) -> bool:
    return bool(a.std() <= CONSTANT_SERIES_RTOL * np.abs(a).max())


def pearson_follow(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two 1-D series of equal length, with the constant case defined.

    $r = \\sum_t (a_t - \\bar a)(b_t - \\bar b) / \\sqrt{\\sum_t (a_t - \\bar a)^2 \\sum_t (b_t - \\bar b)^2}$,
    clipped to [-1, 1]. A series is *constant* when its (population) standard deviation is at most
    :data:`CONSTANT_SERIES_RTOL` (1e-9) times its largest magnitude $\\max_t |a_t|$ (a single
    sample is constant). Then, our choice: both constant and equal (means within the same relative
    tolerance of the larger magnitude) → 1.0; otherwise either constant → 0.0 (nothing follows).

    Args:
        a: Series [T] (e.g. the human's).
        b: Series [T] (e.g. the creature's), the same frames.

    Returns:
        The correlation in [-1, 1].

    Raises:
        ConfigError: not 1-D, empty, different lengths, or a non-finite value.
    """
    x, y = _pair(a, b, "pearson_follow")
    cx, cy = _is_constant(x), _is_constant(y)
    if cx and cy:
        mx, my = x.mean(), y.mean()
        return 1.0 if abs(mx - my) <= CONSTANT_SERIES_RTOL * max(abs(mx), abs(my)) else 0.0
    if cx or cy:
        return 0.0
    dx, dy = x - x.mean(), y - y.mean()
    r = float(dx @ dy / np.sqrt((dx @ dx) * (dy @ dy)))
    return min(1.0, max(-1.0, r))


def follow_gain(a: np.ndarray, b: np.ndarray) -> float | None:
    """How much of ``a`` ``b`` does: the least-squares slope of ``b`` on ``a`` through the origin.

    $g = \\sum_t a_t b_t / \\sum_t a_t^2$. A correlation does not see amplitude: a creature that turns a tenth
    as fast as the human, the same way, correlates as well as one that turns as fast. For a yaw rate (the same
    unit for any two bodies) 1 turns through the human's angle, 0 not at all, a negative gain the other way.

    Args:
        a: Series [T] (e.g. the human's yaw rate, clips concatenated).
        b: Series [T] (the creature's), the same frames.

    Returns:
        The gain, or ``None`` when ``a`` is zero throughout (nothing to follow).

    Raises:
        ConfigError: not 1-D, empty, different lengths, or a non-finite value.
    """
    x, y = _pair(a, b, "follow_gain")
    power = float(x @ x)
    return None if power == 0.0 else float(x @ y) / power


def reachable_gain(a: np.ndarray, limit: float) -> float | None:
    """The :func:`follow_gain` of a series that does ``a`` exactly within ±``limit`` and holds ±``limit`` beyond it.

    $g = \\sum_t a_t \\, \\mathrm{clip}(a_t, -L, L) / \\sum_t a_t^2$: how much of ``a`` a body whose rate is
    bounded at ``limit`` can do by copying it (e.g. the human's yaw rate against the fastest turn in a creature's
    data). Not a ceiling on :func:`follow_gain` (a body may turn faster than its data, or slower and longer), but
    the scale a creature's turn gain is read against: 1 when ``limit`` covers all of ``a``.

    Args:
        a: Series [T] (e.g. the human's yaw rate, clips concatenated).
        limit: The bound (> 0), in ``a``'s unit.

    Returns:
        The gain in (0, 1], or ``None`` when ``a`` is zero throughout.

    Raises:
        ConfigError: ``a`` not a non-empty finite 1-D series, or ``limit`` not a positive finite number.
    """
    x = _series(a, "reachable_gain", "a")
    if not (np.isfinite(limit) and limit > 0):
        raise ConfigError(f"reachable_gain: limit must be a positive finite number, got {limit!r}")
    return follow_gain(x, np.clip(x, -limit, limit))


@dataclass(frozen=True, eq=False)
class FollowScore:
    """Per-pair correlations of :func:`follow_score` and their mean."""

    correlations: Mapping[str, float]
    """:func:`pearson_follow` of each pair, by name (read-only, in the human series' order)."""
    mean: float
    """Unweighted mean of the correlations, in [-1, 1]."""


def follow_score(human_series: Mapping[str, np.ndarray], creature_series: Mapping[str, np.ndarray]) -> FollowScore:
    """Pearson correlation of each human series with the creature series of the same name, and their mean.

    Args:
        human_series: Named 1-D series [T_k] of the human motion.
        creature_series: The creature's series under the same names, each as long as the human's.

    Returns:
        The per-name correlations (:func:`pearson_follow`) and their unweighted mean.

    Raises:
        ConfigError: no pairs, the two mappings name different series, or a bad pair (see :func:`pearson_follow`).
    """
    if not human_series:
        raise ConfigError("follow_score: no series to compare")
    if set(human_series) != set(creature_series):
        missing = sorted(set(human_series) ^ set(creature_series))
        raise ConfigError(f"follow_score: human and creature series differ in names: {', '.join(map(str, missing))}")
    corr: dict[str, float] = {}
    for name, h in human_series.items():
        try:
            corr[name] = pearson_follow(h, creature_series[name])
        except ConfigError as e:
            raise ConfigError(f"follow_score: series {name!r}: {e.message}") from e
    return FollowScore(MappingProxyType(corr), float(np.mean(list(corr.values()))))
