"""The pure-torch reference FK: independent truths (graph rest poses, analytic arm), double backward, offsets."""

import math

import numpy as np
import pytest
import torch
from morphkit_testing import TEST_CREATURES, creature, every_joint, planar_arm, random_q, spot_like

from morphkit.errors import GraphError
from morphkit.model import compile_model
from morphkit.torch.reference import end_effectors_reference, fk_reference


@pytest.mark.parametrize("name", TEST_CREATURES)
def test_rest_pose_matches_graph(name):
    """``Morphology.rest_link_poses`` is an independent NumPy FK (1-DoF joints only, spherical at identity)."""
    m = creature(name)
    k = compile_model(m)
    T = fk_reference(k, torch.tensor(k.rest_q)).numpy()
    np.testing.assert_allclose(T, m.rest_link_poses(), atol=1e-12)


def test_planar_arm_analytic():
    k = compile_model(planar_arm(1.0, 0.7))
    q = torch.tensor([[0.5, 1.1]], dtype=torch.float64)
    tip = end_effectors_reference(k, fk_reference(k, q))[0, 0, :3]
    expected = [math.cos(0.5) + 0.7 * math.cos(1.6), math.sin(0.5) + 0.7 * math.sin(1.6), 0.0]
    torch.testing.assert_close(tip, torch.tensor(expected, dtype=torch.float64))


def test_double_backward():
    k = compile_model(every_joint("planar"))
    q = torch.tensor(random_q(k, 1, seed=1), requires_grad=True)
    assert torch.autograd.gradgradcheck(lambda x: end_effectors_reference(k, fk_reference(k, x))[..., :3], (q,))


def test_offsets_default_to_model_and_get_gradients():
    k = compile_model(spot_like())
    q = torch.tensor(random_q(k, 3, seed=2))
    offsets = torch.tensor(np.array(k.joint_X_parent[:, :3]), requires_grad=True)
    torch.testing.assert_close(fk_reference(k, q, joint_offsets=offsets), fk_reference(k, q))
    small = compile_model(every_joint("fixed"))
    q_small = torch.tensor(random_q(small, 1, seed=2))
    off_small = torch.tensor(np.array(small.joint_X_parent[:, :3]), requires_grad=True)
    assert torch.autograd.gradcheck(
        lambda o: end_effectors_reference(small, fk_reference(small, q_small, joint_offsets=o))[..., :3], (off_small,)
    )
    # Per-sample offsets broadcast against the batch: scaling sample 1's bones scales its link positions.
    per_sample = torch.stack([offsets.detach(), 2 * offsets.detach(), offsets.detach()])
    q0 = torch.tensor(k.rest_q).expand(3, -1)
    P = fk_reference(k, q0, joint_offsets=per_sample)[..., :3]
    torch.testing.assert_close(P[1], 2 * P[0])


def test_rotations_override():
    k = compile_model(every_joint("fixed"))
    q = torch.tensor(random_q(k, 2, seed=3))
    rot = torch.tensor(np.array(k.joint_X_parent[:, 3:]), requires_grad=True)
    torch.testing.assert_close(fk_reference(k, q, joint_rotations=rot), fk_reference(k, q))
    with pytest.raises(GraphError, match="joint_rotations"):
        fk_reference(k, q, joint_rotations=rot[:2])


def test_bad_shapes():
    k = compile_model(planar_arm())
    with pytest.raises(GraphError, match="q: expected shape"):
        fk_reference(k, torch.zeros(3))
    with pytest.raises(GraphError, match="joint_offsets"):
        fk_reference(k, torch.zeros(2), joint_offsets=torch.zeros(3, 3))
    with pytest.raises(GraphError, match="unknown frame"):
        end_effectors_reference(k, fk_reference(k, torch.zeros(2)), frame="up")
