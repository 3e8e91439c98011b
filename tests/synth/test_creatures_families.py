"""Issue 65's body plans (``morphkit generate --family``): a hopping biped with a heavy tail resting behind, short arms
and long feet; a long-necked grazer; an eight-legged body. Each walks as the first three families do, and each has
what its name says."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from morphkit.errors import ConfigError
from morphkit.synth.creatures import FAMILIES, CreatureFamily, random_creature


def _lowest_point(m, link: str) -> float:
    """Height of the lowest point of ``link``'s capsules and boxes at q = 0 [m] (from the shapes' geometry here)."""
    from morphkit.rotations import quat_rotate

    poses = m.rest_link_poses()
    pos, quat = poses[m.link_index(link)][:3], poses[m.link_index(link)][3:]
    low = np.inf
    for sh in m.link(link).shapes:
        centre = pos + quat_rotate(quat, np.asarray(sh.origin.xyz))
        axis = quat_rotate(quat, quat_rotate(np.asarray(sh.origin.quat), np.array([0.0, 0.0, 1.0])))
        if sh.type.name == "CAPSULE":
            low = min(low, centre[2] - 0.5 * sh.length * abs(axis[2]) - sh.radius)
    return float(low)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_every_named_family_walks_on_planted_feet_above_the_ground(name):
    from morphkit.synth import SynthConfig, synthesize
    from morphkit.synth.report import quality_report

    family = FAMILIES[name]
    m = random_creature(family, seed=1)
    res = synthesize(m, frames=150, seed=0, config=replace(SynthConfig(), rollout_seconds=5.0), progress=False)
    r = quality_report(res)
    assert res.rig.summary()["locomotion"] == "legged" and len(res.rig.plan.legs) == family.legs
    assert r["foot_sliding_cm_s"] < 1.0, r
    assert r["penetration_mm"] <= 5.0, (r["penetration_mm"], r.get("deepest_link"))  # the tail's shapes included
    assert r["self_collision_frac"] == 0.0


def test_the_body_plans_have_what_their_names_say():
    for seed in range(3):
        hopper = random_creature(FAMILIES["hopper"], seed)
        roles = sorted(e.role.name for e in hopper.end_effectors)
        assert roles == ["FOOT", "FOOT", "HAND", "HAND", "HEAD"]
        points = hopper.rest_points()[hopper.link_count:]
        ground = float(min(points[i, 2] for i, e in enumerate(hopper.end_effectors) if e.role.name == "FOOT"))
        # the tail's tip rests 2 cm above the ground behind the body: its lowest capsule, not under the feet
        tip = _lowest_point(hopper, "tail_3") - ground
        assert 0.005 < tip < 0.05, tip
        assert all(_lowest_point(hopper, f"tail_{i}") - ground > 0.0 for i in (1, 2, 3))
        # short arms: the hand hangs well above the ground, shorter than the legs
        hands = [e for e in hopper.end_effectors if e.role.name == "HAND"]
        assert all(e.link.endswith("forearm") for e in hands)
        grazer = random_creature(FAMILIES["grazer"], seed)
        assert [n for n in grazer.joint_names if n.startswith("neck")] == ["neck0_pitch", "neck1_pitch", "neck2_pitch"]
        octopod = random_creature(FAMILIES["octopod"], seed)
        assert sum(e.role.name == "FOOT" for e in octopod.end_effectors) == 8
    with pytest.raises(ConfigError, match=r"2, 4 or 6 legs \(or 8\)"):
        CreatureFamily(legs=10)


def test_cli_writes_a_named_family(tmp_path):
    from morphkit.cli import main
    from morphkit.io import read_morphology

    out = tmp_path / "roo.yaml"
    assert main(["generate", "--family", "hopper", "--seed", "3", "--out", str(out)]) == 0
    got, want = read_morphology(out), random_creature(FAMILIES["hopper"], 3)
    assert got.joint_names == want.joint_names
    assert np.allclose(got.rest_link_poses(), want.rest_link_poses(), atol=1e-9)
    eight = tmp_path / "eight.yaml"
    assert main(["generate", "--legs", "8", "--out", str(eight)]) == 0
    assert len([e for e in read_morphology(eight).end_effectors if e.role.name == "FOOT"]) == 8
