"""Generate ``stretch.usda``: morphkit's simplified Stretch-like wheeled mobile manipulator.

The creature is written out here through :class:`~morphkit.graph.MorphologyBuilder`, so every
number sits next to the reason for it, and is saved with morphkit's own USD writer (which
puts the morphkit-specific facts -- base type, wheels, end-effectors, capsule shapes -- in
``morphkit:`` attributes). The committed ``stretch.usda`` is this script's output; the test
suite checks that the two agree. Regenerate after an edit with:

    python morphologies/stretch/make_stretch.py

Sources: the joint positions, axes and limits of Hello Robot Stretch in
``../shared/reference/robots/DIMENSIONS.md`` (the all-zero forward kinematics of the SE3
URDF, re-expressed with every link frame parallel to the base frame); the shapes are rough
boxes and cylinders chosen here. No third-party file was copied. See README.md.

Frames: base_link at the ground between the drive wheels, x forward, y left, z up; every link
frame is parallel to base_link at q = 0. Units: metres and radians.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from morphkit.graph import Limit, Mimic, Morphology, MorphologyBuilder, Shape, ShapeType, Transform

HERE = Path(__file__).resolve().parent
OUTPUT = HERE / "stretch.usda"

WHEEL_RADIUS = 0.0508
"""Drive wheel radius = axle height [m]."""
WHEEL_Y = 0.1704
"""Lateral wheel position [m]; the track is twice this."""
STAGE_TRAVEL = 0.13
"""Travel of each of the four telescoping arm stages [m] (0.52 m in all)."""


def _box(size: tuple[float, float, float], xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Shape:
    return Shape(ShapeType.BOX, Transform(xyz), size=size)


def _along(axis: str, xyz: tuple[float, float, float]) -> Transform:
    """A shape frame at ``xyz`` whose local z (the cylinder/capsule axis) points along ``axis``."""
    rpy = {"x": (0.0, math.pi / 2, 0.0), "y": (-math.pi / 2, 0.0, 0.0), "z": (0.0, 0.0, 0.0)}[axis]
    return Transform.from_xyz_rpy(xyz, rpy)


def build_stretch() -> Morphology:
    """The Stretch-like creature as a :class:`Morphology` (what ``stretch.usda`` holds)."""
    b = MorphologyBuilder("stretch")
    b.set_base("wheeled")
    b.set_root("base_link")

    # Mobile base: a box body above the ground plus the rear caster ball (touching z = 0).
    b.add_link("base_link", shapes=[
        _box((0.34, 0.30, 0.14), (-0.09, 0.0, 0.09)),
        Shape(ShapeType.SPHERE, Transform((-0.245, 0.0, 0.032)), radius=0.032),
    ])

    # Differential drive: wheel axles along +y, so a positive wheel angle rolls the robot forward.
    for side, sy in (("left", 1.0), ("right", -1.0)):
        wheel = Shape(ShapeType.CYLINDER, _along("y", (0.0, 0.0, 0.0)), radius=WHEEL_RADIUS, length=0.03)
        b.add_link(f"link_{side}_wheel", shapes=[wheel])
        b.add_joint_continuous(f"joint_{side}_wheel", "base_link", f"link_{side}_wheel",
                               origin=Transform((0.0, sy * WHEEL_Y, WHEEL_RADIUS)), axis=(0.0, 1.0, 0.0))
    b.set_wheels(["joint_left_wheel", "joint_right_wheel"], WHEEL_RADIUS)

    # Mast: a thin vertical column from the base to the head (1.33 m tall), plus the head bracket.
    b.add_link("link_mast", shapes=[
        _box((0.03, 0.09, 1.25), (0.0, 0.0, 0.705)),
        _box((0.10, 0.16, 0.02), (0.035, -0.07, 1.35)),
    ])
    b.add_joint_fixed("joint_mast", "base_link", "link_mast", origin=Transform((-0.067, 0.135, 0.0284)))

    # Lift: the carriage slides up the mast, 0 .. 1.1 m; at 0 the arm is 0.195 m above the ground.
    b.add_link("link_lift", shapes=[_box((0.10, 0.13, 0.08), (0.0, 0.0, 0.01))])
    b.add_joint_prismatic("joint_lift", "link_mast", "link_lift", origin=Transform((-0.0374, 0.0, 0.1666)),
                          axis=(0.0, 0.0, 1.0), limit=Limit(0.0, 1.1, velocity=1.0, effort=100.0))

    # Telescopic arm: the outer tube (l4) is rigid on the carriage; four nested stages l3..l0
    # slide out along -y (to the robot's right), 0 .. 0.13 m each. Stage frames sit at the
    # outer end of each tube; the tubes reach back towards the carriage.
    b.add_link("link_arm_l4", shapes=[_box((0.04, 0.30, 0.04), (0.0, 0.15, 0.0))])
    b.add_joint_fixed("joint_arm_l4", "link_lift", "link_arm_l4", origin=Transform((0.0, -0.2547, 0.0)))
    stages = (("l3", "l4", -0.013, 0.036), ("l2", "l3", -0.013, 0.032), ("l1", "l2", -0.013, 0.028),
              ("l0", "l1", 0.0137, 0.024))
    for name, parent, dy, width in stages:
        shapes = [_box((width, 0.26, width), (0.0, 0.13, 0.0))]
        if name == "l0":
            # The bracket that carries the wrist in front of (and below) the innermost tube.
            shapes.append(_box((0.10, 0.03, 0.02), (0.045, 0.0, -0.015)))
        b.add_link(f"link_arm_{name}", shapes=shapes)
        b.add_joint_prismatic(f"joint_arm_{name}", f"link_arm_{parent}", f"link_arm_{name}",
                              origin=Transform((0.0, dy, 0.0)), axis=(0.0, -1.0, 0.0),
                              limit=Limit(0.0, STAGE_TRAVEL, velocity=1.0, effort=100.0))

    # Wrist yaw about the vertical; at 0 the gripper points along the arm (-y), positive turns
    # it towards the front (+x).
    b.add_link("link_wrist_yaw", shapes=[
        Shape(ShapeType.CYLINDER, _along("z", (0.0, 0.0, -0.02)), radius=0.02, length=0.04)])
    b.add_joint_revolute("joint_wrist_yaw", "link_arm_l0", "link_wrist_yaw",
                         origin=Transform((0.083, 0.0, -0.0308)), axis=(0.0, 0.0, 1.0),
                         limit=Limit(-1.75, 4.0, velocity=1.0, effort=100.0))

    # Gripper body hanging below the wrist, and two fingers pointing along -y. The right finger
    # mirrors the left one: positive opens both.
    b.add_link("link_gripper", shapes=[_box((0.05, 0.06, 0.04))])
    b.add_joint_fixed("joint_gripper", "link_wrist_yaw", "link_gripper", origin=Transform((0.0, -0.07, -0.045)))
    for side, sx in (("left", 1.0), ("right", -1.0)):
        finger = Shape(ShapeType.CAPSULE, _along("y", (0.0, -0.06, 0.0)), radius=0.01, length=0.10)
        b.add_link(f"link_gripper_finger_{side}", shapes=[finger])
        b.add_joint_revolute(
            f"joint_gripper_finger_{side}", "link_gripper", f"link_gripper_finger_{side}",
            origin=Transform((sx * 0.015, -0.03, 0.0)), axis=(0.0, 0.0, sx),
            limit=Limit(-0.6, 0.6, velocity=1.0, effort=100.0),
            mimic=Mimic("joint_gripper_finger_left") if side == "right" else None,
        )
    b.add_end_effector("gripper", "link_gripper", offset=(0.0, -0.13, 0.0), role="hand")

    # Head: pan about the vertical, then tilt about -y (positive looks up); the camera faces +x
    # at q = 0.
    b.add_link("link_head_pan", shapes=[_box((0.06, 0.06, 0.04), (0.0, 0.0, -0.01))])
    b.add_joint_revolute("joint_head_pan", "link_mast", "link_head_pan", origin=Transform((0.0731, -0.135, 1.3268)),
                         axis=(0.0, 0.0, 1.0), limit=Limit(-3.9, 1.5, velocity=1.0, effort=100.0))
    b.add_link("link_head_tilt", shapes=[_box((0.03, 0.10, 0.03), (0.04, -0.03, 0.005))])
    b.add_joint_revolute("joint_head_tilt", "link_head_pan", "link_head_tilt",
                         origin=Transform((-0.0013, 0.0278, -0.0533)), axis=(0.0, -1.0, 0.0),
                         limit=Limit(-1.53, 0.79, velocity=1.0, effort=100.0))
    b.add_end_effector("head_camera", "link_head_tilt", offset=(0.0406, -0.0307, 0.0053), role="head")
    return b.build()


LAYER_DOC = (
    "stretch: a simplified Stretch-like wheeled mobile manipulator for morphkit. Generated by "
    "make_stretch.py (edit that, not this file); authored from the dimension tables of "
    "DIMENSIONS.md, no third-party file copied. See README.md. Units: metres; Z up."
)
"""Layer documentation written into the generated file's header."""


def main(argv: list[str] | None = None) -> int:
    """Write ``stretch.usda`` next to this script (or to the path given as the first argument)."""
    from pxr import Sdf

    from morphkit.io import write_morphology

    args = sys.argv[1:] if argv is None else argv
    out = Path(args[0]) if args else OUTPUT
    write_morphology(build_stretch(), out)
    layer = Sdf.Layer.FindOrOpen(str(out))
    layer.documentation = LAYER_DOC
    layer.Save()
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
