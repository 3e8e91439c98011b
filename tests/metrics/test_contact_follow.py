"""Foot-contact figures and follow scores on constructed motions of a tiny YAML quadruped (and the metric biped)."""

from __future__ import annotations

import numpy as np
import pytest
from _metric_creatures import biped_motion as _biped_motion
from _metric_creatures import metric_biped

from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.io.yaml_format import parse_yaml
from morphkit.metrics import (
    UFR_LOOSE,
    UFR_MEDIUM,
    UFR_SETTINGS,
    UFR_STRICT,
    FootContactFigures,
    PhysDiffFigures,
    UnrealisticFrameThresholds,
    floating_frames,
    follow_gain,
    follow_score,
    foot_contact_figures,
    longest_flight,
    pearson_follow,
    physdiff_figures,
    reachable_gain,
    skating_ratio,
    unrealistic_frame_ratio,
)
from morphkit.motion import Motion

# A quadruped standing on its four feet when the body is at z = 0.45: hips 5 cm below the body,
# straight legs 0.4 m long. The front-left leg slides along x on a prismatic hip (its foot moves
# horizontally, height unchanged); the other hips pitch about y. A tail (role tool) is no foot.
QUADRUPED_YAML = """
name: metric_quadruped
base: floating
root: body
links:
  body:
    shapes: [{type: box, size: [0.6, 0.3, 0.1]}]
  fl_leg:
    shapes: [{type: capsule, radius: 0.02, length: 0.3, origin: {xyz: [0, 0, -0.2]}}]
  fr_leg:
    shapes: [{type: capsule, radius: 0.02, length: 0.3, origin: {xyz: [0, 0, -0.2]}}]
  hl_leg:
    shapes: [{type: capsule, radius: 0.02, length: 0.3, origin: {xyz: [0, 0, -0.2]}}]
  hr_leg:
    shapes: [{type: capsule, radius: 0.02, length: 0.3, origin: {xyz: [0, 0, -0.2]}}]
joints:
  fl_slide: {type: prismatic, parent: body, child: fl_leg, origin: {xyz: [0.25, 0.12, -0.05]}, axis: [1, 0, 0],
             limit: {lower: -1.0, upper: 1.0}}
  fr_hip: {type: revolute, parent: body, child: fr_leg, origin: {xyz: [0.25, -0.12, -0.05]}, axis: [0, 1, 0],
           limit: {lower: -1.5, upper: 1.5}}
  hl_hip: {type: revolute, parent: body, child: hl_leg, origin: {xyz: [-0.25, 0.12, -0.05]}, axis: [0, 1, 0],
           limit: {lower: -1.5, upper: 1.5}}
  hr_hip: {type: revolute, parent: body, child: hr_leg, origin: {xyz: [-0.25, -0.12, -0.05]}, axis: [0, 1, 0],
           limit: {lower: -1.5, upper: 1.5}}
end_effectors:
  fl_foot: {link: fl_leg, offset: [0, 0, -0.4], role: foot}
  fr_foot: {link: fr_leg, offset: [0, 0, -0.4], role: foot}
  hl_foot: {link: hl_leg, offset: [0, 0, -0.4], role: foot}
  hr_foot: {link: hr_leg, offset: [0, 0, -0.4], role: foot}
  tail: {link: body, offset: [-0.4, 0, -0.45], role: tool}
"""
STAND_Z = 0.45
FPS = 30.0
FEET = ("fl_foot", "fr_foot", "hl_foot", "hr_foot")


@pytest.fixture(scope="module")
def quad() -> Morphology:
    return parse_yaml(QUADRUPED_YAML, source="metric_quadruped.yaml")


def _motion(m: Morphology, T: int, fps: float = FPS, **coords: np.ndarray | float) -> Motion:
    """T frames of the quadruped standing at the origin, coordinates overridden by name (arrays [T] or scalars)."""
    q = np.tile(m.rest_q(), (T, 1))
    q[:, 2] = STAND_Z
    names = list(m.coordinate_names)
    for name, value in coords.items():
        q[:, names.index(name)] = value
    return Motion(m, fps, q, name="constructed")


def _random_motion(m: Morphology, T: int, seed: int) -> Motion:
    """Feet around the ground: some in contact, some sunk, some lifted; legs and body wandering (random walks)."""
    rng = np.random.default_rng(seed)

    def walk(step: float, bound: float) -> np.ndarray:
        return np.clip(np.cumsum(rng.normal(0.0, step, T)), -bound, bound)

    return _motion(
        m,
        T,
        base_x=walk(0.01, 1.0),
        base_y=walk(0.005, 1.0),
        base_z=STAND_Z + walk(0.01, 0.04),
        fl_slide=walk(0.015, 0.2),
        fr_hip=walk(0.05, 0.5),
        hl_hip=walk(0.05, 0.5),
        hr_hip=walk(0.05, 0.5),
    )


def test_the_quadruped_stands_on_its_four_feet(quad):
    pos = _motion(quad, 1).end_effector_positions()[0]
    np.testing.assert_allclose(pos[:, 2], 0.0, atol=1e-12)
    pos = _motion(quad, 1, fl_slide=0.1).end_effector_positions()[0]  # the slide moves the foot along x only
    np.testing.assert_allclose(pos[0], [0.35, 0.12, 0.0], atol=1e-12)


# ---- foot_contact_figures ---------------------------------------------------------------------
def test_one_foot_of_four_sliding_is_a_quarter_of_foot_frames_but_every_ufr_frame(quad):
    # The front-left foot slides 1 cm per frame (0.3 m/s at 30 fps) on the ground, the others stay
    # planted. Backward differences give frame 0 frame 1's velocity, so the foot slides at every frame.
    T = 20
    motion = _motion(quad, T, fl_slide=0.01 * np.arange(T))
    f = foot_contact_figures(motion)
    assert f.foot_names == FEET and f.frame_count == T and f.foot_frame_count == 4 * T
    assert f.sliding.shape == (T, 4) and f.sliding.dtype == bool
    np.testing.assert_array_equal(f.sliding_rate_per_foot, [1.0, 0.0, 0.0, 0.0])
    assert f.sliding_rate == 0.25
    assert f.penetration_rate == 0.0 and not f.penetration_rate_per_foot.any()
    ufr = unrealistic_frame_ratio(motion)
    assert ufr.cause_ratios()["foot_sliding"] == 1.0
    np.testing.assert_array_equal(ufr.foot_sliding, f.sliding.any(axis=1))
    # at 0.5 m/s (medium) the same foot does not slide
    assert foot_contact_figures(motion, UFR_MEDIUM).sliding_rate == 0.0


def test_per_foot_flags_are_ufrs_flags_per_foot_on_random_motions(quad):
    for seed in range(3):
        motion = _random_motion(quad, 40, seed)
        for name, thr in UFR_SETTINGS.items():
            f = foot_contact_figures(motion, thr)
            ufr = unrealistic_frame_ratio(motion, thresholds=thr)
            np.testing.assert_array_equal(f.sliding.any(axis=1), ufr.foot_sliding, err_msg=name)
            np.testing.assert_array_equal(f.penetration.any(axis=1), ufr.foot_penetration, err_msg=name)
    f = foot_contact_figures(_random_motion(quad, 40, 0))
    assert 0.0 < f.sliding_rate < 1.0 and 0.0 < f.penetration_rate < 1.0  # the random motions exercise both


def test_a_touchdown_is_not_sliding_and_penetration_counts_per_foot(quad):
    # Frames 0..4 the front-right leg is pitched 0.6 rad (foot 7 cm up, 23 cm back); it lands at frame 5,
    # whose backward difference reads the swing: no sliding (UFR's rule).
    T = 10
    hip = np.where(np.arange(T) < 5, 0.6, 0.0)
    f = foot_contact_figures(_motion(quad, T, fr_hip=hip))
    assert not f.sliding.any()
    # all four feet 8 mm under the ground for the last 4 of 10 frames: 40 % of foot-frames (beyond 5 mm)
    z = np.where(np.arange(T) >= 6, STAND_Z - 0.008, STAND_Z)
    f = foot_contact_figures(_motion(quad, T, base_z=z))
    assert f.penetration_rate == pytest.approx(0.4)
    np.testing.assert_allclose(f.penetration_rate_per_foot, 0.4)
    assert not f.sliding.any()
    assert foot_contact_figures(_motion(quad, T, base_z=z), UFR_MEDIUM).penetration_rate == 0.0  # within 1 cm


def test_foot_contact_figures_pool_and_name_feet(quad):
    a = foot_contact_figures(_motion(quad, 10, fl_slide=0.01 * np.arange(10)))
    b = foot_contact_figures(_motion(quad, 30))
    pooled = FootContactFigures.concatenate([a, b])
    assert pooled.frame_count == 40 and pooled.sliding_rate == pytest.approx(10 / 160)
    assert FootContactFigures.concatenate([]).sliding_rate == 0.0
    tail = foot_contact_figures(_motion(quad, 10, base_x=0.01 * np.arange(10)), feet=["tail"])
    assert tail.foot_names == ("tail",) and tail.sliding_rate == 1.0
    with pytest.raises(ConfigError, match="differ"):
        FootContactFigures.concatenate([a, tail])
    with pytest.raises(ConfigError, match="no end-effector 'hoof'"):
        foot_contact_figures(_motion(quad, 2), feet=["hoof"])
    none = foot_contact_figures(_motion(quad, 5), feet=[])
    assert none.sliding.shape == (5, 0) and none.sliding_rate == 0.0 and none.sliding_rate_per_foot.shape == (0,)


def test_the_three_ufr_settings():
    assert UFR_STRICT == UnrealisticFrameThresholds()
    assert (UFR_MEDIUM.contact_height, UFR_MEDIUM.sliding_speed, UFR_MEDIUM.penetration_depth) == (0.05, 0.5, 0.01)
    assert (UFR_LOOSE.contact_height, UFR_LOOSE.sliding_speed, UFR_LOOSE.penetration_depth) == (0.05, 1.0, 0.02)
    assert dict(UFR_SETTINGS) == {"strict": UFR_STRICT, "medium": UFR_MEDIUM, "loose": UFR_LOOSE}
    with pytest.raises(TypeError):
        UFR_SETTINGS["custom"] = UFR_STRICT  # type: ignore[index]


# ---- skating ratio ----------------------------------------------------------------------------
def _naive_skating_ratio(pos: np.ndarray, fps: float, height: float, speed: float, window: int) -> float:
    T, F = pos.shape[:2]
    if T < 2:
        return 0.0
    s = [[float(np.hypot(*(pos[k + 1, f, :2] - pos[k, f, :2]))) * fps for f in range(F)] for k in range(T - 1)]
    count = 0
    for k in range(T - 1):
        hit = False
        for f in range(F):
            lo = k - window // 2
            avg = sum(s[j][f] for j in range(lo, lo + window) if 0 <= j < T - 1) / window
            contact = pos[k, f, 2] < height and pos[k + 1, f, 2] < height
            hit = hit or (contact and s[k][f] > speed and avg > speed)
        count += hit
    return count / (T - 1)


def test_skating_ratio_matches_a_naive_loop(quad):
    for seed in range(4):
        motion = _random_motion(quad, 50, seed)
        pos = motion.end_effector_positions()[:, :4]
        for window in (1, 2, 5):
            for height, speed in ((0.05, 0.5), (0.02, 0.2)):
                got = skating_ratio(motion, height, speed, window=window)
                assert got == pytest.approx(_naive_skating_ratio(pos, FPS, height, speed, window), abs=1e-9)
    assert 0.0 < skating_ratio(_random_motion(quad, 50, 0), window=1) < 1.0


def test_skating_ratio_on_constructed_motions(quad):
    # 3 cm per frame at 30 fps = 0.9 m/s in contact: all T - 1 transitions skate, also with GMD's
    # 5-transition zero-padded window (at the ends it averages 3 of 5 transitions: 0.54 > 0.5 m/s).
    T = 20
    motion = _motion(quad, T, fl_slide=0.03 * np.arange(T))
    assert skating_ratio(motion, window=1) == 1.0
    assert skating_ratio(motion) == 1.0
    # 2 cm per frame = 0.6 m/s: with the window the two transitions at each end average
    # 0.6 · 3/5 = 0.36 and 0.6 · 4/5 = 0.48 m/s, below 0.5: 15 of 19 transitions skate.
    motion = _motion(quad, T, fl_slide=0.02 * np.arange(T))
    assert skating_ratio(motion, window=1) == 1.0
    assert skating_ratio(motion) == pytest.approx(15 / 19)
    # standing, or sliding with the foot lifted (body 10 cm up), never skates
    assert skating_ratio(_motion(quad, T)) == 0.0
    assert skating_ratio(_motion(quad, T, base_z=STAND_Z + 0.1, fl_slide=0.03 * np.arange(T))) == 0.0
    assert skating_ratio(_motion(quad, 1)) == 0.0
    with pytest.raises(ConfigError, match="window"):
        skating_ratio(motion, window=0)
    with pytest.raises(ConfigError, match="speed"):
        skating_ratio(motion, speed=-1.0)


# ---- PhysDiff ---------------------------------------------------------------------------------
def _naive_physdiff(pos: np.ndarray, ground: float, contact: float) -> tuple[float, float, float]:
    T, F = pos.shape[:2]
    pen = flo = 0.0
    for t in range(T):
        heights = [pos[t, f, 2] - ground for f in range(F)]
        pen += max(max(0.0, -h) for h in heights)
        flo += max(0.0, min(heights))
    skates = []
    for t in range(T - 1):
        for f in range(F):
            if pos[t, f, 2] - ground < contact and pos[t + 1, f, 2] - ground < contact:
                dx, dy = pos[t + 1, f, :2] - pos[t, f, :2]
                skates.append((dx * dx + dy * dy) ** 0.5)
    skate = sum(skates) / len(skates) if skates else 0.0
    return 1000 * pen / T, 1000 * flo / T, 1000 * skate
def test_pooled_skating_weighs_clips_by_their_transitions(quad):
    """The humans' bar (and each row's skating): transitions pooled over clips, not a mean of per-clip ratios."""
    from morphkit.evaluation.table import pooled_skating

    clips = [_motion(quad, 20, fl_slide=0.03 * np.arange(20)),  # 19 of 19 transitions skate (above)
             _motion(quad, 11),  # standing: 0 of 10
             _motion(quad, 20, fl_slide=0.02 * np.arange(20))]  # 15 of 19
    assert pooled_skating(clips) == pytest.approx(34 / 48)
    assert pooled_skating(clips[1:2]) == 0.0 and pooled_skating([]) == 0.0




def test_physdiff_figures_match_a_naive_loop(quad):
    for seed in range(4):
        motion = _random_motion(quad, 50, seed)
        pos = motion.end_effector_positions()[:, :4]
        for ground, contact in ((0.0, 0.05), (0.01, 0.02), (-0.02, 0.1)):
            got = physdiff_figures(motion, ground_height=ground, contact_height=contact)
            want = _naive_physdiff(pos, ground, contact)
            assert got.penetrate_mm == pytest.approx(want[0], abs=1e-9)
            assert got.float_mm == pytest.approx(want[1], abs=1e-9)
            assert got.skate_mm == pytest.approx(want[2], abs=1e-9)
    got = physdiff_figures(_random_motion(quad, 50, 0))
    assert got.penetrate_mm > 0 and got.float_mm > 0 and got.skate_mm > 0


def test_physdiff_figures_on_constructed_motions(quad):
    T = 10
    stand = physdiff_figures(_motion(quad, T))  # feet at z = 0 up to rounding
    assert (stand.penetrate_mm, stand.float_mm, stand.skate_mm) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    sunk = physdiff_figures(_motion(quad, T, base_z=STAND_Z - 0.01))
    assert sunk.penetrate_mm == pytest.approx(10.0) and sunk.float_mm == 0.0
    up = physdiff_figures(_motion(quad, T, base_z=STAND_Z + 0.03))
    assert up.float_mm == pytest.approx(30.0) and up.penetrate_mm == 0.0 and up.skate_mm == pytest.approx(0.0)
    # one foot 3 cm up, the others down: nothing floats; the body 3 cm up, 6 cm with the ground at -3 cm
    lifted = physdiff_figures(_motion(quad, T, hr_hip=0.4))
    assert lifted.float_mm == pytest.approx(0.0, abs=1e-9)
    assert physdiff_figures(_motion(quad, T, base_z=STAND_Z + 0.03), ground_height=-0.03).float_mm == pytest.approx(
        60.0
    )
    # one foot of four slides 1 cm per frame: mean over the 4 · 9 contact pairs is 2.5 mm
    slide = physdiff_figures(_motion(quad, T, fl_slide=0.01 * np.arange(T)))
    assert slide.skate_mm == pytest.approx(2.5)
    assert physdiff_figures(_motion(quad, T, base_z=0.0), feet=[]) == PhysDiffFigures(0.0, 0.0, 0.0)


# ---- flights ----------------------------------------------------------------------------------
def test_a_hovering_creature_floats(quad):
    # standing 5 frames, hovering 10 cm up for 20 frames, standing 5 frames
    T = 30
    z = np.where((np.arange(T) >= 5) & (np.arange(T) < 25), STAND_Z + 0.1, STAND_Z)
    motion = _motion(quad, T, base_z=z)
    assert longest_flight(motion) == 20
    flags = floating_frames(motion, 6)
    assert flags.dtype == bool and flags.shape == (T,)
    np.testing.assert_array_equal(flags, (np.arange(T) >= 5) & (np.arange(T) < 25))
    assert not floating_frames(motion, 20).any()  # a flight as long as the limit is allowed
    assert floating_frames(motion, 19).sum() == 20


def test_a_gait_with_short_flights_does_not_float(quad):
    # A bounding gait: every 10 frames all feet leave the ground for 3 frames (body 5 cm up),
    # the legs swinging in stance; the creature's own data set says flights last up to 3 frames.
    T = 60
    t = np.arange(T)
    z = np.where(t % 10 >= 7, STAND_Z + 0.05, STAND_Z)
    motion = _motion(quad, T, base_z=z, base_x=0.01 * t, fr_hip=0.1 * np.sin(t / 3))
    assert longest_flight(motion) == 3
    assert not floating_frames(motion, longest_flight(motion)).any()
    assert floating_frames(motion, 2).sum() == 3 * 6  # a stricter limit flags every flight
    # a higher contact height sees no flight at all
    assert longest_flight(motion, contact_height=0.1) == 0


def test_flights_without_feet_and_bad_arguments(quad):
    motion = _motion(quad, 5, base_z=STAND_Z + 1.0)
    assert longest_flight(motion, feet=[]) == 0 and not floating_frames(motion, 0, feet=[]).any()
    assert floating_frames(motion, 0).all()
    with pytest.raises(ConfigError, match="longest_flight_frames"):
        floating_frames(motion, -1)
    with pytest.raises(ConfigError, match="longest_flight_frames"):
        floating_frames(motion, 2.5)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="contact_height"):
        longest_flight(motion, contact_height=float("nan"))


def test_the_biped_too():
    # the metrics are creature-agnostic: the ACE test biped standing has no skating, no flight
    m = metric_biped()
    motion = _biped_motion(m, 10)
    assert skating_ratio(motion) == 0.0 and longest_flight(motion) == 0
    assert foot_contact_figures(motion).foot_names == ("l_foot", "r_foot")


# ---- follow -----------------------------------------------------------------------------------
def test_pearson_follow_cases():
    rng = np.random.default_rng(0)
    a = rng.normal(size=200)
    assert pearson_follow(a, a) == pytest.approx(1.0, abs=1e-12)
    assert pearson_follow(a, 3.0 * a + 7.0) == pytest.approx(1.0, abs=1e-12)
    assert pearson_follow(a, -a) == pytest.approx(-1.0, abs=1e-12)
    assert pearson_follow(a, np.full(200, 2.0)) == 0.0
    assert pearson_follow(np.full(200, 2.0), a) == 0.0
    assert pearson_follow(np.full(5, 2.0), np.full(5, 2.0)) == 1.0
    assert pearson_follow(np.zeros(5), np.zeros(5)) == 1.0
    assert pearson_follow(np.full(5, 2.0), np.full(5, 3.0)) == 0.0
    assert pearson_follow([1.0], [5.0]) == 0.0  # one sample each: constant, unequal
    b = rng.normal(size=20000)
    assert abs(pearson_follow(rng.normal(size=20000), b)) < 0.03
    assert pearson_follow(a, a + 1e-13 * rng.normal(size=200)) == pytest.approx(1.0)
    with pytest.raises(ConfigError, match="different lengths"):
        pearson_follow(a, a[:-1])
    with pytest.raises(ConfigError, match="1-D"):
        pearson_follow(a.reshape(20, 10), a.reshape(20, 10))
    with pytest.raises(ConfigError, match="non-finite"):
        pearson_follow(a, np.full(200, np.nan))


def test_follow_gain_sees_amplitude_where_the_correlation_does_not():
    rng = np.random.default_rng(2)
    a = rng.normal(size=500)
    assert pearson_follow(a, 0.1 * a) == pytest.approx(1.0) and follow_gain(a, 0.1 * a) == pytest.approx(0.1)
    assert follow_gain(a, -2.0 * a) == pytest.approx(-2.0)
    # the slope of a noisy follower: what it does of a, its noise averaged out
    assert follow_gain(a, 0.5 * a + 0.01 * rng.normal(size=500)) == pytest.approx(0.5, abs=0.01)
    assert follow_gain(np.zeros(5), np.ones(5)) is None
    with pytest.raises(ConfigError, match="different lengths"):
        follow_gain(a, a[:-1])


def test_reachable_gain_is_the_gain_of_a_copy_held_at_the_limit():
    # analytic: rates 2, -2 and 0.5 against a limit of 1 -> (2 + 2 + 0.25) / (4 + 4 + 0.25)
    assert reachable_gain(np.array([2.0, -2.0, 0.5]), 1.0) == pytest.approx(4.25 / 8.25)
    rng = np.random.default_rng(3)
    a = 2.0 * rng.normal(size=400)
    capped = [min(max(v, -1.5), 1.5) for v in a]  # a follower that turns as a does, never faster than 1.5
    naive = sum(x * y for x, y in zip(a, capped, strict=True)) / sum(x * x for x in a)
    assert reachable_gain(a, 1.5) == pytest.approx(naive, rel=1e-12)
    assert reachable_gain(a, 1.5) == pytest.approx(follow_gain(a, np.clip(a, -1.5, 1.5)), rel=1e-12)
    assert reachable_gain(a, float(np.abs(a).max())) == pytest.approx(1.0)  # nothing beyond reach
    assert reachable_gain(np.zeros(4), 1.0) is None
    for bad in (0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(ConfigError, match="limit must be a positive finite number"):
            reachable_gain(a, bad)


def test_follow_score_per_pair_and_mean():
    rng = np.random.default_rng(1)
    h = {"height": rng.normal(size=100), "speed": rng.normal(size=100), "yaw": rng.normal(size=50)}
    c = {"yaw": -h["yaw"], "height": 2.0 * h["height"] + 1.0, "speed": np.ones(100)}
    s = follow_score(h, c)
    assert list(s.correlations) == ["height", "speed", "yaw"]
    assert s.correlations["height"] == pytest.approx(1.0)
    assert s.correlations["speed"] == 0.0
    assert s.correlations["yaw"] == pytest.approx(-1.0)
    assert s.mean == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(TypeError):
        s.correlations["x"] = 1.0  # type: ignore[index]
    with pytest.raises(ConfigError, match="differ in names: speed"):
        follow_score(h, {"height": c["height"], "yaw": c["yaw"]})
    with pytest.raises(ConfigError, match="no series"):
        follow_score({}, {})
    with pytest.raises(ConfigError, match=r"series 'yaw'.*different lengths"):
        follow_score(h, {**c, "yaw": c["yaw"][:10]})
