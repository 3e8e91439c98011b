"""DIV and FID on constructed sets whose answers are known in closed form."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from _metric_creatures import biped_motion as motion
from _metric_creatures import metric_biped

from morphkit.errors import ConfigError
from morphkit.metrics import DEFAULT_SUBSET_SIZE, diversity, fid, frechet_distance, gaussian_statistics
from morphkit.motion import motion_features


def _with_moments(mean: np.ndarray, cov: np.ndarray, n: int, seed: int) -> np.ndarray:
    """n samples [n, D] whose sample mean is ``mean`` and unbiased sample covariance is ``cov``, exactly."""
    rng = np.random.default_rng(seed)
    z = rng.normal(size=(n, len(mean)))
    z -= z.mean(axis=0)
    white = z @ np.linalg.inv(np.linalg.cholesky(np.atleast_2d(np.cov(z, rowvar=False)))).T  # sample covariance I
    return mean + white @ np.linalg.cholesky(cov).T


# ---- DIV ----------------------------------------------------------------------------------------
def test_diversity_of_a_constant_set_is_zero():
    psi = np.tile(np.array([0.3, -1.0, 2.0, 0.5]), (400, 1))
    assert diversity(psi, rng=0) == 0.0


def test_diversity_of_standard_normal_vectors_is_the_mean_pair_distance():
    # For independent X, X' ~ N(0, I_D): X - X' ~ N(0, 2 I_D), so E||X - X'|| = 2 Γ((D+1)/2) / Γ(D/2).
    D = 3
    psi = np.random.default_rng(1).normal(size=(20_000, D))
    expected = 2.0 * math.gamma((D + 1) / 2) / math.gamma(D / 2)  # 2.2568
    assert diversity(psi, subset_size=20_000, rng=2) == pytest.approx(expected, abs=0.03)
    assert diversity(psi, rng=2) == pytest.approx(expected, abs=0.2)  # S_d = 300: standard error ~0.05


def test_diversity_is_the_mean_distance_of_paired_draws():
    # Two points 5 apart, drawn with replacement: a pair differs with probability 1/2, so DIV -> 2.5.
    psi = np.array([[0.0, 0.0], [3.0, 4.0]])
    with pytest.warns(UserWarning, match="with replacement"):
        value = diversity(psi, subset_size=4000, rng=0)
    assert value == pytest.approx(2.5, abs=0.2)  # standard error 0.04


def test_diversity_is_reproducible_from_the_generator_and_accepts_torch():
    torch = pytest.importorskip("torch")
    psi = np.random.default_rng(3).normal(size=(500, 7))
    a = diversity(psi, rng=np.random.default_rng(11))
    assert diversity(psi, rng=11) == a
    assert diversity(torch.from_numpy(psi), rng=11) == a
    assert diversity(psi.reshape(50, 10, 7), rng=11) == a  # leading dims are frames
    assert DEFAULT_SUBSET_SIZE == 300


def test_diversity_with_fewer_vectors_than_the_subset_samples_with_replacement():
    psi = np.random.default_rng(4).normal(size=(20, 3))
    with pytest.warns(UserWarning, match="with replacement"):
        value = diversity(psi, rng=0)
    assert value > 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        diversity(psi, subset_size=20, rng=0)  # N = S_d: no warning


@pytest.mark.parametrize(("psi", "kwargs", "match"), [
    (np.zeros((0, 3)), {}, "no feature vectors"),
    (np.zeros(3), {}, r"shape \[\.\.\., D\]"),
    (np.array([[0.0, np.nan]]), {}, "non-finite"),
    (np.zeros((10, 3)), {"subset_size": 0}, "subset_size"),
])
def test_diversity_rejects_bad_input(psi, kwargs, match):
    with pytest.raises(ConfigError, match=match):
        diversity(psi, rng=0, **kwargs)


# ---- FID ----------------------------------------------------------------------------------------
def test_fid_of_identical_sets_is_zero():
    psi = np.random.default_rng(5).normal(size=(600, 23)) * np.linspace(0.1, 3.0, 23)
    assert abs(fid(psi, psi.copy())) < 1e-6


def test_fid_of_identical_rank_deficient_sets_takes_the_offset_fallback():
    # Fewer vectors than dimensions, and one constant dimension: a singular covariance product.
    psi = np.random.default_rng(6).normal(size=(8, 12))
    psi[:, 3] = 1.5
    with pytest.warns(UserWarning, match="adding 1e-06 to the diagonal"):
        value = fid(psi, psi)
    # The offset enters the root only: sqrt((Σ + εI)²) = Σ + εI, so d² = -2 D ε exactly.
    assert value == pytest.approx(-2 * 12 * 1e-6, abs=1e-8)


def test_fid_of_diagonal_gaussians_matches_the_closed_form():
    # Commuting (diagonal) covariances: d² = ||μa - μb||² + Σ_i (√a_i - √b_i)².
    mu_a, mu_b = np.array([0.0, 1.0, -2.0]), np.array([0.5, -1.0, 0.0])
    var_a, var_b = np.array([1.0, 4.0, 0.25]), np.array([9.0, 1.0, 0.25])
    expected = float(np.sum((mu_a - mu_b) ** 2) + np.sum((np.sqrt(var_a) - np.sqrt(var_b)) ** 2))  # 8.25 + 5
    real = _with_moments(mu_a, np.diag(var_a), 400, seed=7)
    fake = _with_moments(mu_b, np.diag(var_b), 900, seed=8)
    assert expected == pytest.approx(13.25)
    assert fid(real, fake) == pytest.approx(expected, rel=1e-9)
    assert fid(fake, real) == pytest.approx(expected, rel=1e-9)


def test_frechet_distance_of_non_commuting_2d_gaussians_matches_the_closed_form():
    # For 2x2 PSD A, B: the eigenvalues λ1, λ2 of AB are >= 0, so
    # Tr (AB)^½ = √λ1 + √λ2 = sqrt(tr(AB) + 2 sqrt(det A det B)).
    A = np.array([[2.0, 0.6], [0.6, 1.0]])
    c, s = math.cos(0.7), math.sin(0.7)
    R = np.array([[c, -s], [s, c]])
    B = R @ np.diag([3.0, 0.2]) @ R.T
    mu_a, mu_b = np.array([1.0, 2.0]), np.array([-0.5, 2.5])
    tr_root = math.sqrt(np.trace(A @ B) + 2 * math.sqrt(np.linalg.det(A) * np.linalg.det(B)))
    expected = float((mu_a - mu_b) @ (mu_a - mu_b) + np.trace(A) + np.trace(B) - 2 * tr_root)
    assert frechet_distance(mu_a, A, mu_b, B) == pytest.approx(expected, rel=1e-10)
    # and through samples with exactly these moments
    assert fid(_with_moments(mu_a, A, 50, 9), _with_moments(mu_b, B, 70, 10)) == pytest.approx(expected, rel=1e-9)


def test_fid_of_one_dimensional_gaussians():
    # D = 1: d² = (μa - μb)² + (σa - σb)².
    real = _with_moments(np.array([2.0]), np.array([[4.0]]), 100, 11)
    fake = _with_moments(np.array([-1.0]), np.array([[0.25]]), 100, 12)
    assert fid(real, fake) == pytest.approx(9.0 + 1.5**2, rel=1e-9)


def test_fid_accepts_torch_and_float32():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(13)
    a, b = rng.normal(size=(300, 5)), rng.normal(size=(300, 5)) + 0.3
    ref = fid(a, b)
    assert fid(torch.from_numpy(a), torch.from_numpy(b)) == pytest.approx(ref, rel=1e-12)
    assert fid(a.astype(np.float32), b.astype(np.float32)) == pytest.approx(ref, rel=1e-5)


def test_gaussian_statistics_are_the_mean_and_unbiased_covariance():
    x = np.array([[0.0, 1.0], [2.0, 1.0], [4.0, 4.0]])
    mu, sigma = gaussian_statistics(x)
    np.testing.assert_allclose(mu, [2.0, 2.0])
    np.testing.assert_allclose(sigma, [[4.0, 3.0], [3.0, 3.0]])  # divided by N - 1 = 2


def test_fid_rejects_bad_input():
    with pytest.raises(ConfigError, match="dimensions differ"):
        fid(np.zeros((5, 3)), np.zeros((5, 4)))
    with pytest.raises(ConfigError, match="at least 2"):
        fid(np.zeros((1, 3)), np.zeros((5, 3)))
    with pytest.raises(ConfigError, match="one D"):
        frechet_distance(np.zeros(2), np.eye(3), np.zeros(2), np.eye(2))
    with pytest.raises(ConfigError, match="imaginary"):
        frechet_distance(np.zeros(2), np.diag([1.0, -1.0]), np.zeros(2), np.eye(2))


# ---- on Ψ of motions ----------------------------------------------------------------------------
def test_diversity_of_a_constant_motion_is_zero_and_of_a_moving_one_is_not():
    m = metric_biped()
    still = motion_features(motion(m, 400))  # [T, 11 + 3 E]: every frame the same Ψ
    assert still.shape[0] == 400
    assert diversity(still, rng=0) == 0.0
    t = np.arange(400) / 30.0
    swinging = motion_features(motion(m, 400, l_hip=0.4 * np.sin(2 * t), r_knee=0.5 * np.sin(3 * t)))
    assert diversity(swinging, rng=0) > 0.01
    # Ψ's root height, orientation and velocities never change here: singular covariances, the
    # offset fallback, and -2 D ε for identical sets.
    with pytest.warns(UserWarning, match="singular"):
        assert fid(swinging, swinging) == pytest.approx(-2 * swinging.shape[1] * 1e-6, abs=1e-9)
