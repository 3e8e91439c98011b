"""Issue 13, synthesis: legs that only pitch walk, the upper body stays above the ground, the report
counts every shape and says which limb cannot be moved well.

Measured with code paths of their own: feet and heights from :meth:`Motion.end_effector_positions`
(the motion layer's FK), shapes from the contact kernel's shape-ground distance, speeds from NumPy
differences; none reuses the synthesiser's targets or the report's figures.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _synth_creatures import read_creature

from morphkit.graph import EndEffectorRole
from morphkit.rotations import quat_rotate
from morphkit.synth.legged import LegConfig

FRAMES = 600  # two 10-second rollouts
CONTACT_HEIGHT = 0.02


@pytest.fixture(scope="module")
def creatures(tmp_path_factory: pytest.TempPathFactory):
    """``name -> (morphology, SynthResult)`` for the strider and the roo, built on first use."""
    from morphkit.synth import SynthConfig, synthesize

    folder = tmp_path_factory.mktemp("any_creature")
    cache: dict = {}

    def get(name: str):
        if name not in cache:
            m = read_creature(name, folder)
            cfg = replace(SynthConfig(), rollout_seconds=10.0)
            cache[name] = (m, synthesize(m, frames=FRAMES, seed=0, config=cfg, progress=False))
        return cache[name]

    return get


def _steps(h: np.ndarray, xy: np.ndarray) -> tuple[list[float], list[float]]:
    """Step lengths and swing apexes [m] of one foot from its heights [T] and positions [T, 2]: a swing is a
    run of frames above the contact height that the clip does not cut."""
    air = h >= CONTACT_HEIGHT
    edges = np.flatnonzero(np.diff(np.concatenate([[0], air.astype(int), [0]])))
    lengths, apexes = [], []
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if start == 0 or stop == len(h):
            continue
        lengths.append(float(np.linalg.norm(xy[stop] - xy[start - 1])))
        apexes.append(float(h[start:stop].max()))
    return lengths, apexes


def test_planar_legs_are_found_and_step_only_fore_aft(creatures):
    m, res = creatures("strider")
    for j in m.joints:
        assert tuple(j.axis) == (0.0, 1.0, 0.0)  # every joint pitches: the fixture is what it claims
    legs = res.rig.legs
    assert legs.fixed_axes is not None and legs.fixed_axes.tolist() == [[False, True], [False, True]]
    assert res.rig.limits.lateral == (0.0, 0.0) and legs.roll == 0.0
    assert res.rig.summary()["max_lateral_speed_m_s"] == 0.0
    # a turn drags the stance feet across their legs' planes: kept slow (the clamp alone would allow more)
    assert res.rig.summary()["max_yaw_rate_rad_s"] == LegConfig().fixed_axis_yaw_rate < res.rig.max_yaw_rate()
    assert len(res.warnings) == 2 and all("sideways" in w for w in res.warnings)
    assert {w.split(":")[0] for w in res.warnings} == {"leg l_sole", "leg r_sole"}


def test_planar_biped_walks_with_long_clear_steps_and_planted_feet(creatures):
    m, res = creatures("strider")
    feet = [i for i, e in enumerate(m.end_effectors) if e.role == EndEffectorRole.FOOT]
    lengths, apexes, speeds = [], [], []
    for mo in res:
        p = mo.end_effector_positions()[:, feet]  # [T, F, 3]
        v = np.linalg.norm(np.gradient(p[..., :2], axis=0), axis=-1) * mo.fps
        speeds.append(v[p[..., 2] < CONTACT_HEIGHT])
        for f in range(len(feet)):
            ll, aa = _steps(p[:, f, 2], p[:, f, :2])
            lengths += ll
            apexes += aa
    assert len(lengths) > 20
    assert np.mean(lengths) >= 0.10  # steps of 10 cm or more (the issue measured 1.4 cm)
    assert np.concatenate(speeds).mean() < 0.01  # sliding < 1 cm/s (was 9.9)
    assert np.min(apexes) > 0.02  # every swing clears 2 cm (was 9 mm)


def test_planar_biped_keeps_its_feet_level_and_nothing_below_the_ground(creatures):
    from morphkit.kernels import eval_fk
    from morphkit.kernels.contact import eval_shape_ground_distance
    from morphkit.model import compile_model

    m, res = creatures("strider")
    model = compile_model(m, device="cpu")
    for mo in res:
        d = eval_shape_ground_distance(model, eval_fk(model, mo.q, device="cpu")).numpy()
        assert d.min() > -0.005  # the foot boxes too: the pitch ankle keeps them level
        X = mo.link_poses()
        for side in ("l", "r"):
            up = quat_rotate(X[:, m.link_index(f"{side}_foot"), 3:], np.array([0.0, 0.0, 1.0]))
            assert up[:, 2].min() > np.cos(0.05)  # the foot's up axis stays within 0.05 rad of vertical


def test_the_tail_stays_above_the_ground(creatures):
    from morphkit.kernels import eval_fk
    from morphkit.kernels.contact import eval_shape_ground_distance
    from morphkit.model import compile_model
    from morphkit.synth import SynthConfig, synthesize

    m, _ = creatures("roo")
    # the roo hopping at its stroke's top speed (Froude 1.9, above the default cap) dips its body enough for
    # the guard to lift the tail in these two rollouts
    cfg = replace(SynthConfig(), rollout_seconds=10.0, legs=replace(LegConfig(), max_froude=None))
    res = synthesize(m, frames=FRAMES, seed=0, config=cfg, progress=False)
    assert res.rig.plan.arms[0].end_effector == "tail_tip"  # no role: a tool, moved like an arm
    model = compile_model(m, device="cpu")
    tail = [s for s in range(model.shape_count) if model.link_names[int(model.shape_link[s])].startswith("tail")]
    tip = m.end_effectors.index(m.end_effector("tail_tip"))
    low_shape = low_tip = np.inf
    for mo in res:
        d = eval_shape_ground_distance(model, eval_fk(model, mo.q, device="cpu")).numpy()
        low_shape = min(low_shape, float(d[:, tail].min()))
        low_tip = min(low_tip, float(mo.end_effector_positions()[:, tip, 2].min()))
    assert res.ground.lifted > 0  # the body's dips pressed the tail down, and the lift held it up
    assert low_shape > -0.005 and low_tip > -0.005
    assert not res.ground.stuck


def test_the_report_counts_every_shape_and_names_the_link(tmp_path):
    """A tail ball on a slider, pushed 3 cm below the ground while the feet stand on it."""
    from morphkit.io import read_morphology
    from morphkit.motion import Motion
    from morphkit.synth.report import quality_report

    (tmp_path / "slider.yaml").write_text(
        "name: slider\nbase: fixed\nroot: body\nlinks:\n"
        "  body: {shapes: [{type: box, size: [0.4, 0.2, 0.1], origin: {xyz: [0, 0, 0.3]}}]}\n"
        "  ball: {shapes: [{type: sphere, radius: 0.05}]}\n"
        "  shin: {shapes: [{type: sphere, radius: 0.04, origin: {xyz: [0, 0, 0.04]}}]}\n"
        "joints:\n"
        "  slide: {type: prismatic, parent: body, child: ball, axis: [0, 0, 1], origin: {xyz: [-0.3, 0, 0.2]},"
        " limit: {lower: -0.5, upper: 0.5}}\n"
        "  fix: {type: fixed, parent: body, child: shin, origin: {xyz: [0.2, 0, 0]}}\n"
        "end_effectors:\n  foot: {link: shin, offset: [0, 0, 0], role: foot}\n"
        "  tip: {link: ball, offset: [0.1, 0, -0.02], role: tool}\n")
    m = read_morphology(tmp_path / "slider.yaml")
    q = np.array([[-0.1], [-0.28]])  # ball centre at 0.1, then at -0.08: 13 cm below less its 5 cm radius
    r = quality_report([Motion(m, 30.0, q, "slider")])
    assert r["foot_penetration_mm"] == 0.0  # the foot point stands on the ground
    assert r["penetration_mm"] == pytest.approx(130.0, abs=1e-3)  # the ball: -0.08 - 0.05
    assert r["deepest_link"] == "ball"
    assert any(w.startswith("link ball: goes 13 cm below the ground") for w in r["warnings"])


def test_a_foot_shape_centred_on_the_foot_point_is_not_penetration(synthesized):
    """Spot's foot spheres are centred on the foot points: 3.6 cm of them is below the ground in stance."""
    from morphkit.kernels import eval_fk
    from morphkit.kernels.contact import eval_shape_ground_distance
    from morphkit.model import compile_model
    from morphkit.synth.report import quality_report

    m, res = synthesized("spot")
    model = compile_model(m, device="cpu")
    d = eval_shape_ground_distance(model, eval_fk(model, res[0].q, device="cpu")).numpy()
    assert d.min() < -0.03
    r = quality_report(res)
    assert r["penetration_mm"] < 1.0 and r["deepest_link"] is None
    assert r["legs"].keys() == {leg.end_effector for leg in res.rig.plan.legs}
    assert r["step_length_m"] > 0.05 and r["warnings"] == []


def test_a_foot_fixed_to_its_shin_is_one_rigid_body_for_the_report(tmp_path):
    """A URDF toe fixed to its calf (A1's, with the foot point at the toe ball's centre) is one rigid body: the
    calf reaching below the foot point as at rest is no penetration, as when the foot point is on the calf itself.
    Truth: splitting a body by a fixed joint changes nothing physical, so both reports agree."""
    from morphkit.io import read_morphology
    from morphkit.motion import Motion
    from morphkit.synth.report import quality_report

    head = ("base: fixed\nroot: body\nlinks:\n"
            "  body: {shapes: [{type: box, size: [0.4, 0.2, 0.1], origin: {xyz: [0, 0, 0.3]}}]}\n"
            # the calf's capsule ends 2 cm below the foot point (the toe's centre, 4 cm above its lower end)
            "  calf: {shapes: [{type: capsule, radius: 0.02, length: 0.2, origin: {xyz: [0, 0, 0.14]}}]}\n")
    joints = ("joints:\n  slide: {type: prismatic, parent: body, child: calf, axis: [0, 0, 1],"
              " origin: {xyz: [0.2, 0, 0.04]}, limit: {lower: -0.5, upper: 0.5}}\n")
    split = (head + "  toe: {shapes: [{type: sphere, radius: 0.02}]}\n" + joints +
             "  toe_fixed: {type: fixed, parent: calf, child: toe, origin: {xyz: [0, 0, 0.04]}}\n"
             "end_effectors:\n  foot: {link: toe, offset: [0, 0, 0], role: foot}\n")
    whole = (head.replace("origin: {xyz: [0, 0, 0.14]}}]}", "origin: {xyz: [0, 0, 0.14]}},"
                          " {type: sphere, radius: 0.02, origin: {xyz: [0, 0, 0.04]}}]}") + joints +
             "end_effectors:\n  foot: {link: calf, offset: [0, 0, 0.04], role: foot}\n")
    reports = []
    for name, text in (("split", split), ("whole", whole)):
        (tmp_path / f"{name}.yaml").write_text(f"name: {name}\n" + text)
        m = read_morphology(tmp_path / f"{name}.yaml")
        q = np.array([[-0.08], [-0.09]])  # the foot point on the ground, then 1 cm under it
        reports.append(quality_report([Motion(m, 30.0, q, name)]))
    split_r, whole_r = reports
    assert whole_r["penetration_mm"] == pytest.approx(10.0, abs=1e-3)  # only the 1 cm push counts
    assert split_r["penetration_mm"] == pytest.approx(whole_r["penetration_mm"], abs=1e-6)
