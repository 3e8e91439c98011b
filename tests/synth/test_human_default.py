"""The embedded default human motion (morphkit.synth.human): upright walking, arm swing, actions.

Everything is measured on the output motions with the motion layer's FK (link poses, end-effector
positions), not on the synthesiser's own targets.
"""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.motion.motion import base_pose_from_q
from morphkit.synth import ACTION_NAMES, analyse, default_human_clips, default_human_motion
from morphkit.synth.human import LOCOMOTION_LABELS

FRAMES = 3000  # ten 10-second clips
CONTACT_HEIGHT = 0.02


@pytest.fixture(scope="module")
def clips():
    return default_human_clips(frames=FRAMES, seed=0, cache_dir=None)


def _yaw(m, q: np.ndarray) -> np.ndarray:
    p = base_pose_from_q(m, q)
    return np.arctan2(2 * (p[:, 6] * p[:, 5] + p[:, 3] * p[:, 4]), 1 - 2 * (p[:, 4] ** 2 + p[:, 5] ** 2))


def _heading(v: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """World vectors [T, ..., 3] -> heading-frame (forward, left, up)."""
    c, s = np.cos(yaw), np.sin(yaw)
    while c.ndim < v.ndim - 1:
        c, s = c[:, None], s[:, None]
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1], v[..., 2]], axis=-1)


def _knee_angle(m, q: np.ndarray, joint: str) -> np.ndarray:
    s = m.joint_q_start[m.joint_index(joint)]
    return 2 * np.arccos(np.clip(np.abs(q[:, s + 3]), 0.0, 1.0))


def _root_speed(mo) -> np.ndarray:
    return np.linalg.norm(np.gradient(mo.q[:, :2], axis=0), axis=1) * mo.fps


def test_the_human_walks_upright(clips):
    m = clips[0].motion.morphology
    rest_height = analyse(m).body_height  # root above the soles at rest: 0.98 m
    stance_knees, swing_knees, walking_z = [], [], []
    feet = [m.end_effectors.index(m.end_effector(n)) for n in ("left_foot", "right_foot")]
    for c in clips:
        mo = c.motion
        h = mo.end_effector_positions()[:, feet, 2]
        walking = _root_speed(mo) > 0.3
        for k, knee in enumerate(("LeftLeg", "RightLeg")):
            a = _knee_angle(m, mo.q, knee)
            stance_knees.append(a[walking & (h[:, k] < CONTACT_HEIGHT)])
            swing_knees.append(a[walking & (h[:, k] > 0.06)])
        walking_z.append(mo.q[walking, 2])
    stance, swing, z = (np.concatenate(x) for x in (stance_knees, swing_knees, walking_z))
    assert stance.size > 1000 and swing.size > 300
    assert stance.mean() < 0.35  # knees near straight in stance (the crouch had ~1.2 rad)
    assert np.median(stance) > 0.1  # ... but not locked
    assert swing.mean() > 0.6  # and bent in swing
    assert z.min() > 0.85 * rest_height
    assert z.mean() > 0.95 * rest_height


def test_arms_swing_opposite_to_the_legs(clips):
    m = clips[0].motion.morphology
    thighs, arms, speeds = [], [], []
    for c in clips:
        mo = c.motion
        free = (c.action == 0) & (_root_speed(mo) > 0.5)
        X = mo.link_poses()
        yaw = _yaw(m, mo.q)

        def pitch(parent: str, child: str, X=X, yaw=yaw) -> np.ndarray:
            bone = _heading(X[:, m.link_index(child), :3] - X[:, m.link_index(parent), :3], yaw)
            return np.arctan2(bone[:, 0], -bone[:, 2])  # forward swing angle of the bone, 0 hanging down

        thighs.append(np.stack([pitch(f"{s}UpLeg", f"{s}Leg") for s in ("Left", "Right")], axis=1)[free])
        arms.append(np.stack([pitch(f"{s}Arm", f"{s}ForeArm") for s in ("Left", "Right")], axis=1)[free])
        speeds.append(_root_speed(mo)[free])
    hip, sh, v = np.concatenate(thighs), np.concatenate(arms), np.concatenate(speeds)
    assert len(hip) > 300
    for k in (0, 1):
        same = np.corrcoef(hip[:, k], sh[:, k])[0, 1]
        other = np.corrcoef(hip[:, k], sh[:, 1 - k])[0, 1]
        assert same < -0.5, same  # an arm swings back while the leg on its side swings forward
        assert other > 0.5, other
    # faster walking, wider swing
    slow, fast = sh[(v > 0.5) & (v < 0.9)], sh[v > 1.2]
    assert len(slow) > 50 and len(fast) > 50
    assert np.ptp(np.percentile(fast, [5, 95], axis=0), axis=0).min() > np.ptp(
        np.percentile(slow, [5, 95], axis=0), axis=0).max()


def test_every_action_happens_and_does_what_it_says(clips):
    m = clips[0].motion.morphology
    ee = {e.name: i for i, e in enumerate(m.end_effectors)}
    seen = dict.fromkeys(ACTION_NAMES[1:], 0)
    for c in clips:
        mo = c.motion
        P = mo.end_effector_positions()
        yaw = _yaw(m, mo.q)
        rel = _heading(P - mo.q[:, None, :3], yaw)  # end-effectors about the root, heading frame
        for sp in c.actions:
            assert (c.action[sp.start:sp.stop] == ACTION_NAMES.index(sp.kind)).all()
            seen[sp.kind] += 1
            hands = [ee[n] for n in sp.arms]
            if sp.stop - sp.start < 0.8 * 30:
                continue  # cut short by the clip's end
            win = slice(sp.start, sp.stop)
            fwd = rel[win][:, hands, 0]
            if sp.kind == "wave":
                above = P[win][:, hands[0], 2] > P[win][:, ee["head"], 2] + 0.05
                assert above.sum() > 15  # hand above the head for half a second
            elif sp.kind in ("reach", "push"):
                assert (fwd > 0.3).all(axis=1).sum() > 8  # hands well in front of the body
                if sp.kind == "push":
                    assert len(hands) == 2
            else:  # point: arm stretched forward or out to the side, at shoulder height
                out = np.linalg.norm(rel[win][:, hands[0], :2], axis=-1)
                assert ((out > 0.55) & (rel[win][:, hands[0], 2] > 0.35)).sum() > 10
        # between actions the hands hang below the chest
        free = c.action == 0
        assert (rel[free][:, [ee["left_hand"], ee["right_hand"]], 2] < 0.15).mean() > 0.95
    assert all(n > 0 for n in seen.values()), seen


def test_clips_are_named_and_labelled_by_their_contents(clips):
    names = [c.motion.name for c in clips]
    assert len(set(names)) == len(names) == FRAMES // 300
    for i, c in enumerate(clips):
        assert c.motion.name.startswith("human_") and c.motion.name.endswith(f"_{i}")
        assert set(c.labels) <= set(LOCOMOTION_LABELS)
        assert c.labels == tuple(k for k in LOCOMOTION_LABELS if k in c.labels)
        for sp in c.actions:
            assert f"_{sp.kind}_" in c.motion.name
        assert c.action.shape == (c.motion.frame_count,)
    assert sum("walk" in c.labels for c in clips) >= len(clips) // 2
    assert any("turn" in c.labels for c in clips)


def test_feet_stay_planted_and_clear_of_the_body(clips):
    from morphkit.synth.report import quality_report

    r = quality_report([c.motion for c in clips])
    # the shipped creatures' synth reports: foot sliding 0.0004 (spot) to 0.003 (crab) cm/s
    assert r["foot_sliding_cm_s"] < 0.003
    assert r["penetration_mm"] < 0.5
    assert r["self_collision_frac"] < 0.005
    assert r["limit_violation_frac"] == 0.0


def test_deterministic_for_a_seed_and_cached(tmp_path):
    a = default_human_motion(frames=200, seed=3, cache_dir=None)
    b = default_human_motion(frames=200, seed=3, cache_dir=tmp_path)
    assert [m.name for m in a] == [m.name for m in b]
    assert all(np.array_equal(x.q, y.q) for x, y in zip(a, b, strict=True))
    assert len(list(tmp_path.glob("human_*.npz"))) == 1
    c = default_human_clips(frames=200, seed=3, cache_dir=tmp_path)  # from the cache
    assert all(np.array_equal(x.q, y.motion.q) and x.name == y.motion.name for x, y in zip(a, c, strict=True))
    d = default_human_motion(frames=200, seed=4, cache_dir=None)
    assert not np.array_equal(a[0].q, d[0].q)


def test_actions_follow_end_effector_roles_not_names(tmp_path):
    """A renamed human (other creature and end-effector names) gets the same actions; Spot, with a
    hand but not an upright biped, gets none unless asked."""
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.synth import ActionConfig, prepare
    from morphkit.synth.actions import calibrate_actions
    from morphkit.synth.human import default_human_config

    text = resolve_morphology("human").read_text()
    for a, b in (("name: human", "name: mannequin"), ("left_hand:", "paw_l:"), ("right_hand:", "paw_r:"),
                 ("left_foot:", "sole_l:"), ("right_foot:", "sole_r:")):
        text = text.replace(a, b)
    p = tmp_path / "mannequin.yaml"
    p.write_text(text)
    rig = prepare(read_morphology(p), config=default_human_config())
    assert rig.actions is not None and set(rig.actions.names) == {"paw_l", "paw_r"}
    assert set(rig.actions.kinds) == {"reach", "wave", "point", "push"} and rig.actions.swing
    assert rig.legs is not None and rig.legs.upright
    spot = read_morphology(resolve_morphology("spot"))
    plan = analyse(spot)
    assert any(a.role.name == "HAND" for a in plan.arms)
    assert calibrate_actions(spot, plan, spot.rest_q(), ActionConfig(), upright=False) is None
