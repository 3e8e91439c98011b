"""The canonical human: convention tables map clips exactly, a round trip (map, write, read) keeps world joint
positions, unknown names fall back to the skeleton's shape with a warning, a dog is refused naming what it
lacks, the human state's size no longer depends on the clip's skeleton, and (with ``MORPHKIT_DATA``) the
same CMU trials in two conventions agree on the canonical human."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from _bvh_creature import creature_bvh
from _human_bvh import CMU22, canonical_clip, renamed_bvh

from morphkit.errors import ConfigError, MotionFormatError
from morphkit.motion import (
    Motion,
    canonical_human,
    canonical_record,
    human_state_from_motion,
    human_state_layout,
    read_canonical_motion,
    read_motion,
    read_skeleton_map,
    skeleton_maps,
    to_canonical,
    write_motion,
)
from morphkit.motion.canonical import find_skeleton_map, map_skeleton_motion, thigh_shank_length
from morphkit.rotations import heading_frame, quat_rotate_inverse

DATA = Path(os.environ["MORPHKIT_DATA"]) if os.environ.get("MORPHKIT_DATA") else None
SCALED = {"LeftLeg": 0.9, "RightLeg": 0.9, "LeftFoot": 0.92, "RightFoot": 0.92, "Spine1": 1.2, "LeftForeArm": 1.1,
          "RightForeArm": 1.1, "Neck": 0.8}
"""Other proportions: shorter legs, a longer trunk and upper arms, a shorter neck."""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_tables_name_every_canonical_link_and_the_canonical_human_passes_unchanged():
    c = canonical_human()
    tables = {t.name: t for t in skeleton_maps()}
    assert set(tables) == {"cmu22", "cmu_daz43", "bandai_namco", "mixamo", "lafan1"}
    for t in tables.values():
        assert list(t.links) == list(c.link_names) or set(t.links) == set(c.link_names)
    clip = canonical_clip(frames=5)
    assert to_canonical(clip) is clip
    assert canonical_record() == {"skeleton": "human", "height": 1.75, "leg_length": 0.84}
    assert human_state_layout(c).dim == 104


def test_thigh_shank_length_is_hip_to_knee_to_ankle_without_the_foot():
    """The length clips are scaled by: thigh + shank between the rest joints, mean of both sides; shorter than
    Morphology.leg_length, which runs on to the foot point."""
    c = canonical_human()
    at = c.rest_link_poses()[:, :3]
    by_hand = np.mean([np.linalg.norm(at[c.link_index(f"{s}Leg")] - at[c.link_index(f"{s}UpLeg")])
                       + np.linalg.norm(at[c.link_index(f"{s}Foot")] - at[c.link_index(f"{s}Leg")])
                       for s in ("Left", "Right")])
    assert thigh_shank_length(c) == pytest.approx(by_hand, abs=1e-12)
    assert round(by_hand, 4) == canonical_record()["leg_length"]
    assert thigh_shank_length(c) < c.leg_length


def test_a_renamed_clip_maps_back_onto_the_same_world_joints(tmp_path):
    clip = canonical_clip()
    src = read_motion(_write(tmp_path, "cmu.bvh", renamed_bvh(clip, CMU22)))
    assert find_skeleton_map(src.morphology, canonical_human()).name == "cmu22"
    mapped = to_canonical(src)
    assert mapped.morphology is canonical_human() and mapped.fps == clip.fps and mapped.name == "cmu"
    np.testing.assert_allclose(mapped.link_positions(), clip.link_positions(), atol=1e-6)
    np.testing.assert_allclose(mapped.end_effector_positions(), clip.end_effector_positions(), atol=1e-6)


def test_round_trip_map_write_read_keeps_world_joint_positions_within_1mm(tmp_path):
    src = read_motion(_write(tmp_path, "cmu.bvh", renamed_bvh(canonical_clip(), CMU22, bone_scale=SCALED)))
    table = find_skeleton_map(src.morphology, canonical_human())
    # Step 1 (the table re-expresses the clip on the canonical topology): every joint where the source's is.
    on_topology = map_skeleton_motion(src, canonical_human(), table, skeleton_name="cmu_mapped")
    names = [table.links[n] for n in canonical_human().link_names]
    np.testing.assert_allclose(on_topology.link_positions(),
                               src.link_positions()[:, [src.morphology.link_index(n) for n in names]], atol=1e-9)
    # Step 2 (canonical proportions), written and read back: the same world joints.
    mapped = to_canonical(src)
    write_motion(mapped, tmp_path / "canonical.bvh")
    back = to_canonical(read_motion(tmp_path / "canonical.bvh"))
    assert np.abs(back.link_positions() - mapped.link_positions()).max() < 1e-3
    assert np.abs(back.end_effector_positions() - mapped.end_effector_positions()).max() < 1e-3
    # Scaled by leg length: the shorter-legged clip's root travels further once on the canonical legs.
    assert np.ptp(mapped.root_pose()[:, 0]) == pytest.approx(np.ptp(canonical_clip().root_pose()[:, 0]), rel=0.02)


@pytest.mark.parametrize(("table", "rename"), [
    ("mixamo", lambda n: f"mixamorig:{n}"),
    ("lafan1", lambda n: n.replace("ToeBase", "Toe")),
])
def test_mixamo_namespaces_and_lafan1_names_are_known(tmp_path, table, rename):
    clip = canonical_clip(frames=10)
    names = {n: rename(n) for n in canonical_human().link_names}
    src = read_motion(_write(tmp_path, "x.bvh", renamed_bvh(clip, names)))
    assert find_skeleton_map(src.morphology, canonical_human()).name == table
    np.testing.assert_allclose(to_canonical(src).link_positions(), clip.link_positions(), atol=1e-6)


def test_unknown_names_fall_back_to_the_shape_with_a_warning_listing_the_guesses(tmp_path):
    clip = canonical_clip()
    names = {n: f"j{i:02d}" for i, n in enumerate(canonical_human().link_names)}
    src = read_motion(_write(tmp_path, "odd.bvh", renamed_bvh(clip, names)), facing="+z")
    with pytest.warns(UserWarning, match="guessed from the skeleton's shape: Hips=j00") as record:
        mapped = to_canonical(src)
    message = str(record[0].message)
    for link, joint in names.items():
        assert f"{link}={joint}" in message
    np.testing.assert_allclose(mapped.link_positions(), clip.link_positions(), atol=1e-6)


def test_a_dog_is_refused_with_one_error_naming_what_is_missing(tmp_path, capsys):
    path = _write(tmp_path, "dog.bvh", creature_bvh(fore="ForeFoot", fore_length=40.0))
    dog = read_motion(path)
    with pytest.raises(MotionFormatError, match="clip 'dog' cannot be mapped onto the canonical human") as info:
        to_canonical(dog)
    assert "no two arms" in str(info.value)
    with pytest.raises(MotionFormatError, match="no two arms") as info:
        read_canonical_motion(path)
    assert info.value.location.path == str(path)
    from morphkit.cli import main

    assert main(["convert", str(path), str(tmp_path / "out.bvh"), "--canonical"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: ") and "no two arms" in err and "Traceback" not in err
    assert not (tmp_path / "out.bvh").exists()


def test_the_human_state_size_does_not_depend_on_the_clip_skeleton(tmp_path):
    dim = human_state_layout(canonical_human()).dim
    clip = canonical_clip(frames=12)
    odd = {n: f"bone{i}" for i, n in enumerate(canonical_human().link_names)}
    sources = [read_motion(_write(tmp_path, "a.bvh", renamed_bvh(clip, CMU22, bone_scale=SCALED))),
               read_motion(_write(tmp_path, "b.bvh", renamed_bvh(clip, bone_scale={"Spine": 1.3}))),
               read_motion(_write(tmp_path, "c.bvh", renamed_bvh(clip, odd)), facing="+z")]
    if DATA is not None:
        root = DATA / "human"
        sources += [read_motion(root / "cmu" / "05_01.bvh").slice(0, 20),
                    read_motion(root / "cmu_daz" / "cmu_05_01.bvh").slice(0, 20),
                    read_motion(sorted((root / "second_skeleton").glob("*.bvh"))[0]).slice(0, 20)]
    with pytest.warns(UserWarning, match="guessed"):
        states = [human_state_from_motion(to_canonical(s)) for s in sources]
    assert {s.shape[1] for s in states} == {dim}
    assert {s.morphology.link_count for s in sources} == ({21, 22, 43} if DATA is not None else {22})


def test_a_user_table_maps_a_new_convention_and_a_bad_one_is_refused_at_its_line(tmp_path):
    clip = canonical_clip(frames=10)
    mine = {n: f"my_{n.lower()}" for n in canonical_human().link_names}
    src = read_motion(_write(tmp_path, "mine.bvh", renamed_bvh(clip, mine)), facing="+z")
    table = _write(tmp_path, "mine.yaml", "name: mine\nlinks:\n" + "".join(f"  {k}: {v}\n" for k, v in mine.items()))
    user = read_skeleton_map(table)
    np.testing.assert_allclose(to_canonical(src, maps=[user]).link_positions(), clip.link_positions(), atol=1e-6)
    bad = _write(tmp_path, "bad.yaml", "name: bad\nlinks:\n  Hips: root\n  Spine: [a, b, 2]\n")
    with pytest.raises(ConfigError, match=r"link 'Spine': expected a source name or \[a, b, w\]") as info:
        read_skeleton_map(bad)
    assert info.value.location.line == 4
    with pytest.raises(ConfigError, match="unknown key"):
        read_skeleton_map(_write(tmp_path, "worse.yaml", "links: {Hips: root}\nunits: cm\n"))


def test_convert_canonical_writes_the_mapped_clip_and_never_over_its_input(tmp_path, capsys):
    from morphkit.cli import main

    clip = canonical_clip(frames=10)
    src = _write(tmp_path, "cmu.bvh", renamed_bvh(clip, CMU22))
    assert main(["convert", str(src), str(tmp_path / "canonical.bvh"), "--canonical"]) == 0
    back = read_motion(tmp_path / "canonical.bvh")
    assert back.morphology.link_names == canonical_human().link_names
    np.testing.assert_allclose(to_canonical(back).link_positions(), clip.link_positions(), atol=1e-6)
    before = src.read_bytes()
    assert main(["convert", str(src), str(src), "--canonical"]) == 2
    assert "OUT is IN" in capsys.readouterr().err and src.read_bytes() == before


# ---------------------------------------------------------------------------------------------
# the real data: one performance in two conventions
# ---------------------------------------------------------------------------------------------
TRIALS = ("05_01", "06_01", "07_03", "08_08", "13_32")
needs_data = pytest.mark.skipif(DATA is None or not (DATA / "human" / "cmu_daz").is_dir(),
                                reason="MORPHKIT_DATA is not set (or has no human/cmu_daz)")


def _local(motion: Motion) -> np.ndarray:
    """End-effectors in the root's heading frame [T, E, 3], what the human state holds."""
    h = heading_frame(motion.root_pose())
    return quat_rotate_inverse(h[:, None, 3:], motion.end_effector_positions() - h[:, None, :3])


def pair_errors(trial: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Mean distances [m] between the canonical CMU-22 clip and the canonical Daz clip of ``trial``: per
    end-effector in the world (after the best yaw and translation of the ground plane and the best lag
    within ±1/30 s) and in the root's heading frame, and the root's."""
    assert DATA is not None
    a = to_canonical(read_motion(DATA / "human" / "cmu" / f"{trial}.bvh"))
    b = to_canonical(read_motion(DATA / "human" / "cmu_daz" / f"cmu_{trial}.bvh").slice(1))  # frame 0: T-pose
    best = None
    for lag in range(-4, 5):
        times = np.arange(a.frame_count) / a.fps + lag / b.fps
        ok = (times >= 0) & (times <= b.duration)
        bb = Motion(b.morphology, a.fps, b.sample(times[ok]))
        pa, pb = a.root_pose()[ok, :2], bb.root_pose()[:, :2]
        H = (pb - pb.mean(0)).T @ (pa - pa.mean(0))
        U, _, Vt = np.linalg.svd(H)
        R = Vt.T @ np.diag([1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
        shift = pa.mean(0) - pb.mean(0) @ R.T
        ea, eb = a.end_effector_positions()[ok], bb.end_effector_positions().copy()
        eb[..., :2] = eb[..., :2] @ R.T + shift
        world = np.linalg.norm(ea - eb, axis=-1).mean(0)
        if best is None or world.mean() < best[0].mean():
            local = np.linalg.norm(_local(a)[ok] - _local(bb), axis=-1).mean(0)
            root = float(np.linalg.norm(pa - (pb @ R.T + shift), axis=-1).mean())
            best = (world, local, root)
    assert best is not None
    return best


@needs_data
def test_one_performance_in_two_conventions_agrees_on_the_canonical_human():
    """The five CMU trials in CMU-22 (AMASS fits, 30 fps) and in the Daz-friendly conversion (120 fps).

    Measured (mean over the trials, cm; ee order head, hands, feet): world 6.9, 12.5, 12.9, 7.3, 7.0, root
    5.1; in the root's heading frame 4.0, 11.1, 10.7, 5.3, 4.7. The issue's target (3 cm) is missed
    because the two conventions are two different fits of the markers, not because of the mapping (which
    is exact, see above): before any mapping their knee angles differ by 12-16 degrees on average, their
    collar bones by 25, and their joint centres relative to the hips by 5-14 cm (scaled by leg length);
    the Daz files share one figure for every subject, so their paths scale differently (root 5 cm).
    These bounds guard the measured values against regressions.
    """
    rows = np.array([np.concatenate([w, loc, [root]]) for w, loc, root in map(pair_errors, TRIALS)]).mean(0)
    world, local, root = rows[:5], rows[5:10], rows[10]
    names = [e.name for e in canonical_human().end_effectors]
    assert names == ["head", "left_hand", "right_hand", "left_foot", "right_foot"]
    assert world[0] < 0.09 and world[1:3].max() < 0.15 and world[3:].max() < 0.09 and root < 0.07
    assert local[0] < 0.06 and local[1:3].max() < 0.13 and local[3:].max() < 0.07


@needs_data
def test_a_bandai_namco_clip_stands_on_level_feet():
    """Bandai's rest pose is not a T-pose: without the fitted twist its feet would roll sideways."""
    from morphkit.rotations import quat_rotate

    assert DATA is not None
    path = sorted((DATA / "human" / "second_skeleton").glob("*walk*.bvh"))[0]
    clip = to_canonical(read_motion(path))
    poses = clip.link_poses()
    c = canonical_human()
    for foot in ("LeftFoot", "RightFoot"):
        q = poses[:, c.link_index(foot), 3:]
        up = quat_rotate(q, np.broadcast_to([0.0, 0.0, 1.0], (len(q), 3)))[:, 2]
        side = quat_rotate(q, np.broadcast_to([0.0, 1.0, 0.0], (len(q), 3)))[:, 2]
        assert up.mean() > 0.7 and abs(side.mean()) < 0.1
    assert clip.end_effector_positions()[..., 2].min() == pytest.approx(0.0, abs=1e-9)
