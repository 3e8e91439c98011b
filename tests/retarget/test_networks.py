"""ACE motion-prior networks: MANN's output blending equals per-sample weight blending; VAE shapes, KL, FLOPs."""

from __future__ import annotations

import pytest
import torch
from torch.utils.flop_counter import FlopCounterMode

from morphkit.retarget.ace.networks import (
    ExpertLinear,
    MixtureOfExperts,
    MotionEncoder,
    MotionPrior,
    MotionVAE,
    kl_divergence,
    reparameterize,
)
from morphkit.retarget.networks import MLP, matmul_flops


def _blend_reference(layer: ExpertLinear, x: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """MANN as written: per sample, W = Σ_k α_k W_k and b = Σ_k α_k b_k, then x @ W + b."""
    rows = []
    for xb, ab in zip(x, alpha, strict=True):
        w = sum(ab[k] * layer.weight[:, k, :] for k in range(layer.expert_count))  # [in, out]
        b = sum(ab[k] * layer.bias[k] for k in range(layer.expert_count))  # [out]
        rows.append(xb @ w + b)
    return torch.stack(rows)


def _mann_reference(net: MixtureOfExperts, x: torch.Tensor, g: torch.Tensor, c: torch.Tensor | None) -> torch.Tensor:
    alpha = net.gate(g)
    h = x
    for i, layer in enumerate(net.layers):
        if c is not None and (i == 0 or net.condition_every_layer):
            h = torch.cat([c, h], dim=-1)
        h = _blend_reference(layer, h, alpha)
        if i < len(net.layers) - 1:
            h = torch.nn.functional.elu(h)
    return h


def test_expert_linear_equals_weight_blending():
    """One GEMM over all experts then the α-weighted sum equals blending the experts' weights per sample."""
    torch.manual_seed(0)
    layer = ExpertLinear(7, 5, 4)
    torch.nn.init.normal_(layer.bias)
    x, alpha = torch.randn(6, 7), torch.softmax(torch.randn(6, 4), -1)
    torch.testing.assert_close(layer(x, alpha), _blend_reference(layer, x, alpha), atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("every_layer", [True, False])
def test_mixture_of_experts_matches_the_naive_mann(every_layer: bool):
    """The whole stack (gate, conditioning at every or the first layer, ELU) equals the per-sample reference."""
    torch.manual_seed(1)
    net = MixtureOfExperts(
        10, 6, 13, condition_features=3, hidden=(32, 32), expert_count=8, condition_every_layer=every_layer
    ).eval()
    for layer in net.layers:
        torch.nn.init.normal_(layer.bias, std=0.1)
    x, g, c = torch.randn(9, 10), torch.randn(9, 13), torch.randn(9, 3)
    out, alpha = net(x, g, c, return_weights=True)
    torch.testing.assert_close(alpha.sum(-1), torch.ones(9))
    torch.testing.assert_close(out, _mann_reference(net, x, g, c), atol=1e-5, rtol=1e-5)


def test_prior_encoder_vae_shapes_and_gradients():
    """π(z, x_prev) and c(x_prev, x) keep leading dimensions; the VAE samples in train mode, uses μ in eval."""
    torch.manual_seed(2)
    encoder = MotionEncoder(12, 4, hidden=(16, 16))
    prior = MotionPrior(12, 4, hidden=(16, 16), expert_count=3, gate_hidden=(8,))
    vae = MotionVAE(encoder, prior)
    x_prev, x = torch.randn(2, 5, 12), torch.randn(2, 5, 12)
    out = vae(x_prev, x, generator=torch.Generator().manual_seed(0))
    assert out.x.shape == (2, 5, 12) and out.mu.shape == out.logvar.shape == out.z.shape == (2, 5, 4)
    ((out.x - x).square().mean() + kl_divergence(out.mu, out.logvar)).backward()
    assert all(p.grad is not None for p in vae.parameters())
    vae.eval()
    assert torch.equal(vae(x_prev, x).z, encoder(x_prev, x)[0])
    with pytest.raises(ValueError, match="latent"):
        MotionVAE(MotionEncoder(12, 5, hidden=(8,)), prior)


def test_reparameterize_and_kl():
    """z = μ + σε is seeded by the generator; KL matches torch.distributions and is 0 at the standard normal."""
    mu, logvar = torch.randn(4, 3), torch.randn(4, 3)
    a = reparameterize(mu, logvar, generator=torch.Generator().manual_seed(5))
    assert torch.equal(a, reparameterize(mu, logvar, generator=torch.Generator().manual_seed(5)))
    q = torch.distributions.Normal(mu, (0.5 * logvar).exp())
    expected = torch.distributions.kl_divergence(q, torch.distributions.Normal(0.0, 1.0))
    torch.testing.assert_close(kl_divergence(mu, logvar, "none"), expected)
    torch.testing.assert_close(kl_divergence(mu, logvar), expected.mean())
    torch.testing.assert_close(kl_divergence(mu, logvar, "batchmean"), expected.sum(-1).mean())
    assert kl_divergence(torch.zeros(2, 3), torch.zeros(2, 3)).item() == 0.0


def test_matmul_flops_agrees_with_torch_flop_counter():
    """matmul_flops counts what torch.utils.flop_counter counts for one forward of the prior and an MLP."""
    prior = MotionPrior(20, 8, hidden=(32, 32), expert_count=4, gate_hidden=(16, 16)).eval()
    mlp = MLP(20, (32, 32), 5)
    for module, args in ((prior, (torch.randn(64, 8), torch.randn(64, 20))), (mlp, (torch.randn(64, 20),))):
        with FlopCounterMode(display=False) as counter:
            module(*args)
        assert matmul_flops(module, 64) == counter.get_total_flops()
        assert matmul_flops(module, 64, backward=True) == 3 * counter.get_total_flops()
