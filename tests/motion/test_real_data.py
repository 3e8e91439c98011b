"""Every clip in ``$MORPHKIT_DATA`` loads; CMU humans stand on the ground at human height; Spot vs
CMU end-effector mapping (skipped when ``MORPHKIT_DATA`` is unset).

All clips are read; reading a BVH file needs no FK kernel. Checks through the FK kernels run on
every CMU clip (one skeleton, one kernel); the other sets are checked on subsets through the
pure-torch reference FK, so the suite generates no kernel for their skeletons.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest
from _motion_compare import reference_link_positions

from morphkit.graph import EndEffectorRole
from morphkit.io.bvh import read_bvh_skeleton
from morphkit.motion import (
    Motion,
    ee_distributions,
    map_end_effectors,
    read_bvh_motion,
    read_motion,
    write_motion,
)
from morphkit.rotations import quat_from_yaw

DATA = Path(os.environ["MORPHKIT_DATA"]) if os.environ.get("MORPHKIT_DATA") else None
FOLDERS = {"cmu": "human/cmu", "cmu_daz": "human/cmu_daz", "second_skeleton": "human/second_skeleton",
           "dog": "creatures/dog"}
HUMANS = ("cmu", "cmu_daz", "second_skeleton")

pytestmark = pytest.mark.skipif(
    DATA is None or not (DATA / "human" / "cmu").is_dir(), reason="MORPHKIT_DATA is not set (or has no human/cmu)"
)

_cache: dict[str, list[Motion]] = {}


def _load(key: str) -> list[Motion]:
    if key not in _cache:
        assert DATA is not None
        files = _files(key)
        if not files:
            pytest.skip(f"no BVH files in {DATA / FOLDERS[key]}")
        _cache[key] = [read_bvh_motion(f) for f in files]  # facing="auto": the dog's is -x
    return _cache[key]


def _files(key: str) -> list[Path]:
    assert DATA is not None
    return sorted((DATA / FOLDERS[key]).glob("*.bvh"))


def _manifest(key: str) -> dict[str, dict[str, str]]:
    assert DATA is not None
    path = DATA / FOLDERS[key] / "MANIFEST.csv"
    if not path.is_file():
        return {}
    with path.open(newline="") as f:
        return {row["file"]: row for row in csv.DictReader(f)}


def _ee(m: Motion, role: EndEffectorRole) -> list[int]:
    return [i for i, e in enumerate(m.morphology.end_effectors) if e.role == role]


@pytest.mark.parametrize("key", list(FOLDERS))
def test_every_clip_loads(key: str) -> None:
    motions = _load(key)
    manifest = _manifest(key)
    for m in motions:
        assert np.isfinite(m.q).all(), m.name
        row = manifest.get(f"{m.name}.bvh")
        if row is not None:
            assert m.frame_count == int(row["frames"]), m.name
            assert m.fps == pytest.approx(float(row["fps"]), rel=1e-3), m.name
        counts = tuple(len(_ee(m, r)) for r in (EndEffectorRole.HAND, EndEffectorRole.FOOT, EndEffectorRole.HEAD))
        # Humans keep their hands whatever the clip (crawling, sun salutation); the dog's front
        # paws, named hands, are feet.
        assert counts == ((2, 2, 1) if key in HUMANS else (0, 4, 1)), (m.name, counts)
    # Grounded: the lowest foot touches z = 0 (every clip through the FK kernels for CMU; for the
    # other sets a subset through the reference FK, so no kernel is generated for their skeletons).
    for m in motions if key == "cmu" else motions[::8]:
        ee = m.end_effector_positions() if key == "cmu" else _reference_ee(m)
        assert ee[:, _ee(m, EndEffectorRole.FOOT), 2].min() == pytest.approx(0.0, abs=1e-6), m.name
    # Clips of one convention share their skeleton object (one compiled FK kernel).
    assert len({id(m.morphology) for m in motions}) <= 3


def test_cmu_clips_stand_on_the_ground_at_human_height() -> None:
    motions = _load("cmu")
    assert len(motions) >= 200
    stance_heights = []
    for m in motions:
        length = m.morphology.characteristic_length
        assert 1.5 <= length <= 1.9, m.name
        ee = m.end_effector_positions()
        feet, head = _ee(m, EndEffectorRole.FOOT), _ee(m, EndEffectorRole.HEAD)
        foot_z = ee[:, feet, 2]
        # Upright: at its tallest (95th percentile) the head is near the rest height above the feet.
        head_above = ee[:, head[0], 2] - foot_z.min(axis=1)
        assert 0.8 * length <= np.percentile(head_above, 95) <= 1.05 * length, m.name
        # Feet in stance (slower than 0.2 m/s) are on the ground.
        speed = np.linalg.norm(np.diff(ee[:, feet], axis=0), axis=-1) * m.fps
        stance = foot_z[1:][speed < 0.2]
        assert stance.size > 0, m.name
        assert np.median(stance) < 0.1, m.name
        stance_heights.append(np.median(stance))
    assert np.median(stance_heights) < 0.04


def _reference_ee(m: Motion) -> np.ndarray:
    """End-effector positions [T, E, 3] through the reference FK (world frame)."""
    import torch

    from morphkit.model import compile_model
    from morphkit.torch.reference import end_effectors_reference, fk_reference

    model = compile_model(m.morphology)
    with torch.no_grad():
        links = fk_reference(model, torch.tensor(np.array(m.q)))
        return end_effectors_reference(model, links)[..., :3].numpy()


def test_other_humans_and_dogs_stand_upright() -> None:
    for m in _load("second_skeleton")[::4]:
        top = np.percentile(reference_link_positions(m)[..., 2].max(axis=1), 95)
        assert 1.2 <= top <= 2.0, m.name
        assert m.morphology.root == "Hips"  # the translating joint_Root was folded away
    for m in _load("dog"):
        # Some dog clips lie down for half their length: judge the standing part.
        standing = m.q[:, 2] >= np.percentile(m.q[:, 2], 90)
        assert 0.35 <= np.median(m.q[standing, 2]) <= 0.8, m.name
        feet = _ee(m, EndEffectorRole.FOOT)
        assert len(feet) == 4
        if "stepup" not in m.name:  # those end on a raised step
            lowest = _reference_ee(m)[standing][:, feet, 2].min(axis=1)
            assert np.median(lowest) < 0.1, m.name


@pytest.mark.parametrize("key", list(FOLDERS))
def test_skeleton_reader_and_motion_reader_agree(key: str) -> None:
    """``read_bvh_skeleton(p)`` is the morphology of ``read_motion(p)`` for every clip: same
    links (Bandai Namco's static root folded away by both), coordinates, joint origins and
    end-effectors (front paws and facing decided the same way)."""
    motions = _load(key)
    for path, motion in zip(_files(key), motions, strict=True):
        skeleton, m = read_bvh_skeleton(path), motion.morphology
        assert skeleton.coordinate_names == m.coordinate_names, path.name
        assert skeleton.link_names == m.link_names, path.name
        for a, b in zip(skeleton.joints, m.joints, strict=True):
            np.testing.assert_allclose(a.origin.xyz, b.origin.xyz, atol=1e-12, err_msg=path.name)
        assert [(e.name, e.link, e.role) for e in skeleton.end_effectors] == [
            (e.name, e.link, e.role) for e in m.end_effectors
        ], path.name
        np.testing.assert_allclose(
            [e.offset for e in skeleton.end_effectors], [e.offset for e in m.end_effectors], atol=1e-12
        )
    if key == "second_skeleton":
        assert {m.morphology.root for m in motions} == {"Hips"}


def test_auto_facing_leaves_humans_unchanged() -> None:
    """Every human skeleton is read facing +z, as before ``facing="auto"``; CMU clips' q is identical."""
    for key in HUMANS:
        # Clips share skeleton objects: checking each distinct one covers every clip.
        for m in {id(x.morphology): x.morphology for x in _load(key)}.values():
            plus_z = read_bvh_skeleton(m.source, facing="+z")
            for a, b in zip(m.joints, plus_z.joints, strict=True):
                np.testing.assert_allclose(a.origin.xyz, b.origin.xyz, atol=1e-12, err_msg=m.source)
    for path, motion in list(zip(_files("cmu"), _load("cmu"), strict=True))[::16]:
        np.testing.assert_array_equal(read_bvh_motion(path, facing="+z").q, motion.q, err_msg=path.name)


def test_auto_facing_turns_the_dog_head_first() -> None:
    """The dog's head ends up ahead of its root along the root's +x, and its walks and runs move
    forwards, in every clip (``facing="auto"`` detects the root frame's -X; +X would walk it
    backwards)."""
    from morphkit.conventions import quat_rotate

    for m in _load("dog"):
        links = reference_link_positions(m)
        x_axis = quat_rotate(m.q[:, 3:7], np.broadcast_to([1.0, 0.0, 0.0], (m.frame_count, 3)))
        level = np.abs(x_axis[:, 2]) < 0.5  # sitting, the root's x points up and no heading exists
        heading = x_axis[:, :2] / np.linalg.norm(x_axis[:, :2], axis=1, keepdims=True)
        head = links[:, m.morphology.link_index("Head"), :2] - m.q[:, :2]
        ahead = np.einsum("fi,fi->f", head, heading)[level]
        assert (ahead > 0.15).mean() > 0.95 and np.median(ahead) > 0.3, m.name  # [m]
        if "walk" in m.name or "run" in m.name:
            step = np.diff(m.q[:, :2], axis=0)  # [T - 1, 2] world [m]
            moving = level[:-1] & (np.linalg.norm(step, axis=1) * m.fps > 0.3)
            forward = np.einsum("fi,fi->f", step[moving], heading[:-1][moving])
            # Mostly forwards: turning walks also sway sideways (dog_walk13: 79% of the path ahead).
            assert (forward > 0).mean() > 0.9, m.name
            assert forward.sum() > 0.75 * np.linalg.norm(step[moving], axis=1).sum(), m.name


def test_real_clip_round_trips(tmp_path: Path) -> None:
    for key in ("cmu",):
        m = _load(key)[0][:60]
        for suffix in (".bvh", ".npz", ".usda"):
            path = tmp_path / f"{key}{suffix}"
            write_motion(m, path)
            back = read_motion(path, ground=False) if suffix == ".bvh" else read_motion(path)
            np.testing.assert_allclose(reference_link_positions(back), m.link_positions(), atol=1e-5)


# ---- Spot vs CMU ---------------------------------------------------------------------------------
def _spot_trot(m, seconds: float = 6.0, fps: float = 30.0, seed: int = 0) -> Motion:
    """A deliberately simple synthetic Spot motion (the synthesis issue provides real ones): the
    base walks forward at standing height along a slowly turning heading, diagonal leg pairs swing
    in antiphase (hip pitch oscillating, knee flexing during swing) with small noise, and the arm
    wanders slowly around a carrying pose in front of the body."""
    from morphkit.motion import ground_motion

    rng = np.random.default_rng(seed)
    T = int(seconds * fps)
    t = np.arange(T) / fps
    q = np.tile(m.rest_q(), (T, 1))
    col = {n: i for i, n in enumerate(m.coordinate_names)}
    speed, freq = rng.uniform(0.3, 0.8), rng.uniform(1.5, 2.2)
    yaw = rng.uniform(-np.pi, np.pi) + np.cumsum(rng.normal(0.0, 0.01, T))
    q[:, 0] = np.cumsum(speed * np.cos(yaw)) / fps
    q[:, 1] = np.cumsum(speed * np.sin(yaw)) / fps
    q[:, 2] = 0.5
    q[:, 3:7] = quat_from_yaw(yaw)
    for leg, phase in (("fl", 0.0), ("hr", 0.0), ("fr", np.pi), ("hl", np.pi)):
        swing = 2 * np.pi * freq * t + phase
        q[:, col[f"{leg}_hx"]] = rng.normal(0.0, 0.05, T)
        q[:, col[f"{leg}_hy"]] = 0.8 + 0.25 * np.sin(swing) + rng.normal(0.0, 0.03, T)
        q[:, col[f"{leg}_kn"]] = -1.6 - 0.35 * np.maximum(0.0, np.cos(swing)) + rng.normal(0.0, 0.03, T)
    carry = {"arm_sh0": 0.0, "arm_sh1": -0.6, "arm_el0": 1.2, "arm_el1": 0.0, "arm_wr0": 0.2, "arm_wr1": 0.0,
             "arm_f1x": -0.5}
    for name, mean in carry.items():
        walk = np.cumsum(rng.normal(0.0, 1.0, T))
        q[:, col[name]] = mean + 0.3 * (walk - walk.mean()) / (walk.std() + 1e-9)
    lower, upper = m.coordinate_limits
    return ground_motion(Motion(m, fps, np.clip(q, lower, upper), f"spot_trot_{seed}"))


def test_spot_feet_map_to_human_feet_and_gripper_to_a_hand() -> None:
    spot_path = Path(__file__).resolve().parents[2] / "morphologies" / "spot" / "spot.urdf"
    if not spot_path.is_file():
        pytest.skip("morphologies/spot/spot.urdf is not there")
    from morphkit.io import read_morphology

    spot = read_morphology(spot_path)
    creature = ee_distributions([_spot_trot(spot, seed=s) for s in range(4)])
    human_motions = _load("cmu")[::4]
    human = ee_distributions(human_motions, max_frames_per_clip=300)
    result = map_end_effectors(creature, human)
    roles = {e.name: e.role for e in human_motions[0].morphology.end_effectors}
    for foot in ("fl_foot", "fr_foot", "hl_foot", "hr_foot"):
        assert roles[result.mapping[foot]] == EndEffectorRole.FOOT, result.format_table()
    # Left legs to the left foot, right legs to the right one (morphkit's +y is left for both).
    assert result.mapping["fl_foot"] == result.mapping["hl_foot"] != result.mapping["fr_foot"]
    assert roles[result.mapping["gripper"]] == EndEffectorRole.HAND, result.format_table()
