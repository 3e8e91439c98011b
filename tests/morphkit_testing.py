"""Small test creatures built in code, shared by the test modules (import as ``morphkit_testing``).

The creature helpers build morphologies with :class:`~morphkit.graph.MorphologyBuilder` (no files),
covering every joint type, every base type, wheels and mimic joints; :func:`shipped_morphology`
adds the shipped creatures. (A plain module rather than ``conftest``: several ``conftest.py``
files exist, and importing "conftest" by name picks whichever pytest loaded last.)
"""

from __future__ import annotations

import math
import socket
from collections.abc import Callable

import numpy as np
import pytest

from morphkit.graph import Limit, Mimic, Morphology, MorphologyBuilder, Shape, ShapeType, Transform

SHIPPED = ("spot", "crab", "stretch", "human")
"""Creatures shipped under ``morphologies/<name>/``."""


# ---- creatures built in code -----------------------------------------------------------------
LIM = Limit(-2.5, 2.5)


def planar_arm(l1: float = 1.0, l2: float = 0.7) -> Morphology:
    """Fixed-base 2-link planar arm in the xy plane: joints about z, links ``l1`` and ``l2`` [m] along x."""
    b = MorphologyBuilder("planar_arm")
    b.set_base("fixed")
    for n in ("base", "upper", "fore"):
        b.add_link(n)
    b.add_joint_revolute("shoulder", "base", "upper", axis=(0, 0, 1), limit=Limit(-math.pi, math.pi))
    b.add_joint_revolute("elbow", "upper", "fore", origin=Transform((l1, 0, 0)), axis=(0, 0, 1),
                         limit=Limit(-math.pi, math.pi))
    b.add_end_effector("tip", "fore", offset=(l2, 0, 0), role="hand")
    return b.build()


def every_joint(base: str = "floating") -> Morphology:
    """A branching tree with every joint type (fixed, revolute, continuous, prismatic, spherical),
    rotated joint origins and oblique axes; ``base`` picks the base type."""
    b = MorphologyBuilder(f"every_joint_{base}")
    b.set_base(base)
    for n in ("torso", "a1", "a2", "a3", "a4", "a5", "b1", "b2", "b3"):
        b.add_link(n)
    b.add_shape("torso", Shape(ShapeType.BOX, size=(0.4, 0.2, 0.1)))
    b.add_shape("a2", Shape(ShapeType.CAPSULE, radius=0.03, length=0.2, origin=Transform((0, 0, -0.1))))
    rot = Transform.from_xyz_rpy
    b.add_joint_revolute("a_rev", "torso", "a1", origin=rot((0.2, 0.1, 0.05), (0.3, -0.2, 0.5)),
                         axis=(0.3, 1.0, -0.2), limit=LIM)
    b.add_joint_spherical("a_sph", "a1", "a2", origin=rot((0.0, 0.0, -0.25), (0.1, 0.2, -0.3)))
    b.add_joint_prismatic("a_pri", "a2", "a3", origin=rot((0.05, 0.0, -0.2), (0.0, 0.4, 0.0)),
                          axis=(0.2, -0.1, 1.0), limit=Limit(-0.1, 0.3))
    b.add_joint_continuous("a_con", "a3", "a4", origin=rot((0.0, 0.1, 0.0), (-0.5, 0.0, 0.2)), axis=(1, 0, 0))
    b.add_joint_fixed("a_fix", "a4", "a5", origin=rot((0.1, -0.05, 0.02), (0.2, 0.3, 0.4)))
    b.add_joint_revolute("b_rev", "torso", "b1", origin=rot((-0.2, -0.1, 0.0), (0.0, 0.0, -0.7)),
                         axis=(0, 1, 0), limit=LIM)
    b.add_joint_spherical("b_sph", "b1", "b2", origin=Transform((0.0, -0.15, -0.2)))
    b.add_joint_revolute("b_rev2", "b2", "b3", origin=rot((0.0, 0.0, -0.3), (0.1, 0.0, 0.0)),
                         axis=(0, 0, 1), limit=LIM)
    b.add_end_effector("a_tip", "a5", offset=(0.05, 0.0, -0.1), role="foot")
    b.add_end_effector("b_tip", "b3", offset=(0.0, 0.02, -0.2), role="hand")
    b.add_end_effector("head", "torso", offset=(0.25, 0.0, 0.1), role="head")
    return b.build()


def wheeled(radius: float = 0.05, track: float = 0.3) -> Morphology:
    """Differential-drive base with two wheels (left axis +y, right axis -y) and a caster mast."""
    b = MorphologyBuilder("wheeled")
    b.set_base("wheeled")
    for n in ("chassis", "wheel_l", "wheel_r", "mast", "head"):
        b.add_link(n)
    b.add_shape("wheel_l", Shape(ShapeType.CYLINDER, radius=radius, length=0.02))
    b.add_joint_continuous("wheel_l_joint", "chassis", "wheel_l", origin=Transform((0.0, track / 2, radius)),
                           axis=(0, 1, 0))
    # The right wheel's axis points right: a positive wheel angle rolls it backwards.
    b.add_joint_continuous("wheel_r_joint", "chassis", "wheel_r", origin=Transform((0.0, -track / 2, radius)),
                           axis=(0, -1, 0))
    b.add_joint_prismatic("lift", "chassis", "mast", origin=Transform((0.1, 0.0, 0.2)), axis=(0, 0, 1),
                          limit=Limit(0.0, 1.0))
    b.add_joint_revolute("pan", "mast", "head", origin=Transform((0.0, 0.0, 0.5)), axis=(0, 0, 1), limit=LIM)
    b.set_wheels(["wheel_l_joint", "wheel_r_joint"], radius)
    b.add_end_effector("camera", "head", offset=(0.05, 0.0, 0.02), role="head")
    b.add_end_effector("wheel_l_contact", "wheel_l", offset=(0.0, 0.0, 0.0), role="foot")
    return b.build()


def mimic() -> Morphology:
    """A fixed-base gripper whose second finger mimics the first (multiplier -1, offset 0.1)."""
    b = MorphologyBuilder("gripper")
    b.set_base("fixed")
    for n in ("palm", "wrist", "finger_a", "finger_b"):
        b.add_link(n)
    b.add_joint_revolute("wrist", "palm", "wrist", origin=Transform((0, 0, 0.1)), axis=(0, 0, 1), limit=LIM)
    b.add_joint_prismatic("finger_a", "wrist", "finger_a", origin=Transform((0.0, 0.02, 0.05)), axis=(0, 1, 0),
                          limit=Limit(0.0, 0.05))
    b.add_joint_prismatic("finger_b", "wrist", "finger_b", origin=Transform((0.0, -0.02, 0.05)), axis=(0, 1, 0),
                          limit=Limit(-0.05, 0.0), mimic=Mimic("finger_a", -1.0, 0.1))
    b.add_end_effector("tip_b", "finger_b", offset=(0, 0, 0.03), role="tool")
    return b.build()


def spot_like() -> Morphology:
    """A Spot-with-arm-like quadruped: floating base, 4 legs × 3 revolute + 7-DoF arm (19 DoF, 21 links)."""
    b = MorphologyBuilder("spot_like")
    b.add_link("body")
    for leg, (sx, sy) in {"fl": (1, 1), "fr": (1, -1), "hl": (-1, 1), "hr": (-1, -1)}.items():
        for n in ("hip", "uleg", "lleg"):
            b.add_link(f"{leg}_{n}")
        b.add_joint_revolute(f"{leg}_hx", "body", f"{leg}_hip", origin=Transform((0.29785 * sx, 0.055 * sy, 0.0)),
                             axis=(1, 0, 0), limit=Limit(-0.78, 0.78))
        b.add_joint_revolute(f"{leg}_hy", f"{leg}_hip", f"{leg}_uleg", origin=Transform((0.0, 0.110945 * sy, 0.0)),
                             axis=(0, 1, 0), limit=Limit(-0.9, 2.3))
        b.add_joint_revolute(f"{leg}_kn", f"{leg}_uleg", f"{leg}_lleg", origin=Transform((0.025, 0.0, -0.3205)),
                             axis=(0, 1, 0), limit=Limit(-2.79, -0.25))
        b.add_end_effector(f"{leg}_foot", f"{leg}_lleg", offset=(0, 0, -0.3365), role="foot")
    arm = [("arm_sh0", (0.292, 0, 0.188), (0, 0, 1)), ("arm_sh1", (0, 0, 0), (0, 1, 0)),
           ("arm_el0", (0.3385, 0, 0), (0, 1, 0)), ("arm_el1", (0.4033, 0, 0.075), (1, 0, 0)),
           ("arm_wr0", (0, 0, 0), (0, 1, 0)), ("arm_wr1", (0, 0, 0), (1, 0, 0)),
           ("arm_f1x", (0.1174, 0, 0.0148), (0, 1, 0))]
    parent = "body"
    for name, xyz, ax in arm:
        b.add_link(f"{name}_link")
        b.add_joint_revolute(name, parent, f"{name}_link", origin=Transform(xyz), axis=ax, limit=LIM)
        parent = f"{name}_link"
    b.add_end_effector("gripper", "arm_wr1_link", offset=(0.15, 0, 0), role="hand")
    return b.build()


HUMAN_TREE = (
    ("lhipjoint", "hips"), ("lfemur", "lhipjoint"), ("ltibia", "lfemur"), ("lfoot", "ltibia"), ("ltoes", "lfoot"),
    ("rhipjoint", "hips"), ("rfemur", "rhipjoint"), ("rtibia", "rfemur"), ("rfoot", "rtibia"), ("rtoes", "rfoot"),
    ("lowerback", "hips"), ("upperback", "lowerback"), ("thorax", "upperback"), ("lowerneck", "thorax"),
    ("upperneck", "lowerneck"), ("head", "upperneck"),
    ("lclavicle", "thorax"), ("lhumerus", "lclavicle"), ("lradius", "lhumerus"), ("lhand", "lradius"),
    ("rclavicle", "thorax"), ("rhumerus", "rclavicle"),
)


def human_like() -> Morphology:
    """A CMU-like human: floating base (hips) and 22 spherical joints."""
    rng = np.random.default_rng(7)
    b = MorphologyBuilder("human_like")
    b.add_link("hips")
    for child, parent in HUMAN_TREE:
        b.add_link(child)
        off = tuple(float(v) for v in rng.uniform(-0.2, 0.2, 3))
        b.add_joint_spherical(child, parent, child, origin=Transform(off))
    for n, role in (("lfoot", "foot"), ("rfoot", "foot"), ("lhand", "hand"), ("head", "head")):
        b.add_end_effector(f"{n}_ee", n, offset=(0.0, 0.0, -0.05), role=role)
    return b.build()


BASES = ("floating", "planar", "wheeled", "fixed")

TEST_CREATURES: dict[str, Callable[[], Morphology]] = {
    "planar_arm": planar_arm,
    **{f"every_joint_{base}": (lambda base=base: every_joint(base)) for base in BASES},
    "wheeled": wheeled,
    "mimic": mimic,
    "spot_like": spot_like,
    "human_like": human_like,
}
"""Every creature built in code, by name."""


def shipped_morphology(name: str) -> Morphology:
    """Read a shipped creature from ``morphologies/<name>/`` (a missing one fails the test)."""
    from pathlib import Path

    from morphkit.io import read_morphology

    root = Path(__file__).resolve().parents[1] / "morphologies" / name
    paths = sorted(p for p in root.glob(f"{name}.*") if p.suffix in (".yaml", ".yml", ".urdf", ".usda", ".usd"))
    if not paths:
        pytest.fail(f"shipped creature {name!r} is missing from morphologies/{name}/")
    return read_morphology(paths[0])


def creature(name: str) -> Morphology:
    """A test creature by name: one built in code, or ``shipped:<name>``."""
    if name.startswith("shipped:"):
        return shipped_morphology(name.split(":", 1)[1])
    return TEST_CREATURES[name]()


ALL_CREATURES = (*TEST_CREATURES, *(f"shipped:{n}" for n in SHIPPED))
"""Names for ``pytest.mark.parametrize``: creatures built in code, then the shipped ones."""


def random_q(model, batch: tuple[int, ...] | int, *, seed: int = 0, dtype=np.float64) -> np.ndarray:
    """Random coordinates for a compiled model: within limits (±π where unbounded), unit quaternions."""
    rng = np.random.default_rng(seed)
    shape = (batch,) if isinstance(batch, int) else tuple(batch)
    lo = np.where(np.isfinite(model.coordinate_lower), model.coordinate_lower, -math.pi)
    hi = np.where(np.isfinite(model.coordinate_upper), model.coordinate_upper, math.pi)
    q = rng.uniform(lo, hi, size=(*shape, model.coordinate_count))
    from morphkit.graph import BaseType, JointType

    quat_starts = []
    if model.base_type == BaseType.FLOATING:
        q[..., 0:3] = rng.uniform(-1.0, 1.0, size=(*shape, 3))
        quat_starts.append(3)
    for j in range(model.joint_count):
        if model.joint_type[j] == JointType.SPHERICAL and model.joint_q_start[j + 1] - model.joint_q_start[j] == 4:
            quat_starts.append(int(model.joint_q_start[j]))
    for s in quat_starts:
        v = rng.normal(size=(*shape, 4))
        q[..., s : s + 4] = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return q.astype(dtype)


def free_port() -> int:
    """A loopback TCP port free at the time of the call (for torchrun's static rendezvous: two test runs at once
    on one machine must not share a fixed port)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ---- robots from the field's model libraries (issue 46's development set) ----------------------
def pybullet_data_file(relative: str) -> str:
    """A file of the ``pybullet`` wheel's ``pybullet_data`` (e.g. ``aliengo/aliengo.urdf``); skips without it."""
    import os

    pybullet_data = pytest.importorskip("pybullet_data", reason="pybullet (the dev extra) ships the URDFs")
    path = os.path.join(pybullet_data.getDataPath(), relative)
    if not os.path.isfile(path):
        pytest.skip(f"pybullet_data has no {relative}")
    return path


TINY_THIGH = TINY_SHIN = 0.2
"""Segment lengths of :func:`tiny_quadruped_urdf`'s legs [m]."""
TINY_LEGS = {"FL": (0.2, 0.1), "FR": (0.2, -0.1), "HL": (-0.2, 0.1), "HR": (-0.2, -0.1)}
"""Its legs and their hips' (x, y) on the body [m]."""


def tiny_quadruped_urdf(root: str = "") -> str:
    """A URDF quadruped named ``tiny``: a 0.5 m box body, four legs (hip and knee hinges about y, a cylinder per
    segment, a sphere foot at the shin's end); ``root`` is XML put before the body link (a world joint)."""
    legs = ""
    for n, (x, y) in TINY_LEGS.items():
        legs += f"""
  <joint name="{n}_hip" type="revolute"><parent link="base"/><child link="{n}_thigh"/>
    <origin xyz="{x} {y} 0"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="10"/></joint>
  <link name="{n}_thigh"><collision><origin xyz="0 0 -0.1"/>
    <geometry><cylinder radius="0.02" length="0.2"/></geometry></collision></link>
  <joint name="{n}_knee" type="revolute"><parent link="{n}_thigh"/><child link="{n}_shin"/>
    <origin xyz="0 0 -{TINY_THIGH}"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="0" effort="10" velocity="10"/></joint>
  <link name="{n}_shin"><collision><origin xyz="0 0 -0.1"/>
    <geometry><cylinder radius="0.015" length="0.2"/></geometry></collision></link>
  <joint name="{n}_foot_fixed" type="fixed"><parent link="{n}_shin"/><child link="{n}_foot"/>
    <origin xyz="0 0 -{TINY_SHIN}"/></joint>
  <link name="{n}_foot"><collision><geometry><sphere radius="0.02"/></geometry></collision></link>"""
    return (f'<?xml version="1.0"?>\n<robot name="tiny">\n{root}  <link name="base"><collision><geometry>'
            f'<box size="0.5 0.25 0.08"/></geometry></collision></link>{legs}\n</robot>\n')


def example_robot_data_file(relative: str) -> str:
    """A file of ``example-robot-data`` 6.0.0's robots folder (e.g. ``go2_description/urdf/go2.urdf``): from
    ``$MORPHKIT_ERD`` (the unzipped wheel's folder), else the installed package (the dev extra installs it), else
    the robot zoo's download in morphkit's cache; skips without any."""
    import os
    import sysconfig
    from pathlib import Path

    from morphkit.cache import cache_dir

    sub = Path("cmeel.prefix/share/example-robot-data/robots")
    roots = [Path(os.environ["MORPHKIT_ERD"]) / sub] if os.environ.get("MORPHKIT_ERD") else []
    roots += [Path(sysconfig.get_paths()["purelib"]) / sub, cache_dir("robot_zoo", "example-robot-data-6.0.0") /
              "unzipped" / sub]
    for root in roots:
        if (root / relative).is_file():
            return str(root / relative)
    pytest.skip(f"example-robot-data not found (set MORPHKIT_ERD or pip install example-robot-data==6.0.0): {relative}")


def playground_xml(robot: str, file: str) -> str:
    """An MJCF of MuJoCo Playground's locomotion robots (``berkeley_humanoid``, ``op3``); skips without it.

    The ``playground`` wheel pulls JAX, so it is not in the dev extra; ``pip install playground --no-deps``
    gives the files (their meshes point into a Menagerie checkout and are missing: the reader leaves them out).
    """
    import importlib.util
    import os

    spec = importlib.util.find_spec("mujoco_playground")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("mujoco_playground not installed (pip install playground --no-deps)")
    path = os.path.join(next(iter(spec.submodule_search_locations)), "_src", "locomotion", robot, "xmls", file)
    if not os.path.isfile(path):
        pytest.skip(f"mujoco_playground has no {robot}/xmls/{file}")
    return path


def dm_suite_xml(name: str) -> str:
    """An MJCF of dm_control's suite (``dog.xml``, ``quadruped.xml``); skips without dm_control."""
    import os

    pytest.importorskip("mujoco")
    dm_control = pytest.importorskip("dm_control")
    return os.path.join(os.path.dirname(dm_control.__file__), "suite", name)
