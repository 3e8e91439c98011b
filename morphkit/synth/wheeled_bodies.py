"""Generated wheeled robots of each drive, with or without an arm, as a vendor would ship them.

:func:`wheeled_body` builds a base box on wheels — no wheels declared, no end-effectors, the root link at the
base's middle above the ground — so that tests and demos exercise the wheel finding
(:func:`morphkit.body.wheels.find_wheels`) and the drives (:mod:`morphkit.synth.wheeled`) on bodies whose true
drive, radius and track are known:

- ``differential``: two wheels on one axle under the base's middle, a free caster swivel (with trail) at the back;
- ``skid_steer``: four wheels on two fixed axles;
- ``ackermann``: two fixed rear wheels and two front wheels on limited steering hinges;
- ``holonomic``: four powered casters (free vertical swivels, each carrying a wheel with trail).

:func:`wheeled_robot` is the same body as a reader hands it over: wheels, drive and end-effectors found.
"""

from __future__ import annotations

import math

from morphkit.body.anatomy import complete_anatomy
from morphkit.graph import JointType, Limit, Morphology, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.graph.elements import WHEEL_DRIVES

__all__ = ["WHEELED_DRIVES", "wheeled_body", "wheeled_robot"]

WHEELED_DRIVES = WHEEL_DRIVES
"""The drives :func:`wheeled_body` builds: every one the graph knows."""

_SIDEWAYS = (math.pi / 2, 0.0, 0.0)
"""A cylinder's (and a wheel joint's) z axis turned onto the base's y axis."""


def _wheel(b: MorphologyBuilder, name: str, parent: str, xyz: tuple[float, float, float], radius: float,
           width: float) -> None:
    b.add_link(name, shapes=[Shape(ShapeType.CYLINDER, radius=radius, length=width)])
    b.add_joint(f"{name}_joint", JointType.CONTINUOUS, parent, name, origin=Transform.from_xyz_rpy(xyz, _SIDEWAYS),
                axis=(0.0, 0.0, 1.0))


def _caster(b: MorphologyBuilder, name: str, xy: tuple[float, float], ground: float, radius: float,
            trail: float) -> None:
    """A free vertical swivel at ``xy`` (base frame, axle height) carrying a wheel of ``radius`` ``trail`` behind
    it, on the ground ``ground`` [m] below the base link's origin."""
    b.add_link(f"{name}_swivel", shapes=[Shape(ShapeType.BOX, size=(0.02, 0.02, 0.02))])
    b.add_joint(f"{name}_swivel_joint", JointType.CONTINUOUS, "base", f"{name}_swivel",
                origin=Transform((xy[0], xy[1], 0.0)), axis=(0.0, 0.0, 1.0))
    _wheel(b, f"{name}_wheel", f"{name}_swivel", (-trail, 0.0, radius - ground), radius, 0.4 * radius)


def wheeled_body(drive: str = "differential", *, arm: bool = False, radius: float = 0.08, track: float = 0.5,
                 wheelbase: float = 0.6, max_steer: float = 0.5, name: str | None = None) -> Morphology:
    """A wheeled robot of ``drive`` (one of :data:`WHEELED_DRIVES`), read as from a vendor file.

    Args:
        drive: The arrangement of its wheels (see the module docstring).
        arm: Add a 4-joint arm on a mast (a yaw, two pitches and a wrist) ending in a tool link ``tool``.
        radius: Wheel radius [m] (casters: half of it).
        track: Lateral distance between the driven wheels' centres [m].
        wheelbase: Longitudinal distance between axles, or between the drive axle and the casters [m].
        max_steer: Steering hinges' limit ±[rad] (``ackermann``).
        name: The robot's name (default ``wheeled_<drive>[_arm]``).

    Returns:
        A morphology with a floating base, no wheels and no end-effectors declared; the ground is ``radius``
        below the base link's origin (the driven axles' height).
    """
    if drive not in WHEELED_DRIVES:
        raise ValueError(f"drive must be one of {', '.join(WHEELED_DRIVES)}, got {drive!r}")
    b = MorphologyBuilder(name or f"wheeled_{drive}{'_arm' if arm else ''}")
    length, width = wheelbase + 2.5 * radius, track - 0.6 * radius
    b.add_link("base", shapes=[Shape(ShapeType.BOX, origin=Transform((0.0, 0.0, 0.6 * radius)),
                                     size=(length, width, 0.8 * radius))])
    half = track / 2
    w = 0.5 * radius
    if drive == "differential":
        for side, y in (("left", half), ("right", -half)):
            _wheel(b, f"wheel_{side}", "base", (0.0, y, 0.0), radius, w)
        _caster(b, "caster_back", (-wheelbase, 0.0), radius, radius / 2, 0.3 * radius)
    elif drive == "skid_steer":
        for end, x in (("front", wheelbase / 2), ("rear", -wheelbase / 2)):
            for side, y in (("left", half), ("right", -half)):
                _wheel(b, f"wheel_{end}_{side}", "base", (x, y, 0.0), radius, w)
    elif drive == "ackermann":
        for side, y in (("left", half), ("right", -half)):
            _wheel(b, f"wheel_rear_{side}", "base", (0.0, y, 0.0), radius, w)
            hinge = f"steer_{side}"
            b.add_link(hinge)
            b.add_joint(f"{hinge}_joint", JointType.REVOLUTE, "base", hinge, origin=Transform((wheelbase, y, 0.0)),
                        axis=(0.0, 0.0, 1.0), limit=Limit(-max_steer, max_steer))
            _wheel(b, f"wheel_front_{side}", hinge, (0.0, 0.0, 0.0), radius, w)
    else:
        for end, x in (("front", wheelbase / 2), ("rear", -wheelbase / 2)):
            for side, y in (("left", half), ("right", -half)):
                _caster(b, f"caster_{end}_{side}", (x, y), radius, radius, 0.25 * radius)
    if arm:
        mast = 0.6
        b.add_link("mast", shapes=[Shape(ShapeType.CYLINDER, origin=Transform((0.0, 0.0, mast / 2)), radius=0.04,
                                         length=mast)])
        b.add_joint("mast_mount", JointType.FIXED, "base", "mast", origin=Transform((0.0, 0.0, radius)))
        along_x = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))  # a capsule's z axis turned onto x
        prev, at = "mast", (0.0, 0.0, mast)
        for i, (kind, axis, seg) in enumerate((("yaw", (0.0, 0.0, 1.0), 0.05), ("pitch", (0.0, 1.0, 0.0), 0.35),
                                               ("pitch", (0.0, 1.0, 0.0), 0.3), ("pitch", (0.0, 1.0, 0.0), 0.1))):
            link = f"arm_{i + 1}"
            b.add_link(link, shapes=[Shape(ShapeType.CAPSULE, origin=Transform((seg / 2, 0.0, 0.0), along_x),
                                           radius=0.03, length=seg)])
            b.add_joint(f"arm_{kind}_{i + 1}", JointType.REVOLUTE, prev, link, origin=Transform(at), axis=axis,
                        limit=Limit(-2.0, 2.0))
            prev, at = link, (seg, 0.0, 0.0)
        b.add_link("tool")
        b.add_joint("tool_joint", JointType.FIXED, prev, "tool", origin=Transform(at))
    return b.build()


def wheeled_robot(drive: str = "differential", *, arm: bool = False, **kw: float | str | None) -> Morphology:
    """:func:`wheeled_body` with its wheels, drive and end-effectors found, as a reader hands a vendor file over
    (:func:`~morphkit.body.anatomy.complete_anatomy`); ``kw`` as :func:`wheeled_body` takes them."""
    return complete_anatomy(wheeled_body(drive, arm=arm, **kw), base_declared=False)  # type: ignore[arg-type]
