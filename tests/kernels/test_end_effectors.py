"""End-effector kernels: world and heading frames, velocities, adjoints against finite differences."""

import math

import numpy as np
import pytest
import torch
import warp as wp
from morphkit_testing import ALL_CREATURES, creature, every_joint, human_like, random_q, spot_like, wheeled

from morphkit.conventions import quat_from_axis_angle, quat_multiply
from morphkit.errors import GraphError
from morphkit.kernels import (
    eval_end_effector_velocities,
    eval_end_effectors,
    eval_end_effectors_adjoint,
    eval_finite_difference,
    eval_fk,
    eval_heading_transforms,
)
from morphkit.model import compile_model
from morphkit.torch.reference import end_effectors_reference, fk_reference

Z = np.array([0, 0, 1.0])
Y = np.array([0, 1.0, 0])


@pytest.mark.parametrize("frame", ["world", "heading"])
@pytest.mark.parametrize("name", ALL_CREATURES)
def test_end_effectors_match_reference(name, frame, device):
    m = compile_model(creature(name))
    q = random_q(m, (2, 3), seed=1)
    ref = end_effectors_reference(m, fk_reference(m, torch.tensor(q)), frame=frame).numpy()
    for dtype, tol in ((np.float64, 1e-12), (np.float32, 2e-5)):
        pos, rot = eval_end_effectors(m, wp.array(q.astype(dtype), device=device), frame=frame)
        assert pos.shape == rot.shape == (2, 3, m.ee_count)
        np.testing.assert_allclose(pos.numpy(), ref[..., :3], atol=tol * 10)
        np.testing.assert_allclose(rot.numpy(), ref[..., 3:], atol=tol * 10)


def test_heading_frame_analytic(device):
    """Root at (1, 2, 0.5), yawed by psi and pitched by theta; the head point sits at (0.25, 0, 0.1) on it."""
    m = compile_model(every_joint("floating"))
    psi, theta = 0.7, -0.4
    q = np.array(m.rest_q)[None].copy()
    q[0, :3] = [1.0, 2.0, 0.5]
    q[0, 3:7] = quat_multiply(quat_from_axis_angle(Z, psi), quat_from_axis_angle(Y, theta))
    head = m.ee_index("head")
    pos, rot = eval_end_effectors(m, wp.array(q, dtype=wp.float64, device=device), frame="heading")
    c, s = math.cos(theta), math.sin(theta)
    # The heading frame's origin is the root itself (conventions), so the height is relative to it.
    np.testing.assert_allclose(pos.numpy()[0, head], [0.25 * c + 0.1 * s, 0.0, -0.25 * s + 0.1 * c], atol=1e-12)
    np.testing.assert_allclose(rot.numpy()[0, head], quat_from_axis_angle(Y, theta), atol=1e-12)
    H = eval_heading_transforms(m, eval_fk(m, wp.array(q, dtype=wp.float64, device=device))).numpy()[0]
    np.testing.assert_allclose(H, [1.0, 2.0, 0.5, *quat_from_axis_angle(Z, psi)], atol=1e-12)
    world, _ = eval_end_effectors(m, wp.array(q, dtype=wp.float64, device=device))
    np.testing.assert_allclose(world.numpy()[0, head, 2], 0.5 - 0.25 * s + 0.1 * c, atol=1e-12)


def test_heading_degenerate_root_pointing_up(device):
    m = compile_model(every_joint("floating"))
    q = np.array(m.rest_q)[None].copy()
    q[0, 3:7] = quat_from_axis_angle(Y, -math.pi / 2)  # root x axis points straight up
    H = eval_heading_transforms(m, eval_fk(m, wp.array(q, dtype=wp.float64, device=device))).numpy()[0]
    np.testing.assert_allclose(H, [0, 0, 0, 0, 0, 0, 1.0], atol=1e-12)


def test_velocities_of_a_translating_creature(device):
    """Constant base velocity, frozen joints: every end-effector moves with the base, in both frames."""
    m = compile_model(every_joint("floating"))
    T, dt, psi = 6, 0.05, 0.9
    v = np.array([1.0, 0.5, -0.2])
    q = np.repeat(random_q(m, 1, seed=2), T, axis=0)[None]
    q[0, :, 3:7] = quat_from_axis_angle(Z, psi)
    q[0, :, :3] = np.arange(T)[:, None] * dt * v
    world = eval_end_effector_velocities(m, wp.array(q, dtype=wp.float64, device=device), dt=dt)
    assert world.shape == (1, T, m.ee_count)
    world = world.numpy()
    np.testing.assert_allclose(world, np.broadcast_to(v, world.shape), atol=1e-9)
    local = eval_end_effector_velocities(m, wp.array(q, dtype=wp.float64, device=device), dt=dt, frame="heading")
    c, s = math.cos(psi), math.sin(psi)
    expected = [c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]]
    np.testing.assert_allclose(local.numpy(), np.broadcast_to(expected, world.shape), atol=1e-9)


def test_finite_difference_kernel(device):
    t = np.linspace(0, 1, 11)
    dt = t[1]
    x = np.zeros((2, 11, 1, 3))
    x[0, :, 0, 0] = t**2
    x[1, :, 0, 2] = 3 * t
    v = eval_finite_difference(wp.array(x, dtype=wp.vec3d, device=device), dt=dt).numpy()
    # Backward differences of t² are exact at the midpoint of each step: 2 (t - dt/2); frame 0 copies frame 1.
    np.testing.assert_allclose(v[0, 1:, 0, 0], 2 * (t[1:] - dt / 2), atol=1e-12)
    np.testing.assert_allclose(v[0, 0, 0, 0], v[0, 1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(v[1, :, 0, 2], 3.0, atol=1e-12)
    single = eval_finite_difference(wp.array(x[:, :1], dtype=wp.vec3d, device=device), dt=dt).numpy()
    np.testing.assert_array_equal(single, 0.0)
    with pytest.raises(GraphError, match="dt must be > 0"):
        eval_finite_difference(wp.array(x, dtype=wp.vec3d, device=device), dt=0.0)


def _fd(m, q, frame, eps=1e-6):
    C = q.shape[0]
    batch = np.repeat(q[None], 2 * C, axis=0)
    for i in range(C):
        batch[2 * i, i] += eps
        batch[2 * i + 1, i] -= eps
    pos, rot = eval_end_effectors(m, wp.array(batch, dtype=wp.float64), frame=frame)
    out = np.concatenate([pos.numpy().reshape(2 * C, -1), rot.numpy().reshape(2 * C, -1)], axis=1)
    return ((out[0::2] - out[1::2]) / (2 * eps)).T


@pytest.mark.parametrize("frame", ["world", "heading"])
@pytest.mark.parametrize("name", ["every_joint_floating", "every_joint_planar", "every_joint_wheeled",
                                  "every_joint_fixed", "wheeled", "spot_like", "human_like"])
def test_adjoint_matches_central_differences(name, frame):
    m = compile_model(creature(name))
    q = random_q(m, 1, seed=3)[0]
    J = _fd(m, q, frame)
    E = m.ee_count
    rng = np.random.default_rng(4)
    wp_, wr = rng.normal(size=(2, E, 3)), rng.normal(size=(2, E, 4))
    qb = wp.array(np.repeat(q[None], 2, 0), dtype=wp.float64)
    Ts = eval_fk(m, qb)
    adj = eval_end_effectors_adjoint(m, qb, Ts, wp.array(wp_, dtype=wp.vec3d), wp.array(wr, dtype=wp.quatd),
                                     frame=frame).numpy()
    expected = np.concatenate([wp_.reshape(2, -1), wr.reshape(2, -1)], axis=1) @ J
    np.testing.assert_allclose(adj, expected, atol=2e-7, rtol=1e-6)
    only_pos = eval_end_effectors_adjoint(m, qb, Ts, wp.array(wp_, dtype=wp.vec3d), None, frame=frame).numpy()
    np.testing.assert_allclose(only_pos, wp_.reshape(2, -1) @ J[: 3 * E], atol=2e-7, rtol=1e-6)


def test_out_buffers_and_errors(device):
    m = compile_model(spot_like())
    q = wp.array(random_q(m, 4, seed=5).astype(np.float32), device=device)
    pos = wp.zeros((4, m.ee_count), dtype=wp.vec3, device=device)
    rot = wp.zeros((4, m.ee_count), dtype=wp.quat, device=device)
    p, r = eval_end_effectors(m, q, out_positions=pos, out_orientations=rot)
    assert p is pos and r is rot and np.abs(pos.numpy()).sum() > 0
    with pytest.raises(GraphError, match="unknown frame 'local'; expected one of: world, heading"):
        eval_end_effectors(m, q, frame="local")
    with pytest.raises(GraphError, match="out_positions"):
        eval_end_effectors(m, q, out_positions=wp.zeros(3, dtype=wp.vec3, device=device))
    with pytest.raises(GraphError, match="motion"):
        eval_end_effector_velocities(m, wp.array(m.rest_q.astype(np.float32), device=device), dt=0.1)


def test_models_without_end_effectors(device):
    m = compile_model(human_like())
    assert m.ee_count == 4
    from morphkit.graph import MorphologyBuilder

    b = MorphologyBuilder("stick")
    b.add_link("a")
    k = compile_model(b.build())
    pos, rot = eval_end_effectors(k, np.zeros((3, 7), np.float32), device=device)
    assert pos.shape == (3, 0) and rot.shape == (3, 0)


def test_wheeled_heading_follows_yaw(device):
    m = compile_model(wheeled())
    q = np.zeros((1, m.coordinate_count))
    q[0, :3] = [0.3, -0.2, 2.5]
    H = eval_heading_transforms(m, eval_fk(m, wp.array(q, dtype=wp.float64, device=device))).numpy()[0]
    np.testing.assert_allclose(H, [0.3, -0.2, 0.0, *quat_from_axis_angle(Z, 2.5)], atol=1e-12)
    cam = m.ee_index("camera")
    pos, _ = eval_end_effectors(m, wp.array(q, dtype=wp.float64, device=device), frame="heading")
    np.testing.assert_allclose(pos.numpy()[0, cam], [0.15, 0.0, 0.72], atol=1e-12)


def test_warp_heading_equals_the_rotations_module(device):
    """The kernels' heading frame is :func:`morphkit.rotations.heading_frame` (one definition, two languages)."""
    from morphkit.rotations import heading_frame

    m = compile_model(every_joint("floating"))
    q = random_q(m, 64, seed=11)
    q[:, :3] = np.random.default_rng(12).normal(size=(64, 3))
    Ts = eval_fk(m, wp.array(q, dtype=wp.float64, device=device))
    H = eval_heading_transforms(m, Ts).numpy()
    np.testing.assert_allclose(H, heading_frame(Ts.numpy()[:, 0]), atol=1e-12)
