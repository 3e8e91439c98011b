"""Wheels found from the body: generated robots of each drive, whose drive, radius and track are known by making."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from morphkit.body.anatomy import complete_anatomy
from morphkit.body.kinematics import BodyKinematics
from morphkit.body.wheels import drive_of, find_wheels, wheel_carried_links
from morphkit.graph import BaseType, EndEffectorRole, JointType, Limit, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.io.yaml_format import dump_yaml, parse_yaml
from morphkit.synth.wheeled_bodies import WHEELED_DRIVES, wheeled_body

RADIUS, TRACK, WHEELBASE, STEER = 0.09, 0.46, 0.55, 0.45


def _found(drive: str, arm: bool = False):
    return complete_anatomy(wheeled_body(drive, arm=arm, radius=RADIUS, track=TRACK, wheelbase=WHEELBASE,
                                         max_steer=STEER), base_declared=False)


@pytest.mark.parametrize("arm", [False, True])
@pytest.mark.parametrize("drive", WHEELED_DRIVES)
def test_drive_radius_and_track_of_generated_bodies(drive: str, arm: bool) -> None:
    m = _found(drive, arm)
    assert m.base == BaseType.WHEELED and m.wheels is not None
    assert m.wheels.drive == drive
    assert m.wheels.radius == pytest.approx(RADIUS, rel=1e-9)
    d = drive_of(m)
    assert d is not None and d.track == pytest.approx(TRACK, rel=1e-9)
    assert d.top_speed == pytest.approx(TRACK)  # no velocity limits: one track width per second
    expected = {"differential": (2, 1), "skid_steer": (4, 0), "ackermann": (2, 2), "holonomic": (0, 4)}[drive]
    assert (len(m.wheels.joints), len(m.wheels.steering)) == expected
    # no end-effector on a wheel; the arm's tool found
    on_wheels = wheel_carried_links(m)
    assert all(m.link_index(e.link) not in on_wheels for e in m.end_effectors)
    tools = [e for e in m.end_effectors if e.role.on_arm]
    assert [e.link for e in tools] == (["tool"] if arm else [])


@pytest.mark.parametrize("drive", WHEELED_DRIVES)
def test_root_on_the_ground_at_the_drive_centre(drive: str) -> None:
    """Every wheel's lowest point at rest is on z = 0 of the new root; the driven axle's middle is its origin."""
    m = _found(drive)
    kin = BodyKinematics(m)
    P = kin.poses(kin.rest[None])[0]
    assert m.wheels is not None
    for name in m.wheels.joints + m.wheels.steered:
        li = m.joint_index(name) + 1
        cyl = m.links[li].shapes[0]
        r = cyl.radius
        centre = P[li][:3, 3]
        assert centre[2] - r == pytest.approx(0.0, abs=1e-9)
    # the generated bodies are symmetric about the drive's reference point: the fixed axle's middle, else the
    # middle of the wheels (of the casters' swivel axes)
    at = m.wheels.joints if drive in ("differential", "ackermann") else (m.wheels.joints or m.wheels.steering)
    xy = np.mean([P[m.joint_index(n) + 1][:2, 3] for n in at], axis=0)
    np.testing.assert_allclose(xy, 0.0, atol=1e-12)


def test_ackermann_steering_limit_and_tightest_turn() -> None:
    """Tightest turn: the inner wheel at the steering limit, R = L / tan(δmax) + t/2."""
    m = _found("ackermann")
    assert m.wheels is not None and m.wheels.max_steer == pytest.approx(STEER)
    d = drive_of(m)
    assert d is not None
    assert d.min_turn_radius == pytest.approx(WHEELBASE / math.tan(STEER) + TRACK / 2)


def test_caster_wheel_keeps_its_own_radius() -> None:
    """The differential body's caster wheel is half the drive wheels' size."""
    m = _found("differential")
    assert m.wheels is not None and m.wheels.steered_radii == pytest.approx((RADIUS / 2,))


def test_found_wheels_round_trip_through_yaml() -> None:
    for drive in WHEELED_DRIVES:
        m = _found(drive)
        back = parse_yaml(dump_yaml(m))
        assert back.wheels == m.wheels
        assert back.base == BaseType.WHEELED


@pytest.mark.parametrize("suffix", [".urdf", ".usda"])
def test_found_wheels_round_trip_through_urdf_and_usd(tmp_path, suffix: str) -> None:
    """Every drive's wheels written as the format's morphkit extension read back as they were found (a URDF or USD
    written from a PR2 once came back as a plain differential drive)."""
    from morphkit.io import read_morphology, write_morphology

    for drive in WHEELED_DRIVES:
        m = _found(drive)
        path = tmp_path / f"{drive}{suffix}"
        write_morphology(m, path)
        back = read_morphology(path)
        assert back.wheels == m.wheels, drive
        assert back.base == BaseType.WHEELED


def test_declared_wheels_win() -> None:
    b = MorphologyBuilder("declared")
    b.base = BaseType.WHEELED
    b.add_link("base")
    for side, y in (("l", 0.2), ("r", -0.2)):
        b.add_link(side, shapes=[Shape(ShapeType.CYLINDER, radius=0.1, length=0.03)])
        b.add_joint(f"w_{side}", JointType.CONTINUOUS, "base", side,
                    origin=Transform.from_xyz_rpy((0.3, y, 0.1), (math.pi / 2, 0, 0)), axis=(0, 0, 1))
    b.set_wheels(["w_l", "w_r"], 0.12)  # not what the shapes say: the declaration wins
    m = b.build()
    assert find_wheels(m) is m


def test_round_roll_joint_off_the_ground_is_no_wheel() -> None:
    """A continuous wrist carrying a cylinder about its axle, high above the ground, leaves the base as it is."""
    b = MorphologyBuilder("arm")
    b.add_link("base", shapes=[Shape(ShapeType.BOX, size=(0.3, 0.3, 0.1))])
    b.add_link("upper", shapes=[Shape(ShapeType.CAPSULE, radius=0.03, length=0.4)])
    b.add_joint("shoulder", JointType.REVOLUTE, "base", "upper", origin=Transform((0, 0, 0.5)), axis=(0, 1, 0),
                limit=Limit(-1, 1))
    for side, y in (("l", 0.1), ("r", -0.1)):
        b.add_link(f"disc_{side}", shapes=[Shape(ShapeType.CYLINDER, radius=0.05, length=0.02)])
        b.add_joint(f"roll_{side}", JointType.CONTINUOUS, "upper", f"disc_{side}",
                    origin=Transform.from_xyz_rpy((0, y, 0.4), (math.pi / 2, 0, 0)), axis=(0, 0, 1))
    m = b.build()
    assert find_wheels(m) is m


def test_frozen_vendor_wheels_turn() -> None:
    """Fixed joints named as caster swivels and wheels (as some vendors freeze them) become continuous."""
    b = MorphologyBuilder("frozen")
    b.add_link("base", shapes=[Shape(ShapeType.BOX, size=(0.6, 0.6, 0.1), origin=Transform((0, 0, 0.2)))])
    for cx, cy in ((0.25, 0.25), (0.25, -0.25), (-0.25, 0.25), (-0.25, -0.25)):
        tag = f"{'f' if cx > 0 else 'b'}{'l' if cy > 0 else 'r'}"
        b.add_link(f"{tag}_caster")
        b.add_joint(f"{tag}_caster_rotation_joint", JointType.FIXED, "base", f"{tag}_caster",
                    origin=Transform((cx, cy, 0.08)), axis=(0, 0, 1))
        b.add_link(f"{tag}_wheel", shapes=[Shape(ShapeType.CYLINDER, radius=0.08, length=0.03,
                                                 origin=Transform.from_xyz_rpy(rpy=(math.pi / 2, 0, 0)))])
        b.add_joint(f"{tag}_wheel_joint", JointType.FIXED, f"{tag}_caster", f"{tag}_wheel",
                    origin=Transform((-0.02, 0, 0)), axis=(0, 1, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = find_wheels(b.build())
    assert m.wheels is not None and m.wheels.drive == "holonomic"
    assert len(m.wheels.steering) == 4 and len(m.wheels.steered) == 4
    assert all(m.joint(n).type == JointType.CONTINUOUS for n in m.wheels.steering + m.wheels.steered)
    assert m.wheels.radius == pytest.approx(0.08)
    assert not [e for e in complete_anatomy(m).end_effectors if e.role == EndEffectorRole.FOOT]


def _four_wheels(names: tuple[str, ...]) -> MorphologyBuilder:
    b = MorphologyBuilder("four")
    b.add_link("base", shapes=[Shape(ShapeType.BOX, size=(0.6, 0.4, 0.1), origin=Transform((0, 0, 0.1)))])
    for name, (x, y) in zip(names, ((0.25, 0.25), (0.25, -0.25), (-0.25, 0.25), (-0.25, -0.25)), strict=True):
        b.add_link(name, shapes=[Shape(ShapeType.CYLINDER, radius=0.07, length=0.05)])
        b.add_joint(f"{name}_joint", JointType.CONTINUOUS, "base", name,
                    origin=Transform.from_xyz_rpy((x, y, 0.07), (math.pi / 2, 0, 0)), axis=(0, 0, 1))
    return b


def test_mecanum_wheels_by_name_are_holonomic_else_skid_steer() -> None:
    """Rollers are not in a file: four fixed wheels are skid-steer unless the file names them omni or mecanum."""
    plain = find_wheels(_four_wheels(("w_fl", "w_fr", "w_rl", "w_rr")).build())
    mecanum = find_wheels(_four_wheels(("mecanum_fl", "mecanum_fr", "mecanum_rl", "mecanum_rr")).build())
    assert plain.wheels is not None and plain.wheels.drive == "skid_steer"
    assert mecanum.wheels is not None and mecanum.wheels.drive == "holonomic"
    assert len(mecanum.wheels.joints) == 4 and not mecanum.wheels.steering


def test_yaml_wheels_with_an_unknown_drive_is_refused_at_its_line() -> None:
    from morphkit.errors import MorphkitError

    text = dump_yaml(_found("ackermann")).replace("drive: ackermann", "drive: tank")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if s.startswith("wheels:"))
    with pytest.raises(MorphkitError, match="drive must be one of") as err:
        parse_yaml(text, source="car.yaml")
    assert err.value.location is not None and err.value.location.line == line


def suspended_body() -> MorphologyBuilder:
    """Two wheels, each on a prismatic suspension under the base (as TIAGo's), and a ball caster at the back."""
    b = MorphologyBuilder("suspended")
    b.add_link("base", shapes=[Shape(ShapeType.BOX, size=(0.5, 0.3, 0.1), origin=Transform((0, 0, 0.15)))])
    b.add_link("ball", shapes=[Shape(ShapeType.SPHERE, radius=0.03)])
    b.add_joint("ball_mount", JointType.FIXED, "base", "ball", origin=Transform((-0.2, 0, 0.03)))
    for side, y in (("l", 0.2), ("r", -0.2)):
        b.add_link(f"susp_{side}")
        b.add_joint(f"susp_{side}_joint", JointType.PRISMATIC, "base", f"susp_{side}", axis=(0, 0, 1),
                    limit=Limit(-0.005, 0.005))
        b.add_link(f"wheel_{side}", shapes=[Shape(ShapeType.CYLINDER, radius=0.08, length=0.03)])
        b.add_joint(f"wheel_{side}_joint", JointType.CONTINUOUS, f"susp_{side}", f"wheel_{side}",
                    origin=Transform.from_xyz_rpy((0, y, 0.08), (math.pi / 2, 0, 0)), axis=(0, 0, 1))
    return b


def test_a_suspension_that_carries_only_a_wheel_is_no_limb() -> None:
    m = complete_anatomy(suspended_body().build(), base_declared=False)
    assert m.wheels is not None and m.wheels.drive == "differential"
    assert m.end_effectors == ()
    carried = {m.links[li].name for li in wheel_carried_links(m)}
    assert carried == {"susp_l", "susp_r", "wheel_l", "wheel_r"}
