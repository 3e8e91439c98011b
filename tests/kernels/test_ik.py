"""Damped-least-squares IK: the analytic Jacobian against finite differences, convergence, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from morphkit_testing import creature, human_like, random_q, spot_like

from morphkit.conventions import quat_from_axis_angle, quat_multiply, transform_multiply
from morphkit.errors import GraphError
from morphkit.graph import BaseType, JointType, Limit, MorphologyBuilder, Transform
from morphkit.kernels.fk import eval_fk
from morphkit.kernels.ik import eval_ee_jacobian, ik_dof_mask, ik_solve, ik_step
from morphkit.model import compile_model


def ee_positions(model, q: np.ndarray, ee=None) -> np.ndarray:
    """End-effector world positions [..., E, 3] from the FK kernel and the offsets (float64)."""
    q = np.asarray(q, dtype=np.float64)
    X = eval_fk(model, q, device="cpu").numpy().reshape(*q.shape[:-1], model.link_count, 7)
    idx = range(model.ee_count) if ee is None else [model.ee_index(e) if isinstance(e, str) else e for e in ee]
    pts = []
    for e in idx:
        T = X[..., int(model.ee_link[e]), :]
        off = np.concatenate([model.ee_offset[e], [0, 0, 0, 1]])
        pts.append(transform_multiply(T, np.broadcast_to(off, T.shape))[..., :3])
    return np.stack(pts, axis=-2)


def perturb(model, q: np.ndarray, dof: int, eps: float) -> np.ndarray:
    """q moved by eps along DoF ``dof`` with the conventions of the IK module (see its docstring)."""
    q = q.copy()
    base = BaseType(model.base_type)
    if base == BaseType.FLOATING and dof < 6:
        if dof < 3:
            q[dof] += eps
        else:
            q[3:7] = quat_multiply(quat_from_axis_angle(np.eye(3)[dof - 3], eps), q[3:7])
        return q
    if base == BaseType.PLANAR and dof < 3:
        q[dof] += eps
        return q
    if base == BaseType.WHEELED and dof < 2:
        if dof == 0:
            q[0] += eps * math.cos(q[2])
            q[1] += eps * math.sin(q[2])
        else:
            q[2] += eps
        return q
    j = int(np.searchsorted(model.joint_qd_start[1:], dof, side="right"))
    s = int(model.joint_q_start[j])
    k = dof - int(model.joint_qd_start[j])
    if JointType(int(model.joint_type[j])) == JointType.SPHERICAL:
        q[s : s + 4] = quat_multiply(q[s : s + 4], quat_from_axis_angle(np.eye(3)[k], eps))
    else:
        q[s] += eps
    return q


@pytest.mark.parametrize(
    "name", ["every_joint_floating", "every_joint_planar", "every_joint_wheeled", "mimic", "spot_like", "human_like"]
)
def test_jacobian_matches_central_differences(name):
    """Every column (base and joint DoFs, mimic included) equals the central difference of the EE positions."""
    model = compile_model(creature(name))
    q = random_q(model, 1, seed=3)[0]
    mask = ik_dof_mask(model, base=True)
    J, dofs = eval_ee_jacobian(model, q, dof_mask=mask)
    J = J.numpy()
    assert J.shape == (3 * model.ee_count, len(dofs))
    eps = 1e-6
    for c, dof in enumerate(dofs):
        fd = (ee_positions(model, perturb(model, q, dof, eps)) - ee_positions(model, perturb(model, q, dof, -eps)))
        np.testing.assert_allclose(J[:, c], fd.reshape(-1) / (2 * eps), atol=1e-7, err_msg=f"dof {dof}")
    # DoFs reaching no end-effector are left out; with the base free every base DoF reaches all of them.
    nb = {BaseType.FIXED: 0, BaseType.FLOATING: 6, BaseType.PLANAR: 3, BaseType.WHEELED: 2}[model.base_type]
    assert list(dofs[:nb]) == list(range(nb))


def test_mimic_column_lands_on_the_followed_joint():
    """The gripper's mimic finger moves its tip only through the finger it follows (multiplier -1)."""
    model = compile_model(creature("mimic"))
    J, dofs = eval_ee_jacobian(model, model.rest_q)
    a = model.joint_index("finger_a")
    col = list(dofs).index(int(model.joint_qd_start[a]))
    np.testing.assert_allclose(J.numpy()[:, col], [0, -1, 0], atol=1e-12)  # finger_b slides along -y


def test_planar_arm_converges_to_reachable_target():
    """2-link planar arm: a reachable target is reached to < 1e-4 m in at most 50 steps."""
    model = compile_model(creature("planar_arm"))
    target = ee_positions(model, np.array([0.7, 1.1]))  # [1, 3]
    res = ik_solve(model, np.array([0.1, 0.3]), target, iterations=50, tolerance=1e-4)
    assert res.converged and res.iterations <= 50
    assert res.error.max() < 1e-4
    np.testing.assert_allclose(ee_positions(model, res.q.numpy()), target, atol=1e-4)


def limited_arm():
    b = MorphologyBuilder("limited_arm")
    b.set_base("fixed")
    for n in ("base", "upper", "fore"):
        b.add_link(n)
    b.add_joint_revolute("shoulder", "base", "upper", axis=(0, 0, 1), limit=Limit(-1.0, 1.0))
    b.add_joint_revolute("elbow", "upper", "fore", origin=Transform((1.0, 0, 0)), axis=(0, 0, 1),
                         limit=Limit(0.2, 2.0))
    b.add_end_effector("tip", "fore", offset=(0.7, 0, 0), role="hand")
    return compile_model(b.build())


@pytest.mark.parametrize("target", [(0.0, 3.0, 0.0), (-1.0, -0.5, 0.0), (0.1, 0.05, 0.0)])
def test_unreachable_target_keeps_joints_within_limits(target):
    """Out of reach (too far, behind the limits, too close): every iterate stays within the joint limits."""
    model = limited_arm()
    lo, hi = model.coordinate_lower, model.coordinate_upper
    q = np.array([0.3, 0.5])
    errors = []
    for _ in range(60):
        q_new, res = ik_step(model, q, np.array([target]))
        errors.append(np.linalg.norm(res.numpy()))
        q = q_new.numpy()
        assert np.isfinite(q).all()
        assert (q >= lo - 1e-12).all() and (q <= hi + 1e-12).all()
    assert errors[-1] <= errors[0] + 1e-9


def test_straight_out_of_reach_target_stretches_the_arm():
    """A target 5 m straight ahead (reach 1.7 m): with a clamped error and real damping the arm ends stretched
    towards it, 3.3 m short (full Gauss–Newton steps would oscillate about the stretched singularity)."""
    model = compile_model(creature("planar_arm"))
    res = ik_solve(model, np.array([0.3, 0.5]), np.array([[5.0, 0.0, 0.0]]), iterations=100, max_error=0.2,
                   damping=0.3)
    assert not res.converged
    assert res.error[0] == pytest.approx(5.0 - 1.7, abs=1e-6)
    np.testing.assert_allclose(res.q.numpy(), [0.0, 0.0], atol=1e-4)


def test_spot_like_leg_moves_foot_to_target():
    """Spot-like quadruped, base fixed: the front-left foot reaches a displaced target; nothing else moves."""
    model = compile_model(spot_like())
    q0 = np.array(model.rest_q)
    q0[[model.coordinate_index(f"{leg}_kn") for leg in ("fl", "fr", "hl", "hr")]] = -1.2
    q0[[model.coordinate_index(f"{leg}_hy") for leg in ("fl", "fr", "hl", "hr")]] = 0.6
    foot0 = ee_positions(model, q0, ["fl_foot"])
    target = foot0 + np.array([0.06, 0.03, 0.08])
    res = ik_solve(model, q0, target, ee=["fl_foot"], iterations=50)
    assert res.converged and res.error.max() < 1e-4
    q = res.q.numpy()
    moved = np.flatnonzero(np.abs(q - q0) > 0)
    assert {model.coordinate_names[i] for i in moved} <= {"fl_hx", "fl_hy", "fl_kn"}
    assert (q >= model.coordinate_lower).all() and (q <= model.coordinate_upper).all()
    np.testing.assert_allclose(ee_positions(model, q, ["fl_foot"]), target, atol=1e-4)


def test_spot_like_moves_its_floating_base_when_allowed():
    """All four feet 5 cm further forward with only the base free: the base translates (and the error vanishes)."""
    model = compile_model(spot_like())
    q0 = random_q(model, 1, seed=2)[0]
    feet = ["fl_foot", "fr_foot", "hl_foot", "hr_foot"]
    target = ee_positions(model, q0, feet) + np.array([0.05, 0.0, 0.0])
    mask = ik_dof_mask(model, base=True, joints=[])
    res = ik_solve(model, q0, target, ee=feet, dof_mask=mask, iterations=50)
    assert res.converged
    q = res.q.numpy()
    np.testing.assert_allclose(q[:3] - q0[:3], [0.05, 0.0, 0.0], atol=1e-4)
    np.testing.assert_allclose(q[7:], q0[7:], atol=0)  # joints did not move


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_human_like_spherical_joints_reach_batched_targets(dtype):
    """22 spherical joints (dual solve, 66 DoF vs 12 rows), batch [2, 2]: targets from random poses are reached."""
    model = compile_model(human_like())
    q_goal = random_q(model, (2, 2), seed=5)
    q_goal[..., :7] = model.rest_q[:7]  # same base: the base stays fixed
    targets = ee_positions(model, q_goal)
    q0 = np.broadcast_to(model.rest_q, (2, 2, model.coordinate_count)).astype(dtype)
    res = ik_solve(model, q0, targets.astype(dtype), iterations=100, tolerance=2e-4 if dtype == np.float32 else 1e-6)
    assert res.error.shape == (2, 2, model.ee_count)
    assert res.converged, res.error.max()
    q = res.q.numpy()
    for j in range(model.joint_count):
        s = int(model.joint_q_start[j])
        np.testing.assert_allclose(np.linalg.norm(q[..., s : s + 4], axis=-1), 1.0, atol=1e-5)


def test_ik_step_rejects_bad_input():
    """Bad targets shape, unknown end-effector, wrong mask size and negative damping are reported."""
    model = compile_model(creature("planar_arm"))
    with pytest.raises(GraphError, match="targets: expected shape"):
        ik_step(model, np.zeros(2), np.zeros((2, 3)))
    with pytest.raises(GraphError, match="no end-effector 'foot'"):
        ik_step(model, np.zeros(2), np.zeros((1, 3)), ee=["foot"])
    with pytest.raises(GraphError, match="dof_mask"):
        ik_step(model, np.zeros(2), np.zeros((1, 3)), dof_mask=[True])
    with pytest.raises(GraphError, match="damping"):
        ik_step(model, np.zeros(2), np.zeros((1, 3)), damping=-1.0)


def test_weighted_step_is_the_step_of_the_weighted_least_squares_problem():
    """An end-effector of weight 0 is left out (the same step as without it); weight w on every end-effector is
    the unweighted step with damping lambda / w (w^2 J^T J + l^2 I = w^2 (J^T J + (l/w)^2 I)); one step each."""
    model = compile_model(spot_like())
    q0 = random_q(model, 3, seed=7)
    feet = ["fl_foot", "fr_foot", "hl_foot", "hr_foot"]
    target = ee_positions(model, q0, feet) + np.array([0.03, -0.02, 0.04])
    mask = ik_dof_mask(model, base=True)
    weight = np.array([1.0, 0.0, 1.0, 1.0])
    q_w, res_w = ik_step(model, q0, target, ee=feet, dof_mask=mask, weight=weight, damping=0.02, max_step=None)
    kept = [0, 2, 3]
    q_ref, _ = ik_step(model, q0, target[:, kept], ee=[feet[k] for k in kept], dof_mask=mask, damping=0.02,
                       max_step=None)
    np.testing.assert_allclose(q_w.numpy(), q_ref.numpy(), atol=1e-10)
    # the residual is reported unweighted
    np.testing.assert_allclose(res_w.numpy()[:, 1], target[:, 1] - ee_positions(model, q0, ["fr_foot"])[:, 0],
                               atol=1e-12)
    q_s, _ = ik_step(model, q0, target, ee=feet, dof_mask=mask, weight=np.full(4, 2.0), damping=0.02, max_step=None)
    q_d, _ = ik_step(model, q0, target, ee=feet, dof_mask=mask, damping=0.01, max_step=None)
    np.testing.assert_allclose(q_s.numpy(), q_d.numpy(), atol=1e-10)
    with pytest.raises(GraphError, match="weight"):
        ik_step(model, q0, target, ee=feet, weight=np.array([1.0, -1.0, 1.0, 1.0]))
