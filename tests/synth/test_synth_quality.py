"""The issue-4 quality bar, measured on generated data with independent code paths.

Foot positions come from :meth:`Motion.end_effector_positions` (the motion layer's FK), velocities
from NumPy central differences, limits from the morphology, collisions from the contact kernels;
none of it reuses the synthesiser's own targets.
"""

from __future__ import annotations

import numpy as np
import pytest
from _synth_creatures import CREATURES

from morphkit.graph import EndEffectorRole
from morphkit.motion.motion import base_pose_from_q

LEGGED = ("spot", "crab", "human", "tripod", "spider")
CONTACT_HEIGHT = 0.02


def _feet(m) -> list[int]:
    return [i for i, e in enumerate(m.end_effectors) if e.role == EndEffectorRole.FOOT]


@pytest.mark.parametrize("name", CREATURES)
def test_every_creature_synthesises_valid_motions(synthesized, name):
    m, res = synthesized(name)
    assert res.frame_count == 1200
    assert len(res) == 4
    for mo in res:
        assert mo.morphology is m
        assert mo.q.shape == (300, m.coordinate_count)
        assert np.isfinite(mo.q).all()
        assert mo.fps == 30.0


@pytest.mark.parametrize("name", LEGGED)
def test_stance_feet_neither_slide_nor_penetrate(synthesized, name):
    m, res = synthesized(name)
    feet = _feet(m)
    speeds, depth = [], 0.0
    for mo in res:
        p = mo.end_effector_positions()[:, feet]  # [T, F, 3]
        v = np.gradient(p, axis=0) * mo.fps
        h = p[..., 2]
        contact = h < CONTACT_HEIGHT
        speeds.append(np.linalg.norm(v[..., :2], axis=-1)[contact])
        depth = max(depth, float(-h.min()))
    speed = np.concatenate(speeds)
    assert speed.size > 0.3 * res.frame_count * len(feet)  # feet do spend time on the ground
    assert speed.mean() < 0.01  # < 1 cm/s
    assert depth < 0.005  # < 5 mm


@pytest.mark.parametrize("name", LEGGED)
def test_swing_feet_clear_the_ground(synthesized, name):
    m, res = synthesized(name)
    order = [m.end_effectors.index(m.end_effector(leg.end_effector)) for leg in res.rig.plan.legs]
    swings = 0
    for mo, contact in zip(res, res.contact, strict=True):
        h = mo.end_effector_positions()[:, order, 2]
        for leg in range(len(order)):
            air = ~contact[:, leg]
            edges = np.flatnonzero(np.diff(np.concatenate([[0], air.astype(int), [0]])))
            for start, stop in zip(edges[::2], edges[1::2], strict=True):
                if start == 0 or stop == len(air):
                    continue  # cut by the clip's ends
                swings += 1
                assert h[start:stop, leg].min() > CONTACT_HEIGHT  # off the ground from the first airborne frame
                assert h[start:stop, leg].max() >= 0.5 * res.rig.legs.swing_height
    assert swings > 0


@pytest.mark.parametrize("name", CREATURES)
def test_joint_limits_always_hold(synthesized, name):
    m, res = synthesized(name)
    lower, upper = m.coordinate_limits
    for mo in res:
        assert (mo.q >= lower - 1e-9).all()
        assert (mo.q <= upper + 1e-9).all()


@pytest.mark.parametrize("name", CREATURES)
def test_self_collision_in_under_one_percent_of_frames(synthesized, name):
    from morphkit.kernels import eval_fk
    from morphkit.kernels.contact import eval_self_collision_distance, self_collision_pairs
    from morphkit.model import compile_model

    m, res = synthesized(name)
    model = compile_model(m, device="cpu")
    pairs = self_collision_pairs(model, rest_margin=0.005)
    hits = 0
    for mo in res:
        d = eval_self_collision_distance(model, pairs, eval_fk(model, mo.q, device="cpu")).numpy()
        hits += int((d < -0.001).any(axis=1).sum())
    assert hits / res.frame_count < 0.01


@pytest.mark.parametrize("name", ["spot", "crab", "stretch", "human", "tripod", "spider"])
def test_root_velocity_tracks_the_command(synthesized, name):
    m, res = synthesized(name)
    errors, moving = [], 0
    for mo, target, settled in zip(res, res.target, res.settled, strict=True):
        pose = base_pose_from_q(m, mo.q)
        yaw = np.unwrap(np.arctan2(2 * (pose[:, 3] * pose[:, 4] + pose[:, 5] * pose[:, 6]),
                                   1 - 2 * (pose[:, 4] ** 2 + pose[:, 5] ** 2)))
        vw = np.gradient(pose[:, :2], axis=0) * mo.fps
        c, s = np.cos(yaw), np.sin(yaw)
        v = np.stack([c * vw[:, 0] + s * vw[:, 1], -s * vw[:, 0] + c * vw[:, 1]], axis=1)
        ok = settled.copy()
        ok[[0, -1]] = False
        vt = target[:, :2]
        speed = np.linalg.norm(vt, axis=1)
        errors.append((np.linalg.norm(v - vt, axis=1) / np.maximum(speed, 0.1))[ok])
        moving += int((ok & (speed > 0.1)).sum())
    err = np.concatenate(errors)
    assert err.size > 100 and moving > 50
    assert err.mean() < 0.10


def test_human_knees_bend_forward_with_ball_joints(synthesized):
    m, res = synthesized("human")
    for mo in res:
        X = mo.link_poses()
        for side in ("Left", "Right"):
            hip, knee, ankle = (X[:, m.link_index(f"{side}{b}"), :3] for b in ("UpLeg", "Leg", "Foot"))
            pose = base_pose_from_q(m, mo.q)
            fwd = np.stack([1 - 2 * (pose[:, 4] ** 2 + pose[:, 5] ** 2),
                            2 * (pose[:, 3] * pose[:, 4] + pose[:, 5] * pose[:, 6])], axis=1)
            fwd /= np.linalg.norm(fwd, axis=1, keepdims=True)
            # the knee lies ahead of the hip-ankle line, and roughly in the leg's sagittal plane
            mid = 0.5 * (hip + ankle)
            ahead = np.sum((knee - mid)[:, :2] * fwd, axis=1)
            assert (ahead > 0.02).mean() > 0.99
            side_dir = np.stack([-fwd[:, 1], fwd[:, 0]], axis=1)
            lateral = np.abs(np.sum((knee - mid)[:, :2] * side_dir, axis=1))
            assert np.percentile(lateral, 99) < 0.1


@pytest.mark.parametrize("name", ["spot", "stretch", "tripod"])
def test_arms_and_prismatic_joints_move(synthesized, name):
    m, res = synthesized(name)
    q = np.concatenate([mo.q for mo in res])
    for arm in res.rig.plan.arms:
        tips = np.concatenate([mo.end_effector_positions()[:, m.end_effectors.index(m.end_effector(arm.end_effector))]
                               - mo.root_pose()[:, None, :3][:, 0] for mo in res])
        assert tips.std(axis=0).max() > 0.02
        for n in arm.joints:
            j = m.joint(n)
            if j.type.name == "PRISMATIC" and j.mimic is None:
                s = m.joint_q_start[m.joint_index(n)]
                assert np.ptp(q[:, s]) > 0.2 * (j.limit.upper - j.limit.lower)


def test_wheeled_base_drives_without_sideways_motion_and_turns_its_wheels(synthesized):
    m, res = synthesized("stretch")
    assert m.base.name == "WHEELED"
    for mo in res:
        x, y, yaw = mo.q[:, 0], mo.q[:, 1], mo.q[:, 2]
        vx, vy = np.gradient(x) * mo.fps, np.gradient(y) * mo.fps
        lateral = -np.sin(yaw) * vx + np.cos(yaw) * vy
        forward = np.cos(yaw) * vx + np.sin(yaw) * vy
        assert np.abs(lateral).max() < 0.05 * max(np.abs(forward).max(), 1e-3) + 1e-6
        w = mo.wheel_angles()
        assert w.shape[1] == 2
        # rolling without slipping: mean wheel angle change x radius = distance travelled along the heading
        dist = np.sum(forward[1:-1]) / mo.fps
        mean_angle = 0.5 * (w[-2] - w[1]).sum() * np.sign(m.wheels.radius)
        assert abs(abs(mean_angle * m.wheels.radius) - abs(dist)) < 0.05 * abs(dist) + 0.02


@pytest.mark.parametrize("name", ["spot", "crab", "human"])
def test_gaits_follow_the_leg_count(synthesized, name):
    _, res = synthesized(name)
    used = {res.gait_names[g] for gs in res.gait for g in np.unique(gs) if g >= 0}
    expected = {"spot": {"walk", "trot", "pace", "bound", "gallop"}, "crab": {"wave", "ripple", "tripod"},
                "human": {"walk", "run"}}[name]
    assert used <= expected
    assert len(used) >= 2


def test_stretch_arm_joints_cover_their_travel():
    """Every limited 1-DoF joint of Stretch's arm, the lift included, is driven over ≥ 95 % of the travel its
    limits allow in 20,000 frames (the issue's measure); with :meth:`ArmConfig.partial_travel` (ACE's default
    data) the lift stops well short of it."""
    from morphkit.io import read_morphology
    from morphkit.synth import ArmConfig, SynthConfig, synthesize

    m = read_morphology("stretch")
    res = synthesize(m, frames=20_000, seed=0, config=SynthConfig(), progress=False)
    q = np.concatenate([mo.q for mo in res])
    checked = []
    for arm in res.rig.plan.arms:
        for n in arm.joints:
            j = m.joint(n)
            if j.type.name in ("PRISMATIC", "REVOLUTE") and j.mimic is None:
                s = m.joint_q_start[m.joint_index(n)]
                assert np.ptp(q[:, s]) >= 0.95 * (j.limit.upper - j.limit.lower), n
                checked.append(n)
    assert "joint_lift" in checked
    lift = m.joint_q_start[m.joint_index("joint_lift")]
    part = synthesize(m, frames=3000, seed=0, config=SynthConfig(arms=ArmConfig.partial_travel()), progress=False)
    travel = np.ptp(np.concatenate([mo.q[:, lift] for mo in part]))
    assert travel < 0.8 * (m.joint("joint_lift").limit.upper - m.joint("joint_lift").limit.lower)


def test_full_travel_arms_keep_clear_of_swinging_legs(synth_creature):
    """The tripod's arm yaws ±2.5 rad, back to its legs: its poses over the whole travel keep 15 % of the leg
    reach from the leg shapes, so walking legs do not run into a held arm."""
    from dataclasses import replace

    from morphkit.kernels import eval_fk
    from morphkit.kernels.contact import eval_self_collision_distance, self_collision_pairs
    from morphkit.model import compile_model
    from morphkit.synth import SynthConfig, synthesize

    m = synth_creature("tripod")
    cfg = replace(SynthConfig(), rollout_seconds=10.0)
    res = synthesize(m, frames=1200, seed=0, config=cfg, progress=False)
    model = compile_model(m, device="cpu")
    pairs = self_collision_pairs(model, rest_margin=0.005)
    hits = sum(int((eval_self_collision_distance(model, pairs, eval_fk(model, mo.q, device="cpu")).numpy() < -0.001)
                   .any(axis=1).sum()) for mo in res)
    assert hits == 0
