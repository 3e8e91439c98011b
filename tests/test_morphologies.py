"""The shipped creatures (``morphologies/<name>/``): folder lint, counts, rest pose, round trips.

The facts asserted here come from each creature's README (what it claims to be: DoF, base,
end-effectors, dimensions), checked against the description as the readers see it. Geometry
is checked with a small NumPy forward kinematics written here, independent of the kernels.
"""

from __future__ import annotations

import collections
import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from morphkit.conventions import quat_from_axis_angle, quat_rotate, transform_multiply
from morphkit.errors import DescriptionError
from morphkit.graph import BaseType, EndEffectorRole, JointType, Morphology, Shape, ShapeType
from morphkit.io.shipped import resolve_morphology, shipped_names, shipped_path

REPO = Path(__file__).resolve().parents[1]
MORPHOLOGIES = REPO / "morphologies"

EXPECTED = {
    "spot": {
        "suffix": ".urdf", "base": BaseType.FLOATING, "links": 21, "dof": 19, "coordinates": 26,
        "joints": {JointType.REVOLUTE: 19, JointType.FIXED: 1},
        "roles": {EndEffectorRole.FOOT: 4, EndEffectorRole.HAND: 1, EndEffectorRole.HEAD: 1},
        "length": (0.6, 1.0),
    },
    "crab": {
        "suffix": ".yaml", "base": BaseType.FLOATING, "links": 25, "dof": 24, "coordinates": 31,
        "joints": {JointType.REVOLUTE: 24},
        "roles": {EndEffectorRole.FOOT: 6, EndEffectorRole.HAND: 2, EndEffectorRole.HEAD: 1},
        "length": (0.2, 0.4),
    },
    "stretch": {
        "suffix": ".usda", "base": BaseType.WHEELED, "links": 16, "dof": 9, "coordinates": 12,
        "joints": {JointType.CONTINUOUS: 2, JointType.FIXED: 3, JointType.PRISMATIC: 5, JointType.REVOLUTE: 5},
        "roles": {EndEffectorRole.HAND: 1, EndEffectorRole.HEAD: 1},
        "length": (1.2, 1.5),
    },
    "human": {
        "suffix": ".yaml", "base": BaseType.FLOATING, "links": 22, "dof": 63, "coordinates": 91,
        "joints": {JointType.SPHERICAL: 21},
        "roles": {EndEffectorRole.FOOT: 2, EndEffectorRole.HAND: 2, EndEffectorRole.HEAD: 1},
        "length": (1.6, 1.9),
    },
}
"""What each shipped creature's README promises."""

README_SECTIONS = ("provenance", "dimensions", "degrees of freedom", "end-effectors", "simplifications", "frames")
"""Headings every creature README carries (case-insensitive)."""


# ---- helpers ---------------------------------------------------------------------------------
def _read(name: str) -> Morphology:
    """The shipped creature ``name``; a missing description fails the test (morphkit ships all of them)."""
    from morphkit.io import read_morphology

    path = MORPHOLOGIES / name / f"{name}{EXPECTED[name]['suffix']}"
    assert path.is_file(), f"the shipped description {path} is missing"
    return read_morphology(path)


@pytest.fixture(scope="module")
def creatures() -> dict[str, Morphology]:
    """Cache of the shipped creatures read once per module."""
    return {}


def _get(creatures: dict[str, Morphology], name: str) -> Morphology:
    if name not in creatures:
        creatures[name] = _read(name)
    return creatures[name]


@pytest.fixture(params=sorted(EXPECTED))
def creature(request: pytest.FixtureRequest, creatures: dict[str, Morphology]) -> Morphology:
    return _get(creatures, request.param)


def _load_script(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"_morphkit_test_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    # No __pycache__ inside morphologies/: the folder ships in the wheel as data.
    saved, sys.dont_write_bytecode = sys.dont_write_bytecode, True
    try:
        spec.loader.exec_module(module)
    finally:
        sys.dont_write_bytecode = saved
    return module


def _compare_module() -> ModuleType:
    """The shared round-trip comparison of ``tests/io/_compare.py``."""
    return _load_script(Path(__file__).resolve().parent / "io" / "_compare.py")


def link_poses(m: Morphology, values: dict[str, float] | None = None) -> np.ndarray:
    """``T_world_link`` [link_count, 7] with the base at the origin, joints at rest except ``values``.

    Handles fixed, revolute, continuous and prismatic joints (spherical joints stay at identity)
    and mimic joints; written here so the checks do not depend on the FK kernels.
    """
    rest = dict(zip(m.coordinate_names, m.rest_q(), strict=True))
    q = {j.name: rest.get(j.name, 0.0) for j in m.joints}
    q.update(values or {})
    for j in m.joints:
        if j.mimic is not None:
            q[j.name] = j.mimic.multiplier * q[j.mimic.joint] + j.mimic.offset
    poses = np.zeros((m.link_count, 7))
    poses[0, 6] = 1.0
    for ji, j in enumerate(m.joints):
        local = j.origin.as_array()
        axis = np.asarray(j.axis, dtype=float)
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            local = transform_multiply(local, np.array([0, 0, 0, *quat_from_axis_angle(axis, q[j.name])]))
        elif j.type == JointType.PRISMATIC:
            local = transform_multiply(local, np.array([*(q[j.name] * axis), 0, 0, 0, 1]))
        poses[ji + 1] = transform_multiply(poses[m.link_parent[ji + 1]], local)
    return poses


def ee_positions(m: Morphology, values: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """World position [m] of every end-effector (see :func:`link_poses`)."""
    poses = link_poses(m, values)
    return {
        e.name: transform_multiply(poses[m.link_index(e.link)], np.array([*e.offset, 0, 0, 0, 1]))[:3]
        for e in m.end_effectors
    }


def inner_capsule(shape: Shape, T_world_link: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """A capsule (segment ends [3], [3] and radius) inside ``shape``, in the world frame.

    Spheres and capsules are exact; a cylinder becomes the capsule inside it, and a box the
    capsule along its longest side with the half of its smallest other side as radius. Inner
    shapes never report a contact that the true shapes lack, so a reported overlap is real.
    Meshes are skipped (``None``).
    """
    T = transform_multiply(T_world_link, shape.origin.as_array())
    p, q = T[:3], T[3:]
    if shape.type == ShapeType.SPHERE:
        return p, p, shape.radius
    if shape.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        half = shape.length / 2 if shape.type == ShapeType.CAPSULE else max(shape.length / 2 - shape.radius, 0.0)
        u = quat_rotate(q, np.array([0.0, 0.0, 1.0]))
        return p - half * u, p + half * u, shape.radius
    if shape.type == ShapeType.BOX:
        size = np.asarray(shape.size, dtype=float)
        k = int(np.argmax(size))
        radius = float(np.delete(size, k).min() / 2)
        half = max(size[k] / 2 - radius, 0.0)
        u = quat_rotate(q, np.eye(3)[k])
        return p - half * u, p + half * u, radius
    return None


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> float:
    """Distance [m] between segments ``p1 q1`` and ``p2 q2`` (closest points, clamped)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = d1 @ d1, d2 @ d2, d2 @ r
    eps = 1e-12
    if a <= eps and e <= eps:
        return float(np.linalg.norm(r))
    if a <= eps:
        s, t = 0.0, float(np.clip(f / e, 0.0, 1.0))
    else:
        c = d1 @ r
        if e <= eps:
            s, t = float(np.clip(-c / a, 0.0, 1.0)), 0.0
        else:
            b = d1 @ d2
            den = a * e - b * b
            s = float(np.clip((b * f - c * e) / den, 0.0, 1.0)) if den > eps else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = float(np.clip(-c / a, 0.0, 1.0)), 0.0
            elif t > 1.0:
                s, t = float(np.clip((b - c) / a, 0.0, 1.0)), 1.0
    return float(np.linalg.norm((p1 + s * d1) - (p2 + t * d2)))


def path_joints(m: Morphology, i: int, j: int) -> list[int]:
    """Indices of the joints on the tree path between links ``i`` and ``j``."""
    def ancestors(k: int) -> list[int]:
        out = [k]
        while m.link_parent[out[-1]] >= 0:
            out.append(m.link_parent[out[-1]])
        return out

    ai, aj = ancestors(i), ancestors(j)
    common = set(ai) & set(aj)
    return [k - 1 for k in ai + aj if k not in common]


def telescoping(m: Morphology, joints: list[int], poses: np.ndarray) -> bool:
    """Whether the path is rigid or telescoping: only fixed joints and prismatic joints along one line."""
    directions = []
    for ji in joints:
        j = m.joints[ji]
        if j.type == JointType.PRISMATIC:
            parent = poses[m.link_parent[ji + 1]]
            directions.append(quat_rotate(transform_multiply(parent, j.origin.as_array())[3:], np.asarray(j.axis)))
        elif j.type != JointType.FIXED:
            return False
    return all(abs(abs(float(d @ directions[0])) - 1.0) < 1e-6 for d in directions)


# ---- the folder ------------------------------------------------------------------------------
def test_shipped_names_are_the_creature_folders() -> None:
    folders = sorted(p.name for p in MORPHOLOGIES.iterdir() if p.is_dir() and not p.name.startswith((".", "_")))
    assert set(shipped_names()) <= set(EXPECTED)
    assert list(shipped_names()) == sorted(shipped_names())
    # Every creature folder is a shipped creature (a folder without a description fails here).
    assert set(folders) <= set(EXPECTED), f"unexpected folders in morphologies/: {set(folders) - set(EXPECTED)}"
    for name in shipped_names():
        assert name in folders


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_folder_lint(name: str) -> None:
    folder = MORPHOLOGIES / name
    description = folder / f"{name}{EXPECTED[name]['suffix']}"
    assert description.is_file(), f"the shipped description {description} is missing"
    readme = folder / "README.md"
    assert readme.is_file(), f"{folder} has no README.md"
    text = readme.read_text(encoding="utf-8").lower()
    headings = [line.lstrip("#").strip() for line in text.splitlines() if line.startswith("#")]
    for section in README_SECTIONS:
        assert any(section in h for h in headings), f"{readme}: no section about {section!r}"
    assert "copied" in text, f"{readme}: the provenance must say that no third-party file was copied"
    # One description per folder: the name lookup must not have to guess.
    descriptions = [p for p in folder.iterdir() if p.stem == name and p.suffix in (".yaml", ".yml", ".urdf", ".usda",
                                                                                     ".usdc", ".usd")]
    assert descriptions == [description]
    assert shipped_path(name) == description


def test_resolve_morphology(tmp_path: Path) -> None:
    for name in shipped_names():
        assert resolve_morphology(name) == shipped_path(name)
        # An existing folder or file wins over the name lookup.
        assert resolve_morphology(MORPHOLOGIES / name) == shipped_path(name)
        assert resolve_morphology(str(shipped_path(name))) == shipped_path(name)
    local = tmp_path / "spot"
    local.write_text("not a description")
    assert resolve_morphology(local) == local
    with pytest.raises(DescriptionError) as err:
        resolve_morphology("no_such_creature")
    assert "no_such_creature" in str(err.value)
    for name in shipped_names():
        assert name in err.value.message
    with pytest.raises(DescriptionError, match="shipped"):
        shipped_path("no_such_creature")
    with pytest.raises(DescriptionError, match="no description"):
        resolve_morphology(tmp_path)


def test_read_morphology_takes_the_names_the_cli_takes(creatures: dict[str, Morphology], tmp_path: Path) -> None:
    """``read_morphology`` resolves shipped names and creature folders as the CLI does."""
    from morphkit.io import read_morphology

    for name in ("human", "spot"):
        by_name, by_path = read_morphology(name), _get(creatures, name)
        assert by_name.name == name and by_name.coordinate_names == by_path.coordinate_names
        assert by_name.source == by_path.source
    assert read_morphology(MORPHOLOGIES / "crab").coordinate_names == _get(creatures, "crab").coordinate_names
    with pytest.raises(DescriptionError, match="no shipped creature of that name") as err:
        read_morphology("no_such_creature")
    assert "human" in err.value.message
    with pytest.raises(DescriptionError, match="not found"):
        read_morphology(tmp_path / "missing.yaml")


def test_unrelated_folder_does_not_hide_a_shipped_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "spot").mkdir()
    (tmp_path / "spot" / "renders.txt").write_text("output of an earlier run")
    monkeypatch.chdir(tmp_path)
    assert resolve_morphology("spot") == shipped_path("spot")


# ---- what each creature is -------------------------------------------------------------------
def test_counts(creature: Morphology) -> None:
    exp = EXPECTED[creature.name]
    assert creature.base == exp["base"]
    assert creature.link_count == exp["links"]
    assert dict(collections.Counter(j.type for j in creature.joints)) == exp["joints"]
    assert creature.dof == exp["dof"]
    assert creature.coordinate_count == exp["coordinates"]
    roles = collections.Counter(e.role for e in creature.end_effectors)
    assert dict(roles) == exp["roles"]
    lo, hi = exp["length"]
    assert lo <= creature.characteristic_length <= hi
    # Every link but massless connector frames carries a shape.
    bare = [link.name for link in creature.links if not link.shapes]
    assert len(bare) <= 1, f"links without shapes: {bare}"


def test_spot_is_a_spot(creatures: dict[str, Morphology]) -> None:
    m = _get(creatures, "spot")
    for leg in ("fl", "fr", "hl", "hr"):
        assert m.chain(f"{leg}_lleg") == (f"{leg}_hx", f"{leg}_hy", f"{leg}_kn")
        assert m.joint(f"{leg}_hx").axis == (1.0, 0.0, 0.0)
        assert m.joint(f"{leg}_kn").limit.upper < -0.2  # knees are slightly bent at rest
    arm = ("arm_sh0", "arm_sh1", "arm_el0", "arm_el1", "arm_wr0", "arm_wr1")
    moving = tuple(j for j in m.end_effector_chains["gripper"] if m.joint(j).type != JointType.FIXED)
    assert moving == arm
    assert m.joint("arm_f1x").type == JointType.REVOLUTE
    # Leg bones: thigh ≈ 0.32 m (hip-y to knee), shank 0.3365 m (knee to foot).
    thigh = np.linalg.norm(m.joint("fl_kn").origin.xyz)
    assert thigh == pytest.approx(0.321, abs=2e-3)
    assert m.end_effector("fl_foot").offset == pytest.approx((0.0, 0.0, -0.3365))
    # Spot's signs: positive hip flexion swings the foot backward; the knee bends backward, so a
    # more negative knee angle folds the shank (and the foot) forward.
    rest = ee_positions(m)["fl_foot"]
    assert ee_positions(m, {"fl_hy": 0.3})["fl_foot"][0] < rest[0] - 0.1
    assert ee_positions(m, {"fl_kn": -0.8})["fl_foot"][0] > rest[0] + 0.1
    # MuJoCo Menagerie's "home" (hy 1.04, kn -1.8) stands the body 0.46 m up: the foot spheres
    # (radius 0.036) then touch z = 0.
    home = {f"{leg}_{j}": v for leg in ("fl", "fr", "hl", "hr") for j, v in (("hy", 1.04), ("kn", -1.8))}
    feet = ee_positions(m, home)
    for leg in ("fl", "fr", "hl", "hr"):
        assert feet[f"{leg}_foot"][2] - 0.036 == pytest.approx(-0.46, abs=0.01)


def test_crab_limbs_move_alike_on_both_sides(creatures: dict[str, Morphology]) -> None:
    m = _get(creatures, "crab")
    rest = ee_positions(m)
    for side in "lr":
        for i in (1, 2, 3):
            leg = f"{side}{i}"
            assert m.chain(f"{leg}_tibia") == (f"{leg}_swing", f"{leg}_lift", f"{leg}_knee")
            foot = f"{leg}_foot"
            # Positive swing moves the foot forward; positive lift and knee raise it.
            assert ee_positions(m, {f"{leg}_swing": 0.3})[foot][0] > rest[foot][0] + 0.05
            assert ee_positions(m, {f"{leg}_lift": 0.3})[foot][2] > rest[foot][2] + 0.05
            assert ee_positions(m, {f"{leg}_knee": 0.3})[foot][2] > rest[foot][2] + 0.02
        claw = f"{side}_claw"
        sy = 1.0 if side == "l" else -1.0
        assert sy * ee_positions(m, {f"{claw}_yaw": 0.3})[claw][1] > sy * rest[claw][1] + 0.05
        assert ee_positions(m, {f"{claw}_shoulder": 0.3})[claw][2] > rest[claw][2] + 0.05
    # Left and right are mirror images at rest.
    for name, p in rest.items():
        mirror = {"l": "r", "r": "l"}.get(name[0], name[0]) + name[1:] if name != "head" else name
        np.testing.assert_allclose(rest[mirror], p * np.array([1.0, -1.0, 1.0]), atol=1e-9)


def test_stretch_drives_lifts_and_telescopes(creatures: dict[str, Morphology]) -> None:
    m = _get(creatures, "stretch")
    assert m.wheels is not None
    assert m.wheels.joints == ("joint_left_wheel", "joint_right_wheel")
    assert m.wheels.radius == pytest.approx(0.0508)
    track = m.joint("joint_left_wheel").origin.xyz[1] - m.joint("joint_right_wheel").origin.xyz[1]
    assert track == pytest.approx(2 * 0.1704)
    poses = link_poses(m)
    for w in m.wheels.joints:
        # Wheels touch the ground (z = 0 with the base at the origin) and spin about the lateral axis.
        assert poses[m.link_index(m.joint(w).child)][2] == pytest.approx(m.wheels.radius)
        np.testing.assert_allclose(np.abs(m.joint(w).axis), [0.0, 1.0, 0.0], atol=1e-12)
    stages = ("joint_arm_l3", "joint_arm_l2", "joint_arm_l1", "joint_arm_l0")
    assert all(m.joint(s).type == JointType.PRISMATIC for s in stages)
    assert all(m.joint(s).limit.upper == pytest.approx(0.13) for s in stages)
    assert m.joint("joint_lift").limit.upper == pytest.approx(1.1)
    assert "joint_wrist_yaw" in m.end_effector_chains["gripper"]
    rest = ee_positions(m)
    # The lift raises the gripper straight up; the four stages push it out to the right (-y).
    up = ee_positions(m, {"joint_lift": 0.5})
    np.testing.assert_allclose(up["gripper"] - rest["gripper"], [0.0, 0.0, 0.5], atol=1e-9)
    out = ee_positions(m, dict.fromkeys(stages, 0.13))
    np.testing.assert_allclose(out["gripper"] - rest["gripper"], [0.0, -0.52, 0.0], atol=1e-9)
    # The head camera sits on top of the mast (about 1.3 m up) and looks forward at rest.
    assert 1.2 < rest["head_camera"][2] < 1.45


def test_human_stands_in_t_pose(creatures: dict[str, Morphology]) -> None:
    m = _get(creatures, "human")
    assert m.root == "Hips"
    assert len(m.joints) == 21
    rest = ee_positions(m)
    poses = link_poses(m)
    # Root height 0.98 m: soles at z = -0.98 with the base at the origin.
    assert rest["left_foot"][2] == pytest.approx(-0.98)
    assert rest["right_foot"][2] == pytest.approx(-0.98)
    # T-pose: hands level with the shoulders, arms straight out along ±y.
    for side, sy in (("left", 1.0), ("right", -1.0)):
        shoulder = poses[m.link_index(f"{side.capitalize()}Arm")]
        hand = rest[f"{side}_hand"]
        assert hand[2] == pytest.approx(shoulder[2])
        assert sy * hand[1] > 0.7
    # Standing height from the shapes (sole to crown) is the 1.75 m adult.
    lows, highs = [], []
    for li, link in enumerate(m.links):
        for s in link.shapes:
            a, b, r = inner_capsule(s, poses[li])
            lows.append(min(a[2], b[2]) - r)
            highs.append(max(a[2], b[2]) + r)
    assert max(highs) - min(lows) == pytest.approx(1.75, abs=0.01)
    assert min(lows) == pytest.approx(-0.98, abs=0.005)


# ---- rest pose -------------------------------------------------------------------------------
def test_feet_stand_below_the_body(creature: Morphology) -> None:
    feet = creature.ee_by_role(EndEffectorRole.FOOT)
    if not feet:
        pytest.skip(f"{creature.name} has no feet")
    poses = link_poses(creature)
    rest = ee_positions(creature)
    body_bottom = min(min(a[2], b[2]) - r for a, b, r in
                      (inner_capsule(s, poses[0]) for s in creature.links[0].shapes))
    foot_z = np.array([rest[f.name][2] for f in feet])
    assert foot_z.max() < body_bottom - 0.05, "feet must reach below the body at rest"
    assert np.ptp(foot_z) < 0.01, "feet must stand on one level at rest"
    # Nothing reaches lower than the feet (allowing the foot's own sole shape).
    assert min(p[2] for p in rest.values()) == pytest.approx(foot_z.min())
    assert poses[:, 2].min() >= foot_z.min() - 1e-9


def test_no_deep_overlap_at_rest(creature: Morphology) -> None:
    """No two shapes overlap by more than 1 cm at rest, except near neighbours and telescopes.

    Exempt pairs: links at most two joints apart (hip housings nest in the body, a collar in the
    chest) and links joined only by fixed joints and prismatic joints along one line (rigid
    assemblies, telescoping stages). Everything else must be clear.
    TODO: switch to the contact kernels' exact shape distances once ``morphkit.kernels`` ships them.
    """
    poses = link_poses(creature)
    capsules = [
        (li, c) for li, link in enumerate(creature.links) for s in link.shapes
        if (c := inner_capsule(s, poses[li])) is not None
    ]
    overlaps = []
    for x, (i, (a1, b1, r1)) in enumerate(capsules):
        for j, (a2, b2, r2) in capsules[x + 1:]:
            if i == j:
                continue
            joints = path_joints(creature, i, j)
            if len(joints) <= 2 or telescoping(creature, joints, poses):
                continue
            depth = r1 + r2 - segment_distance(a1, b1, a2, b2)
            if depth > 0.01:
                overlaps.append((creature.link_names[i], creature.link_names[j], round(depth, 4)))
    assert not overlaps, f"shapes overlap at rest: {overlaps}"


def test_rest_pose_is_within_limits(creature: Morphology) -> None:
    q = creature.rest_q()
    lower, upper = creature.coordinate_limits
    assert np.all(q >= lower) and np.all(q <= upper)
    assert np.all(np.isfinite(creature.rest_points()))


# ---- round trips -----------------------------------------------------------------------------
def test_yaml_round_trip(creature: Morphology, tmp_path: Path) -> None:
    from morphkit.io import read_morphology, write_morphology

    path = tmp_path / f"{creature.name}.yaml"
    write_morphology(creature, path)
    _compare_module().assert_morphology_equal(creature, read_morphology(path), tol=1e-6)


def test_native_round_trip(creature: Morphology, tmp_path: Path) -> None:
    """Write each creature back in its own format (YAML, URDF or USD) and read it again."""
    from morphkit.io import read_morphology, write_morphology

    suffix = EXPECTED[creature.name]["suffix"]
    path = tmp_path / f"{creature.name}{suffix}"
    write_morphology(creature, path)
    _compare_module().assert_morphology_equal(creature, read_morphology(path), tol=1e-6)


def test_stretch_usda_is_generated_by_its_script() -> None:
    """``stretch.usda`` is the output of ``make_stretch.py``; the two must not drift apart."""
    m = _read("stretch")
    script = _load_script(MORPHOLOGIES / "stretch" / "make_stretch.py")
    _compare_module().assert_morphology_equal(script.build_stretch(), m, tol=1e-6)


def test_characteristic_lengths_differ_by_creature(creatures: dict[str, Morphology]) -> None:
    """Sanity across creatures: the human is the tallest, the crab the flattest."""
    lengths = {name: _get(creatures, name).characteristic_length for name in EXPECTED}
    assert lengths["human"] > lengths["spot"] > lengths["crab"]
    assert all(math.isfinite(v) and v > 0 for v in lengths.values())
