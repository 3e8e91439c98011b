"""The NumPy reference FK against the Warp kernels, on every base and joint type the shipped creatures hold."""

from __future__ import annotations

import numpy as np
import pytest
from morphkit_testing import shipped_morphology

from morphkit.graph import BaseType, JointType
from morphkit.graph.kinematics import link_poses
from morphkit.motion._fk import link_poses_and_end_effectors


def _random_q(m, n: int, rng: np.random.Generator) -> np.ndarray:
    lower, upper = m.coordinate_limits
    lower, upper = np.maximum(lower, -2.0), np.minimum(upper, 2.0)
    q = rng.uniform(lower, upper, size=(n, m.coordinate_count))
    if m.base == BaseType.FLOATING:
        q[:, 3:7] = rng.normal(size=(n, 4)) * 1.7  # not unit: both normalise
    for ji, j in enumerate(m.joints):
        if j.type == JointType.SPHERICAL and not m.is_driven(j):
            s = m.joint_q_start[ji]
            q[:, s : s + 4] = rng.normal(size=(n, 4))
    return q


@pytest.mark.parametrize("name", ["spot", "crab", "human", "stretch"])
def test_link_poses_match_the_kernels(name: str) -> None:
    """Spot (floating, revolute), the crab, the human (ball joints), Stretch (wheeled base, prismatic lift,
    mimic telescope): positions and rotations as the kernels give them."""
    m = shipped_morphology(name)
    q = _random_q(m, 16, np.random.default_rng(7))
    ref, _ = link_poses_and_end_effectors(m, q)
    got = link_poses(m, q)
    np.testing.assert_allclose(got[..., :3], ref[..., :3], atol=1e-9)
    # q and -q are one rotation: compare |<q_got, q_ref>| with 1
    dots = np.abs(np.sum(got[..., 3:] * ref[..., 3:], axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-9)


def test_rest_link_poses_are_the_reference_fk_at_rest() -> None:
    m = shipped_morphology("spot")
    q = m.rest_q()
    q[:3] = [1.0, 2.0, 3.0]
    at_origin = link_poses(m, q[None], root_at_origin=True)[0]
    np.testing.assert_array_equal(m.rest_link_poses(), at_origin)
    moved = link_poses(m, q[None])[0, :, :3] - at_origin[:, :3]
    np.testing.assert_allclose(moved, np.tile([1.0, 2.0, 3.0], (m.link_count, 1)))
