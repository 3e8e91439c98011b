"""ForwardKinematics: both backends agree; bone-offset gradients; double backward via the escape hatch."""

import numpy as np
import pytest
import torch
from morphkit_testing import every_joint, human_like, random_q, spot_like, wheeled

from morphkit.errors import GraphError
from morphkit.model import compile_model
from morphkit.torch import ForwardKinematics


@pytest.mark.parametrize("factory", [spot_like, human_like, wheeled, lambda: every_joint("planar")])
def test_backends_agree(factory, device):
    m = factory()
    fast = ForwardKinematics(m, device=device)
    ref = ForwardKinematics(compile_model(m), backend="reference")
    q = torch.tensor(random_q(fast.model, (3, 2), seed=1), device=device, requires_grad=True)
    torch.testing.assert_close(fast(q), ref(q), atol=1e-12, rtol=0)
    torch.testing.assert_close(fast.link_positions(q), ref.link_positions(q), atol=1e-12, rtol=0)
    for frame in ("world", "heading"):
        torch.testing.assert_close(fast.end_effector_positions(q, frame=frame),
                                   ref.end_effector_positions(q, frame=frame), atol=1e-12, rtol=0)
    (g_fast,) = torch.autograd.grad(fast.link_positions(q).square().sum(), q)
    (g_ref,) = torch.autograd.grad(ref.link_positions(q).square().sum(), q)
    torch.testing.assert_close(g_fast, g_ref, atol=1e-10, rtol=1e-9)
    assert "backend='warp'" in repr(fast)


def test_learnable_offsets_get_finite_difference_gradients():
    layer = ForwardKinematics(every_joint("fixed"), differentiable_offsets=True, dtype=torch.float64)
    assert layer.backend == "reference"
    assert [n for n, _ in layer.named_parameters()] == ["joint_offsets"]
    q = torch.tensor(random_q(layer.model, 2, seed=2))

    def loss(offsets):
        return layer(q, joint_offsets=offsets)[..., :3].square().sum()

    offsets = layer.joint_offsets.detach().clone().requires_grad_()
    assert torch.autograd.gradcheck(loss, (offsets,))
    # The parameter itself is used by default and receives the same gradient.
    layer(q)[..., :3].square().sum().backward()
    (expected,) = torch.autograd.grad(loss(offsets), offsets)
    torch.testing.assert_close(layer.joint_offsets.grad, expected)


def test_per_sample_offsets_switch_to_reference():
    layer = ForwardKinematics(spot_like())
    q = torch.tensor(random_q(layer.model, 2, seed=3))
    base = torch.tensor(np.array(layer.model.joint_X_parent[:, :3]))
    offsets = torch.stack([base, 1.5 * base]).requires_grad_()
    P = layer.link_positions(q, joint_offsets=offsets)
    assert P.shape == (2, layer.model.link_count, 3)
    torch.testing.assert_close(P[0], layer.link_positions(q)[0], atol=1e-12, rtol=0)
    P.sum().backward()
    assert offsets.grad is not None and offsets.grad.abs().sum() > 0


def test_double_backward_through_reference_backend():
    layer = ForwardKinematics(every_joint(), backend="reference")
    q = torch.tensor(random_q(layer.model, 2, seed=4), requires_grad=True)
    (g,) = torch.autograd.grad(layer.link_positions(q).square().sum(), q, create_graph=True)
    g.square().sum().backward()
    assert torch.isfinite(q.grad).all()


def test_time_series_wheels_both_backends():
    m = wheeled()
    fast, ref = ForwardKinematics(m), ForwardKinematics(m, backend="reference")
    q = torch.zeros(2, 5, fast.model.coordinate_count, dtype=torch.float64)
    q[..., 0] = torch.linspace(0, 0.5, 5)
    torch.testing.assert_close(fast(q, time_series=True), ref(q, time_series=True), atol=1e-12, rtol=0)


def test_bad_backend():
    with pytest.raises(GraphError, match="unknown backend 'jax'; expected one of: warp, reference"):
        ForwardKinematics(spot_like(), backend="jax")
