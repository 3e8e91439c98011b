"""Body length puts a human and any creature on one scale in Ψ (issue 9, item 4).

The property: in Ψ (root height / body length, end-effector positions in the heading frame / body
length) a standing human's feet and a standing Spot's or crab's feet sit at about the same
normalised height below the root, and Stretch's reachable gripper heights span a human's hand
heights. Checked on the shipped creatures, and on CMU, Bandai Namco and dog clips when
``MORPHKIT_DATA`` is set.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import human_like, random_q, shipped_morphology

from morphkit.errors import ConfigError
from morphkit.graph import HUMAN_HAND_REACH, BodyLengthRule, EndEffectorRole, Morphology, MorphologyBuilder
from morphkit.motion import (
    ROOT_FEATURE_DIM,
    Motion,
    ee_distributions,
    ground_motion,
    measured_body_length,
    motion_features,
    read_motion,
    standing_height,
)
from morphkit.motion._fk import compiled_model
from morphkit.rotations import quat_from_yaw

DATA = Path(os.environ["MORPHKIT_DATA"]) if os.environ.get("MORPHKIT_DATA") else None


def _roles(m: Morphology, role: EndEffectorRole) -> list[int]:
    return [i for i, e in enumerate(m.end_effectors) if e.role == role]


def _psi_heights(motion: Motion, role: EndEffectorRole, length: float | None = None) -> np.ndarray:
    """Heights of the ``role`` end-effectors below (-) or above (+) the root in Ψ, shape [T, k]."""
    psi = motion_features(motion, length=length)
    ee = psi[:, ROOT_FEATURE_DIM:].reshape(psi.shape[0], -1, 3)
    return ee[:, _roles(motion.morphology, role), 2]


def _psi_above_ground(motion: Motion, role: EndEffectorRole, length: float | None = None) -> np.ndarray:
    """Heights above the ground in Ψ (root height plus the end-effector's height over the root), [T, k]."""
    psi = motion_features(motion, length=length)
    return psi[:, :1] + _psi_heights(motion, role, length)


def _pose(m: Morphology, frames: int = 10, **joints: float) -> Motion:
    """``m`` holding a pose (named 1-DoF joints set, the rest at rest), drifting forward, feet on the ground."""
    q = np.tile(m.rest_q(), (frames, 1))
    col = {n: i for i, n in enumerate(m.coordinate_names)}
    for name, value in joints.items():
        q[:, col[name]] = value
    q[:, 0] = np.linspace(0.0, 0.1, frames)  # a little motion, so velocities are defined
    return ground_motion(Motion(m, 30.0, q, f"{m.name}_pose"))


def _spot_home(spot: Morphology) -> Motion:
    """Spot standing in MuJoCo Menagerie's "home" keyframe (morphologies/spot/README.md): knees bent, arm stowed."""
    legs = {f"{leg}_{j}": v for leg in ("fl", "fr", "hl", "hr") for j, v in (("hx", 0.0), ("hy", 1.04), ("kn", -1.8))}
    arm = {"arm_sh1": -3.14, "arm_el0": 3.06}
    return _pose(spot, **legs, **arm)


def _spot_trot(spot: Morphology, seconds: float = 4.0, fps: float = 30.0) -> Motion:
    """Spot trotting on bent legs (diagonal pairs in antiphase), arm stowed, grounded."""
    T = int(seconds * fps)
    t = np.arange(T) / fps
    q = np.tile(spot.rest_q(), (T, 1))
    col = {n: i for i, n in enumerate(spot.coordinate_names)}
    q[:, 0] = 0.5 * t
    q[:, 3:7] = quat_from_yaw(np.zeros(T))
    for leg, phase in (("fl", 0.0), ("hr", 0.0), ("fr", np.pi), ("hl", np.pi)):
        swing = 2 * np.pi * 1.8 * t + phase
        q[:, col[f"{leg}_hy"]] = 0.9 + 0.2 * np.sin(swing)
        q[:, col[f"{leg}_kn"]] = -1.7 - 0.3 * np.maximum(0.0, np.cos(swing))
    q[:, col["arm_sh1"]], q[:, col["arm_el0"]] = -3.14, 3.06
    lower, upper = spot.coordinate_limits
    return ground_motion(Motion(spot, fps, np.clip(q, lower, upper), "spot_trot"))


# ---- the graph's rule on rest poses -----------------------------------------------------------
@pytest.mark.parametrize("name", ["spot", "crab", "human"])
def test_rest_stance_puts_the_root_at_one_and_the_feet_at_minus_one(name: str) -> None:
    m = shipped_morphology(name)
    rest = _pose(m)
    assert m.body_length_rule == BodyLengthRule.STANCE
    feet = _psi_heights(rest, EndEffectorRole.FOOT, length=m.body_length)
    np.testing.assert_allclose(feet.min(axis=1), -1.0, atol=1e-6)
    np.testing.assert_allclose(motion_features(rest, length=m.body_length)[:, 0], 1.0, atol=1e-6)
    # Measured on the rest pose itself, the standing height is the same.
    assert measured_body_length(m, rest) == pytest.approx(m.body_length, abs=1e-6)


# ---- standing feet agree across creatures -----------------------------------------------------
@pytest.fixture(scope="module")
def standing() -> dict[str, Motion]:
    """Standing clips of the shipped creatures with feet: Spot in its home pose and trotting, the crab
    and the human at rest (their rest poses are their stance)."""
    spot, crab, human = (shipped_morphology(n) for n in ("spot", "crab", "human"))
    return {"spot home": _spot_home(spot), "spot trot": _spot_trot(spot), "crab": _pose(crab), "human": _pose(human)}


def _median_lowest_foot(motion: Motion) -> float:
    """Median over frames of the lowest foot's height below the root in Ψ, with the default body length."""
    return float(np.median(_psi_heights(motion, EndEffectorRole.FOOT).min(axis=1)))


def test_standing_feet_sit_at_one_normalised_height(standing: dict[str, Motion]) -> None:
    heights = {name: _median_lowest_foot(m) for name, m in standing.items()}
    for name, h in heights.items():
        assert -1.05 <= h <= -0.95, (name, heights)
    assert max(heights.values()) - min(heights.values()) <= 0.05, heights


def test_spot_is_measured_at_the_height_it_stands_not_on_straight_legs(standing: dict[str, Motion]) -> None:
    spot = standing["spot home"].morphology
    home = measured_body_length(spot, standing["spot home"])
    trot = measured_body_length(spot, standing["spot trot"])
    # Home pose: feet 0.428 m below the body (README); trotting on bent legs: ACE's Spot (≈ 0.51 m).
    assert home == pytest.approx(0.428, abs=0.005)
    assert 0.42 <= trot <= 0.55
    # The rest pose, on straight legs, would put the standing feet well above -1.
    straight = _psi_heights(standing["spot home"], EndEffectorRole.FOOT, length=spot.body_length).min(axis=1)
    assert np.median(straight) > -0.7


# ---- Stretch's gripper heights span a human's hand heights ------------------------------------
def _stretch_sweep() -> Motion:
    """Stretch driving while the lift sweeps its whole travel, the arm telescopes and the wrist turns."""
    m = shipped_morphology("stretch")
    T = 120
    s = np.linspace(0.0, 1.0, T)
    q = np.tile(m.rest_q(), (T, 1))
    col = {n: i for i, n in enumerate(m.coordinate_names)}
    q[:, 0] = 0.2 * s  # base x
    lower, upper = m.coordinate_limits
    for name in m.coordinate_names:
        i = col[name]
        if name == "joint_lift":
            q[:, i] = lower[i] + (upper[i] - lower[i]) * 0.5 * (1 - np.cos(2 * np.pi * s))
        elif name.startswith(("joint_arm", "joint_wrist")):
            q[:, i] = lower[i] + (upper[i] - lower[i]) * s
    return Motion(m, 30.0, q, "stretch_sweep")


def _stretch_range() -> tuple[float, float]:
    m = shipped_morphology("stretch")
    lo, hi = m.hand_height_range
    return lo / m.body_length, hi / m.body_length


def test_stretch_reach_in_psi_runs_from_near_the_floor_to_a_raised_human_hand() -> None:
    sweep = _stretch_sweep()
    assert sweep.morphology.body_length_rule == BodyLengthRule.HAND_REACH
    grip = _psi_above_ground(sweep, EndEffectorRole.HAND)
    lo, hi = _stretch_range()
    assert hi == pytest.approx(HUMAN_HAND_REACH)
    assert grip.min() == pytest.approx(lo, abs=1e-3) and grip.max() == pytest.approx(hi, abs=1e-3)
    assert lo < 0.25  # 0.12 m above the floor: a human's hand about 0.2 m above it


def test_stretch_gripper_heights_span_the_shipped_human_hands() -> None:
    lo, hi = _stretch_range()
    human = shipped_morphology("human")
    # A standing human's hand, from hanging by the side to raised overhead, on the human's scale.
    pts = human.rest_points()
    shoulder = pts[human.link_index("LeftArm")]
    arm = np.linalg.norm(pts[human.link_count + _roles(human, EndEffectorRole.HAND)[0]] - shoulder)
    hang = (human.body_length + shoulder[2] - arm) / human.body_length  # 0.79 m above the floor
    overhead = human.hand_height_range[1] / human.body_length  # 2.08 m
    assert lo <= hang < overhead <= hi
    rest = _psi_above_ground(_pose(human), EndEffectorRole.HAND)  # T-pose: hands at shoulder height
    assert (lo <= rest).all() and (rest <= hi).all()


# ---- the motion-based measurement ---------------------------------------------------------------
def test_standing_height_ignores_frames_spent_lying_down() -> None:
    m = human_like()
    stand = _pose(m, frames=30)
    q = np.array(stand.q)
    q[:20, 3:7] = [0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5)]  # lying on its back for two thirds of the clip
    mixed = Motion(m, 30.0, q, "lie_then_stand")
    assert standing_height(mixed) == pytest.approx(standing_height(stand), rel=1e-9)
    assert standing_height([]) is None
    stretch = shipped_morphology("stretch")
    assert standing_height(Motion(stretch, 30.0, np.tile(stretch.rest_q(), (3, 1)))) is None  # no feet


def test_declared_length_wins_over_motion_and_other_creatures_are_refused() -> None:
    m = human_like()
    motion = Motion(m, 30.0, random_q(compiled_model(m), 12, seed=1), "random")
    b = MorphologyBuilder("declared")
    b.add_link("body")
    b.set_body_length(0.55)
    declared = b.build()
    assert measured_body_length(declared) == 0.55
    assert measured_body_length(declared, Motion(declared, 30.0, np.tile([0.0, 0, 0, 0, 0, 0, 1], (3, 1)))) == 0.55
    with pytest.raises(ConfigError, match="end-effectors differ"):
        measured_body_length(declared, motion)


def test_ee_distributions_share_one_length_over_the_clips() -> None:
    m = human_like()
    clips = [Motion(m, 30.0, random_q(compiled_model(m), 15, seed=s), f"c{s}") for s in range(3)]
    pooled = measured_body_length(m, clips)
    assert len({round(measured_body_length(m, c), 9) for c in clips}) > 1  # clips differ on their own
    auto = ee_distributions(clips)
    given = ee_distributions(clips, length=pooled)
    for name in auto:
        np.testing.assert_allclose(auto[name].mean, given[name].mean, atol=1e-12)


# ---- real data ----------------------------------------------------------------------------------
def _clips(folder: str, every: int, pattern: str = "*.bvh") -> list[Motion]:
    if DATA is None or not (DATA / folder).is_dir():
        pytest.skip(f"MORPHKIT_DATA is not set (or has no {folder})")
    files = sorted((DATA / folder).glob(pattern))[::every]
    if not files:
        pytest.skip(f"no BVH files in {DATA / folder}")
    return [read_motion(f) for f in files]


@pytest.fixture(scope="module")
def cmu() -> list[Motion]:
    return _clips("human/cmu", 10)


@pytest.fixture(scope="module")
def bandai() -> list[Motion]:
    return _clips("human/second_skeleton", 10)


@pytest.fixture(scope="module")
def dog() -> list[Motion]:
    return _clips("creatures/dog", 1, "dog_walk0*.bvh")[:3]


@pytest.mark.parametrize("rig", ["cmu", "bandai", "dog"])
def test_mocap_feet_sit_where_the_shipped_creatures_feet_do(rig: str, request: pytest.FixtureRequest,
                                                           standing: dict[str, Motion]) -> None:
    clips = request.getfixturevalue(rig)
    m = clips[0].morphology
    length = measured_body_length(m, clips)
    if rig == "cmu":
        assert m.body_length_rule == BodyLengthRule.STANCE  # its rest pose stands
    else:
        # Rest poses that are not upright (Bandai's bones along y, the dog's paws forward): the graph
        # falls back to the leg length, within 10 % of the height the rig stands at in its motion.
        assert m.body_length_rule == BodyLengthRule.STRAIGHT_LEGS
        assert m.characteristic_length < 0.5 * length  # what Ψ used to divide by: 0.13 m, 0.22 m
        assert m.body_length == pytest.approx(length, rel=0.1)
    lowest = np.concatenate([_psi_heights(c, EndEffectorRole.FOOT, length).min(axis=1) for c in clips])
    spot = _median_lowest_foot(standing["spot trot"])
    assert -1.05 <= np.median(lowest) <= -0.9, (rig, np.median(lowest))
    assert abs(np.median(lowest) - spot) <= 0.1, (rig, np.median(lowest), spot)


@pytest.mark.parametrize("rig", ["cmu", "bandai"])
def test_stretch_gripper_heights_span_mocap_hand_heights(rig: str, request: pytest.FixtureRequest) -> None:
    clips = request.getfixturevalue(rig)
    length = measured_body_length(clips[0].morphology, clips)
    hands = np.concatenate([_psi_above_ground(c, EndEffectorRole.HAND, length).ravel() for c in clips])
    lo, hi = _stretch_range()
    # Everything but hands on the floor (a human picking something up; Stretch's lowest is 0.12 m).
    assert lo <= np.percentile(hands, 5) and np.percentile(hands, 99.5) <= hi, np.percentile(hands, [0, 5, 99.5, 100])
    assert np.mean((hands >= lo) & (hands <= hi)) >= 0.97
