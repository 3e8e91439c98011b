"""The feature loss L_fea (ACE Eq. 9) on NumPy and torch, against hand-computed distances."""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.errors import ConfigError
from morphkit.metrics import feature_loss


def test_feature_loss_is_the_mean_euclidean_distance_per_frame():
    human = np.zeros((2, 3))
    creature = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])  # distances 5 and 0: the norm, not its square
    assert feature_loss(human, creature) == pytest.approx(2.5)
    np.testing.assert_allclose(feature_loss(human, creature, reduction="none"), [5.0, 0.0])


def test_feature_loss_averages_over_every_leading_dimension():
    rng = np.random.default_rng(0)
    h, c = rng.normal(size=(4, 6, 17)), rng.normal(size=(4, 6, 17))
    per_frame = np.sqrt(((h - c) ** 2).sum(axis=-1))
    assert feature_loss(h, c) == pytest.approx(per_frame.mean(), rel=1e-12)
    assert feature_loss(h, c, reduction="none").shape == (4, 6)
    assert feature_loss(h, h) == 0.0


def test_feature_loss_on_torch_matches_numpy_and_is_differentiable():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(1)
    h, c = rng.normal(size=(5, 8)), rng.normal(size=(5, 8))
    c[2] = h[2]  # one frame with zero difference: its gradient is 0, not NaN
    th = torch.tensor(h)
    tc = torch.tensor(c, requires_grad=True)
    loss = feature_loss(th, tc)
    assert isinstance(loss, torch.Tensor) and loss.dim() == 0
    assert loss.item() == pytest.approx(feature_loss(h, c), rel=1e-12)
    loss.backward()
    # d/dc mean_t ||c_t - h_t|| = (c_t - h_t) / (T ||c_t - h_t||)
    diff = c - h
    norm = np.linalg.norm(diff, axis=1, keepdims=True)
    expected = np.divide(diff, 5 * norm, out=np.zeros_like(diff), where=norm > 0)
    np.testing.assert_allclose(tc.grad.numpy(), expected, rtol=1e-10, atol=1e-15)
    assert torch.autograd.gradcheck(lambda x: feature_loss(th, x), (tc.detach().clone().requires_grad_(),))


def test_weighted_feature_loss_scales_each_column_of_the_difference():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(2)
    h, c = rng.normal(size=(6, 14)), rng.normal(size=(6, 14))
    w = np.ones(14)
    w[5:11] = 3.0  # the root velocity rows, as G's term weighs them
    naive = np.mean([np.sqrt(sum((w[i] * (h[t, i] - c[t, i])) ** 2 for i in range(14))) for t in range(6)])
    assert feature_loss(h, c, weights=w) == pytest.approx(naive, rel=1e-12)
    assert feature_loss(h, c, weights=np.ones(14)) == pytest.approx(feature_loss(h, c), rel=1e-12)
    zero = w.copy()
    zero[5:11] = 0.0  # columns weighed 0 no longer count
    c2 = c.copy()
    c2[:, 5:11] += 7.0
    assert feature_loss(h, c2, weights=zero) == pytest.approx(feature_loss(h, c, weights=zero), rel=1e-12)
    assert feature_loss(torch.tensor(h), torch.tensor(c), weights=torch.tensor(w)).item() == pytest.approx(naive,
                                                                                                        rel=1e-12)
    with pytest.raises(ConfigError, match="weights"):
        feature_loss(h, c, weights=np.ones(13))


def test_feature_loss_rejects_bad_input():
    torch = pytest.importorskip("torch")
    with pytest.raises(ConfigError, match="shapes differ"):
        feature_loss(np.zeros((3, 4)), np.zeros((3, 5)))
    with pytest.raises(ConfigError, match="two NumPy arrays or two torch tensors"):
        feature_loss(np.zeros((3, 4)), torch.zeros(3, 4))
    with pytest.raises(ConfigError, match="reduction"):
        feature_loss(np.zeros((3, 4)), np.zeros((3, 4)), reduction="sum")
    with pytest.raises(ConfigError, match="no frames"):
        feature_loss(np.zeros((0, 4)), np.zeros((0, 4)))
    with pytest.raises(ConfigError, match="scalar"):
        feature_loss(np.float64(1.0), np.float64(2.0))
