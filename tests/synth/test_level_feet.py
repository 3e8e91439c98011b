"""Flat feet stay level and ball feet roll: the soles of a six-hinge leg and the balls of a toe stay out of the
ground while the legs walk (issue 46: Berkeley's and OP3's flat feet tilted 4-8 cm under, Aliengo's toe balls
sank r (1 - cos theta) as the shin turned)."""

from __future__ import annotations

import numpy as np
import pytest
from _synth_creatures import read_creature
from morphkit_testing import pybullet_data_file

from morphkit.kernels import eval_fk
from morphkit.kernels.contact import eval_shape_ground_distance
from morphkit.model import compile_model
from morphkit.rotations import quat_rotate
from morphkit.synth import SynthConfig, prepare, synthesize
from morphkit.synth.report import quality_report


def _tilt_deg(quat: np.ndarray) -> np.ndarray:
    """Angle [deg] between a link's z axis and the world's, for xyzw quaternions [..., 4]."""
    x, y = quat[..., 0], quat[..., 1]
    return np.degrees(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))


def test_six_hinge_legs_keep_flat_feet_level_and_out_of_the_ground(tmp_path):
    """The walker (hip yaw-roll-pitch, knee, ankle pitch-roll, box feet): every planted foot level to 0.5 deg, no
    shape under the ground, planted feet still; it steps (feet in the air lean only as the ankle makes them)."""
    m = read_creature("walker", tmp_path)
    res = synthesize(m, frames=600, seed=0, config=SynthConfig(rollout_seconds=10.0), progress=False)
    r = quality_report(res)
    assert r["foot_sliding_cm_s"] < 0.1, r
    assert r["penetration_mm"] < 1.0, (r["penetration_mm"], r.get("deepest_link"))
    assert res.rig.legs.semi_axes[:, 0].min() > 0.03  # steps fore-aft
    model = compile_model(m, device="cpu")
    for motion, planted in zip(res, res.contact, strict=True):
        X = eval_fk(model, motion.q, device="cpu").numpy()
        for k, side in enumerate(("l", "r")):
            tilt = _tilt_deg(X[:, model.link_index(f"{side}_foot"), 3:])
            assert planted[:, k].any() and tilt[planted[:, k]].max() < 0.5


def test_a_ball_foot_point_is_lifted_by_what_its_ball_turned():
    """``rolling_lift``: the foot point's height above its ball's lowest point (from FK: centre z - r), at
    poses whose shins turned away from the stance; 0 at the stance."""
    from morphkit.io import read_morphology

    m = read_morphology(pybullet_data_file("aliengo/aliengo.urdf"))
    rig = prepare(m, fps=30.0)
    solver = rig.solver
    assert len(solver.balls) == 4
    q = np.repeat(rig.q_stance[None], 3, axis=0)
    knees = [m.joint_q_start[i] for i, j in enumerate(m.joints) if j.name.endswith("lower_joint")]
    q[1, knees] += 0.3
    q[2, knees] -= 0.5
    lift = solver.rolling_lift(q)
    model = compile_model(m, device="cpu")
    X = eval_fk(model, q, device="cpu").numpy()
    for li, link, centre, r in solver.balls:
        ee = m.end_effector(rig.plan.legs[li].end_effector)
        T = X[:, link]
        point_z = (T[:, :3] + quat_rotate(T[:, 3:], np.broadcast_to(np.asarray(ee.offset), (3, 3))))[:, 2]
        lowest_z = (T[:, :3] + quat_rotate(T[:, 3:], np.broadcast_to(centre, (3, 3))))[:, 2] - r
        np.testing.assert_allclose(lift[:, li], point_z - lowest_z, atol=1e-9)
    assert lift[0].max() < 1e-6 and lift[1:].min() > 1e-4


@pytest.mark.parametrize("frames", [3000])
def test_ball_feet_stay_out_of_the_ground_over_a_long_walk(frames):
    """Aliengo's toe balls over 3,000 frames: no shape more than 2.5 mm under (5.2 mm before the balls rolled)."""
    from morphkit.io import read_morphology

    m = read_morphology(pybullet_data_file("aliengo/aliengo.urdf"))
    res = synthesize(m, frames=frames, seed=0, progress=False)
    model = compile_model(m, device="cpu")
    deepest = max(float(-eval_shape_ground_distance(model, eval_fk(model, mo.q, device="cpu")).numpy().min())
                  for mo in res)
    assert deepest < 2.5e-3
    assert quality_report(res)["foot_sliding_cm_s"] < 0.1
