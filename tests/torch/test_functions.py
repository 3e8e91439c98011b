"""The torch bridge: values and gradients against the pure-torch reference, gradcheck, wheels, errors."""

import math

import numpy as np
import pytest
import torch
from morphkit_testing import ALL_CREATURES, creature, planar_arm, random_q, spot_like, wheeled

import morphkit.torch as mt
from morphkit.errors import GraphError
from morphkit.model import compile_model
from morphkit.torch.reference import end_effectors_reference, fk_reference, wheel_angles_reference


def _q(m, shape, device, dtype=torch.float64, seed=0):
    return torch.tensor(random_q(m, shape, seed=seed), dtype=dtype, device=device, requires_grad=True)


@pytest.mark.parametrize("name", ALL_CREATURES)
def test_fk_and_gradients_match_reference(name, device):
    m = compile_model(creature(name))
    q = _q(m, (2, 3), device)
    T = mt.fk(m, q)
    ref = fk_reference(m, q)
    torch.testing.assert_close(T, ref, atol=1e-12, rtol=0)
    w = torch.randn_like(T)
    (g,) = torch.autograd.grad((T * w).sum(), q)
    (g_ref,) = torch.autograd.grad((ref * w).sum(), q)
    torch.testing.assert_close(g, g_ref, atol=1e-11, rtol=1e-9)

    P = mt.link_positions(m, q)
    torch.testing.assert_close(P, ref.detach()[..., :3], atol=1e-12, rtol=0)
    (g,) = torch.autograd.grad((P * w[..., :3]).sum(), q)
    (g_ref,) = torch.autograd.grad((fk_reference(m, q)[..., :3] * w[..., :3]).sum(), q)
    torch.testing.assert_close(g, g_ref, atol=1e-11, rtol=1e-9)


@pytest.mark.parametrize("frame", ["world", "heading"])
@pytest.mark.parametrize("name", ALL_CREATURES)
def test_end_effectors_and_gradients_match_reference(name, frame, device):
    m = compile_model(creature(name))
    q = _q(m, (4,), device, seed=1)
    pos, rot = mt.end_effectors(m, q, frame=frame)
    ref = end_effectors_reference(m, fk_reference(m, q), frame=frame)
    torch.testing.assert_close(pos, ref[..., :3], atol=1e-12, rtol=0)
    torch.testing.assert_close(rot, ref[..., 3:], atol=1e-12, rtol=0)
    if m.ee_count == 0:
        return
    wp_, wr = torch.randn_like(pos), torch.randn_like(rot)
    (g,) = torch.autograd.grad((pos * wp_).sum() + (rot * wr).sum(), q)
    (g_ref,) = torch.autograd.grad((ref[..., :3] * wp_).sum() + (ref[..., 3:] * wr).sum(), q)
    torch.testing.assert_close(g, g_ref, atol=1e-11, rtol=1e-9)
    # Only the positions in the graph: the orientation gradient is None inside backward.
    (g_pos,) = torch.autograd.grad((mt.end_effector_positions(m, q, frame=frame) * wp_).sum(), q)
    (g_pos_ref,) = torch.autograd.grad(
        (end_effectors_reference(m, fk_reference(m, q), frame=frame)[..., :3] * wp_).sum(), q
    )
    torch.testing.assert_close(g_pos, g_pos_ref, atol=1e-11, rtol=1e-9)


@pytest.mark.parametrize("name", ["every_joint_floating", "every_joint_planar", "every_joint_wheeled",
                                  "every_joint_fixed", "mimic", "wheeled"])
def test_gradcheck_float64(name, device):
    m = compile_model(creature(name))
    q = _q(m, (2,), device, seed=2)
    assert torch.autograd.gradcheck(lambda x: mt.fk(m, x), (q,))
    assert torch.autograd.gradcheck(lambda x: mt.link_positions(m, x), (q,))
    assert torch.autograd.gradcheck(lambda x: mt.end_effectors(m, x, frame="heading"), (q,))


def test_float32_matches_float64(device):
    m = compile_model(spot_like())
    q64 = _q(m, (8,), device, seed=3)
    q32 = q64.detach().float().requires_grad_()
    T32, T64 = mt.fk(m, q32), mt.fk(m, q64)
    assert T32.dtype == torch.float32
    torch.testing.assert_close(T32.double(), T64, atol=1e-5, rtol=0)
    T32.sum().backward()
    T64.sum().backward()
    torch.testing.assert_close(q32.grad.double(), q64.grad, atol=1e-4, rtol=1e-4)


def test_planar_arm_through_torch(device):
    m = compile_model(planar_arm(1.0, 0.7))
    q = torch.tensor([[0.3, -0.4]], dtype=torch.float64, device=device, requires_grad=True)
    tip = mt.end_effector_positions(m, q)[0, 0]
    expected = [math.cos(0.3) + 0.7 * math.cos(-0.1), math.sin(0.3) + 0.7 * math.sin(-0.1), 0.0]
    torch.testing.assert_close(tip, torch.tensor(expected, dtype=torch.float64, device=device))
    tip[0].backward()
    # d tip_x / d q = (-sin t1 - 0.7 sin(t1 + t2), -0.7 sin(t1 + t2))
    s1, s12 = math.sin(0.3), math.sin(-0.1)
    torch.testing.assert_close(q.grad[0], torch.tensor([-s1 - 0.7 * s12, -0.7 * s12], dtype=torch.float64,
                                                       device=device))


def test_outputs_survive_later_calls(device):
    m = compile_model(planar_arm())
    a = mt.fk(m, torch.zeros(1, 2, device=device))
    b = mt.fk(m, torch.ones(1, 2, device=device))
    assert not torch.equal(a, b)
    torch.testing.assert_close(a, mt.fk(m, torch.zeros(1, 2, device=device)))


def test_leading_shapes(device):
    m = compile_model(spot_like())
    for shape in [(), (5,), (2, 3)]:
        q = torch.tensor(random_q(m, shape or (1,), seed=4), dtype=torch.float32, device=device)
        q = q.reshape(*shape, -1)
        assert mt.fk(m, q).shape == (*shape, m.link_count, 7)
        assert mt.link_positions(m, q).shape == (*shape, m.link_count, 3)
        assert mt.end_effector_positions(m, q).shape == (*shape, m.ee_count, 3)
    big = torch.tensor(random_q(m, 5000, seed=5), dtype=torch.float32, device=device)  # threaded on CPU
    torch.testing.assert_close(mt.fk(m, big), fk_reference(m, big), atol=2e-5, rtol=0)


def test_non_contiguous_input(device):
    m = compile_model(spot_like())
    q = torch.tensor(random_q(m, (6, 2), seed=6), dtype=torch.float64, device=device).transpose(0, 1)
    assert not q.is_contiguous()
    torch.testing.assert_close(mt.fk(m, q), fk_reference(m, q), atol=1e-12, rtol=0)


def test_wheels_integrate_along_time(device):
    r, track, R = 0.05, 0.3, 2.0
    m = compile_model(wheeled(radius=r, track=track))
    T = 30
    t = torch.linspace(0, 2 * math.pi * 0.75, T, dtype=torch.float64)
    q = torch.zeros(1, T, m.coordinate_count, dtype=torch.float64)
    q[0, :, 0], q[0, :, 1], q[0, :, 2] = R * torch.sin(t), R * (1 - torch.cos(t)), t
    q = q.to(device)
    angles = mt.wheel_angles(m, q)
    expected = torch.stack([(R - track / 2) * t / r, -(R + track / 2) * t / r], -1).to(device)
    torch.testing.assert_close(angles[0], expected, rtol=1e-9, atol=1e-6)
    torch.testing.assert_close(angles, wheel_angles_reference(m, q), rtol=1e-9, atol=1e-9)
    Ts = mt.fk(m, q, time_series=True)
    torch.testing.assert_close(Ts, fk_reference(m, q, wheel_q=angles), atol=1e-12, rtol=0)
    # A single pose (no time axis) keeps the wheels at 0.
    torch.testing.assert_close(mt.fk(m, q[0]), fk_reference(m, q[0]), atol=1e-12, rtol=0)


def test_end_effector_velocities(device):
    m = compile_model(spot_like())
    q = torch.tensor(random_q(m, (2, 7), seed=7), dtype=torch.float64, device=device, requires_grad=True)
    v = mt.end_effector_velocities(m, q, dt=0.1)
    assert v.shape == (2, 7, m.ee_count, 3)
    from morphkit.kernels import eval_end_effector_velocities

    expected = eval_end_effector_velocities(m, q.detach().cpu().numpy(), dt=0.1, frame="world", device="cpu")
    np.testing.assert_allclose(v.detach().cpu().numpy(), expected.numpy(), atol=1e-12)
    vh = mt.end_effector_velocities(m, q, dt=0.1, frame="heading")
    expected = eval_end_effector_velocities(m, q.detach().cpu().numpy(), dt=0.1, frame="heading", device="cpu")
    np.testing.assert_allclose(vh.detach().cpu().numpy(), expected.numpy(), atol=1e-12)
    vh.square().sum().backward()
    assert torch.isfinite(q.grad).all()


def test_errors_are_morphkit_errors(device):
    m = compile_model(planar_arm())
    with pytest.raises(GraphError, match=r"expected shape \[\.\.\., 2\]"):
        mt.fk(m, torch.zeros(3, 4, device=device))
    with pytest.raises(GraphError, match="float32 or float64"):
        mt.fk(m, torch.zeros(3, 2, dtype=torch.int64, device=device))
    with pytest.raises(GraphError, match="KinematicModel"):
        mt.fk(planar_arm(), torch.zeros(3, 2, device=device))
    with pytest.raises(GraphError, match="unknown frame"):
        mt.end_effectors(m, torch.zeros(3, 2, device=device), frame="body")
    with pytest.raises(GraphError, match="wheel_q"):
        mt.fk(compile_model(wheeled()), torch.zeros(3, 5, device=device), wheel_q=torch.zeros(3, 1))


def test_backward_is_once_differentiable(device):
    m = compile_model(planar_arm())
    q = torch.tensor([[0.3, 0.2]], dtype=torch.float64, device=device, requires_grad=True)
    (g,) = torch.autograd.grad(mt.link_positions(m, q).sum(), q, create_graph=True)
    with pytest.raises(RuntimeError):
        g.sum().backward()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_matches_cpu():
    m = compile_model(spot_like())
    q = torch.tensor(random_q(m, 64, seed=8), dtype=torch.float32)
    torch.testing.assert_close(mt.fk(m, q.cuda()).cpu(), mt.fk(m, q), atol=1e-5, rtol=0)


def test_broadcast_and_strided_incoming_gradients(device):
    """``loss.sum()`` hands backward a fully broadcast gradient; slicing hands it strided ones."""
    m = compile_model(spot_like())
    q = _q(m, (5,), device, seed=9)
    for loss in (lambda y: y.sum(), lambda y: y[..., ::2, :].sum(), lambda y: (y.transpose(0, 1) * 2).sum(),
                 lambda y: y[..., 0].sum()):
        (g,) = torch.autograd.grad(loss(mt.fk(m, q)), q)
        (g_ref,) = torch.autograd.grad(loss(fk_reference(m, q)), q)
        torch.testing.assert_close(g, g_ref, atol=1e-11, rtol=1e-9)
        (g,) = torch.autograd.grad(loss(mt.end_effector_positions(m, q)), q)
        (g_ref,) = torch.autograd.grad(loss(end_effectors_reference(m, fk_reference(m, q))[..., :3]), q)
        torch.testing.assert_close(g, g_ref, atol=1e-11, rtol=1e-9)


def test_repeated_calls_with_changing_batch_sizes(device):
    """The small-batch path replays one recorded launch; sizes, inputs and outputs change between calls."""
    m = compile_model(spot_like())
    for seed, B in enumerate([1, 3, 1, 64, 5000, 2, 2]):
        q = torch.tensor(random_q(m, B, seed=seed), dtype=torch.float32, device=device)
        torch.testing.assert_close(mt.fk(m, q), fk_reference(m, q), atol=2e-5, rtol=0)
        torch.testing.assert_close(mt.link_positions(m, q), fk_reference(m, q)[..., :3], atol=2e-5, rtol=0)
