"""The active hand: a lone creature hand or tool follows whichever human hand moves."""

from __future__ import annotations

import numpy as np
import pytest
from morphkit_testing import random_q

from morphkit.errors import ConfigError
from morphkit.motion import (
    ACTIVE_HAND,
    ActiveHand,
    Motion,
    Pairing,
    canonical_human,
    features,
    fit_gaussian,
    human_state_from_motion,
    human_state_layout,
    map_end_effectors,
)
from morphkit.motion._fk import compiled_model


def _states(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, object]:
    """Human states of the canonical human with its two hands' heading-frame positions [T, 3] written in."""
    m = canonical_human()
    motion = Motion(m, 30.0, random_q(compiled_model(m), len(left), seed=0))
    layout = human_state_layout(m)
    x = human_state_from_motion(motion).copy()
    ee = layout.slice("ee_positions").start
    for name, p in (("left_hand", left), ("right_hand", right)):
        i = layout.ee_names.index(name)
        x[:, ee + 3 * i : ee + 3 * i + 3] = p
    return x, layout


def test_the_block_is_the_hand_moved_furthest_from_its_mean() -> None:
    """Left hand 0.5 above its mean, right at its mean: the block is the left hand's displacement (weight
    1/(1+e^-10)); swapped, the right one's; both equally far: their average; on torch, the same numbers."""
    import torch

    means = np.array([0.0, 0.2, 0.8, 0.0, -0.2, 0.8])  # [left, right], body length 1
    up = np.array([0.1, 0.0, 0.5])
    left = np.array([means[:3] + up, means[:3], means[:3] + up])
    right = np.array([means[3:], means[3:] + up, means[3:] - up])
    x, layout = _states(left, right)
    hand = ActiveHand(("left_hand", "right_hand"), means=tuple(means))
    block = hand.block(x, layout, 1.0)
    d = float(np.linalg.norm(up)) / hand.softness
    w = 1.0 / (1.0 + np.exp(-d))  # the moved hand's softmax weight against a hand at its mean
    np.testing.assert_allclose(block[0], w * up, atol=1e-12)
    np.testing.assert_allclose(block[1], w * up, atol=1e-12)
    np.testing.assert_allclose(block[2], 0.5 * up + 0.5 * -up, atol=1e-12)
    np.testing.assert_allclose(hand.block(torch.as_tensor(x), layout, 1.0).numpy(), block, atol=1e-12)
    # mirrored: the left hand's lateral displacement is negated, nothing else
    out = np.array([0.0, 0.4, 0.0])
    x2, _ = _states(np.array([means[:3] + out]), np.array([means[3:]]))
    mirrored = ActiveHand(("left_hand", "right_hand"), means=tuple(means), mirror=(True, False)).block(x2, layout, 1.0)
    w2 = 1.0 / (1.0 + np.exp(-0.4 / hand.softness))
    np.testing.assert_allclose(mirrored[0], w2 * np.array([0.0, -0.4, 0.0]), atol=1e-12)


def test_features_place_the_active_hand_where_the_pairing_puts_it() -> None:
    left = np.array([[0.1, 0.2, 1.4], [0.0, 0.2, 0.8]])
    right = np.array([[0.0, -0.2, 0.8], [0.0, -0.2, 0.8]])
    x, layout = _states(left, right)
    hand = ActiveHand(("left_hand", "right_hand"))
    psi = features(x, layout, length=2.0, ee_names=["head", ACTIVE_HAND], active_hand=hand)
    np.testing.assert_allclose(psi[:, -3:], hand.block(x, layout, 0.5))
    np.testing.assert_allclose(psi[:, :-3], features(x, layout, length=2.0, ee_names=["head"]))
    with pytest.raises(ConfigError, match="active_hand"):
        features(x, layout, length=2.0, ee_names=[ACTIVE_HAND])
    with pytest.raises(ConfigError, match="ActiveHand"):
        Pairing(("gripper",), (ACTIVE_HAND,), 1.0, 1.0)
    with pytest.raises(ConfigError, match="two or more"):
        ActiveHand(("left_hand",))


def test_a_clip_waving_either_hand_moves_the_active_hand_alike() -> None:
    """A human waving the left hand and the same human waving the right: the active hand's height is the
    same series (a one-hand mapping sees the second wave only); centres come from the data, not the clip."""
    t = np.linspace(0.0, 2.0, 60)
    wave = np.stack([0.1 * np.ones_like(t), np.zeros_like(t), 0.6 * np.sin(np.pi * t / 2.0) ** 2], axis=-1)
    rest_l, rest_r = np.array([0.0, 0.2, 0.8]), np.array([0.0, -0.2, 0.8])
    x_l, layout = _states(rest_l + wave * [1, 1, 1], np.repeat(rest_r[None], len(t), 0))
    x_r, _ = _states(np.repeat(rest_l[None], len(t), 0), rest_r + wave)
    hand = ActiveHand(("left_hand", "right_hand"), means=tuple(np.concatenate([rest_l, rest_r])))
    z_l = features(x_l, layout, length=1.0, ee_names=[ACTIVE_HAND], active_hand=hand)[:, -1]
    z_r = features(x_r, layout, length=1.0, ee_names=[ACTIVE_HAND], active_hand=hand)[:, -1]
    np.testing.assert_allclose(z_l, z_r, atol=1e-12)
    assert np.corrcoef(z_l, wave[:, 2])[0, 1] > 0.99
    one_hand = features(x_l, layout, length=1.0, ee_names=["right_hand"])[:, -1]
    assert np.ptp(one_hand) == 0.0


def test_a_lone_tool_maps_to_the_active_hand_and_a_pair_of_hands_to_their_sides() -> None:
    rng = np.random.default_rng(5)
    human = {"lhand": fit_gaussian(rng.normal([0.1, 0.3, 0.0], 0.05, (2000, 3))),
             "rhand": fit_gaussian(rng.normal([0.1, -0.3, 0.0], 0.3, (2000, 3))),
             "foot": fit_gaussian(rng.normal([0.0, 0.0, -1.0], 0.05, (2000, 3)))}
    h_roles = {"lhand": "hand", "rhand": "hand", "foot": "foot"}
    mid = {"gripper": fit_gaussian(rng.normal([0.5, 0.0, 0.3], 0.2, (2000, 3))),
           "paw": fit_gaussian(rng.normal([0.3, 0.0, -1.0], 0.05, (2000, 3)))}
    roles = ({"gripper": "tool", "paw": "foot"}, h_roles)
    one = map_end_effectors(mid, human, roles=roles)
    assert one.mapping["gripper"] == "rhand" and one.active_hand is None  # KL's one hand, as before
    got = map_end_effectors(mid, human, roles=roles, active_hand=True)
    assert got.mapping == {"gripper": ACTIVE_HAND, "paw": "foot"}
    assert got.active_hand == ActiveHand(("lhand", "rhand"), mirror=(False, False))
    assert got.to_json()["active_hand"] == {"hands": ["lhand", "rhand"], "mirror": [False, False]}
    assert ACTIVE_HAND in got.format_table()
    assert map_end_effectors(mid, human, roles=roles, active_hand=True, override={"gripper": "lhand"}).mapping[
        "gripper"] == "lhand"
    assert map_end_effectors(mid, human, roles=roles, active_hand=True, kl_only=True).active_hand is None
    # a tool on the creature's right follows the left hand mirrored
    side = {**mid, "gripper": fit_gaussian(rng.normal([0.5, -0.4, 0.3], 0.2, (2000, 3)))}
    assert map_end_effectors(side, human, roles=roles, active_hand=True).active_hand.mirror == (True, False)
    # two hands: each to its side, no active hand
    two = {"l_claw": fit_gaussian(rng.normal([0.5, 0.4, 0.0], 0.1, (2000, 3))),
           "r_claw": fit_gaussian(rng.normal([0.5, -0.4, 0.0], 0.1, (2000, 3)))}
    pair = map_end_effectors(two, human, roles=({"l_claw": "hand", "r_claw": "hand"}, h_roles), active_hand=True)
    assert pair.mapping == {"l_claw": "lhand", "r_claw": "rhand"} and pair.active_hand is None
