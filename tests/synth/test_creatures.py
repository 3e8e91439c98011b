"""Generated creatures (issue 48's test creatures, issue 46's anatomy rules): every family walks cleanly, and
the readers' body-based guess finds the generator's own end-effectors on the unlabelled creature."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from morphkit.body.anatomy import complete_anatomy
from morphkit.errors import ConfigError
from morphkit.synth.creatures import CreatureFamily, random_creature

FAMILIES = [
    CreatureFamily(legs=2, arm=True, neck=True),
    CreatureFamily(legs=4, arm=True, tail=True, neck=True),
    CreatureFamily(legs=6, tail=True),
]


@pytest.mark.parametrize("family", FAMILIES, ids=lambda f: f.name)
def test_every_family_walks_on_planted_feet_above_the_ground(family):
    from morphkit.synth import SynthConfig, synthesize
    from morphkit.synth.report import quality_report

    m = random_creature(family, seed=1)
    res = synthesize(m, frames=150, seed=0, config=replace(SynthConfig(), rollout_seconds=5.0), progress=False)
    r = quality_report(res)
    assert res.rig.summary()["locomotion"] == "legged" and len(res.rig.plan.legs) == family.legs
    assert r["foot_sliding_cm_s"] < 1.0, r
    assert r["penetration_mm"] <= 5.0, (r["penetration_mm"], r.get("deepest_link"))
    assert r["self_collision_frac"] == 0.0


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("family", FAMILIES, ids=lambda f: f.name)
def test_the_body_based_guess_finds_the_generators_end_effectors(family, seed):
    truth = random_creature(family, seed)
    guess = complete_anatomy(random_creature(family, seed, labelled=False), base_declared=True)
    def roles(m):
        return sorted((e.link, e.role) for e in m.end_effectors)

    assert roles(guess) == roles(truth)
    feet = {e.link: np.asarray(e.offset) for e in truth.end_effectors if e.role.name == "FOOT"}
    for e in guess.end_effectors:
        if e.link in feet:  # the sole of the foot ball, found from its shape
            assert np.allclose(e.offset, feet[e.link], atol=1e-3)


def test_a_seed_is_a_creature():
    f = FAMILIES[1]
    assert random_creature(f, 3) == random_creature(f, 3)
    assert random_creature(f, 3) != random_creature(f, 4)
    with pytest.raises(ConfigError, match="2, 4 or 6 legs"):
        CreatureFamily(legs=3)


def test_cli_writes_a_new_file_and_refuses_to_overwrite(tmp_path, capsys):
    from morphkit.cli import main
    from morphkit.io import read_morphology

    out = tmp_path / "c.yaml"
    assert main(["generate", "--legs", "6", "--arm", "--seed", "2", "--out", str(out)]) == 0
    got, want = read_morphology(out), random_creature(CreatureFamily(legs=6, arm=True), 2)
    assert got.joint_names == want.joint_names and got.link_names == want.link_names
    def ees(m):
        return [(e.name, e.link, e.role) for e in m.end_effectors]

    assert ees(got) == ees(want)
    assert np.allclose(got.rest_link_poses(), want.rest_link_poses(), atol=1e-9)
    before = out.read_text()
    assert main(["generate", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err and out.read_text() == before
    unlabelled = tmp_path / "u.yaml"
    assert main(["generate", "--legs", "6", "--arm", "--seed", "2", "--unlabelled", "--out", str(unlabelled)]) == 0
    guessed = read_morphology(unlabelled)  # the reader's guess, from the body alone
    assert sorted((e.link, e.role) for e in guessed.end_effectors) == sorted(
        (e.link, e.role) for e in want.end_effectors)
