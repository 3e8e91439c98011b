"""Legs with more hinges than their feet need (issue 46: dm_control's dog turns each hip and scapula three ways):
the hinges that turn a leg out of its plane of bending, all but one, are held at rest, out of the IK.

Truths used: the creature's own description (which axis each hinge turns about, its rest angle) and the
coordinates the synthesis writes."""

from __future__ import annotations

import numpy as np
from _synth_creatures import read_creature

from morphkit.synth import SynthConfig, synthesize
from morphkit.synth._ik import LimbSolver
from morphkit.synth.analysis import analyse
from morphkit.synth.report import quality_report


def test_a_redundant_hip_yaw_stays_at_rest_while_the_leg_walks(tmp_path):
    """The swivel's hips turn about z (yaw), x (roll) and y (pitch), with a y knee: the yaw, which moves a foot
    under its hip least across the leg's plane, is held at its rest angle (0.1 rad) over the whole synthesis;
    the pitch and knee walk, the roll stays in the solve, the feet stay planted."""
    m = read_creature("swivel", tmp_path)
    solver = LimbSolver(m, analyse(m))
    held = {m.joints[j].name for j in solver.held_joints}
    assert held == {f"{n}_yaw" for n in ("fl", "fr", "hl", "hr")}
    q_of = {j.name: m.joint_q_start[i] for i, j in enumerate(m.joints)}
    assert all(solver.leg_mask[m.joint_qd_start[m.joint_index(f"{n}_roll")]] for n in ("fl", "fr", "hl", "hr"))

    res = synthesize(m, frames=300, seed=0, config=SynthConfig(rollout_seconds=10.0), progress=False)
    q = np.concatenate([mo.q for mo in res])
    for n in ("fl", "fr", "hl", "hr"):
        np.testing.assert_array_equal(q[:, q_of[f"{n}_yaw"]], 0.1)
        assert np.ptp(q[:, q_of[f"{n}_pitch"]]) > 0.05 and np.ptp(q[:, q_of[f"{n}_knee"]]) > 0.05
    assert quality_report(res)["foot_sliding_cm_s"] < 1.0


def test_a_leg_with_one_hinge_out_of_its_plane_holds_nothing(tmp_path):
    """The spider's legs (a yaw, then two pitch hinges) and the walker's six-hinge legs (flat feet, their pose held
    by the IK itself) keep every hinge in the solve."""
    for name in ("spider", "walker"):
        m = read_creature(name, tmp_path)
        assert LimbSolver(m, analyse(m)).held_joints == [], name


def test_advice_does_not_name_the_held_hinges(tmp_path):
    """A leg that cannot reach is told to widen the limits of the joints that move it, not of its held hip yaw."""
    from morphkit.synth.report import limit_advice

    m = read_creature("swivel", tmp_path)
    leg = analyse(m).legs[0]
    said = limit_advice(m, leg, held={"fl_yaw", "fr_yaw", "hl_yaw", "hr_yaw"})
    moving = [n for n in leg.joints if not n.endswith("_yaw")]
    assert "_yaw" not in said and all(n in said for n in moving), said
    assert all(n in limit_advice(m, leg) for n in leg.joints)
