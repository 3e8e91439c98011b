"""The evaluation's figures on cases with a known answer: a clip retargeted onto itself, centred Ψ."""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.evaluation.table import dataset_row, evaluate_clips, follow_figures, follow_series, reference_data
from morphkit.motion import (
    ROOT_FEATURE_DIM,
    Motion,
    Pairing,
    features,
    human_state_from_motion,
    human_state_layout,
    mirror_motion,
)


@pytest.fixture(scope="module")
def clips():
    from morphkit.synth import default_human_motion

    return list(default_human_motion(frames=240, seed=3, cache_dir=None))


def _identity(clips) -> Pairing:
    ees = tuple(e.name for e in clips[0].morphology.end_effectors)
    return Pairing(ees, ees, 1.7, 1.7).with_centres(clips, clips)


def test_a_clip_retargeted_onto_itself_follows_exactly_and_has_no_feature_loss(clips):
    pairing = _identity(clips)
    roles = {e.name: e.role.name.lower() for e in clips[0].morphology.end_effectors}
    follow = follow_figures(clips, clips, pairing, roles)
    assert follow["follow"] == pytest.approx(1.0)
    assert follow["follow_hand"] == pytest.approx(1.0) and follow["follow_forward"] == pytest.approx(1.0)
    row = evaluate_clips("self", clips, clips, reference_data(clips, pairing), pairing)
    assert row.feature_loss == pytest.approx(0.0, abs=1e-9)
    assert row.follow == pytest.approx(1.0)
    # the matched reference of a data set against itself is that data set: FID near 0 either way
    assert row.fid < 0.5 and row.fid_all < 1e-6


def test_a_clip_played_backwards_does_not_follow(clips):
    pairing = _identity(clips)
    roles = {e.name: e.role.name.lower() for e in clips[0].morphology.end_effectors}
    backwards = [c.replace(q=c.q[::-1].copy()) for c in clips]
    follow = follow_figures(clips, backwards, pairing, roles)
    assert follow["follow"] < 0.5


def test_a_mirrored_clip_turns_the_other_way_as_far(clips):
    """Each clip's mirror image turns through the same angle the other way: turn gain −1, yaw follow −1."""
    pairing = _identity(clips)
    roles = {e.name: e.role.name.lower() for e in clips[0].morphology.end_effectors}
    mirrored = [mirror_motion(c) for c in clips]
    follow = follow_figures(clips, mirrored, pairing, roles)
    assert follow["turn_gain"] == pytest.approx(-1.0, abs=1e-9)
    assert follow["follow_yaw"] == pytest.approx(-1.0, abs=1e-9)
    assert follow_figures(clips, clips, pairing, roles)["turn_gain"] == pytest.approx(1.0, abs=1e-12)


def test_drift_is_the_speed_at_which_the_creature_leaves_the_humans_path(clips):
    """The same clips with the root pushed along world x at 0.2 m/s: each frame's heading-frame velocity gains
    R(−yaw_t)·(0.2, 0), so the drift is ‖mean_t R(−yaw_t)·(0.2, 0)‖ / body length — the yaw read from the root
    quaternion here, not through Ψ."""
    pairing = _identity(clips)
    roles = {e.name: e.role.name.lower() for e in clips[0].morphology.end_effectors}
    assert follow_figures(clips, clips, pairing, roles)["drift"] == pytest.approx(0.0, abs=1e-12)
    pushed, expected = [], []
    for c in clips:
        q = c.q.copy()
        q[:, 0] += 0.2 * np.arange(c.frame_count) / c.fps
        pushed.append(c.replace(q=q))
        x, y, z, w = c.q[:, 3:7].T
        yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        added = 0.2 * np.stack([np.cos(yaw), -np.sin(yaw)], axis=-1)  # R(−yaw)·(0.2, 0)
        expected.append(np.linalg.norm(added.mean(axis=0)) / pairing.creature_length)
    got = follow_figures(clips, pushed, pairing, roles)["drift"]
    assert got == pytest.approx(np.mean(expected), rel=1e-6)
    assert got > 0.01


def test_follow_series_are_heights_above_the_ground_and_root_velocities(clips):
    """An end-effector's series is root height + its heading-frame z (Ψ divides both by the body length)."""
    clip = clips[0]
    pairing = _identity(clips[:1])
    plain = Pairing(pairing.creature_ees, pairing.human_ees, 1.0, 1.0)
    series = follow_series(plain.human_psi(clip), plain.creature_ees)
    world = clip.end_effector_positions()
    for i, name in enumerate(plain.creature_ees):
        np.testing.assert_allclose(series[f"{name} height"], world[:, i, 2], atol=1e-6)


def test_centred_psi_does_not_see_a_constant_end_effector_offset(clips):
    """Centring on each side's own data: shifting every end-effector by a constant leaves Ψ unchanged."""
    clip = clips[0]
    layout = human_state_layout(clip.morphology)
    x = human_state_from_motion(clip)
    ee = layout.slice("ee_positions")
    shifted = x.copy()
    shifted[:, ee] += np.tile([0.3, -0.1, 0.05], (ee.stop - ee.start) // 3)
    psi = {}
    for name, states in (("plain", x), ("shifted", shifted)):
        raw = features(states, layout, length=1.7)
        centre = raw[:, ROOT_FEATURE_DIM:].mean(axis=0)
        psi[name] = features(states, layout, length=1.7, centre=centre)
    np.testing.assert_allclose(psi["shifted"], psi["plain"], atol=1e-12)
    # and the centred block averages to zero over the data it was centred on
    np.testing.assert_allclose(psi["plain"][:, ROOT_FEATURE_DIM:].mean(axis=0), 0.0, atol=1e-12)


def test_dataset_row_reports_matched_and_whole_data_diversity(clips):
    pairing = _identity(clips)
    row = dataset_row(clips, pairing, humans=clips[:1])
    whole = dataset_row(clips, pairing)
    assert row.div_all == pytest.approx(whole.div) and row.fid == 0.0
    assert row.follow is None and row.floating == 0.0


def test_reach_follow_is_the_correlation_of_the_hands_forward_offsets(clips):
    """``follow_reach`` against a naive reference: each hand's world position from FK, minus the root's, turned into
    the root's heading (yaw read from its quaternion), its x correlated with the other clip's, per clip and hand."""
    pairing = _identity(clips)
    roles = {e.name: e.role.name.lower() for e in clips[0].morphology.end_effectors}
    hands = [i for i, e in enumerate(clips[0].morphology.end_effectors) if e.role.name.lower() == "hand"]
    assert len(hands) == 2

    def forward(c, n):
        x, y, z, w = c.q[:n, 3:7].T
        yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        d = c.end_effector_positions()[:n, hands, :2] - c.q[:n, None, :2]
        return np.cos(yaw)[:, None] * d[..., 0] + np.sin(yaw)[:, None] * d[..., 1]  # [n, hands]

    others = [c.replace(q=c.q[::-1].copy()) for c in clips]  # played backwards: a correlation far from ±1
    expected = []
    for a, b in zip(clips, others, strict=True):
        n = min(a.frame_count, b.frame_count)
        fa, fb = forward(a, n), forward(b, n)
        expected += [np.corrcoef(fa[:, k], fb[:, k])[0, 1] for k in range(len(hands))]
    got = follow_figures(clips, others, pairing, roles)
    assert got["follow_reach"] == pytest.approx(np.mean(expected), abs=1e-9)
    assert abs(got["follow_reach"]) < 0.9
    assert follow_figures(clips, clips, pairing, roles)["follow_reach"] == pytest.approx(1.0)


# A post bolted to the ground and an arm on a hinge 0.5 m up: the tool at its tip (0.4 m along the arm).
BOLTED_ARM = """\
name: bolted_arm
base: fixed
root: post
links:
  post:
    shapes: [{type: box, size: [0.1, 0.1, 0.5], origin: {xyz: [0, 0, 0.25]}}]
  arm: {}
joints:
  hinge:
    type: revolute
    parent: post
    child: arm
    origin: {xyz: [0, 0, 0.5]}
    axis: [0, 1, 0]
    limit: {lower: -1.5, upper: 1.5}
end_effectors:
  tool: {link: arm, offset: [0.4, 0, 0], role: tool}
"""


def test_a_bolted_down_arm_follows_with_its_tool_alone(clips, tmp_path):
    """A fixed base cannot walk or turn: forward, yaw, turn gain and drift are not its figures (None) and
    ``follow`` is its tool's. Truth: per clip, the Pearson correlation of the human's right-hand height and the
    tool's height, both read from FK in world frame, averaged over the clips."""
    from morphkit.evaluation.table import moves_over_ground
    from morphkit.io import read_morphology

    path = tmp_path / "bolted_arm.yaml"
    path.write_text(BOLTED_ARM)
    arm = read_morphology(path)
    rng = np.random.default_rng(0)
    motions = []
    for c in clips:  # the hinge swings at a frequency and phase of its own per clip
        t = np.arange(c.frame_count) / c.fps
        q = 0.8 * np.sin(2 * np.pi * rng.uniform(0.2, 1.0) * t + rng.uniform(0, 2 * np.pi))
        motions.append(Motion(arm, c.fps, q[:, None], name=c.name))
    hand = [e.name for e in clips[0].morphology.end_effectors].index("right_hand")
    pairing = Pairing(("tool",), ("right_hand",), 0.9, 1.7).with_centres(motions, clips)
    got = follow_figures(clips, motions, pairing, {"tool": "tool"})
    expected = np.mean([np.corrcoef(c.end_effector_positions()[:, hand, 2], m.end_effector_positions()[:, 0, 2])[0, 1]
                        for c, m in zip(clips, motions, strict=True)])
    assert not moves_over_ground(motions) and moves_over_ground(clips)
    assert got["follow_forward"] is None and got["follow_yaw"] is None
    assert got["turn_gain"] is None and got["drift"] is None
    assert got["follow_hand"] == pytest.approx(expected, abs=1e-9)
    assert got["follow"] == pytest.approx(expected, abs=1e-9)
    assert abs(expected) > 0.01  # a real comparison, not two constants
