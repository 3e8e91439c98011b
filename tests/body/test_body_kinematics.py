"""The body's batched matrix FK poses links as the reference FK does (to rounding), a limb alone as the whole."""

from __future__ import annotations

import numpy as np
from morphkit_testing import shipped_morphology

from morphkit.body.kinematics import BodyKinematics
from morphkit.graph.kinematics import link_poses_of_values
from morphkit.rotations import matrix_from_quat


def test_body_kinematics_agrees_with_the_reference_fk() -> None:
    m = shipped_morphology("stretch")  # prismatic lift, mimic telescope, revolute wrist, wheels
    kin = BodyKinematics(m)
    rng = np.random.default_rng(2)
    values = kin.sample(range(m.joint_count), 12, rng)
    got = kin.poses(values)
    ref = link_poses_of_values(m, values)
    np.testing.assert_allclose(got[..., :3, 3], ref[..., :3], atol=1e-12)
    np.testing.assert_allclose(got[..., :3, :3], matrix_from_quat(ref[..., 3:]), atol=1e-12)
    tip = m.link_count - 1
    chain = kin.chain([tip])
    limb = kin.poses(values, chain)
    np.testing.assert_array_equal(limb[:, tip], got[:, tip])
    others = [li for li in range(1, m.link_count) if li - 1 not in chain]
    assert others and not limb[:, others].any()
