"""Left-right mirroring of a motion (:mod:`morphkit.motion.mirror`), checked by FK against the reflection.

The independent truth: a mirrored pose's links, through the FK kernels, sit where the reflection
$M = \\mathrm{diag}(1, -1, 1)$ puts their partner's, and turn as $M R M$; a link's partner is found
here from the rest pose alone (the link of its depth whose rest position is the reflection of its own), not
from the joint matching the module does.
"""

from __future__ import annotations

import numpy as np
import pytest
from morphkit_testing import every_joint, random_q, shipped_morphology, spot_like

from morphkit.errors import ConfigError
from morphkit.graph import Transform
from morphkit.model import compile_model
from morphkit.motion import Motion, canonical_human
from morphkit.motion.mirror import mirror_motion, mirror_partners
from morphkit.rotations import matrix_from_quat

M = np.diag([1.0, -1.0, 1.0])


def _rest_partner(morphology) -> np.ndarray:
    rest = Motion(morphology, 30.0, morphology.rest_q()[None]).link_positions()[0]
    depth = np.array([len(morphology.chain(name)) for name in morphology.link_names])
    dist = np.linalg.norm(rest[:, None, :] - (rest @ M)[None, :, :], axis=-1)  # [L, L]
    return (dist + 1e3 * (depth[:, None] != depth[None, :])).argmin(axis=0)  # links that coincide: by depth


@pytest.mark.parametrize("make", [canonical_human, spot_like, lambda: shipped_morphology("spot")],
                         ids=["canonical_human", "spot_like", "spot"])
def test_mirrored_links_are_the_reflection_of_their_partners(make) -> None:
    m = make()
    q = random_q(compile_model(m, device="cpu"), 12, seed=3)
    motion = Motion(m, 30.0, q, name="clip")
    mirrored = mirror_motion(motion)
    assert mirrored.name == "clip_mirrored" and mirrored.frame_count == 12
    partner = _rest_partner(m)
    assert sorted(partner) == list(range(m.link_count))  # a permutation: every link has one partner
    p, pm = motion.link_poses(), mirrored.link_poses()
    np.testing.assert_allclose(pm[..., :3], p[:, partner, :3] @ M, atol=1e-9)
    R, Rm = matrix_from_quat(p[:, partner, 3:]), matrix_from_quat(pm[..., 3:])
    np.testing.assert_allclose(Rm, M @ R @ M, atol=1e-9)
    twice = mirror_motion(mirrored)
    np.testing.assert_allclose(twice.link_poses()[..., :3], p[..., :3], atol=1e-9)


def test_a_left_turn_becomes_a_right_turn() -> None:
    m = canonical_human()
    yaw = np.linspace(0.0, 1.0, 10)
    q = np.tile(m.rest_q(), (10, 1))
    q[:, 0] = np.linspace(0.0, 0.5, 10)
    q[:, 3:7] = np.stack([np.zeros(10), np.zeros(10), np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
    mirrored = mirror_motion(Motion(m, 30.0, q))
    heading = matrix_from_quat(mirrored.q[:, 3:7])[:, :, 0]  # the root's forward axis in the world
    np.testing.assert_allclose(np.arctan2(heading[:, 1], heading[:, 0]), -yaw, atol=1e-12)


def test_spot_like_partner_signs() -> None:
    m = spot_like()
    names = m.joint_names
    partners = {names[j]: (names[k], s) for j, (k, s) in enumerate(mirror_partners(m))}
    assert partners["fl_hx"] == ("fr_hx", -1.0)  # abduction about x: mirrored
    assert partners["fl_hy"] == ("fr_hy", 1.0)  # pitch about y: kept
    assert partners["arm_sh0"] == ("arm_sh0", -1.0)  # yaw of a midline joint: negated
    assert partners["arm_sh1"] == ("arm_sh1", 1.0)


def test_an_asymmetric_creature_is_refused_naming_the_joint() -> None:
    with pytest.raises(ConfigError, match="not left-right symmetric: joint"):
        mirror_partners(every_joint())
    m = canonical_human()
    j = m.joints[m.joint_index("LeftArm")]
    bent = type(m)(m.name, m.base, m.root, m.links,
                   tuple(type(j)(j.name, j.type, j.parent, j.child, Transform((0.0, 0.17, 0.0)), j.axis)
                         if k.name == "LeftArm" else k for k in m.joints), m.end_effectors)
    with pytest.raises(ConfigError, match="'LeftArm'"):
        mirror_partners(bent)
