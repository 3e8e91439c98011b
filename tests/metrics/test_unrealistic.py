"""UFR on constructed motions of a tiny YAML biped: each effect where it is built in, nowhere else."""

from __future__ import annotations

import numpy as np
import pytest
from _metric_creatures import FPS, STAND_Z, metric_biped
from _metric_creatures import biped_motion as _motion

from morphkit.errors import ConfigError
from morphkit.metrics import UnrealisticFrames, UnrealisticFrameThresholds, unrealistic_frame_ratio


@pytest.fixture(scope="module")
def biped():
    return metric_biped()


def test_the_biped_stands_on_its_feet(biped):
    # Preconditions of every case below, from the FK: feet and tail on the ground, legs 0.2 m apart.
    pos = _motion(biped, 1).end_effector_positions()[0]
    np.testing.assert_allclose(pos[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(pos[:2, 1], [0.1, -0.1], atol=1e-12)


def test_a_clean_standing_pose_has_no_unrealistic_frame(biped):
    r = unrealistic_frame_ratio(_motion(biped, 30))
    assert r.ratio == 0.0
    assert r.frame_count == 30 and r.unrealistic_count == 0
    for flags in (r.self_collision, r.foot_penetration, r.foot_sliding, r.unrealistic):
        assert flags.shape == (30,) and flags.dtype == bool and not flags.any()
    assert r.foot_names == ("l_foot", "r_foot")  # role foot; the tail (tool) is not a foot


def test_a_foot_sliding_one_centimetre_per_frame_in_contact_is_counted(biped):
    T = 20
    r = unrealistic_frame_ratio(_motion(biped, T, base_x=0.01 * np.arange(T)))  # 0.3 m/s at 30 fps
    assert r.foot_sliding.all()
    assert not r.foot_penetration.any() and not r.self_collision.any()
    assert r.ratio == 1.0
    # the threshold decides: 0.3 m/s is below a 0.5 m/s limit
    slow = unrealistic_frame_ratio(_motion(biped, T, base_x=0.01 * np.arange(T)),
                                   thresholds=UnrealisticFrameThresholds(sliding_speed=0.5))
    assert not slow.foot_sliding.any()


def test_only_the_sliding_frames_are_counted(biped):
    # Standing still for 10 frames, then sliding 1 cm per frame: with backward differences the
    # velocity of frame t is (p_t - p_{t-1}) fps, so frames 11..19 move (frame 10 is the last still one).
    T = 20
    x = np.where(np.arange(T) > 10, 0.01 * (np.arange(T) - 10), 0.0)
    r = unrealistic_frame_ratio(_motion(biped, T, base_x=x))
    np.testing.assert_array_equal(r.foot_sliding, np.arange(T) > 10)
    assert r.ratio == pytest.approx(9 / 20)


def test_feet_in_the_air_do_not_slide_and_only_feet_count(biped):
    # Knees bent by 1.2 rad lift both feet 0.3 (1 - cos 1.2) = 19 cm; the body glides 1 cm per
    # frame with the tail (role tool) dragging on the ground: not foot sliding.
    T = 20
    motion = _motion(biped, T, base_x=0.01 * np.arange(T), l_knee=1.2, r_knee=1.2)
    assert motion.end_effector_positions()[:, :2, 2].min() > 0.15
    r = unrealistic_frame_ratio(motion)
    assert not r.foot_sliding.any() and r.ratio == 0.0
    tail = unrealistic_frame_ratio(motion, feet=["tail"])  # unless the tail is named as a foot
    assert tail.foot_sliding.all() and tail.foot_names == ("tail",)


def test_a_foot_one_centimetre_under_the_ground_is_counted(biped):
    r = unrealistic_frame_ratio(_motion(biped, 10, base_z=STAND_Z - 0.01))
    assert r.foot_penetration.all() and r.ratio == 1.0
    assert not r.foot_sliding.any() and not r.self_collision.any()
    shallow = unrealistic_frame_ratio(_motion(biped, 10, base_z=STAND_Z - 0.004))  # 4 mm: within the 5 mm threshold
    assert not shallow.foot_penetration.any()
    strict = unrealistic_frame_ratio(_motion(biped, 10, base_z=STAND_Z - 0.004),
                                     thresholds=UnrealisticFrameThresholds(penetration_depth=0.002))
    assert strict.foot_penetration.all()


def test_crossed_legs_are_a_self_collision_and_touchdown_is_not_sliding(biped):
    # Left hip at -0.5 rad swings the left leg across the right one (their capsules intersect,
    # overlap ~6 cm) and lifts the left foot 7 cm; frames 0..4 crossed, 5..9 standing.
    T = 10
    hip = np.where(np.arange(T) < 5, -0.5, 0.0)
    motion = _motion(biped, T, l_hip=hip)
    r = unrealistic_frame_ratio(motion)
    np.testing.assert_array_equal(r.self_collision, np.arange(T) < 5)
    assert not r.foot_penetration.any()
    # At frame 5 the left foot lands (in contact) and its backward difference reads the swing
    # from frame 4: the kernel sees speed > 0.2 m/s, but the foot was in the air, so no sliding.
    from morphkit.kernels import eval_sliding_speed

    speed = eval_sliding_speed(motion.end_effector_positions(), FPS, feet=[0]).numpy()[:, 0]
    assert speed[5] > 0.2
    assert not r.foot_sliding.any()
    assert r.ratio == 0.5
    # no pair of neighbours across a joint is checked: hips and knees at their limits never collide
    bent = unrealistic_frame_ratio(_motion(biped, 3, base_z=1.5, l_knee=2.0, r_knee=-2.0))
    assert not bent.self_collision.any()


def test_results_pool_over_clips(biped):
    clean = unrealistic_frame_ratio(_motion(biped, 30))
    sunk = unrealistic_frame_ratio(_motion(biped, 10, base_z=STAND_Z - 0.01))
    pooled = UnrealisticFrames.concatenate([clean, sunk])
    assert pooled.frame_count == 40 and pooled.ratio == pytest.approx(10 / 40)
    assert pooled.cause_ratios() == {"self_collision": 0.0, "foot_penetration": 0.25, "foot_sliding": 0.0}
    assert UnrealisticFrames.concatenate([]).ratio == 0.0


def test_a_creature_without_feet_is_never_flagged_on_the_ground(biped):
    r = unrealistic_frame_ratio(_motion(biped, 5, base_z=0.0), feet=[])  # sunk 65 cm, but no feet checked
    assert not r.foot_penetration.any() and not r.foot_sliding.any() and r.foot_names == ()


def test_bad_thresholds_and_feet_are_rejected(biped):
    with pytest.raises(ConfigError, match="sliding_speed must be >= 0"):
        UnrealisticFrameThresholds(sliding_speed=-1.0)
    with pytest.raises(ConfigError, match="finite"):
        UnrealisticFrameThresholds(contact_height=float("nan"))
    assert UnrealisticFrameThresholds(ground_height=-0.1).ground_height == -0.1
    with pytest.raises(ConfigError, match=r"no end-effector 'hoof'.*l_foot, r_foot, tail"):
        unrealistic_frame_ratio(_motion(biped, 2), feet=["hoof"])
