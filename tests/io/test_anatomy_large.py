"""Big bodies read without recursion and in time near linear in their size: a chain longer than Python's recursion
limit, with and without named end-effectors, and a star of more legs than a stance is searched for."""

from __future__ import annotations

import math
import sys
import time

import numpy as np
import pytest

from morphkit.body.anatomy import ANATOMY
from morphkit.graph import EndEffectorRole
from morphkit.io.yaml_format import parse_yaml

STANCE_SEARCH_MAX_LEGS = ANATOMY.max_legs


def _chain_yaml(offsets: np.ndarray, *, named_tip: bool) -> str:
    """A fixed-base chain l0 - l1 - ... whose joint ``k`` sits at ``offsets[k]`` [m] from its parent (no rotation)."""
    lines = ["name: chain", "base: fixed", "root: l0", "links:"]
    lines += [f"  l{i}: {{}}" for i in range(len(offsets) + 1)]
    lines.append("joints:")
    lines += [f"  j{k}: {{type: revolute, parent: l{k}, child: l{k + 1}, axis: [0, 1, 0], "
              f"origin: {{xyz: [{x!r}, {y!r}, {z!r}]}}, limit: {{lower: -1, upper: 1}}}}"
              for k, (x, y, z) in enumerate(offsets.tolist())]
    if named_tip:
        lines += ["end_effectors:", f"  tip: {{link: l{len(offsets)}, role: hand}}"]
    return "\n".join(lines) + "\n"


def _offsets(n: int) -> np.ndarray:
    return np.random.default_rng(n).uniform([0.0, -0.01, -0.01], [0.02, 0.01, 0.01], (n, 3))


def _exact_sum(offsets: np.ndarray) -> np.ndarray:
    return np.array([math.fsum(offsets[:, k]) for k in range(3)])


def test_a_chain_of_3000_links_reads_and_its_tip_is_the_sum_of_the_offsets():
    offsets = _offsets(3000)
    assert len(offsets) > sys.getrecursionlimit()  # a recursive walk over it would fail
    m = parse_yaml(_chain_yaml(offsets, named_tip=True), source="chain.yaml")
    assert m.link_count == 3001 and len(m.chain("l3000")) == 3000
    tip = m.rest_link_poses()[-1]
    np.testing.assert_allclose(tip[:3], _exact_sum(offsets), rtol=0, atol=1e-9)
    np.testing.assert_allclose(m.rest_points()[-1], _exact_sum(offsets), rtol=0, atol=1e-9)  # the end-effector


def test_a_chain_longer_than_the_recursion_limit_gets_its_hand_guessed():
    offsets = _offsets(1500)
    assert len(offsets) > sys.getrecursionlimit()
    m = parse_yaml(_chain_yaml(offsets, named_tip=False), source="chain.yaml")  # no end-effectors: guessed
    (ee,) = m.end_effectors
    assert (ee.link, ee.role) == ("l1500", EndEffectorRole.HAND)
    np.testing.assert_allclose(m.rest_link_poses()[-1, :3], _exact_sum(offsets), rtol=0, atol=1e-9)
    assert m.hand_height_range is not None


def _star_yaml(legs: int) -> str:
    lines = ["name: star", "base: floating", "root: body", "links:",
             "  body: {shapes: [{type: box, size: [0.3, 0.3, 0.1]}]}"]
    lines += [f"  l{i}: {{shapes: [{{type: sphere, radius: 0.01}}]}}" for i in range(legs)]
    lines.append("joints:")
    for i in range(legs):
        a = 2 * math.pi * (i + 0.5) / legs  # off the midline: every one a leg
        lines.append(f"  j{i}: {{type: revolute, parent: body, child: l{i}, axis: [0, 1, 0], "
                     f"origin: {{xyz: [{0.2 * math.cos(a):.4f}, {0.2 * math.sin(a):.4f}, -0.05]}}, "
                     "limit: {lower: -1, upper: 1}}")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("legs", [STANCE_SEARCH_MAX_LEGS + 8])
def test_a_star_of_more_legs_than_the_search_bound_keeps_its_pose_with_a_note(legs: int):
    start = time.perf_counter()
    m = parse_yaml(_star_yaml(legs), source="star.yaml")
    elapsed = time.perf_counter() - start
    assert len(m.ee_by_role(EndEffectorRole.FOOT)) == legs
    assert dict(m.rest_pose) == {}  # q = 0 kept
    assert any(f"no stance searched for {legs} legs (at most {STANCE_SEARCH_MAX_LEGS})" in n for n in m.notes)
    assert elapsed < 30.0  # the search took 2.5 s a leg on this star (100 s for 40 legs); now about one second
