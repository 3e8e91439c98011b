"""A content-matched reference set for FID and DIV: the creature's data frames resampled so that their
root speed and yaw rate are distributed as in the evaluated (human) clips.

FID against the creature's whole data set compares retargeted motion with locomotion at random
commands; held-out human clips mostly stand, bend and reach, so that FID rewards moving rather than
retargeting. Matching the reference's *motion content* (how fast the root travels and turns) to the
query's removes that bias, so FID and DIV measure how creature-like the motion looks for what it does.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphkit.errors import ConfigError
from morphkit.metrics._distribution import as_matrix
from morphkit.motion import GROUND_MOTION_FEATURES, ROOT_FEATURE_DIM

__all__ = ["MatchedSample", "matched_indices", "matched_reference", "motion_content"]

_HORIZONTAL_VELOCITY = slice(GROUND_MOTION_FEATURES[0], GROUND_MOTION_FEATURES[1] + 1)
"""Ψ's root linear velocity along the heading frame's x and y (ground plane) [body lengths/s]."""
_YAW_RATE = GROUND_MOTION_FEATURES[2]
"""Ψ's root angular velocity about the heading frame's z (world up) [rad/s]."""


def motion_content(psi: Any) -> np.ndarray:
    """Per-frame motion content of Ψ: horizontal root speed and yaw rate.

    Args:
        psi: Ψ of frames, shape [..., D] with D >= 11 (:func:`morphkit.motion.features`); NumPy or torch.

    Returns:
        [..., 2] float64: column 0 the root's speed in the ground plane [body lengths/s] (norm of
        the heading-frame x, y velocity), column 1 its yaw rate [rad/s] (signed; + turns left).

    Raises:
        ConfigError: fewer than 11 features.
    """
    if hasattr(psi, "detach") and hasattr(psi, "cpu"):  # a torch tensor, without importing torch here
        psi = psi.detach().cpu().numpy()
    x = np.asarray(psi, dtype=np.float64)
    if x.ndim < 1 or x.shape[-1] < ROOT_FEATURE_DIM:
        raise ConfigError(f"motion_content: expected Ψ of shape [..., D >= {ROOT_FEATURE_DIM}], got {list(x.shape)}")
    speed = np.linalg.norm(x[..., _HORIZONTAL_VELOCITY], axis=-1)
    return np.stack([speed, x[..., _YAW_RATE]], axis=-1)


@dataclass(frozen=True, eq=False)
class MatchedSample:
    """Reference frames drawn by :func:`matched_indices`, and how well they match the query."""

    indices: np.ndarray
    """[size] int64 indices into the reference frames (with repeats: drawn with replacement)."""
    coverage: float
    """Fraction of query frames whose (speed, yaw rate) bin holds at least one reference frame, in [0, 1];
    the other query frames cannot be matched and are left out of the target distribution."""
    size: int
    """Number of indices drawn."""
    fallback: bool
    """True when no bin was shared (coverage 0): ``indices`` are then the reference frames nearest in
    content to query frames drawn uniformly, not a histogram match."""
    speed_edges: np.ndarray
    """Bin edges over root speed [body lengths/s], increasing (at most ``bins[0] + 1``)."""
    yaw_edges: np.ndarray
    """Bin edges over yaw rate [rad/s], increasing (at most ``bins[1] + 1``)."""


def _content(x: Any, what: str) -> np.ndarray:
    c = np.asarray(x, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 2:
        raise ConfigError(f"{what}: expected content of shape [T, 2] (speed, yaw rate), got {list(c.shape)}")
    if c.shape[0] == 0:
        raise ConfigError(f"{what}: no frames")
    if not np.isfinite(c).all():
        raise ConfigError(f"{what}: non-finite value in frame {int(np.argwhere(~np.isfinite(c))[0, 0])}")
    return c


def _quantile_edges(x: np.ndarray, n: int) -> np.ndarray:
    """Edges at the quantiles 0, 1/n, ..., 1 of ``x``, ties merged (so possibly fewer than n + 1)."""
    return np.unique(np.quantile(x, np.linspace(0.0, 1.0, n + 1)))


def _bin(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of each value: [e_i, e_i+1), the last bin closed; a single edge e is the bin [e, e]; -1 outside."""
    last = max(len(edges) - 1, 1) - 1
    i = np.searchsorted(edges, x, side="right") - 1
    i = np.where(x == edges[-1], last, i)
    return np.where((x < edges[0]) | (x > edges[-1]), -1, i)


def _nearest(reference: np.ndarray, points: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    _, idx = cKDTree(reference).query(points)
    return np.asarray(idx, dtype=np.int64)


def matched_indices(
    reference_content: Any,
    query_content: Any,
    *,
    size: int | None = None,
    bins: tuple[int, int] = (12, 12),
    seed: int = 0,
) -> MatchedSample:
    """Reference frames drawn so that their (speed, yaw rate) histogram matches the query's.

    The choices that are ours:

    - **Bins**: a grid over (speed, yaw rate) whose edges, per axis, are the query's quantiles 0,
      1/n, ..., 1 (ties merged), so every bin holds about the same share of the query. Human
      clips crowd near zero speed with a long tail of walking; linear edges over the range would
      put nearly all of them in one bin and match nothing within it, quantile edges resolve the
      content where the query has it. The speed axis starts at 0 (the lowest possible speed) so
      a reference frame standing stiller than any query frame still counts as standing. Reference
      frames outside the query's range (faster, or turning harder, than any query frame) fall in
      no bin and are never drawn.
    - **Weights**: a reference frame in bin b weighs (query frames in b) / (reference frames in b),
      so the drawn frames' bin shares equal the query's, renormalised over the bins the reference
      covers; within a bin frames are drawn uniformly. Query frames in bins without reference
      frames cannot be matched and are left out; ``coverage`` says which share of the query is kept.
    - **Draws**: ``size`` indices with replacement from ``np.random.default_rng(seed)``.
    - **Fallback**: if no query bin holds a reference frame, each of ``size`` query frames drawn
      uniformly (same generator) takes the reference frame nearest to it in content (Euclidean in
      (body lengths/s, rad/s), unscaled); ``fallback`` is set and a :class:`UserWarning` says so.

    Args:
        reference_content: :func:`motion_content` of the reference (creature data) frames, [N_r, 2].
        query_content: :func:`motion_content` of the evaluated clips' frames, [N_q, 2].
        size: Number of indices to draw (default N_q).
        bins: Bins per axis (speed, yaw rate), each >= 1.
        seed: Seed of the generator the indices are drawn with.

    Returns:
        The indices, coverage, fallback flag and bin edges.

    Raises:
        ConfigError: empty, non-finite or wrongly shaped content; ``size`` or ``bins`` < 1.
    """
    ref = _content(reference_content, "matched_indices: reference_content")
    query = _content(query_content, "matched_indices: query_content")
    n_q = query.shape[0]
    size = n_q if size is None else size
    if int(size) != size or size < 1:
        raise ConfigError(f"matched_indices: size must be a positive integer, got {size!r}")
    size = int(size)
    if len(bins) != 2 or any(int(b) != b or b < 1 for b in bins):
        raise ConfigError(f"matched_indices: bins must be two positive integers, got {bins!r}")
    speed_edges = _quantile_edges(query[:, 0], int(bins[0]))
    speed_edges[0] = min(speed_edges[0], 0.0)
    yaw_edges = _quantile_edges(query[:, 1], int(bins[1]))
    n_yaw = max(len(yaw_edges) - 1, 1)
    n_bins = max(len(speed_edges) - 1, 1) * n_yaw

    def joint(c: np.ndarray) -> np.ndarray:
        s, y = _bin(c[:, 0], speed_edges), _bin(c[:, 1], yaw_edges)
        return np.where((s < 0) | (y < 0), -1, s * n_yaw + y)

    q_bin, r_bin = joint(query), joint(ref)
    q_count = np.bincount(q_bin, minlength=n_bins)  # every query frame is inside the query's edges
    inside = r_bin >= 0
    r_count = np.bincount(r_bin[inside], minlength=n_bins)
    coverage = float(q_count[r_count > 0].sum() / n_q)
    rng = np.random.default_rng(seed)
    if coverage == 0.0:
        warnings.warn(
            "matched_indices: no reference frame shares a (speed, yaw rate) bin with the query; "
            "using the reference frames nearest in content",
            stacklevel=2,
        )
        picks = rng.choice(n_q, size, replace=True)
        return MatchedSample(_nearest(ref, query[picks]), 0.0, size, True, speed_edges, yaw_edges)
    weights = np.zeros(ref.shape[0])
    weights[inside] = q_count[r_bin[inside]] / r_count[r_bin[inside]]
    indices = rng.choice(ref.shape[0], size, replace=True, p=weights / weights.sum())
    return MatchedSample(indices.astype(np.int64), coverage, size, False, speed_edges, yaw_edges)


def matched_reference(reference_psi: Any, query_psi: Any, **kw: Any) -> tuple[np.ndarray, MatchedSample]:
    """The reference's Ψ rows resampled to the query's motion content (:func:`matched_indices` on
    :func:`motion_content`), for :func:`~morphkit.metrics.fid` and :func:`~morphkit.metrics.diversity`.

    Args:
        reference_psi: Ψ of the creature's data frames, [N_r, D] (or [..., D]); NumPy or torch.
        query_psi: Ψ of the evaluated (human) frames, [N_q, D'] (or [..., D']); only the root blocks
            are read, so D' may differ from D.
        **kw: ``size``, ``bins`` and ``seed`` of :func:`matched_indices`.

    Returns:
        The drawn reference rows [size, D] (float64) and the sample.

    Raises:
        ConfigError: as :func:`matched_indices`, or Ψ with fewer than 11 features.
    """
    ref = as_matrix(reference_psi, "matched_reference: reference_psi")
    query = as_matrix(query_psi, "matched_reference: query_psi")
    sample = matched_indices(motion_content(ref), motion_content(query), **kw)
    return ref[sample.indices], sample
