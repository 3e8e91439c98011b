"""Synthesis building blocks against analytic truths: gaits, commands, root integration, body plans,
IK projections; and the dataset's determinism and storage through the motion data layer."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from morphkit.errors import ConfigError
from morphkit.synth import SynthConfig, analyse, synthesize
from morphkit.synth.gait import GaitClock, gait_bands, leg_layout
from morphkit.synth.locomotion_commands import CommandConfig, CommandLimits, draw_commands, integrate_root

# ---- gaits -----------------------------------------------------------------------------------
QUAD = np.array([[0.3, 0.15], [0.3, -0.15], [-0.3, 0.15], [-0.3, -0.15]])  # LF RF LH RH
HEX = np.array([[0.2, 0.3], [0.0, 0.35], [-0.2, 0.3], [0.2, -0.3], [0.0, -0.35], [-0.2, -0.3]])


def _gait(bands, name):
    return next(g for b in bands for g in b.gaits if g.name == name)


def test_quadruped_gaits_pair_the_right_legs():
    bands = gait_bands(QUAD)
    LF, RF, LH, RH = range(4)
    trot, pace, bound = _gait(bands, "trot"), _gait(bands, "pace"), _gait(bands, "bound")
    assert trot.touchdown[LF] == trot.touchdown[RH] and trot.touchdown[RF] == trot.touchdown[LH]
    assert abs(trot.touchdown[LF] - trot.touchdown[RF]) == pytest.approx(0.5)
    assert pace.touchdown[LF] == pace.touchdown[LH] and pace.touchdown[RF] == pace.touchdown[RH]
    assert bound.touchdown[LF] == bound.touchdown[RF] and bound.touchdown[LH] == bound.touchdown[RH]
    walk = _gait(bands, "walk")
    assert sorted(walk.touchdown) == [0.0, 0.25, 0.5, 0.75]  # one foot at a time
    duties = [max(g.duty for g in b.gaits) for b in bands]
    assert duties == sorted(duties, reverse=True)  # slower bands keep feet down longer
    assert [b.upper for b in bands] == sorted(b.upper for b in bands)


def test_hexapod_tripod_alternates_triangles():
    tripod = _gait(gait_bands(HEX), "tripod")
    lay = leg_layout(HEX)
    l1, l2, l3 = lay["left"]
    r1, r2, r3 = lay["right"]
    a = {tripod.touchdown[i] for i in (l1, r2, l3)}
    b = {tripod.touchdown[i] for i in (r1, l2, r3)}
    assert len(a) == 1 and len(b) == 1 and abs(a.pop() - b.pop()) == pytest.approx(0.5)
    wave = _gait(gait_bands(HEX), "wave")
    assert wave.duty == pytest.approx(5 / 6)
    assert len(set(wave.touchdown)) == 6


@pytest.mark.parametrize("n", [3, 5, 8])
def test_other_leg_counts_get_a_wave_and_a_fast_gait(n):
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False) + 0.1
    feet = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    bands = gait_bands(feet)
    wave = bands[0].gaits[0]
    assert wave.name == "wave" and wave.duty == pytest.approx(1 - 1 / n)
    assert sorted(np.round(wave.touchdown, 9)) == sorted(np.round(np.arange(n) / n, 9))
    # with duty 1 - 1/n and evenly spaced touchdowns, never more than one foot is in the air
    phase = ((np.arange(1000) + 0.5) / 1000)[:, None]  # off the exact switching phases
    airborne = ((phase - np.array(wave.touchdown)) % 1.0 >= wave.duty).sum(axis=1)
    assert airborne.max() <= 1
    fast = bands[-1].gaits[0]
    assert fast.duty == 0.5
    if n % 2 == 0:
        ring = leg_layout(feet)["ring"]
        phases = [fast.touchdown[i] for i in ring]
        assert all(abs(a - b) == pytest.approx(0.5) for a, b in itertools.pairwise(phases))


def test_gait_clock_blends_and_advances():
    bands = gait_bands(QUAD)
    clock = GaitClock(bands, 3)
    s = np.array([0.0, 0.2, 0.9])
    for _ in range(85):
        psi = clock.advance(s, np.zeros(3), lambda duty: np.full(3, 2.0), 1 / 30)
    names = [clock.gaits[i].name for i in clock.current]
    assert names == ["walk", "trot", "gallop"]
    for r, name in enumerate(names):  # after ~3 s the blend has reached the target gait
        np.testing.assert_allclose(clock.touchdown[r], _gait(bands, name).touchdown, atol=1e-9)
        assert clock.duty[r] == pytest.approx(_gait(bands, name).duty)
    assert clock.phase == pytest.approx(np.full(3, (85 * 2.0 / 30) % 1.0))
    assert psi.shape == (3, 4)


# ---- commands --------------------------------------------------------------------------------
LIMITS = CommandLimits(forward=(-1.0, 3.0), lateral=(-0.5, 0.5), yaw=(-1.0, 1.0), height=(-0.05, 0.02),
                       pitch=0.1, roll=0.05, acceleration=2.0, yaw_acceleration=2.0)


def test_commands_stay_in_range_and_respect_acceleration():
    rngs = [np.random.default_rng(i) for i in range(8)]
    cfg = CommandConfig()
    fps = 30.0
    track = draw_commands(rngs, 900, fps, cfg, LIMITS)
    c = track.command
    assert c.shape == (8, 900, 6)
    assert (c[..., 0] >= -1.0 - 1e-12).all() and (c[..., 0] <= 3.0 + 1e-12).all()
    assert (np.abs(c[..., 1]) <= 0.5 + 1e-12).all() and (np.abs(c[..., 2]) <= 1.0 + 1e-12).all()
    assert (c[..., 3] >= -0.05 - 1e-12).all() and (c[..., 3] <= 0.02 + 1e-12).all()
    acc = np.abs(np.diff(c[..., :2], axis=1)) * fps
    assert acc.max() <= 2.0 * 1.05  # smoothstep ramps sized to the acceleration limit
    assert (np.abs(np.diff(c[..., 2], axis=1)) * fps).max() <= 2.0 * 1.05
    # settled frames: the command equals its target
    np.testing.assert_allclose(c[track.settled], track.target[track.settled], atol=1e-12)
    assert track.settled.mean() > 0.3
    np.testing.assert_array_equal(c[:, 0], 0.0)  # rollouts start standing


def test_commands_depend_only_on_their_generator():
    cfg = CommandConfig()
    a = draw_commands([np.random.default_rng(5)], 300, 30.0, cfg, LIMITS).command[0]
    b = draw_commands([np.random.default_rng(1), np.random.default_rng(5)], 300, 30.0, cfg, LIMITS).command[1]
    np.testing.assert_array_equal(a, b)


def test_feasibility_clamp_scales_targets():
    lim = replace(LIMITS, clamp=lambda v: v * 0.5)
    track = draw_commands([np.random.default_rng(0)], 900, 30.0, CommandConfig(), lim)
    assert np.abs(track.target[..., 0]).max() <= 1.5 + 1e-12
    assert track.clamped.any()


def test_the_fastest_turn_on_the_spot_is_what_the_legs_can_step(synth_creature):
    """The crab's short steps far from its centre cap its turns (the range drawn is wider: the clamp scales a
    faster turn down); the cap is what the speed fraction's formula gives by hand: turning at w moves foot l along
    its tangent at w|p_l|, i.e. w|p_l|/2r_l strokes per second with r_l the ellipse's half-chord along the
    tangent."""
    from morphkit.synth import prepare

    m = synth_creature("crab")
    cfg = replace(SynthConfig(), commands=replace(CommandConfig(), yaw_rate=(-3.0, 3.0)))
    rig = prepare(m, config=cfg)
    lr, lc = rig.legs, cfg.legs
    p, ax = lr.nominal_xy, lr.semi_axes
    tangent = np.stack([-p[:, 1], p[:, 0]], axis=1) / np.linalg.norm(p, axis=1, keepdims=True)
    half_chord = 1.0 / np.hypot(tangent[:, 0] / ax[:, 0], tangent[:, 1] / ax[:, 1])
    strokes_per_radian = (np.linalg.norm(p, axis=1) / (2.0 * half_chord)).max()
    top = lc.speed_fraction_limit * lc.max_stroke_usage / (strokes_per_radian * lr.stance_span(lr.duty_min))
    assert 0.5 < top < 3.0
    assert rig.max_yaw_rate() == pytest.approx(top, rel=1e-9)
    assert rig.summary()["max_yaw_rate_rad_s"] == pytest.approx(top, abs=1e-3)
    np.testing.assert_allclose(rig.limits.clamp(np.array([[0.0, 0.0, -3.0]])), [[0.0, 0.0, -top]], rtol=1e-9)
    assert rig.limits.yaw == (-3.0, 3.0)


def test_dynamic_similarity_bounds_the_body_speed_not_the_turn(synth_creature):
    """With ``max_froude`` F the fastest command is sqrt(F g h) (h the stance height) in every direction, the
    turn rate untouched; without it the legs' stroke alone bounds it (faster here). Where the bound is below the
    stroke's top, every speed range shrinks by their ratio (backwards and sideways too); where it is above (the
    default on this quadruped, Froude 0.7 at its stroke's top), the ranges are the stroke's. The synthesised
    root never moves faster than the bound, measured from its positions."""
    from morphkit.synth import prepare
    from morphkit.synth.legged import GRAVITY, LegConfig

    m = synth_creature("spot")
    F = 0.2
    cfg = replace(SynthConfig(), legs=replace(LegConfig(), max_froude=F))
    rig = prepare(m, config=cfg)
    top = np.sqrt(F * GRAVITY * rig.legs.stance_height)
    free = prepare(m, config=replace(SynthConfig(), legs=replace(LegConfig(), max_froude=None)))
    assert free.max_speed(np.array([1.0, 0.0])) > 1.5 * top
    for d in ([1.0, 0.0], [0.0, 1.0], [-0.6, 0.8]):
        assert rig.max_speed(np.array(d)) == pytest.approx(top, rel=1e-9)
    cmd = np.array([[1.3 * top, 0.0, 0.1]])  # within the stroke's reach: only the speed is scaled
    np.testing.assert_allclose(free.limits.clamp(cmd), cmd, rtol=1e-12)
    np.testing.assert_allclose(rig.limits.clamp(cmd), [[top, 0.0, 0.1]], rtol=1e-9)
    assert rig.max_yaw_rate() == pytest.approx(free.max_yaw_rate(), rel=1e-9)
    k = top / free.limits.forward[1]  # the bound over the stroke's top
    cc = cfg.commands  # the paper's ranges at this size, then times k (all below what the stroke allows)
    np.testing.assert_allclose(rig.limits.forward, [cc.forward_speed[0] * rig.scale * k, top], rtol=1e-9)
    np.testing.assert_allclose(rig.limits.lateral, np.multiply(cc.lateral_speed, rig.scale * k), rtol=1e-9)
    default = prepare(m)
    assert default.limits.forward == free.limits.forward and default.limits.lateral == free.limits.lateral
    motion = synthesize(m, frames=900, seed=1, config=cfg, progress=False)[0]
    speed = np.linalg.norm(np.diff(motion.root_pose()[:, :2], axis=0), axis=1) * motion.fps
    assert speed.max() <= top * 1.05
    assert speed.max() >= 0.5 * top  # it does walk


def test_stance_extension_defaults_match_the_anatomy_where_their_docstrings_say_so():
    """LegConfig's fallback stance and cap are the anatomy's stance numbers, kept apart by layer: a change to one
    must revisit the other's docstring."""
    from morphkit.body import ANATOMY
    from morphkit.synth.legged import LegConfig

    legs = LegConfig()
    assert legs.stance_extension_fallback == 0.8 and ANATOMY.stance_extension == 0.72
    assert legs.stance_extension_max == ANATOMY.biped_stance_extension == 0.92
    assert legs.biped_stance_extension_fallback == 0.88


def test_integrate_root_follows_a_circle():
    fps, v, w = 60.0, 1.2, 0.5
    T = 600
    cmd = np.zeros((1, T, 6))
    cmd[..., 0], cmd[..., 2] = v, w
    xy, yaw = integrate_root(cmd, fps, np.array([0.3]))
    t = np.arange(T) / fps
    np.testing.assert_allclose(yaw[0], 0.3 + w * t, atol=1e-12)
    r = v / w
    centre = np.array([-r * np.sin(0.3), r * np.cos(0.3)])
    np.testing.assert_allclose(np.linalg.norm(xy[0] - centre, axis=1), r, rtol=1e-4)


# ---- body plans and IK -------------------------------------------------------------------------
def test_yaml_creatures_body_plans(synth_creature):
    tri = analyse(synth_creature("tripod"))
    assert len(tri.legs) == 3 and len(tri.arms) == 1
    assert tri.arms[0].joints == ("arm_yaw", "arm_pitch", "arm_extend")
    spider = analyse(synth_creature("spider"))
    assert len(spider.legs) == 8 and not spider.arms and spider.head == "head"
    assert spider.leg_reach == pytest.approx(0.04 + 0.16 + 0.2, rel=1e-6)


def test_ball_joint_projection_keeps_hinges_and_removes_hip_twist(synth_creature):
    from morphkit.conventions import quat_from_axis_angle, quat_multiply
    from morphkit.synth._ik import LimbSolver

    m = synth_creature("human")
    solver = LimbSolver(m, analyse(m))
    kinds = {k for _, _, k in solver.ball_constraints}
    assert -2 in kinds and any(k >= 0 for k in kinds)  # knees and hips
    rng = np.random.default_rng(0)
    q = np.repeat(m.rest_q()[None], 16, axis=0)
    for s, _axis, _kind in solver.ball_constraints:
        q[:, s:s + 4] = quat_multiply(quat_from_axis_angle(rng.normal(size=(16, 3)) /
                                                           np.sqrt(3), rng.uniform(-1, 1, 16)), q[:, s:s + 4])
        q[:, s:s + 4] /= np.linalg.norm(q[:, s:s + 4], axis=1, keepdims=True)
    p = solver.constrain(q.copy())
    for s, axis, kind in solver.ball_constraints:
        quat = p[:, s:s + 4]
        np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
        if kind == -2:  # knee: a rotation about its hinge axis only
            others = [a for a in range(3) if a != axis]
            np.testing.assert_allclose(quat[:, others], 0.0, atol=1e-12)
        else:  # hip: projecting twice changes nothing, and the bone still points the same way
            np.testing.assert_allclose(solver.constrain(p.copy())[:, s:s + 4], quat, atol=1e-9)
            from morphkit.conventions import quat_rotate

            e = np.zeros(3)
            e[axis] = 1.0
            np.testing.assert_allclose(quat_rotate(quat, e), quat_rotate(q[:, s:s + 4], e), atol=1e-9)


# ---- datasets -----------------------------------------------------------------------------------
def test_same_seed_same_motions_whatever_the_batch(synth_creature):
    m = synth_creature("crab")
    cfg = replace(SynthConfig(), rollout_seconds=3.0)
    a = synthesize(m, frames=270, seed=3, config=cfg, progress=False)
    b = synthesize(m, frames=270, seed=3, config=replace(cfg, batch=1), progress=False)
    c = synthesize(m, frames=270, seed=4, config=cfg, progress=False)
    assert [len(x) for x in a] == [90, 90, 90]
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.q, y.q)
        assert x.name == y.name
    assert not np.allclose(a[0].q, c[0].q)


def test_last_rollout_is_shortened_to_the_frame_count(synth_creature):
    m = synth_creature("stretch")
    res = synthesize(m, frames=100, seed=0, config=replace(SynthConfig(), rollout_seconds=1.0), progress=False)
    assert [x.frame_count for x in res] == [30, 30, 30, 10]
    assert res.frame_count == 100


def test_saved_folder_reads_back_through_the_data_layer(synthesized, tmp_path):
    from morphkit.motion import read_motion
    from morphkit.motion.datasets import load_motions
    from morphkit.motion.io_npz import read_npz_motion_with_extra
    from morphkit.motion.states import character_state_from_motion

    m, res = synthesized("tripod")
    paths = res.save(tmp_path / "tripod_data")
    assert len(paths) == len(res)
    loaded = load_motions(tmp_path / "tripod_data", cache_dir=None)
    assert [x.name for x in loaded] == [x.name for x in res]
    for a, b in zip(loaded, res, strict=True):
        np.testing.assert_array_equal(a.q, b.q)
        assert a.fps == b.fps and a.morphology.coordinate_names == m.coordinate_names
    _, extra = read_npz_motion_with_extra(paths[0])
    assert extra["command"].shape == (res[0].frame_count, 6)
    assert extra["contact"].shape == (res[0].frame_count, 3)
    assert list(extra["gait_names"]) == list(res.gait_names)
    states = character_state_from_motion(read_motion(paths[0]))
    assert states.shape[0] == res[0].frame_count and np.isfinite(states).all()


def test_saved_single_file_concatenates_with_clip_starts(synthesized, tmp_path):
    from morphkit.motion.io_npz import read_npz_motion_with_extra

    _, res = synthesized("stretch")
    (path,) = res.save(tmp_path / "all.npz")
    motion, extra = read_npz_motion_with_extra(path)
    assert motion.frame_count == res.frame_count
    starts = extra["clip_starts"]
    np.testing.assert_array_equal(starts, np.cumsum([0, *[x.frame_count for x in res][:-1]]))
    for s, x in zip(starts, res, strict=True):
        np.testing.assert_array_equal(motion.q[s:s + x.frame_count], x.q)


def test_bad_arguments_raise_config_errors(synth_creature):
    m = synth_creature("crab")
    with pytest.raises(ConfigError):
        synthesize(m, frames=0, progress=False)
    with pytest.raises(ConfigError):
        synthesize(m, frames=10, fps=0.0, progress=False)
    with pytest.raises(ConfigError):
        synthesize(m, frames=10, config=replace(SynthConfig(), batch=0), progress=False)


def test_report_keys_and_figures(synthesized):
    from morphkit.synth.report import REPORT_KEYS, format_report, quality_report

    _, res = synthesized("spot")
    r = quality_report(res)
    assert set(REPORT_KEYS) <= set(r)
    assert r["frames"] == res.frame_count and r["frames_per_s"] > 0
    assert r["foot_sliding_cm_s"] < 1.0 and r["penetration_mm"] < 5.0
    assert r["limit_violation_frac"] == 0.0 and r["self_collision_frac"] < 0.01
    assert r["tracking_error"] < 0.1
    assert "foot sliding" in format_report(r)


def _arm_creature(base: str):
    from morphkit.graph import Limit, MorphologyBuilder, Shape, ShapeType, Transform

    b = MorphologyBuilder(f"arm_on_{base}")
    b.set_base(base)
    for n in ("torso", "upper", "fore"):
        b.add_link(n)
    b.add_shape("torso", Shape(ShapeType.BOX, size=(0.3, 0.3, 0.2), origin=Transform((0, 0, 0.1))))
    b.add_shape("upper", Shape(ShapeType.CAPSULE, radius=0.03, length=0.3, origin=Transform.from_xyz_rpy(
        (0.15, 0, 0), (0, 1.5708, 0))))
    b.add_shape("fore", Shape(ShapeType.CAPSULE, radius=0.025, length=0.25, origin=Transform.from_xyz_rpy(
        (0.125, 0, 0), (0, 1.5708, 0))))
    b.add_joint_revolute("yaw", "torso", "upper", origin=Transform((0, 0, 0.3)), axis=(0, 0, 1),
                         limit=Limit(-2.0, 2.0))
    b.add_joint_revolute("elbow", "upper", "fore", origin=Transform((0.3, 0, 0)), axis=(0, -1, 0),
                         limit=Limit(-0.5, 1.5))
    b.add_end_effector("tip", "fore", offset=(0.25, 0, 0), role="hand")
    return b.build()


def test_fixed_base_arm_stays_mounted_and_moves():
    m = _arm_creature("fixed")
    res = synthesize(m, frames=300, seed=0, config=replace(SynthConfig(), rollout_seconds=5.0), progress=False)
    assert res.rig.locomotion.value == "fixed"
    # starts at a pose of its pool (the rest, or where its walk begins), not turned about the mount
    pool = res.rig.arms
    assert np.abs(pool.q - res[0].q[0, pool.coords]).max(axis=1).min() < 1e-9
    tips = np.concatenate([x.end_effector_positions()[:, 0] for x in res])
    assert tips.std(axis=0).max() > 0.02
    lower, upper = m.coordinate_limits
    q = np.concatenate([x.q for x in res])
    assert (q >= lower - 1e-9).all() and (q <= upper + 1e-9).all()


def test_legless_floating_creature_glides_on_the_ground():
    m = _arm_creature("floating")
    res = synthesize(m, frames=300, seed=0, config=replace(SynthConfig(), rollout_seconds=5.0), progress=False)
    assert res.rig.locomotion.value == "glide"
    for x in res:
        np.testing.assert_allclose(x.q[:, 2], x.q[0, 2])  # constant height: lowest rest point on the ground
        assert abs(m.rest_points()[:, 2].min() + x.q[0, 2]) < 1e-9
    travelled = np.linalg.norm(res[-1].q[-1, :2] - res[-1].q[0, :2])
    assert travelled > 0.1


def test_limb_solver_step_on_recorded_buffers_equals_the_plain_ik_step(synth_creature):
    """``LimbSolver.step`` runs on recorded launches over padded buffers; the numbers are :func:`ik_step`'s,
    bit for bit (the old path, taken when a ``max_error`` is given, at the solver's own)."""
    from morphkit.synth import prepare

    m = synth_creature("tripod")
    solver = prepare(m).solver
    rng = np.random.default_rng(4)
    q = np.repeat(prepare(m).q_stance[None], 5, axis=0)
    q[:, 7:] += rng.normal(0.0, 0.1, (5, q.shape[1] - 7))
    targets = solver.link_transforms(q)[:, [0]][..., :3] + rng.normal(0.0, 0.2, (5, len(solver.leg_ee), 3))
    fast = solver.step(q, targets, ee=solver.leg_ee, mask=solver.leg_mask, iterations=3)
    plain = solver.step(q, targets, ee=solver.leg_ee, mask=solver.leg_mask, iterations=3, max_error=solver.max_error)
    np.testing.assert_array_equal(fast[0], plain[0])
    np.testing.assert_array_equal(fast[1], plain[1])
    assert np.abs(fast[0] - q).max() > 1e-3  # it moved


def test_hang_share_moves_arms_to_the_lowest_neighbour_and_keeps_random_walks_otherwise():
    """A hand-built pose graph: with ``hang_share`` 1 every move goes to the neighbour whose arm tips hang
    lowest; with 0 the walk is the plain random one (the same draws as before the option: same generator,
    same walk); in between, the walk's arm tips sit lower on average."""
    from morphkit.synth.arms import ArmConfig, PosePool, draw_upper_body

    heights = np.array([0.5, 0.1, 0.9, 0.3, 0.7])
    neighbours = np.array([[1, 2], [2, 3], [0, 4], [0, 1], [2, -1]])
    tips = np.zeros((5, 2, 3))
    tips[:, 0, 2], tips[:, 1, 2] = heights - 0.05, heights + 0.05  # two arms, mean height = heights
    pool = PosePool(coords=np.arange(1), quat_offsets=(), q=np.zeros((5, 1)), tips=tips, neighbours=neighbours,
                    arm_coords=np.arange(0), arm_quat_offsets=(), direct=np.arange(1), reach=np.ones(2))
    lowest = {p: min((n for n in row if n >= 0), key=lambda n: heights[n]) for p, row in enumerate(neighbours)}

    def walk(share: float, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
        track = draw_upper_body([np.random.default_rng(seed)], pool, 600, 30.0, replace(ArmConfig(), hang_share=share))
        return track.i0[0], track.i1[0]

    i0, i1 = walk(1.0)
    assert all(b == lowest[a] for a, b in zip(i0, i1, strict=True))
    plain, default = walk(0.0), draw_upper_body([np.random.default_rng(3)], pool, 600, 30.0, ArmConfig())
    np.testing.assert_array_equal(plain[1], default.i1[0])
    assert any(b != lowest[a] for a, b in zip(*plain, strict=True))
    mean_height = [np.mean([heights[walk(s, seed)[0]].mean() for seed in range(20)]) for s in (0.0, 0.5)]
    assert mean_height[1] < mean_height[0] - 0.05
