"""The content-matched reference set on constructed data whose answers are known by construction."""

from __future__ import annotations

import numpy as np
import pytest
from _metric_creatures import biped_motion, metric_biped
from scipy import stats

from morphkit.errors import ConfigError
from morphkit.metrics import MatchedSample, fid, matched_indices, matched_reference, motion_content
from morphkit.motion import motion_features

D = 17  # Ψ with two end-effectors: 11 root features + 6


def _psi(n: int, cluster: str, seed: int) -> np.ndarray:
    """n Ψ rows [n, D] of a standing or walking cluster: velocities written at Ψ's documented offsets
    (linear x, y, z at 5:8; angular x, y, z at 8:11), every other feature from a per-cluster Gaussian."""
    rng = np.random.default_rng(seed)
    scale = np.linspace(0.3, 1.2, D)
    if cluster == "standing":
        psi = 0.5 + scale * rng.normal(size=(n, D))
        psi[:, 5:8] = rng.normal(0.0, 0.02, size=(n, 3))
        psi[:, 10] = rng.normal(0.0, 0.03, size=n)
    else:
        psi = -1.5 + scale[::-1] * 1.5 * rng.normal(size=(n, D))
        psi[:, 5] = rng.normal(1.0, 0.15, size=n)
        psi[:, 6] = rng.normal(0.0, 0.1, size=n)
        psi[:, 10] = rng.normal(0.0, 0.6, size=n)
    return psi


def _content(points: list[tuple[float, float]]) -> np.ndarray:
    return np.array(points, dtype=np.float64)


# ---- motion_content -----------------------------------------------------------------------------
def test_motion_content_reads_speed_and_yaw_rate_of_a_moving_turning_motion():
    # The biped glides along world x at 1.2 m/s while turning at 0.8 rad/s: whatever its heading, the
    # horizontal speed is 1.2 m/s, i.e. 0.6 body lengths/s with a length of 2 m, and the yaw rate 0.8.
    m = metric_biped()
    t = np.arange(60) / 30.0
    motion = biped_motion(m, 60, base_x=1.2 * t, base_qz=np.sin(0.4 * t), base_qw=np.cos(0.4 * t))
    content = motion_content(motion_features(motion, length=2.0))
    assert content.shape == (60, 2)
    np.testing.assert_allclose(content[5:-5, 0], 0.6, atol=1e-3)
    np.testing.assert_allclose(content[5:-5, 1], 0.8, atol=1e-3)


def test_motion_content_keeps_leading_dims_and_rejects_short_psi():
    psi = np.zeros((2, 3, D))
    psi[..., 5], psi[..., 6], psi[..., 10] = 3.0, -4.0, -0.25
    np.testing.assert_array_equal(motion_content(psi), np.tile([5.0, -0.25], (2, 3, 1)))
    with pytest.raises(ConfigError, match="D >= 11"):
        motion_content(np.zeros((4, 10)))


# ---- matching -----------------------------------------------------------------------------------
def test_a_standing_query_draws_standing_reference_frames_and_fid_then_rewards_standing():
    n = 4000
    reference = np.concatenate([_psi(n, "standing", 1), _psi(n, "walking", 2)])  # rows < n stand
    query = _psi(3000, "standing", 3)
    fresh = _psi(3000, "standing", 4)  # an independent standing sample to measure FID against
    matched, sample = matched_reference(reference, query, seed=5)
    assert matched.shape == (3000, D)
    assert sample.size == 3000 and not sample.fallback
    assert sample.coverage > 0.95
    assert np.mean(sample.indices < n) >= 0.99
    np.testing.assert_array_equal(matched, reference[sample.indices])
    assert fid(matched, fresh) < 0.5
    assert fid(reference, fresh) > 5.0


def test_the_matched_sample_has_the_query_content_histogram():
    # Reference: uniform over speed [0, 2] and yaw [-2, 2]; query: mostly slow, turning little.
    rng = np.random.default_rng(10)
    reference = np.column_stack([rng.uniform(0, 2, 200_000), rng.uniform(-2, 2, 200_000)])
    query = np.column_stack([np.minimum(rng.exponential(0.2, 5000), 1.9), rng.normal(0, 0.3, 5000)])

    # Coarse bins: the unweighted in-range reference is far from the query, the matched sample is not.
    sample = matched_indices(reference, query, size=20_000, bins=(4, 4), seed=11)
    assert sample.coverage == 1.0 and len(sample.indices) == 20_000
    edges = (sample.speed_edges, sample.yaw_edges)
    want = np.histogram2d(query[:, 0], query[:, 1], bins=edges)[0] / len(query)
    got = np.histogram2d(*reference[sample.indices].T, bins=edges)[0] / 20_000
    plain = np.histogram2d(*reference.T, bins=edges)[0]
    assert np.abs(got - want).max() < 0.03
    assert np.abs(plain / plain.sum() - want).max() > 0.1
    assert np.median(reference[sample.indices, 0]) == pytest.approx(np.median(query[:, 0]), rel=0.1)
    assert np.median(reference[:, 0]) > 0.9

    # Default 12 x 12 bins: the drawn counts fit the query's shares (chi-square, 143 degrees of freedom).
    sample = matched_indices(reference, query, size=20_000, seed=12)
    assert sample.coverage == 1.0
    edges = (sample.speed_edges, sample.yaw_edges)
    assert len(edges[0]) == len(edges[1]) == 13
    want = (np.histogram2d(query[:, 0], query[:, 1], bins=edges)[0] / len(query)).ravel()
    got = np.histogram2d(*reference[sample.indices].T, bins=edges)[0].ravel()
    used = want > 0
    assert got[~used].sum() == 0
    chi2 = float((((got - 20_000 * want) ** 2)[used] / (20_000 * want[used])).sum())
    assert stats.chi2.sf(chi2, used.sum() - 1) > 1e-3


# Ten query frames in four quadrants of (speed, yaw): median speed 0.75, median yaw 0, so with 2 x 2
# bins each quadrant is one bin, whatever quantile convention splits the middle gap.
QUERY = _content([
    (0.1, -0.9), (0.2, -0.5), (0.3, -0.3),   # slow, turning right: 3
    (0.4, 0.3), (0.5, 0.8),                  # slow, turning left: 2
    (1.0, -0.8), (1.2, -0.4),                # fast, turning right: 2
    (1.1, 0.4), (1.3, 0.6), (1.5, 0.9),      # fast, turning left: 3 (no reference frame here)
])
REFERENCE = _content([
    (0.25, -0.5), (0.2, -0.6),               # 0, 1: slow right
    (0.3, 0.5), (0.35, 0.4), (0.3, 0.6),     # 2, 3, 4: slow left
    (1.2, -0.5),                             # 5: fast right
    (5.0, 0.0), (0.3, 3.0),                  # 6, 7: faster / turning harder than any query frame
])


def test_coverage_counts_the_query_frames_whose_bin_the_reference_misses():
    sample = matched_indices(REFERENCE, QUERY, size=70_000, bins=(2, 2), seed=0)
    assert isinstance(sample, MatchedSample)
    assert sample.coverage == pytest.approx(7 / 10)  # the 3 fast-left query frames are unmatched
    counts = np.bincount(sample.indices, minlength=len(REFERENCE)) / 70_000
    # Bin shares renormalised over the covered bins: 3/7, 2/7, 2/7, split evenly within a bin.
    np.testing.assert_allclose(counts[:6], [3 / 14, 3 / 14, 2 / 21, 2 / 21, 2 / 21, 2 / 7], atol=0.01)
    assert counts[6:].sum() == 0  # outside the query's range: never drawn


def test_full_coverage_determinism_and_default_size():
    sample = matched_indices(QUERY, QUERY, seed=3)
    assert sample.coverage == 1.0 and sample.size == len(sample.indices) == len(QUERY)
    again = matched_indices(QUERY, QUERY, seed=3)
    np.testing.assert_array_equal(sample.indices, again.indices)
    big = [matched_indices(REFERENCE, QUERY, size=500, bins=(2, 2), seed=s).indices for s in (1, 1, 2)]
    np.testing.assert_array_equal(big[0], big[1])
    assert not np.array_equal(big[0], big[2])


def test_a_disjoint_reference_falls_back_to_the_nearest_frames():
    reference = _content([(5.0, 0.0), (5.0, 1.0), (9.0, 0.0)])
    query = _content([(0.1, 1.0), (0.2, 0.0), (0.15, 1.0), (0.1, 0.05)])  # nearest: 1, 0, 1, 0
    with pytest.warns(UserWarning, match="nearest in content"):
        sample = matched_indices(reference, query, size=400, seed=0)
    assert sample.fallback and sample.coverage == 0.0 and sample.size == 400
    assert set(np.unique(sample.indices)) == {0, 1}
    with pytest.warns(UserWarning, match="nearest in content"):
        again = matched_indices(reference, query, size=400, seed=0)
    np.testing.assert_array_equal(sample.indices, again.indices)


@pytest.mark.parametrize(("reference", "query", "kwargs", "match"), [
    (np.zeros((0, 2)), QUERY, {}, "no frames"),
    (REFERENCE, np.zeros((5, 3)), {}, r"shape \[T, 2\]"),
    (REFERENCE, np.array([[0.0, np.nan]]), {}, "non-finite"),
    (REFERENCE, QUERY, {"size": 0}, "size"),
    (REFERENCE, QUERY, {"bins": (0, 3)}, "bins"),
])
def test_matched_indices_rejects_bad_input(reference, query, kwargs, match):
    with pytest.raises(ConfigError, match=match):
        matched_indices(reference, query, **kwargs)
