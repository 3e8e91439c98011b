"""write_motion_files: one clip in every format (.npz, .bvh, USD, robot-command .csv), read back with the readers."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from _motion_compare import assert_q_close
from morphkit_testing import TEST_CREATURES, random_q

from morphkit.errors import MotionFormatError
from morphkit.motion import Motion, read_bvh_motion, read_motion, write_motion_files
from morphkit.motion._fk import compiled_model
from morphkit.motion.io_commands import arm_joints, robot_commands


@pytest.fixture
def motion() -> Motion:
    m = TEST_CREATURES["spot_like"]()
    return Motion(m, 30.0, random_q(compiled_model(m), 9, seed=2), "walk")


def test_every_format_reads_back_as_the_motion(motion: Motion, tmp_path: Path):
    stem = tmp_path / "clips" / "walk"  # the folder does not exist yet
    paths = write_motion_files(motion, stem)
    assert paths == [tmp_path / "clips" / f"walk{s}" for s in (".npz", ".bvh", ".csv")]
    assert sorted(p.name for p in (tmp_path / "clips").iterdir()) == ["walk.bvh", "walk.csv", "walk.npz"]
    m = motion.morphology
    npz = read_motion(paths[0])
    np.testing.assert_allclose(npz.q, motion.q, atol=1e-6, rtol=0)
    assert npz.fps == motion.fps and npz.name == "walk"
    assert_q_close(m, read_bvh_motion(paths[1], morphology=m).q, motion.q, atol=1e-6)

    with paths[2].open(newline="") as f:
        header, *rows = list(csv.reader(f))
    columns, expected = robot_commands(motion)
    assert header == columns and header[:7] == ["time", "vx", "vy", "yaw_rate", "height", "pitch", "roll"]
    assert header[7:] == list(arm_joints(m)) and len(header) > 7  # spot_like's arm
    assert len(rows) == motion.frame_count
    np.testing.assert_allclose(np.array(rows, dtype=float), expected, rtol=1e-5, atol=1e-9)  # 6 significant digits


def test_formats_without_a_dot_usd_and_an_unknown_one(motion: Motion, tmp_path: Path):
    pytest.importorskip("pxr")
    paths = write_motion_files(motion, tmp_path / "walk", ("npz", "usda"))
    assert paths == [tmp_path / "walk.npz", tmp_path / "walk.usda"]
    assert_q_close(motion.morphology, read_motion(paths[1]).q, motion.q, atol=1e-6)
    # An unknown format is refused before anything is written.
    with pytest.raises(MotionFormatError, match=r"cannot write '\.txt' files; supported: .*\.csv"):
        write_motion_files(motion, tmp_path / "other", (".npz", ".txt"))
    assert not list(tmp_path.glob("other*"))
