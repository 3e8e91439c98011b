"""Every contact-aware export drives a wheeled base as its wheels allow: a differential base's crab walk comes out
with no sideways motion in any mode, its caster trailing the drivable path; legged motions pass as they were."""

from __future__ import annotations

import math

import numpy as np
import pytest

from morphkit.contact_export import CONTACT_MODES, apply_contacts
from morphkit.motion import Motion
from morphkit.motion.heading import heading_velocity
from morphkit.synth.wheeled import drivable
from morphkit.synth.wheeled_bodies import wheeled_robot

FPS, YAW_RATE, CASTER_X = 30.0, 0.3, -0.6  # wheeled_body's caster swivel: one default wheelbase behind the axle


def _crab_walk(m, frames: int = 120) -> Motion:
    """Side-steps to the left at 0.2 m/s while drifting forward at 0.1 m/s and turning slowly (0.3 rad/s), the
    arm (if any) waving."""
    t = np.arange(frames) / FPS
    yaw = YAW_RATE * t
    # the heading-frame velocity (0.1, 0.2) in the world, each step taken at the heading it ends at
    vx = 0.1 * np.cos(yaw) - 0.2 * np.sin(yaw)
    vy = 0.1 * np.sin(yaw) + 0.2 * np.cos(yaw)
    q = np.repeat(m.rest_q()[None], frames, axis=0)
    q[:, 0] = np.concatenate([[0.0], np.cumsum(vx[1:]) / FPS])
    q[:, 1] = np.concatenate([[0.0], np.cumsum(vy[1:]) / FPS])
    q[:, 2] = yaw
    free = [m.joint_q_start[m.joint_index(j.name)] for j in m.joints if j.name.startswith("arm_")]
    q[:, free] = 0.3 * np.sin(2 * math.pi * 0.5 * t)[:, None]
    return Motion(m, FPS, q, "crab")


def _sideways_p95(motion: Motion) -> float:
    return float(np.percentile(np.abs(heading_velocity(motion.root_pose(), motion.fps).linear[:, 1]), 95))


@pytest.mark.parametrize("mode", CONTACT_MODES)
def test_crab_walk_of_a_differential_base_exports_without_sideways_motion(mode: str) -> None:
    m = wheeled_robot("differential", arm=True)
    crab = _crab_walk(m)
    assert _sideways_p95(crab) > 0.15  # the input does side-step
    out = apply_contacts(crab, mode)
    assert out.frame_count == crab.frame_count and out.fps == crab.fps
    assert _sideways_p95(out) <= 0.01
    # the root path is drivable's (forward part and turn kept), whatever the mode does to the rest
    np.testing.assert_allclose(out.q[:, :3], drivable(m, crab.q, FPS)[:, :3], atol=1e-12)
    np.testing.assert_allclose(out.q[-1, 2] - out.q[0, 2], crab.q[-1, 2] - crab.q[0, 2], atol=1e-9)
    # the caster trails its swivel axis' velocity in the base, (v, ω x_c): v the forward part of the step's
    # chord at its mid heading, h = ω dt / 2 (frames inside: the ends' velocities are one-sided)
    h = 0.5 * YAW_RATE / FPS
    v = 0.1 * math.cos(h) - 0.2 * math.sin(h)
    swivel = m.joint_q_start[m.joint_index(m.wheels.steering[0])]  # type: ignore[union-attr]
    np.testing.assert_allclose(out.q[2:-2, swivel], math.atan2(YAW_RATE * CASTER_X, v), rtol=1e-4)


def test_a_drivable_path_and_a_legged_motion_pass_unchanged() -> None:
    from morphkit_testing import shipped_morphology

    m = wheeled_robot("differential")
    t = np.arange(60) / FPS
    q = np.repeat(m.rest_q()[None], 60, axis=0)
    q[:, 0] = 0.2 * t  # straight ahead: nothing for the drive to clip, the caster already trailing
    straight = apply_contacts(Motion(m, FPS, q), "none")
    np.testing.assert_allclose(straight.q[:, :3], q[:, :3], atol=1e-12)
    caster = m.joint_q_start[m.joint_index(m.wheels.steered[0])]  # type: ignore[union-attr]
    # the caster wheel (half the drive wheels' radius, 0.04 m) rolls the distance the base drives
    np.testing.assert_allclose(np.abs(straight.q[:, caster]), q[:, 0] / 0.04, atol=1e-9)
    assert apply_contacts(straight, "none") is straight
    # an arc within the drive's speed: its caster swivels once to trail it, and the export is then a fixed point
    psi = 0.3 * t
    q[:, 0], q[:, 1], q[:, 2] = np.sin(psi) / 1.5, (1 - np.cos(psi)) / 1.5, psi  # 0.2 m/s on a circle of 2/3 m
    once = apply_contacts(Motion(m, FPS, q), "none")
    np.testing.assert_allclose(once.q[:, :3], q[:, :3], atol=1e-12)
    assert apply_contacts(once, "none") is once
    spot = shipped_morphology("spot")
    legged = Motion(spot, FPS, np.repeat(spot.rest_q()[None], 5, axis=0))
    assert apply_contacts(legged, "none") is legged
