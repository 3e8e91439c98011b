"""Robot commands of wheeled bases against closed forms: a differential base on an arc (no sideways speed, yaw rate
v / R), an Ackermann base on a circle (the bicycle model's steering angle), and the commands driving the exported
path back when integrated as exact unicycle arcs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from morphkit.body.wheels import drive_of
from morphkit.motion import Motion
from morphkit.motion.io_commands import robot_commands
from morphkit.synth.wheeled import drivable
from morphkit.synth.wheeled_bodies import wheeled_robot

RADIUS, TRACK, WHEELBASE, STEER, FPS = 0.09, 0.46, 0.55, 0.45, 30.0


def _robot(drive: str, arm: bool = False):
    return wheeled_robot(drive, arm=arm, radius=RADIUS, track=TRACK, wheelbase=WHEELBASE, max_steer=STEER)


def _arc(radius: float, speed: float, frames: int, *, sideways: bool = False) -> np.ndarray:
    """Root path [T, 3] on a circle of ``radius`` [m] (centre to the left) at ``speed`` [m/s], heading along it
    (or across it, moving to its left, with ``sideways``)."""
    t = np.arange(frames) / FPS
    psi = speed / radius * t
    xy = np.stack([radius * np.sin(psi), radius * (1.0 - np.cos(psi))], axis=1)
    return np.concatenate([xy, (psi - (math.pi / 2 if sideways else 0.0))[:, None]], axis=1)


def _motion(m, path: np.ndarray) -> Motion:
    q = np.repeat(m.rest_q()[None], len(path), axis=0)
    q[:, :3] = path
    return Motion(m, FPS, q, "arc")


def _column(motion: Motion, name: str) -> np.ndarray:
    columns, rows = robot_commands(motion)
    return rows[:, columns.index(name)]


@pytest.mark.parametrize("arm", [False, True])
def test_differential_arc_has_no_sideways_speed_and_yaw_rate_v_over_r(arm: bool) -> None:
    m = _robot("differential", arm)
    R, v = 1.3, 0.3
    d = drive_of(m)
    assert d is not None and v * (1 + d.half_track / R) < d.top_speed  # the arc is within the wheels' speed
    motion = _motion(m, _arc(R, v, 90))
    columns, rows = robot_commands(motion)
    assert columns[:7] == ["time", "vx", "vy", "yaw_rate", "height", "pitch", "roll"]
    assert "steering_angle" not in columns and not set(columns) & set(m.wheels.all_joints)  # type: ignore[union-attr]
    np.testing.assert_array_equal(rows[:, 2], 0.0)
    np.testing.assert_allclose(rows[:, 1], v, rtol=1e-9)  # the arc's own speed, not its chord's
    np.testing.assert_allclose(rows[:, 3], v / R, rtol=1e-9)


def test_differential_crab_walk_commands_turn_in_place_without_sideways_speed() -> None:
    """Moving across its heading, a differential base can only turn: vy is 0, vx about 0 (the chord across the
    heading has no forward part at the step's mid heading), the yaw rate the path's."""
    m = _robot("differential")
    R, v = 1.3, 0.3
    motion = _motion(m, _arc(R, v, 90, sideways=True))
    np.testing.assert_array_equal(_column(motion, "vy"), 0.0)
    np.testing.assert_allclose(_column(motion, "vx"), 0.0, atol=1e-12)
    np.testing.assert_allclose(_column(motion, "yaw_rate"), v / R, rtol=1e-9)


def test_ackermann_steering_column_is_the_bicycle_angle_on_a_circle() -> None:
    m = _robot("ackermann")
    d = drive_of(m)
    assert d is not None and d.kind == "ackermann"
    for R in (1.2 * d.min_turn_radius, 3.0 * d.min_turn_radius):
        motion = _motion(m, _arc(R, 0.3, 60))
        np.testing.assert_allclose(_column(motion, "steering_angle"), math.atan(WHEELBASE / R), rtol=1e-9)
        np.testing.assert_allclose(_column(motion, "yaw_rate") / _column(motion, "vx"), 1.0 / R, rtol=1e-9)
        # driving backwards round the same circle steers the same way (cot δ = R / L either way)
        back = _motion(m, _arc(R, 0.3, 60)[::-1])
        np.testing.assert_allclose(_column(back, "steering_angle"), math.atan(WHEELBASE / R), rtol=1e-9)
    # a turn tighter than the steering allows is commanded at the tightest one
    tight = _motion(m, _arc(0.5 * d.min_turn_radius, 0.2, 60))
    curvature = _column(tight, "yaw_rate") / _column(tight, "vx")
    assert np.all(np.abs(curvature) <= 1.0 / d.min_turn_radius)
    np.testing.assert_allclose(curvature, 1.0 / d.min_turn_radius, rtol=2e-3)


def test_ackermann_standing_still_holds_its_steering() -> None:
    m = _robot("ackermann")
    path = np.concatenate([_arc(2.0, 0.3, 30), np.repeat(_arc(2.0, 0.3, 30)[-1:], 20, axis=0)])
    steer = _column(_motion(m, path), "steering_angle")
    np.testing.assert_allclose(steer, math.atan(WHEELBASE / 2.0), rtol=1e-9)


@pytest.mark.parametrize("drive", ["differential", "skid_steer", "ackermann"])
def test_commands_integrated_as_arcs_drive_the_drivable_path(drive: str) -> None:
    """A wandering path with side-steps: its commands, integrated as exact unicycle arcs from the first frame,
    land on every frame of the path that :func:`drivable` makes of it."""
    m = _robot(drive)
    T = 150
    t = np.arange(T) / FPS
    rng = np.random.default_rng(3)
    path = np.stack([0.25 * t + 0.05 * np.sin(3 * t), 0.1 * np.sin(1.7 * t + rng.uniform()),
                     0.4 * np.sin(0.9 * t)], axis=1)
    motion = _motion(m, path)
    _, rows = robot_commands(motion)
    v, vy, w = rows[:, 1], rows[:, 2], rows[:, 3]
    assert np.abs(vy).max() == 0.0
    x, y, psi = path[0]
    got = [(x, y, psi)]
    dt = 1.0 / FPS
    for k in range(1, T):
        p1 = psi + w[k] * dt
        if abs(w[k]) > 1e-12:
            x += v[k] / w[k] * (math.sin(p1) - math.sin(psi))
            y -= v[k] / w[k] * (math.cos(p1) - math.cos(psi))
        else:
            x += v[k] * dt * math.cos(psi)
            y += v[k] * dt * math.sin(psi)
        psi = p1
        got.append((x, y, psi))
    want = drivable(m, motion.q, FPS)[:, :3]
    np.testing.assert_allclose(np.array(got), want, atol=1e-9)
    assert np.abs(want[:, :2] - path[:, :2]).max() > 0.01  # the side-steps were taken out: the test can fail


def test_holonomic_base_keeps_its_sideways_speed() -> None:
    """Powered casters move sideways: a crab walk on a circle is commanded as it is (vy the path's speed, vx 0)."""
    m = _robot("holonomic")
    d = drive_of(m)
    R, v = 2.0, 0.2
    assert d is not None and d.kind == "holonomic" and v + v / R * d.reach < d.top_speed
    motion = _motion(m, _arc(R, v, 60, sideways=True))
    np.testing.assert_allclose(_column(motion, "vy"), v, rtol=1e-9)
    np.testing.assert_allclose(_column(motion, "vx"), 0.0, atol=1e-12)
    np.testing.assert_allclose(_column(motion, "yaw_rate"), v / R, rtol=1e-9)
