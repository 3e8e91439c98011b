"""Arm actions for a biped whose elbow limits forbid the straight hanging pose (issue 66: a humanoid robot whose
forearms cannot hang, like the G1's, still gets arm actions: the hanging pose as near as its limits allow)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
from _synth_creatures import _upright_leg, _yaml

from morphkit.synth import ActionConfig, analyse
from morphkit.synth.actions import POSE_NAMES, calibrate_actions

_SH = (0.0, 0.22, 0.1)  # left shoulder in the body frame [m]
_L1, _L2 = 0.25, 0.25  # upper arm and forearm [m]
_ELBOW = (-2.0, -0.6)  # elbow pitch limits [rad]: the forearm stays at least 0.6 rad forward of the upper arm


def _bent_arm_biped() -> str:
    """The strider's body and pitch legs with two arms: shoulder pitch, roll and yaw at one point, an elbow
    pitch (a humanoid robot's arm)."""
    links = ["  body: {shapes: [{type: box, size: [0.24, 0.3, 0.3]}]}"]
    joints: list[str] = []
    ees: list[str] = []
    rest: list[str] = []
    down = "origin: {xyz: [0, 0, -0.125]}"
    for side, s in (("l", 1.0), ("r", -1.0)):
        leg, knee = _upright_leg(side, 0.32)
        links += [*leg, f"  {side}_foot: {{shapes: [{{type: box, size: [0.18, 0.08, 0.04], "
                        f"origin: {{xyz: [0.03, 0, -0.03]}}}}]}}",
                  f"  {side}_sh: {{}}", f"  {side}_sh2: {{}}",
                  f"  {side}_upper: {{shapes: [{{type: capsule, radius: 0.03, length: 0.2, {down}}}]}}",
                  f"  {side}_fore: {{shapes: [{{type: capsule, radius: 0.03, length: 0.2, {down}}}]}}"]
        joints += [
            f"  {side}_hip: {{type: revolute, parent: body, child: {side}_thigh, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, {0.1 * s}, -0.15]}}, limit: {{lower: -1.3, upper: 1.3}}}}",
            knee,
            f"  {side}_ankle: {{type: revolute, parent: {side}_shin, child: {side}_foot, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, 0, -0.4]}}, limit: {{lower: -0.9, upper: 0.9}}}}",
            f"  {side}_sh_pitch: {{type: revolute, parent: body, child: {side}_sh, axis: [0, 1, 0], "
            f"origin: {{xyz: [{_SH[0]}, {_SH[1] * s}, {_SH[2]}]}}, limit: {{lower: -2.5, upper: 2.5}}}}",
            f"  {side}_sh_roll: {{type: revolute, parent: {side}_sh, child: {side}_sh2, axis: [1, 0, 0], "
            "limit: {lower: -1.5, upper: 1.5}}",
            f"  {side}_sh_yaw: {{type: revolute, parent: {side}_sh2, child: {side}_upper, axis: [0, 0, 1], "
            "limit: {lower: -1.5, upper: 1.5}}",
            f"  {side}_elbow: {{type: revolute, parent: {side}_upper, child: {side}_fore, axis: [0, 1, 0], "
            f"origin: {{xyz: [0, 0, {-_L1}]}}, limit: {{lower: {_ELBOW[0]}, upper: {_ELBOW[1]}}}}}",
        ]
        ees += [f"  {side}_sole: {{link: {side}_foot, offset: [0, 0, -0.05], role: foot}}",
                f"  {side}_hand: {{link: {side}_fore, offset: [0, 0, {-_L2}], role: hand}}"]
        rest.append(f"  {side}_elbow: -1.0")
    ees.append("  head: {link: body, offset: [0.12, 0, 0.1], role: head}")
    return _yaml("bentarm", links, joints, ees) + "rest_pose:\n" + "\n".join(rest) + "\n"


def _rx(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _ry(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rz(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _arm_fk(pitch: np.ndarray, roll: np.ndarray, yaw: np.ndarray, elbow: np.ndarray,
            side: float) -> tuple[np.ndarray, np.ndarray]:
    """Elbow and hand [N, 3] in the body frame, written out by hand (independent of morphkit's kernels)."""
    sh = np.array([_SH[0], side * _SH[1], _SH[2]])
    R1 = _ry(pitch) @ _rx(roll) @ _rz(yaw)
    down = np.array([0.0, 0.0, -1.0])
    e = sh + _L1 * R1 @ down
    h = e + _L2 * (R1 @ _ry(elbow)) @ down
    return e, h


def test_arms_whose_limits_forbid_hanging_hang_as_near_as_the_limits_allow(tmp_path: Path) -> None:
    from morphkit.io import read_morphology

    p = tmp_path / "bentarm.yaml"
    p.write_text(_bent_arm_biped())
    m = read_morphology(p)
    plan = analyse(m)
    rig = calibrate_actions(m, plan, m.rest_q(), ActionConfig(), upright=True)
    assert rig is not None and set(rig.names) == {"l_hand", "r_hand"}
    assert rig.kinds, "the arms act"
    qs = m.joint_q_start
    for a, name in enumerate(rig.names):
        side = 1.0 if name.startswith("l") else -1.0
        idx = [int(qs[m.joint_index(f"{name[0]}_{j}")]) for j in ("sh_pitch", "sh_roll", "sh_yaw", "elbow")]
        col = [int(np.flatnonzero(rig.coords[a] == i)[0]) for i in idx]
        q = rig.key_q[a][0, col]
        assert _ELBOW[0] - 1e-6 <= q[3] <= _ELBOW[1] + 1e-6
        # the ideal hanging hand (actions.py's "hang" directions)
        u = np.array([0.0, 0.26 * side, -1.0])
        f = np.array([0.3, 0.12 * side, -1.0])
        E = np.array([_SH[0], side * _SH[1], _SH[2]]) + _L1 * u / np.linalg.norm(u)
        H = E + _L2 * f / np.linalg.norm(f)
        _, h = _arm_fk(*(np.array([v]) for v in q), side)
        np.testing.assert_allclose(h[0], rig.key_tips[0, a], atol=1e-4)  # morphkit's FK agrees with ours
        miss = float(np.linalg.norm(h[0] - H))
        # brute force over the joint limits: the nearest the hand can get to the ideal one
        g = [np.linspace(-2.5, 2.5, 51), np.linspace(-1.5, 1.5, 31), np.linspace(-1.5, 1.5, 31),
             np.linspace(*_ELBOW, 15)]
        P = np.array(list(itertools.product(*g)))
        _, hb = _arm_fk(P[:, 0], P[:, 1], P[:, 2], P[:, 3], side)
        best = float(np.linalg.norm(hb - H, axis=-1).min())
        assert best > 0.01, "the limits must forbid the ideal pose for this test to mean anything"
        assert miss <= best + 0.01, (miss, best)
        # the pose hangs: the hand is well below the shoulder, not held up in front
        assert h[0, 2] < _SH[2] - 0.3
    assert rig.valid[POSE_NAMES.index("neutral")].all()
