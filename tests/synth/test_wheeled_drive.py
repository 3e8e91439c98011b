"""Driving as the wheels allow: wheel and steering angles against closed forms, the drives' command limits,
and synthesis on generated bodies of each drive."""

from __future__ import annotations

import math

import numpy as np
import pytest

from morphkit.body.anatomy import complete_anatomy
from morphkit.body.kinematics import BodyKinematics
from morphkit.body.wheels import drive_of
from morphkit.synth.wheeled import drivable, rolled_angle, steer_wheels
from morphkit.synth.wheeled_bodies import wheeled_body

RADIUS, TRACK, WHEELBASE, STEER, FPS = 0.09, 0.46, 0.55, 0.45, 30.0


def _body(drive: str, arm: bool = False):
    return complete_anatomy(wheeled_body(drive, arm=arm, radius=RADIUS, track=TRACK, wheelbase=WHEELBASE,
                                         max_steer=STEER), base_declared=False)


def _arc(radius: float, speed: float, frames: int, *, sideways: bool = False) -> np.ndarray:
    """Root path [T, 3] on a circle of ``radius`` [m] (centre to the left) at ``speed`` [m/s], heading along it
    (or across it, moving sideways to the left, with ``sideways``)."""
    t = np.arange(frames) / FPS
    psi = speed / radius * t
    xy = np.stack([radius * np.sin(psi), radius * (1.0 - np.cos(psi))], axis=1)
    return np.concatenate([xy, (psi - (math.pi / 2 if sideways else 0.0))[:, None]], axis=1)


def _motion(m, path: np.ndarray) -> np.ndarray:
    q = np.repeat(m.rest_q()[None], len(path), axis=0)
    q[:, :3] = path
    return q


def test_rolled_angle_on_a_known_arc() -> None:
    """A fixed wheel at lateral offset y on a base turning about a centre R to its left rolls (R - y) Δψ / r."""
    R, v, T = 1.3, 0.4, 200
    path = _arc(R, v, T)
    psi = path[:, 2]
    for y in (0.25, -0.25):
        centres = path[:, :2] + y * np.stack([-np.sin(psi), np.cos(psi)], axis=1)
        axes = np.stack([-np.sin(psi), np.cos(psi), np.zeros(T)], axis=1)  # the base's +y
        theta = rolled_angle(centres, axes, RADIUS)
        # rolling forward about +y is a positive turn (right-hand rule: the top, +z, moves to +x)
        np.testing.assert_allclose(theta, (R - y) * (psi - psi[0]) / RADIUS, rtol=2e-4)


def test_fk_wheel_scan_on_a_known_arc() -> None:
    """The FK's wheel scan turns a differential body's fixed wheels as the closed form does, signs included."""
    from morphkit.kernels import eval_wheel_angles
    from morphkit.model import compile_model

    m = _body("differential")
    R, T = 1.3, 120
    path = _arc(R, 0.4, T)
    angles = np.asarray(eval_wheel_angles(compile_model(m), _motion(m, path), device="cpu"))
    psi = path[:, 2] - path[0, 2]
    for w, name in enumerate(m.wheels.joints):  # type: ignore[union-attr]
        kin = BodyKinematics(m)
        P = kin.poses(kin.rest[None])[0][m.joint_index(name) + 1]
        y = P[1, 3]
        a = P[:3, :3] @ np.asarray(m.joint(name).axis)
        np.testing.assert_allclose(angles[:, w], np.sign(a[1]) * (R - y) * psi / RADIUS, rtol=1e-6, atol=1e-9)


def test_ackermann_steering_pair_against_the_bicycle_model() -> None:
    """On a circle of radius R about the rear axle's middle, the inner and outer front wheels steer to
    atan(L / (R ∓ t/2)) — each perpendicular to the line to the turn's centre — so that the bicycle model's
    cot δ = R / L is their mean cotangent; each rolls its own circle's length over r."""
    m = _body("ackermann")
    d = drive_of(m)
    assert d is not None
    R = 1.6 * d.min_turn_radius
    path = _arc(R, 0.3, 150)
    q = _motion(m, path)
    steer_wheels(m, q, FPS)
    qs = m.joint_q_start
    left = q[5:-5, qs[m.joint_index("steer_left_joint")]]
    right = q[5:-5, qs[m.joint_index("steer_right_joint")]]
    inner, outer = math.atan(WHEELBASE / (R - TRACK / 2)), math.atan(WHEELBASE / (R + TRACK / 2))
    np.testing.assert_allclose(left, inner, atol=1e-6)  # the turn's centre is to the left: the left wheel is inner
    np.testing.assert_allclose(right, outer, atol=1e-6)
    bicycle = math.atan(WHEELBASE / R)
    assert 0.5 * (1 / math.tan(inner) + 1 / math.tan(outer)) == pytest.approx(1 / math.tan(bicycle), rel=1e-9)
    psi = path[:, 2] - path[0, 2]
    for wheel, lateral in (("wheel_front_left_joint", TRACK / 2), ("wheel_front_right_joint", -TRACK / 2)):
        spin = q[:, qs[m.joint_index(wheel)]]
        expected = math.hypot(WHEELBASE, R - lateral) * psi / RADIUS
        np.testing.assert_allclose(np.abs(spin[-1] - spin[0]), expected[-1], rtol=1e-3)


def test_ackermann_clamp_keeps_turns_within_the_steering() -> None:
    m = _body("ackermann")
    d = drive_of(m)
    assert d is not None
    rng = np.random.default_rng(3)
    cmd = rng.uniform([-1, -1, -2], [1, 1, 2], (2000, 3))
    out = d.clamp(cmd)
    assert np.all(out[:, 1] == 0.0)
    assert np.all(np.abs(out[:, 2]) * d.min_turn_radius <= np.abs(out[:, 0]) + 1e-12)  # never on the spot
    assert np.all(np.abs(out[:, 0]) + np.abs(out[:, 2]) * d.half_track <= d.top_speed + 1e-12)


def test_differential_and_holonomic_clamps() -> None:
    rng = np.random.default_rng(4)
    cmd = rng.uniform([-1, -1, -2], [1, 1, 2], (2000, 3))
    diff = drive_of(_body("differential"))
    holo = drive_of(_body("holonomic"))
    assert diff is not None and holo is not None
    out = diff.clamp(cmd)
    assert np.all(out[:, 1] == 0.0)
    assert np.all(np.abs(out[:, 0]) + np.abs(out[:, 2]) * TRACK / 2 <= diff.top_speed + 1e-12)  # rim speeds
    # turning on the spot is allowed: a pure yaw command keeps its sign and is only scaled
    spin = diff.clamp(np.array([[0.0, 0.0, 1.0]]))
    assert spin[0, 2] > 0 and spin[0, 0] == 0.0
    side = holo.clamp(np.array([[0.0, 0.2, 0.0]]))
    np.testing.assert_allclose(side, [[0.0, 0.2, 0.0]])
    # a turn the wheels can make keeps its rate; travel takes the rim speed left (|v| = top - |w| t/2)
    w = 0.5 * diff.top_speed / (TRACK / 2)
    walk = diff.clamp(np.array([[2.0 * diff.top_speed, 0.0, w]]))
    np.testing.assert_allclose(walk, [[diff.top_speed - w * TRACK / 2, 0.0, w]], rtol=1e-12)


def test_powered_casters_point_along_a_sideways_path() -> None:
    """A holonomic base moving straight to its left: every caster turns a quarter turn (either way) and its wheel
    rolls the distance over r."""
    m = _body("holonomic")
    T = 60
    path = np.zeros((T, 3))
    path[:, 1] = 0.25 * np.arange(T) / FPS
    q = _motion(m, path)
    steer_wheels(m, q, FPS)
    qs = m.joint_q_start
    assert m.wheels is not None
    for swivel, wheel in zip(m.wheels.steering, m.wheels.steered, strict=True):
        angle = q[:, qs[m.joint_index(swivel)]]
        np.testing.assert_allclose(np.abs(angle), math.pi / 2, atol=1e-9)
        spin = q[:, qs[m.joint_index(wheel)]]
        assert abs(spin[-1] - spin[0]) == pytest.approx(path[-1, 1] / RADIUS, rel=1e-6)


def test_trailing_caster_follows_behind() -> None:
    """The differential body's passive caster trails: driving backward, it swings round to point the other way."""
    m = _body("differential")
    T = 40
    path = np.zeros((T, 3))
    path[:, 0] = -0.2 * np.arange(T) / FPS
    q = _motion(m, path)
    steer_wheels(m, q, FPS)
    angle = q[5:, m.joint_q_start[m.joint_index("caster_back_swivel_joint")]]
    np.testing.assert_allclose(np.abs(angle), math.pi, atol=1e-9)


def test_drivable_keeps_a_drivable_arc_and_removes_sideways_slide() -> None:
    """An arc the Ackermann base can drive comes back as it was; a crab-walk of the differential base loses its
    sideways part (it then only turns as the yaw did), and a holonomic base keeps it."""
    ack = _body("ackermann")
    d = drive_of(ack)
    assert d is not None
    arc = _motion(ack, _arc(1.5 * d.min_turn_radius, 0.2, 90))
    np.testing.assert_allclose(drivable(ack, arc, FPS)[:, :3], arc[:, :3], atol=1e-9)
    slide = np.zeros((60, 3))
    slide[:, 0] = 0.1 * np.arange(60) / FPS
    slide[:, 1] = 0.1 * np.arange(60) / FPS  # 45° off the heading
    diff = _body("differential")
    out = drivable(diff, _motion(diff, slide), FPS)
    np.testing.assert_allclose(out[:, 1], 0.0, atol=1e-12)  # forward part kept, the sideways part gone
    np.testing.assert_allclose(out[:, 0], slide[:, 0], atol=1e-12)
    holo = _body("holonomic")
    np.testing.assert_allclose(drivable(holo, _motion(holo, slide), FPS)[:, :3], slide, atol=1e-12)


@pytest.mark.parametrize("drive", ["differential", "ackermann", "holonomic"])
def test_synthesis_drives_as_the_wheels_allow(drive: str) -> None:
    from morphkit.synth import synthesize

    m = _body(drive)
    d = drive_of(m)
    assert d is not None
    res = synthesize(m, frames=600, fps=FPS, seed=1, progress=False)
    kin = BodyKinematics(m)
    lateral, speed, turn = [], [], []
    for mo in res:
        q = mo.q
        v = np.diff(q[:, :2], axis=0) * FPS
        dpsi = np.diff(q[:, 2])
        mid = q[:-1, 2] + 0.5 * dpsi
        fwd = np.cos(mid) * v[:, 0] + np.sin(mid) * v[:, 1]
        lat = -np.sin(mid) * v[:, 0] + np.cos(mid) * v[:, 1]
        lateral.append(np.abs(lat))
        speed.append(np.hypot(fwd, lat))
        turn.append(np.abs(dpsi * FPS) - np.abs(fwd) / max(d.min_turn_radius, 1e-12))
        # the steered wheels stay on the ground: a vertical swivel keeps each wheel's lowest point at z = 0
        poses = kin.poses(np.array([_values(m, row) for row in q[::50]]))
        for n in m.wheels.steered:  # type: ignore[union-attr]
            li = m.joint_index(n) + 1
            r = m.links[li].shapes[0].radius
            np.testing.assert_allclose(poses[:, li, 2, 3] - r, 0.0, atol=1e-9)
    lateral, speed, turn = map(np.concatenate, (lateral, speed, turn))
    assert speed.max() <= d.top_speed * 1.001
    if drive == "holonomic":
        assert np.percentile(lateral, 95) > 0.01  # it does move sideways
    else:
        assert np.percentile(lateral, 95) <= 0.01
    if drive == "ackermann":
        assert turn.max() <= 1e-9


def _values(m, row: np.ndarray) -> np.ndarray:
    """Joint values [joint_count] of a coordinate row (1-DoF joints; driven wheels left at 0)."""
    out = np.zeros(m.joint_count)
    qs = m.joint_q_start
    for ji in range(m.joint_count):
        if qs[ji + 1] - qs[ji] == 1:
            out[ji] = row[qs[ji]]
    return out


def test_suspensions_stay_at_rest_while_the_base_drives() -> None:
    import sys
    from pathlib import Path

    from morphkit.synth import synthesize

    sys.path.insert(0, str(Path(__file__).parents[1] / "body"))
    from test_wheels import suspended_body

    m = complete_anatomy(suspended_body().build(), base_declared=False)
    res = synthesize(m, frames=120, fps=FPS, seed=2, progress=False)
    qs = m.joint_q_start
    for mo in res:
        assert np.ptp(mo.q[:, 0]) + np.ptp(mo.q[:, 1]) > 0.0  # it drives
        for n in ("susp_l_joint", "susp_r_joint"):
            np.testing.assert_array_equal(mo.q[:, qs[m.joint_index(n)]], 0.0)
