"""DIV and FID over sets of feature vectors Ψ (ACE, Li et al. 2023, §7; after Guo et al. 2022).

Both metrics compare *sets* of per-frame feature vectors $\\Psi(\\mathbf{x}) \\in \\mathbb{R}^D$
(:func:`morphkit.motion.features`, :func:`morphkit.motion.motion_features`): unit-free numbers,
since Ψ divides lengths by the body length and velocities are per second (see
:mod:`morphkit.motion.features` for the blocks).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from morphkit.errors import ConfigError

__all__ = ["DEFAULT_SUBSET_SIZE", "diversity", "fid", "frechet_distance", "gaussian_statistics"]

DEFAULT_SUBSET_SIZE = 300
"""$S_d$, the size of each of DIV's two random subsets (ACE §7; ``diversity_times`` of Guo et al. 2022)."""

FID_EPS = 1e-6
"""Diagonal offset added to both covariances when $\\Sigma_a\\Sigma_b$ is singular (pytorch-fid's ``eps``)."""


def as_matrix(x: Any, what: str) -> np.ndarray:
    """``x`` (NumPy array, torch tensor on any device, nested lists) as float64 [N, D]; leading dims flattened."""
    if hasattr(x, "detach") and hasattr(x, "cpu"):  # a torch tensor, without importing torch here
        x = x.detach().cpu().numpy()
    a = np.asarray(x, dtype=np.float64)
    if a.ndim < 2:
        raise ConfigError(f"{what}: expected feature vectors of shape [..., D], got {list(a.shape)}")
    a = a.reshape(-1, a.shape[-1])
    if not np.isfinite(a).all():
        row = int(np.argwhere(~np.isfinite(a))[0, 0])
        raise ConfigError(f"{what}: non-finite value in feature vector {row}")
    return a


def diversity(psi: Any, *, subset_size: int = DEFAULT_SUBSET_SIZE, rng: np.random.Generator | int) -> float:
    """Diversity (DIV) of a set of feature vectors, ACE §7.

    Two subsets of the same size $S_d$ are drawn at random from the N vectors, each without
    replacement and independently of the other, giving pairs
    $(\\Psi(\\mathbf{x}_i), \\Psi(\\mathbf{x}'_i))$; DIV is their mean Euclidean distance

    $$\\mathrm{DIV} = \\frac{1}{S_d} \\sum_{i=1}^{S_d} \\lVert \\Psi(\\mathbf{x}_i) - \\Psi(\\mathbf{x}'_i) \\rVert_2$$

    This is ``calculate_diversity`` of Guo et al. (2022), whose evaluation ACE borrows, with
    $S_d = 300$. Higher means more varied motion; for retargeting, the best DIV is the one closest
    to the DIV of the creature's own dataset (ACE Table 1: dataset 2.254 on Spot). A constant
    motion has DIV 0.

    When there are fewer than $S_d$ vectors (Guo et al. refuse), both subsets are drawn *with*
    replacement and a :class:`UserWarning` says so; pairs may then repeat a vector, which biases DIV
    slightly low.

    Args:
        psi: Feature vectors, shape [N, D] (or [..., D], flattened to N rows); NumPy or torch.
        subset_size: $S_d$ (>= 1).
        rng: The generator the two subsets are drawn from (or a seed for one).

    Returns:
        DIV, in Ψ's units (unit-free for ACE's body-length-normalised Ψ).

    Raises:
        ConfigError: if ``psi`` is empty, not [..., D] or non-finite, or ``subset_size`` < 1.
    """
    x = as_matrix(psi, "diversity: psi")
    n = x.shape[0]
    if n == 0:
        raise ConfigError("diversity: no feature vectors")
    if int(subset_size) != subset_size or subset_size < 1:
        raise ConfigError(f"diversity: subset_size must be a positive integer, got {subset_size!r}")
    subset_size = int(subset_size)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    replace = n < subset_size
    if replace:
        warnings.warn(
            f"diversity: only {n} feature vectors for subsets of S_d = {subset_size}; sampling with replacement",
            stacklevel=2,
        )
    first = gen.choice(n, subset_size, replace=replace)
    second = gen.choice(n, subset_size, replace=replace)
    return float(np.linalg.norm(x[first] - x[second], axis=1).mean())


def gaussian_statistics(psi: Any) -> tuple[np.ndarray, np.ndarray]:
    """Mean [D] and unbiased covariance [D, D] (``np.cov``, N - 1) of feature vectors [N, D], float64.

    Raises:
        ConfigError: with fewer than 2 vectors (no covariance), or a bad shape or value.
    """
    x = as_matrix(psi, "psi")
    if x.shape[0] < 2:
        raise ConfigError(f"a covariance needs at least 2 feature vectors, got {x.shape[0]}")
    return x.mean(axis=0), np.atleast_2d(np.cov(x, rowvar=False))


def _sqrtm(a: np.ndarray) -> tuple[np.ndarray, bool]:
    """``scipy.linalg.sqrtm(a)`` and whether it is usable (finite, and scipy did not find ``a`` singular)."""
    from scipy import linalg

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", linalg.LinAlgWarning)
        try:
            root = linalg.sqrtm(a)
        except (linalg.LinAlgError, ValueError):
            return np.full_like(a, np.nan), False
    singular = any(issubclass(w.category, linalg.LinAlgWarning) for w in caught)
    return np.asarray(root), not singular and bool(np.isfinite(root).all())


def frechet_distance(mu_a: Any, sigma_a: Any, mu_b: Any, sigma_b: Any, *, eps: float = FID_EPS) -> float:
    """Fréchet distance between two Gaussians $N(\\mu_a, \\Sigma_a)$ and $N(\\mu_b, \\Sigma_b)$.

    $$d^2 = \\lVert \\mu_a - \\mu_b \\rVert_2^2
          + \\operatorname{Tr}\\bigl(\\Sigma_a + \\Sigma_b - 2 (\\Sigma_a \\Sigma_b)^{1/2}\\bigr)$$

    computed as the reference FID code does (pytorch-fid / TTUR ``calculate_frechet_distance``,
    "stable version" by D. J. Sutherland): the square root is ``scipy.linalg.sqrtm`` of the
    product; if the product is singular (scipy warns) or the root has non-finite values, $\\epsilon I$
    is added to both covariances and the root recomputed (a :class:`UserWarning` says so); a small
    imaginary part from rounding is dropped (the real part is kept).

    Args:
        mu_a: Mean of the first Gaussian, shape [D].
        sigma_a: Its covariance, shape [D, D].
        mu_b: Mean of the second Gaussian, shape [D].
        sigma_b: Its covariance, shape [D, D].
        eps: The diagonal offset of the fallback.

    Returns:
        $d^2$ (the quantity FID reports; no square root is taken), in Ψ's units squared.

    Raises:
        ConfigError: on mismatched shapes, or a root whose diagonal keeps an imaginary part
            above 1e-3 (the covariances are not positive semi-definite).
    """
    mu_a = np.atleast_1d(np.asarray(mu_a, dtype=np.float64))
    mu_b = np.atleast_1d(np.asarray(mu_b, dtype=np.float64))
    sigma_a = np.atleast_2d(np.asarray(sigma_a, dtype=np.float64))
    sigma_b = np.atleast_2d(np.asarray(sigma_b, dtype=np.float64))
    d = mu_a.shape[0]
    if mu_a.shape != (d,) or mu_b.shape != (d,) or sigma_a.shape != (d, d) or sigma_b.shape != (d, d):
        raise ConfigError(
            f"frechet_distance: means must be [D] and covariances [D, D] with one D; got "
            f"{list(mu_a.shape)}, {list(sigma_a.shape)}, {list(mu_b.shape)}, {list(sigma_b.shape)}"
        )
    diff = mu_a - mu_b
    covmean, ok = _sqrtm(sigma_a @ sigma_b)
    if not ok:
        warnings.warn(
            f"frechet_distance: singular covariance product; adding {eps:g} to the diagonal of both covariances",
            stacklevel=2,
        )
        offset = eps * np.eye(d)
        covmean, _ = _sqrtm((sigma_a + offset) @ (sigma_b + offset))
    if np.iscomplexobj(covmean):
        if not np.allclose(np.diagonal(covmean).imag, 0.0, atol=1e-3):
            raise ConfigError(
                f"frechet_distance: the matrix square root has an imaginary part of "
                f"{np.abs(covmean.imag).max():.3g}; are the covariances positive semi-definite?"
            )
        covmean = covmean.real
    if not np.isfinite(covmean).all():
        raise ConfigError("frechet_distance: the matrix square root is not finite even with the diagonal offset")
    return float(diff @ diff + np.trace(sigma_a) + np.trace(sigma_b) - 2.0 * np.trace(covmean))


def fid(psi_real: Any, psi_fake: Any) -> float:
    """Fréchet distance (FID) between Gaussians fitted to two sets of feature vectors, ACE §7.

    ACE's FID is the Fréchet Inception Distance of Guo et al. (2022) with the hand-designed Ψ in
    place of a learned motion encoder: fit $N(\\mu, \\Sigma)$ to the Ψ of the creature's own motion
    dataset and to the Ψ of the retargeted motion (mean, unbiased covariance), then take
    :func:`frechet_distance`. Lower is better; identical sets give 0 up to rounding (~1e-12).
    With fewer vectors than Ψ has dimensions, or a Ψ component that never changes (a constant
    root height, a fixed base's zero velocity), the covariances are singular, the offset fallback
    fires, and identical sets give $-2 D \\epsilon$ (-4e-5 for D = 20), as in the reference code.

    Args:
        psi_real: Ψ of the reference (creature dataset) motion, shape [N_a, D] (or [..., D]); NumPy or torch.
        psi_fake: Ψ of the generated (retargeted) motion, shape [N_b, D] (or [..., D]).

    Returns:
        FID, in Ψ's units squared (unit-free for ACE's Ψ).

    Raises:
        ConfigError: fewer than 2 vectors in a set, different D, or non-finite values.
    """
    mu_a, sigma_a = gaussian_statistics(psi_real)
    mu_b, sigma_b = gaussian_statistics(psi_fake)
    if mu_a.shape != mu_b.shape:
        raise ConfigError(f"fid: feature dimensions differ: {mu_a.shape[0]} (real) and {mu_b.shape[0]} (fake)")
    return frechet_distance(mu_a, sigma_a, mu_b, sigma_b)
