"""Torch autograd over the contact kernels: values, gradchecks (float64) and end-to-end gradients through FK."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from morphkit_testing import spot_like

from morphkit.graph import Limit, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.kernels.contact import foot_indices, self_collision_pairs
from morphkit.model import compile_model
from morphkit.torch import contact as C
from morphkit.torch import end_effector_positions, fk


def _torch_device(device: str) -> torch.device:
    return torch.device("cuda" if device.startswith("cuda") else "cpu")


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_penetration_one_centimetre_and_heights(dtype, device):
    """A foot 1 cm below the ground penetrates 0.01 m; heights keep their sign; leading shape kept."""
    dev = _torch_device(device)
    p = torch.zeros((2, 3, 4, 3), dtype=dtype, device=dev)
    p[1, 2, 3, 2] = -0.01
    p[0, 0, 1, 2] = 0.2
    d = C.penetration_depth(p)
    assert d.shape == (2, 3, 4) and d.dtype == dtype
    assert d[1, 2, 3].item() == pytest.approx(0.01, abs=1e-7)
    assert d.sum().item() == pytest.approx(0.01, abs=1e-7)
    h = C.foot_heights(p, feet=[3, 1], ground_height=0.05)
    assert h.shape == (2, 3, 2)
    assert h[1, 2, 0].item() == pytest.approx(-0.06, abs=1e-7)
    assert h[0, 0, 1].item() == pytest.approx(0.15, abs=1e-7)


def test_sliding_and_flags_values(device):
    """1 cm per frame at 30 fps on the ground -> 0.3 m/s; contact flags follow the thresholds."""
    dev = _torch_device(device)
    T = 10
    P = torch.zeros((1, T, 2, 3), dtype=torch.float64, device=dev)
    P[0, :, 0, 0] = 0.01 * torch.arange(T, dtype=torch.float64)
    P[0, :, 1, 2] = 0.5
    s = C.sliding_speed(P, 30.0)
    torch.testing.assert_close(s[0, :, 0], torch.full((T,), 0.3, dtype=torch.float64, device=dev))
    assert (s[0, :, 1] == 0).all()
    flags = C.contact_flags(P, 30.0, speed_threshold=0.5)
    assert flags.dtype == torch.bool and flags[0, :, 0].all() and not flags[0, :, 1].any()
    assert not C.contact_flags(P, 30.0, speed_threshold=0.2)[0, :, 0].any()


def test_penetration_gradcheck():
    """torch.autograd.gradcheck (float64) of the penetration depth, away from the kink at the ground."""
    g = torch.Generator().manual_seed(0)
    p = torch.rand((3, 4, 3), generator=g, dtype=torch.float64) * 0.1 - 0.05
    p[..., 2] = torch.tensor([-0.03, 0.02, -0.01, 0.04], dtype=torch.float64)
    p.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x: C.penetration_depth(x, feet=[0, 2, 3]), (p,), eps=1e-6, atol=1e-7)
    assert torch.autograd.gradcheck(lambda x: C.foot_heights(x, ground_height=0.1), (p,), eps=1e-6, atol=1e-7)


def test_sliding_gradcheck():
    """gradcheck (float64) of the sliding speed on a random motion, feet well inside or outside the gate."""
    g = torch.Generator().manual_seed(1)
    P = torch.randn((2, 6, 3, 3), generator=g, dtype=torch.float64) * 0.05
    P[..., 2] = torch.where(torch.rand((2, 6, 3), generator=g) < 0.7, -0.01, 0.2).to(torch.float64)
    P.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x: C.sliding_speed(x, 30.0, feet=[0, 2]), (P,), eps=1e-6, atol=1e-6)


def crossing_arms(r1: float = 0.05, r2: float = 0.04):
    """Two sibling capsules: A along x (yawing), B along y lifted by a prismatic joint of travel [0.3, 1] m."""
    b = MorphologyBuilder("crossing")
    b.set_base("fixed")
    b.add_link("root")
    b.add_link("arm_a", shapes=[Shape(ShapeType.CAPSULE, radius=r1, length=1.0,
                                      origin=Transform.from_xyz_rpy((0, 0, 0), (0, math.pi / 2, 0)))])
    b.add_link("arm_b", shapes=[Shape(ShapeType.CAPSULE, radius=r2, length=0.8,
                                      origin=Transform.from_xyz_rpy((0, 0, 0), (math.pi / 2, 0, 0)))])
    b.add_joint_revolute("yaw_a", "root", "arm_a", axis=(0, 0, 1), limit=Limit(-1.0, 1.0))
    b.add_joint_prismatic("lift_b", "root", "arm_b", axis=(0, 0, 1), limit=Limit(0.3, 1.0))
    return compile_model(b.build())


def test_self_collision_through_fk_gradient_is_minus_one_per_metre_of_lift(device):
    """Crossing capsules d apart: penetration r1 + r2 - d, and d(penetration)/d(lift) = -1 through FK."""
    dev = _torch_device(device)
    model = crossing_arms()
    pairs = self_collision_pairs(model)
    q = torch.tensor([[0.4, 0.05], [-0.2, 0.02], [0.1, 0.5]], dtype=torch.float64, device=dev, requires_grad=True)
    pen = C.self_collision_penetration(model, pairs, fk(model, q))  # [3, 1]
    torch.testing.assert_close(pen[:, 0], torch.tensor([0.04, 0.07, 0.0], dtype=torch.float64, device=dev))
    pen.sum().backward()
    torch.testing.assert_close(q.grad, torch.tensor([[0.0, -1.0], [0.0, -1.0], [0.0, 0.0]], dtype=torch.float64,
                                                    device=dev), atol=1e-12, rtol=0)


def small_creature_model():
    """Torso box with two legs (hip sphere, thigh capsule), floating base."""
    b = MorphologyBuilder("small")
    b.add_link("torso", shapes=[Shape(ShapeType.BOX, size=(0.4, 0.2, 0.1))])
    for side, y in (("l", 0.12), ("r", -0.12)):
        b.add_link(f"{side}_hip", shapes=[Shape(ShapeType.SPHERE, radius=0.04)])
        b.add_link(f"{side}_thigh",
                   shapes=[Shape(ShapeType.CAPSULE, radius=0.03, length=0.2, origin=Transform((0, 0, -0.1)))])
        b.add_joint_revolute(f"{side}_hx", "torso", f"{side}_hip", origin=Transform((0.15, y, 0.0)), axis=(1, 0, 0),
                             limit=Limit(-1.5, 1.5))
        b.add_joint_revolute(f"{side}_hy", f"{side}_hip", f"{side}_thigh", origin=Transform((0, 0, -0.05)),
                             axis=(0, 1, 0), limit=Limit(-1.5, 1.5))
    b.add_end_effector("l_foot", "l_thigh", offset=(0, 0, -0.23), role="foot")
    b.add_end_effector("r_foot", "r_thigh", offset=(0, 0, -0.23), role="foot")
    return compile_model(b.build())


def test_self_collision_and_shape_ground_gradcheck_wrt_transforms():
    """gradcheck (float64) w.r.t. link transforms of the pair distances, penetrations and shape ground heights."""
    model = small_creature_model()
    pairs = self_collision_pairs(model)
    q = torch.tensor(model.rest_q, dtype=torch.float64)
    q[2] = 0.2
    q[model.coordinate_index("l_hx")] = -0.6
    q[model.coordinate_index("r_hx")] = 0.6
    q[model.coordinate_index("l_hy")] = 0.1  # off the symmetric plane: the axes pass 2 cm apart, not through

    Ts = fk(model, q[None]).detach().requires_grad_(True)  # [1, L, 7]
    assert C.self_collision_penetration(model, pairs, Ts).max() > 0.01  # the thighs cross
    for f in (lambda X: C.self_collision_distance(model, pairs, X),
              lambda X: C.self_collision_penetration(model, pairs, X),
              lambda X: C.shape_ground_distance(model, X, ground_height=0.01)):
        assert torch.autograd.gradcheck(f, (Ts,), eps=1e-6, atol=1e-6)


def test_end_to_end_losses_gradcheck_wrt_q():
    """Foot penetration + sliding + self-collision losses composed with the Warp FK: gradcheck w.r.t. q (float64)."""
    model = small_creature_model()
    pairs = self_collision_pairs(model)
    feet = foot_indices(model)
    g = torch.Generator().manual_seed(3)
    T = 5
    q = torch.tensor(model.rest_q, dtype=torch.float64).repeat(T, 1)
    q[:, 2] = 0.25
    q[:, 0] = 0.02 * torch.arange(T)
    q[:, 7:] += 0.3 * torch.randn((T, model.coordinate_count - 7), generator=g, dtype=torch.float64)
    q[:, model.coordinate_index("l_hx")] -= 0.6
    q.requires_grad_(True)

    def loss(x: torch.Tensor) -> torch.Tensor:
        p = end_effector_positions(model, x)  # [T, E, 3]
        pen = C.penetration_depth(p, feet=feet, ground_height=0.01).sum()
        slide = C.sliding_speed(p[None], 30.0, feet=feet, height_threshold=0.05).sum()
        selfc = C.self_collision_penetration(model, pairs, fk(model, x)).sum()
        return torch.stack([pen, slide, selfc])

    values = loss(q)
    assert (values > 0).all(), values  # every term is active at this pose
    assert torch.autograd.gradcheck(loss, (q,), eps=1e-6, atol=1e-6)


def test_spot_like_foot_penetration_gradient_points_up():
    """Pushing Spot-like's body 3 cm into the ground: every foot penetrates, the loss gradient on base z is -4."""
    model = compile_model(spot_like())
    q = torch.tensor(model.rest_q, dtype=torch.float64)
    p0 = end_effector_positions(model, q)
    q = q.clone()
    q[2] = -p0[foot_indices(model), 2].max() - 0.03  # deepest-standing foot 3 cm below
    q.requires_grad_(True)
    d = C.penetration_depth(end_effector_positions(model, q), feet=foot_indices(model))
    assert d.min().item() >= 0.03 - 1e-12
    d.sum().backward()
    assert q.grad[2].item() == pytest.approx(-4.0)


def test_bad_inputs_are_reported():
    """Wrong shapes and types give GraphError naming the argument."""
    from morphkit.errors import GraphError

    model = crossing_arms()
    pairs = self_collision_pairs(model)
    with pytest.raises(GraphError, match=r"Ts: expected shape \[\.\.\., 3, 7\]"):
        C.self_collision_distance(model, pairs, torch.zeros((2, 4, 7)))
    with pytest.raises(GraphError, match=r"p: expected shape \[\.\.\., E, 3\]"):
        C.penetration_depth(torch.zeros((4, 2)))
    with pytest.raises(GraphError, match="float32 or float64"):
        C.penetration_depth(torch.zeros((4, 3), dtype=torch.int64))
    np.testing.assert_equal(C.sliding_speed(torch.zeros((1, 3, 2, 3)), 30.0).numpy(), np.zeros((1, 3, 2)))
