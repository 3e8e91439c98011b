"""``WithContacts`` hands ``replan`` the human's foot swings for the creature feet paired one-to-one with a human
foot (a biped's), and none where two creature feet share one (a quadruped's)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from morphkit_testing import spot_like

import morphkit.contact_export
from morphkit.graph import Limit, MorphologyBuilder, Transform
from morphkit.motion import Motion, Pairing
from morphkit.retarget import RetargetedClip, WithContacts
from morphkit.retarget.retargeter import paired_swings

FPS = 30.0
T = 60
LEFT_UP = slice(10, 22)  # the human's left foot 15 cm up over these frames
RIGHT_UP = slice(30, 41)


@pytest.fixture(scope="module")
def human() -> Motion:
    """Two feet on vertical sliders under a floating pelvis standing still: their heights are the coordinates."""
    b = MorphologyBuilder("sliders")
    b.add_link("pelvis")
    for side, y in (("left", 0.1), ("right", -0.1)):
        b.add_link(f"{side}_shin")
        b.add_joint_prismatic(f"{side}_lift", "pelvis", f"{side}_shin", origin=Transform((0.0, y, -0.9)),
                              axis=(0, 0, 1), limit=Limit(-0.1, 0.5))
        b.add_end_effector(f"{side}_foot", f"{side}_shin", role="foot")
    b.add_end_effector("left_hand", "pelvis", offset=(0.0, 0.3, 0.4), role="hand")
    m = b.build()
    q = np.zeros((T, m.coordinate_count))
    q[:, 2], q[:, 6] = 0.9, 1.0  # pelvis 0.9 m up, level (xyzw)
    names = m.coordinate_names
    q[LEFT_UP, names.index("left_lift")] = 0.15
    q[RIGHT_UP, names.index("right_lift")] = 0.15
    return Motion(m, FPS, q, "steps")


def _pairing(creature_ees: tuple[str, ...], human_ees: tuple[str, ...]) -> Pairing:
    return Pairing(creature_ees, human_ees, creature_length=1.0, human_length=1.0)


def _truth(sl: slice) -> np.ndarray:
    air = np.zeros(T, dtype=bool)
    air[sl] = True
    return air


def test_only_feet_paired_alone_with_a_human_foot_get_its_swings(human):
    creature = spot_like()
    spot = _pairing(("fl_foot", "fr_foot", "hl_foot", "hr_foot", "gripper"),
                    ("left_foot", "right_foot", "left_foot", "right_foot", "left_hand"))
    assert paired_swings(human, creature, spot) == {}
    # one front foot per human foot, the hind feet on a hand: a biped's pairing on four legs
    biped = _pairing(("fl_foot", "fr_foot", "hl_foot", "hr_foot"),
                     ("left_foot", "right_foot", "left_hand", "left_hand"))
    hints = paired_swings(human, creature, biped)
    assert set(hints) == {"fl_foot", "fr_foot"}
    np.testing.assert_array_equal(hints["fl_foot"], _truth(LEFT_UP))
    np.testing.assert_array_equal(hints["fr_foot"], _truth(RIGHT_UP))
    mixed = _pairing(("fl_foot", "hl_foot", "fr_foot"), ("left_foot", "left_foot", "right_foot"))
    assert set(paired_swings(human, creature, mixed)) == {"fr_foot"}


def test_with_contacts_hands_replan_the_hints_and_lock_none(human, monkeypatch):
    creature = spot_like()
    seen: list[tuple[str, object]] = []

    def record(motion, mode, *, stance=None, swing_hint=None):
        seen.append((mode, swing_hint))
        return motion

    monkeypatch.setattr(morphkit.contact_export, "apply_contacts", record)
    clip = RetargetedClip(human, Motion(creature, FPS, np.repeat(creature.rest_q()[None], T, axis=0), "out"))
    for pairing, feet in ((_pairing(("fl_foot", "fr_foot"), ("left_foot", "right_foot")), {"fl_foot", "fr_foot"}),
                          (_pairing(("fl_foot", "hl_foot"), ("left_foot", "left_foot")), None)):
        inner = SimpleNamespace(label="x", creature=creature, pairing=pairing, fps=FPS, data=None, human_data=None)
        for mode in ("replan", "lock"):
            seen.clear()
            WithContacts(inner, mode).export(clip)
            hint = seen[-1][1]
            if mode == "replan" and feet is not None:
                assert [m for m, _ in seen] == ["replan", "replan"] and seen[0][1] is None  # with and without
                assert set(hint) == feet
                np.testing.assert_array_equal(hint["fl_foot"], _truth(LEFT_UP))
            else:
                assert len(seen) == 1 and hint is None


def test_the_human_timing_is_kept_only_where_it_costs_no_realism(human, monkeypatch):
    """``contact_export`` keeps the hinted plan unless it has more unrealistic frames than the planner's own: here
    the hinted plan is made to sink the body 10 cm (its feet under the ground, counted by the UFR), then not."""
    from morphkit.metrics import unrealistic_frame_ratio
    from morphkit.retarget.retargeter import contact_export

    creature = spot_like()
    q = np.repeat(creature.rest_q()[None], T, axis=0)
    q[:, 2] -= Motion(creature, FPS, q[:1]).end_effector_positions()[0, :4, 2].min()  # the feet on the ground
    standing = Motion(creature, FPS, q, "out")
    assert unrealistic_frame_ratio(standing).unrealistic_count == 0
    sunk_q = standing.q.copy()
    sunk_q[:, 2] -= 0.1
    sunk = standing.replace(q=sunk_q)
    assert unrealistic_frame_ratio(sunk).unrealistic_count == T
    lifted_q = standing.q.copy()
    lifted_q[:, 2] += 1e-4  # as realistic as standing, and told apart from it
    lifted = standing.replace(q=lifted_q)
    pairing = _pairing(("fl_foot", "fr_foot"), ("left_foot", "right_foot"))
    clip = RetargetedClip(human, standing)
    for hinted, expected in ((sunk, standing), (lifted, lifted)):
        monkeypatch.setattr(morphkit.contact_export, "apply_contacts",
                            lambda motion, mode, *, stance=None, swing_hint=None, h=hinted:
                            h if swing_hint is not None else motion)
        assert contact_export(clip, "replan", pairing) is expected
