"""morphkit.rotations: NumPy and torch paths agree, round trips, analytic cases, finite gradients."""

import math

import numpy as np
import pytest
import torch

from morphkit import rotations as R

rng = np.random.default_rng(7)


def _unit(n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


GENERIC = {
    "quat_multiply": lambda: (_unit(6), _unit(6)),
    "quat_conjugate": lambda: (_unit(6),),
    "quat_rotate": lambda: (_unit(6), rng.normal(size=(6, 3))),
    "quat_rotate_inverse": lambda: (_unit(6), rng.normal(size=(6, 3))),
    "quat_normalize": lambda: (rng.normal(size=(6, 4)),),
    "quat_canonical": lambda: (_unit(6),),
    "quat_from_axis_angle": lambda: (np.array([0.0, 0.6, 0.8]), rng.normal(size=6)),
    "quat_from_rotation_vector": lambda: (rng.normal(size=(6, 3)),),
    "axis_angle_from_quat": lambda: (_unit(6),),
    "quat_between_vectors": lambda: (_unit(6)[:, :3] / np.linalg.norm(_unit(6)[:, :3], axis=-1, keepdims=True),
                                     np.tile([0.0, 0.0, 1.0], (6, 1))),
    "matrix_from_quat": lambda: (_unit(6),),
    "quat_from_rpy": lambda: (rng.uniform(-3, 3, size=(6, 3)),),
    "rpy_from_quat": lambda: (_unit(6),),
    "yaw_from_quat": lambda: (_unit(6),),
    "quat_from_yaw": lambda: (rng.uniform(-3, 3, size=6),),
    "heading_frame": lambda: (np.concatenate([rng.normal(size=(6, 3)), _unit(6)], axis=-1),),
    "transform_multiply": lambda: (np.concatenate([rng.normal(size=(6, 3)), _unit(6)], -1),
                                   np.concatenate([rng.normal(size=(6, 3)), _unit(6)], -1)),
    "transform_inverse": lambda: (np.concatenate([rng.normal(size=(6, 3)), _unit(6)], -1),),
    "quat_xyzw_to_wxyz": lambda: (_unit(6),),
    "wrap_angle": lambda: (rng.uniform(-20, 20, size=6),),
}


@pytest.mark.parametrize("name", sorted(GENERIC))
def test_torch_equals_numpy(name):
    args = GENERIC[name]()
    f = getattr(R, name)
    want = f(*args)
    got = f(*(torch.tensor(a) for a in args))
    assert isinstance(got, torch.Tensor) and got.dtype == torch.float64
    np.testing.assert_allclose(got.numpy(), want, atol=1e-12)


def test_round_trips():
    q = R.quat_canonical(_unit(50))
    np.testing.assert_allclose(R.quat_from_rotation_vector(R.axis_angle_from_quat(q)), q, atol=1e-12)
    np.testing.assert_allclose(R.quat_canonical(R.quat_from_rpy(R.rpy_from_quat(q))), q, atol=1e-12)
    np.testing.assert_allclose(R.quat_from_matrix(R.matrix_from_quat(q)), q, atol=1e-12)
    for order in ("zyx", "zxy", "xyz"):
        np.testing.assert_allclose(R.quat_canonical(R.quat_from_euler(R.euler_from_quat(q, order), order)), q,
                                   atol=1e-12)
    T = np.concatenate([rng.normal(size=(50, 3)), q], -1)
    ident = R.transform_multiply(R.transform_inverse(T), T)
    np.testing.assert_allclose(ident, np.tile([0, 0, 0, 0, 0, 0, 1.0], (50, 1)), atol=1e-12)


def test_analytic_cases():
    a = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(R.axis_angle_from_quat(R.quat_from_axis_angle(a, 0.5)), 0.5 * a, atol=1e-15)
    # Shortest arc: +z onto +y is a quarter turn about -x; opposite vectors give a half turn.
    np.testing.assert_allclose(R.quat_between_vectors(np.array([0, 0, 1.0]), np.array([0, 1.0, 0])),
                               [-math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-15)
    half = R.quat_between_vectors(np.array([1.0, 0, 0]), np.array([-1.0, 0, 0]))
    np.testing.assert_allclose(R.quat_rotate(half, np.array([1.0, 0, 0])), [-1.0, 0, 0], atol=1e-15)
    assert R.yaw_from_quat(R.quat_from_yaw(2.0)) == pytest.approx(2.0)
    assert R.wrap_angle(3 * math.pi) == pytest.approx(-math.pi)


def test_heading_frame_keeps_the_root_origin():
    """The one heading frame: origin at the root (height included), yaw of the facing axis only."""
    tilt = R.quat_from_axis_angle(np.array([0, 1.0, 0]), 0.3)
    T = np.array([1.0, 2.0, 3.0, *R.quat_multiply(R.quat_from_yaw(0.8), tilt)])
    np.testing.assert_allclose(R.heading_frame(T), [1.0, 2.0, 3.0, *R.quat_from_yaw(0.8)], atol=1e-15)


def test_singular_points_have_finite_gradients():
    up = torch.tensor([[0, 0, 0, 0, -math.sin(math.pi / 4), 0, math.cos(math.pi / 4)]], dtype=torch.float64,
                      requires_grad=True)  # root x axis vertical: heading falls back to world x
    H = R.heading_frame(up)
    torch.testing.assert_close(H[0, 3:], torch.tensor([0, 0, 0, 1.0], dtype=torch.float64))
    H.sum().backward()
    assert torch.isfinite(up.grad).all()
    ident = torch.tensor([[0, 0, 0, 1.0]], dtype=torch.float64, requires_grad=True)
    R.axis_angle_from_quat(ident).sum().backward()
    assert torch.isfinite(ident.grad).all()
    zero = torch.zeros(1, 3, dtype=torch.float64, requires_grad=True)
    R.quat_from_rotation_vector(zero).sum().backward()
    assert torch.isfinite(zero.grad).all()


def test_gradients_match_finite_differences():
    q = torch.tensor(_unit(3), requires_grad=True)
    v = torch.tensor(rng.normal(size=(3, 3)), requires_grad=True)
    assert torch.autograd.gradcheck(lambda a, b: R.quat_rotate(R.quat_normalize(a), b), (q, v))
    assert torch.autograd.gradcheck(lambda a: R.axis_angle_from_quat(R.quat_normalize(a)), (q,))
    assert torch.autograd.gradcheck(lambda a: R.yaw_from_quat(R.quat_normalize(a)), (q,))
