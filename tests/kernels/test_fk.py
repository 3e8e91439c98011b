"""Warp FK kernels: against the torch reference, analytic cases, finite-difference adjoints, wheels."""

import math
from pathlib import Path

import numpy as np
import pytest
import torch
import warp as wp
from morphkit_testing import ALL_CREATURES, creature, every_joint, mimic, planar_arm, random_q, spot_like, wheeled

from morphkit.conventions import quat_from_axis_angle, quat_multiply, transform_multiply
from morphkit.errors import GraphError
from morphkit.kernels import (
    cpu_thread_count,
    eval_fk,
    eval_fk_adjoint,
    eval_link_positions,
    eval_link_positions_adjoint,
    eval_wheel_angles,
    fk_module,
    set_cpu_thread_count,
)
from morphkit.kernels.fk import generate_fk_source
from morphkit.model import compile_model
from morphkit.torch.reference import fk_reference, wheel_angles_reference

TOL = {np.float32: 2e-5, np.float64: 1e-12}


def _model(name):
    return compile_model(creature(name))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", ALL_CREATURES)
def test_fk_matches_reference(name, dtype, device):
    m = _model(name)
    q = random_q(m, (3, 4), seed=1)
    T = eval_fk(m, wp.array(q.astype(dtype), device=device)).numpy()
    assert T.shape == (3, 4, m.link_count, 7)
    ref = fk_reference(m, torch.tensor(q)).numpy()
    np.testing.assert_allclose(T, ref, atol=TOL[dtype] * 10)
    P = eval_link_positions(m, wp.array(q.astype(dtype), device=device)).numpy()
    np.testing.assert_allclose(P, ref[..., :3], atol=TOL[dtype] * 10)


def test_planar_arm_analytic(device):
    l1, l2 = 1.0, 0.7
    m = compile_model(planar_arm(l1, l2))
    rng = np.random.default_rng(0)
    q = rng.uniform(-math.pi, math.pi, size=(50, 2))
    T = eval_fk(m, wp.array(q, dtype=wp.float64, device=device)).numpy()
    t1, t2 = q[:, 0], q[:, 1]
    elbow = np.stack([l1 * np.cos(t1), l1 * np.sin(t1), 0 * t1], -1)
    np.testing.assert_allclose(T[:, 2, :3], elbow, atol=1e-12)
    np.testing.assert_allclose(T[:, 1, :3], 0.0, atol=1e-12)
    # Orientation of the forearm: a rotation by t1 + t2 about z (up to the quaternion sign).
    yaw = 2 * np.arctan2(T[:, 2, 5], T[:, 2, 6])
    np.testing.assert_allclose(np.cos(yaw), np.cos(t1 + t2), atol=1e-12)
    np.testing.assert_allclose(np.sin(yaw), np.sin(t1 + t2), atol=1e-12)
    np.testing.assert_allclose(T[:, :, 3:5], 0.0, atol=1e-12)
    tip = elbow + np.stack([l2 * np.cos(t1 + t2), l2 * np.sin(t1 + t2), 0 * t1], -1)
    fore = T[:, 2]
    tip_fk = transform_multiply(fore, np.array([l2, 0, 0, 0, 0, 0, 1.0]))[:, :3]
    np.testing.assert_allclose(tip_fk, tip, atol=1e-12)


def test_mimic_joint_follows_target(device):
    m = compile_model(mimic())
    q = np.array([[0.3, 0.02]])
    T = eval_fk(m, wp.array(q, dtype=wp.float64, device=device)).numpy()[0]
    wrist = T[m.link_index("wrist")]
    b = m.joint_index("finger_b")
    value = -1.0 * 0.02 + 0.1
    expected = transform_multiply(wrist, np.array([0.0, -0.02 + value, 0.05, 0, 0, 0, 1]))
    np.testing.assert_allclose(T[b + 1], expected, atol=1e-12)


def test_spherical_and_floating_quaternions_are_normalised(device):
    m = compile_model(every_joint("floating"))
    q = random_q(m, 4, seed=2)
    scaled = q.copy()
    scaled[:, 3:7] *= 3.0
    s = m.joint_q_start[m.joint_index("a_sph")]
    scaled[:, s : s + 4] *= 0.25
    a = eval_fk(m, wp.array(q, dtype=wp.float64, device=device)).numpy()
    b = eval_fk(m, wp.array(scaled, dtype=wp.float64, device=device)).numpy()
    np.testing.assert_allclose(a, b, atol=1e-12)


def test_base_types(device):
    for base in ("planar", "wheeled"):
        m = compile_model(every_joint(base))
        q = np.zeros((1, m.coordinate_count))
        q[0, :3] = [0.5, -0.25, 0.7]
        T = eval_fk(m, wp.array(q, dtype=wp.float64, device=device)).numpy()[0, 0]
        np.testing.assert_allclose(T, [0.5, -0.25, 0.0, *quat_from_axis_angle(np.array([0, 0, 1.0]), 0.7)],
                                   atol=1e-12)
    m = compile_model(every_joint("fixed"))
    T = eval_fk(m, wp.array(m.rest_q[None], dtype=wp.float64, device=device)).numpy()[0, 0]
    np.testing.assert_allclose(T, [0, 0, 0, 0, 0, 0, 1.0])


@pytest.mark.parametrize("shape", [(), (1,), (7,), (2, 3), (2, 1, 3)])
def test_leading_shapes_and_out(shape, device):
    m = compile_model(spot_like())
    q = random_q(m, shape if shape else (1,), seed=3).astype(np.float32)
    if not shape:
        q = q[0]
    T = eval_fk(m, wp.array(q, device=device))
    assert T.shape == (*shape, m.link_count)
    out = wp.zeros_like(T)
    again = eval_fk(m, wp.array(q, device=device), out=out)
    assert again is out
    np.testing.assert_array_equal(out.numpy(), T.numpy())
    assert eval_link_positions(m, q, device=device).shape == (*shape, m.link_count)


def test_empty_batch(device):
    m = compile_model(planar_arm())
    assert eval_fk(m, np.zeros((0, 2), np.float32), device=device).shape == (0, 3)


def test_bad_inputs_name_the_problem(device):
    m = compile_model(planar_arm())
    with pytest.raises(GraphError, match=r"expected shape \[\.\.\., 2\] for 'planar_arm'"):
        eval_fk(m, np.zeros((4, 3), np.float32), device=device)
    with pytest.raises(GraphError, match="float32 or float64"):
        eval_fk(m, wp.zeros((4, 2), dtype=wp.int32, device=device))
    with pytest.raises(GraphError, match="out: expected a contiguous array of shape"):
        eval_fk(m, np.zeros((4, 2), np.float32), out=wp.zeros(4, dtype=wp.transform, device=device), device=device)
    with pytest.raises(GraphError, match="wheel_q"):
        eval_fk(compile_model(wheeled()), np.zeros((4, 5), np.float32), wheel_q=np.zeros((4, 3)), device=device)


def _fd_jacobian(m, q, kernel, eps=1e-6):
    """Central-difference Jacobian of FK outputs at one pose q [C]: shape [L * width, C]."""
    C = q.shape[0]
    batch = np.repeat(q[None], 2 * C, axis=0)
    for i in range(C):
        batch[2 * i, i] += eps
        batch[2 * i + 1, i] -= eps
    out = kernel(m, wp.array(batch, dtype=wp.float64)).numpy().reshape(2 * C, -1)
    return ((out[0::2] - out[1::2]) / (2 * eps)).T


@pytest.mark.parametrize("name", ALL_CREATURES)
def test_adjoint_matches_central_differences(name):
    """Every joint and base type: the Warp adjoint (float64) equals J^T w from central differences."""
    m = _model(name)
    q = random_q(m, 1, seed=4)[0]
    rng = np.random.default_rng(5)
    for kernel, adjoint, width, vec in ((eval_fk, eval_fk_adjoint, 7, wp.transformd),
                                        (eval_link_positions, eval_link_positions_adjoint, 3, wp.vec3d)):
        J = _fd_jacobian(m, q, kernel)
        w = rng.normal(size=(3, m.link_count, width))
        adj_q = adjoint(m, wp.array(np.repeat(q[None], 3, 0), dtype=wp.float64), wp.array(w, dtype=vec)).numpy()
        np.testing.assert_allclose(adj_q, w.reshape(3, -1) @ J, atol=2e-7, rtol=1e-6)


def test_adjoint_float32_close_to_float64():
    m = compile_model(spot_like())
    q = random_q(m, 16, seed=6)
    w = np.random.default_rng(7).normal(size=(16, m.link_count, 7))
    a64 = eval_fk_adjoint(m, wp.array(q, dtype=wp.float64), wp.array(w, dtype=wp.transformd)).numpy()
    a32 = eval_fk_adjoint(m, wp.array(q, dtype=wp.float32), wp.array(w, dtype=wp.transform)).numpy()
    np.testing.assert_allclose(a32, a64, atol=1e-4, rtol=1e-4)


def test_adjoint_accumulates_into_adj_q():
    m = compile_model(planar_arm())
    q = wp.array([[0.3, 0.5]], dtype=wp.float64)
    w = wp.array(np.ones((1, 3, 3)), dtype=wp.vec3d)
    once = eval_link_positions_adjoint(m, q, w).numpy()
    acc = wp.array(np.ones((1, 2)), dtype=wp.float64)
    eval_link_positions_adjoint(m, q, w, adj_q=acc)
    np.testing.assert_allclose(acc.numpy(), once + 1.0)


def test_tape_records_fk():
    m = compile_model(every_joint())
    q = wp.array(random_q(m, 3000, seed=8), dtype=wp.float64, requires_grad=True)
    out = wp.zeros((3000, m.link_count), dtype=wp.vec3d, requires_grad=True)
    tape = wp.Tape()
    with tape:
        eval_link_positions(m, q, out=out)
    w = np.random.default_rng(9).normal(size=(3000, m.link_count, 3))
    tape.backward(grads={out: wp.array(w, dtype=wp.vec3d)})
    expected = eval_link_positions_adjoint(m, q, wp.array(w, dtype=wp.vec3d)).numpy()
    np.testing.assert_allclose(q.grad.numpy(), expected, atol=1e-12)


def test_threaded_cpu_launch_equals_single_thread():
    m = compile_model(spot_like())
    q = wp.array(random_q(m, 9001, seed=10).astype(np.float32))
    before = cpu_thread_count()
    try:
        set_cpu_thread_count(1)
        one = eval_fk(m, q).numpy()
        set_cpu_thread_count(3)
        three = eval_fk(m, q).numpy()
        w = wp.array(np.ones((9001, m.link_count, 7), np.float32), dtype=wp.transform)
        g3 = eval_fk_adjoint(m, q, w).numpy()
        set_cpu_thread_count(1)
        g1 = eval_fk_adjoint(m, q, w).numpy()
    finally:
        set_cpu_thread_count(before)
    np.testing.assert_array_equal(one, three)
    np.testing.assert_array_equal(g1, g3)
    with pytest.raises(ValueError):
        set_cpu_thread_count(0)


def test_generated_source_bakes_constants():
    m = compile_model(spot_like())
    src = generate_fk_source(m)
    assert "S(0.29785)" in src and "def fk_transforms(" in src and "def fk_positions(" in src
    assert "wp.float64" in generate_fk_source(m, "float64")
    # The module that runs is this source (its FK equals the reference: test_fk_matches_reference).
    module = fk_module(m)
    assert module is fk_module(m) and Path(module.__file__).read_text() == src
    assert module.fk_transforms.key == "fk_transforms"
    # Deterministic: an equal morphology built again generates the same source, so both share one module.
    again = compile_model(spot_like())
    assert again is not m and generate_fk_source(again) == src and fk_module(again) is module
    # Specialised: other creatures get other code, and so does one joint origin moved (constants are baked).
    assert generate_fk_source(compile_model(every_joint("floating"))) != src
    short, long = (generate_fk_source(compile_model(planar_arm(l1, 0.7))) for l1 in (1.0, 1.25))
    assert short != long and "S(1.25)" in long and "S(1.25)" not in short


# ---- wheels ----------------------------------------------------------------------------------
def _circle(m, radius, turns, T):
    """A motion driving counter-clockwise around a circle of ``radius`` [m], heading tangent."""
    t = np.linspace(0.0, 2 * math.pi * turns, T)
    q = np.zeros((1, T, m.coordinate_count))
    q[0, :, 0] = radius * np.sin(t)
    q[0, :, 1] = radius * (1 - np.cos(t))
    q[0, :, 2] = t
    return q, t


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_wheels_driving_a_circle(dtype, device):
    r, track, R = 0.05, 0.3, 2.0
    m = compile_model(wheeled(radius=r, track=track))
    q, t = _circle(m, R, 1.3, 40)
    angles = eval_wheel_angles(m, wp.array(q.astype(dtype), device=device)).numpy()
    assert angles.shape == (1, 40, 2)
    # Left wheel (axis +y) rolls the inner circle R - track/2 forwards; the right wheel's axis points
    # right, so rolling the outer circle forwards is a negative angle.
    expected = np.stack([(R - track / 2) * t / r, -(R + track / 2) * t / r], -1)
    np.testing.assert_allclose(angles[0], expected, rtol=1e-4 if dtype == np.float32 else 1e-9, atol=1e-3)
    ref = wheel_angles_reference(m, torch.tensor(q)).numpy()
    np.testing.assert_allclose(angles, ref, rtol=1e-4, atol=1e-3)


def test_wheels_straight_and_reverse(device):
    r = 0.1
    m = compile_model(wheeled(radius=r))
    q = np.zeros((2, 5, m.coordinate_count))
    q[0, :, 0] = np.linspace(0, 1, 5)  # forward 1 m along x
    q[1, :, 2] = math.pi / 2  # facing +y, backing up 0.5 m
    q[1, :, 1] = np.linspace(0, -0.5, 5)
    angles = eval_wheel_angles(m, wp.array(q, dtype=wp.float64, device=device)).numpy()
    np.testing.assert_allclose(angles[0, -1], [1 / r, -1 / r], atol=1e-12)
    np.testing.assert_allclose(angles[1, -1], [-0.5 / r, 0.5 / r], atol=1e-12)
    np.testing.assert_allclose(angles[:, 0], 0.0)


def test_wheel_angles_turn_the_wheel_links(device):
    m = compile_model(wheeled())
    q = random_q(m, 3, seed=11)
    wheel_q = np.array([[0.4, -1.0], [2.0, 0.1], [0.0, 0.0]])
    T = eval_fk(m, wp.array(q, dtype=wp.float64, device=device), wheel_q=wheel_q).numpy()
    T0 = eval_fk(m, wp.array(q, dtype=wp.float64, device=device)).numpy()
    left = m.joint_index("wheel_l_joint") + 1
    for i in range(3):
        spin = quat_from_axis_angle(np.array([0, 1.0, 0]), wheel_q[i, 0])
        np.testing.assert_allclose(T[i, left, 3:], quat_multiply(T0[i, left, 3:], spin), atol=1e-12)
        np.testing.assert_allclose(T[i, left, :3], T0[i, left, :3], atol=1e-12)
    ref = fk_reference(m, torch.tensor(q), wheel_q=torch.tensor(wheel_q)).numpy()
    np.testing.assert_allclose(T, ref, atol=1e-12)


def test_wheel_angles_need_a_motion():
    m = compile_model(wheeled())
    with pytest.raises(GraphError, match="motion"):
        eval_wheel_angles(m, np.zeros(5))
    assert eval_wheel_angles(compile_model(planar_arm()), np.zeros((1, 4, 2))).shape == (1, 4, 0)


def test_generated_source_falls_back_to_a_temporary_folder(monkeypatch, tmp_path):
    from morphkit.kernels import fk as fk_mod

    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(blocked))
    path = fk_mod._write_source("morphkit_fk_test_fallback", "# test\n")
    assert path.read_text() == "# test\n" and blocked not in path.parents
