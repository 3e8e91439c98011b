"""The one keyword table: descriptions and BVH skeletons read their hints from it."""

from __future__ import annotations

import pytest

from morphkit.body.roles import BVH_ROLE_WORDS, BVH_WEAK_ROLE_WORDS, PART_WORDS, hint_rank, keyword_role, name_hint
from morphkit.graph import EndEffectorRole

HAND, FOOT, HEAD = EndEffectorRole.HAND, EndEffectorRole.FOOT, EndEffectorRole.HEAD


@pytest.mark.parametrize(("name", "part"), [
    ("FR_calf", "foot"), ("RL_foot", "foot"), ("l_sole", "foot"), ("leg_left_6_link", "foot"),
    ("gripper_left_finger", "tool"), ("panda_hand_tcp", "tool"), ("arm_left_7_link", "hand"),
    ("wrist_3_link", "hand"), ("head_2_link", "head"), ("torso_lidar", "skip"), ("tail_tip", "skip"),
    # strong words of a later row beat weak words of an earlier one (example-robot-data's human and Romeo)
    ("middle_head", "head"), ("HeadTouchMiddle_frame", "head"),
    ("base_link", None), ("thigh", None),
])
def test_names_of_real_robot_parts_hint_what_they_are(name: str, part: str | None) -> None:
    assert name_hint(name) == part


@pytest.mark.parametrize(("name", "role"), [
    ("LeftHand", HAND), ("RightToeBase", FOOT), ("Head", HEAD), ("lfemur", None), ("LHipJoint", None),
])
def test_bvh_names_take_roles_by_substring(name: str, role: EndEffectorRole | None) -> None:
    """Motion-capture rigs glue words together: a keyword anywhere in the name counts."""
    assert keyword_role(name) == role
    assert keyword_role("LeftArm", BVH_WEAK_ROLE_WORDS) == HAND and keyword_role("LeftArm") is None


def test_both_readers_take_their_words_from_the_one_table() -> None:
    """Every word of the table hints its row's part to the description reader, unless a strong word of an
    earlier row claims it; the BVH tables are the table's hand, foot and head rows, strong and weak."""
    claimed: set[str] = set()
    for strong in (True, False):
        for row in PART_WORDS:
            for word, is_strong in row.words:
                if is_strong != strong:
                    continue
                assert name_hint(f"x_{word}_1") == row.part or word in claimed, word
                claimed.add(word)
    rows = {r.role: r for r in PART_WORDS if r.part in ("hand", "foot", "head")}
    for table, strong in ((BVH_ROLE_WORDS, True), (BVH_WEAK_ROLE_WORDS, False)):
        assert [role for role, _ in table] == [HAND, FOOT, HEAD]
        for role, words in table:
            assert words == tuple(w for w, s in rows[role].words if s == strong)


def test_strong_hints_rank_before_weak_ones() -> None:
    assert hint_rank("l_sole") < hint_rank("l_knee") < hint_rank("link") and hint_rank("head") < hint_rank("jaw")
