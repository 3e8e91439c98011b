"""NPZ motion files: exact round trip, self-contained morphology, located errors, read/write dispatch."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _motion_compare import reference_link_positions
from morphkit_testing import TEST_CREATURES, random_q

from morphkit.errors import MotionFormatError
from morphkit.motion import Motion, read_motion, read_npz_motion, write_motion, write_npz_motion
from morphkit.motion._fk import compiled_model
from morphkit.motion.io_npz import read_npz_motion_with_extra


@pytest.mark.parametrize("name", ["every_joint_floating", "wheeled", "mimic", "spot_like"])
def test_npz_round_trip_is_exact(name: str, tmp_path: Path) -> None:
    m = TEST_CREATURES[name]()
    motion = Motion(m, 50.0, random_q(compiled_model(m), 7, seed=1), f"clip_{name}")
    path = tmp_path / "m.npz"
    write_motion(motion, path)
    back = read_motion(path)
    np.testing.assert_array_equal(back.q, motion.q)
    assert back.fps == 50.0 and back.name == f"clip_{name}"
    assert back.morphology.link_names == m.link_names
    assert back.morphology.coordinate_names == m.coordinate_names
    assert [e.name for e in back.morphology.end_effectors] == [e.name for e in m.end_effectors]
    np.testing.assert_allclose(reference_link_positions(back), reference_link_positions(motion), atol=1e-9)
    assert read_motion(path, fps=25.0).frame_count == 4


def test_npz_extra_arrays_and_errors(tmp_path: Path) -> None:
    m = TEST_CREATURES["planar_arm"]()
    motion = Motion(m, 30.0, np.zeros((3, m.coordinate_count)))
    path = tmp_path / "x.npz"
    write_npz_motion(motion, path, states=np.ones((3, 5)))
    back, extra = read_npz_motion_with_extra(path)
    np.testing.assert_array_equal(back.q, motion.q)
    np.testing.assert_array_equal(extra["states"], np.ones((3, 5)))
    with pytest.raises(MotionFormatError, match="reserved"):
        write_npz_motion(motion, path, q=np.zeros(1))

    bad = tmp_path / "bad.npz"
    np.savez(bad, q=np.zeros((2, 2)))
    with pytest.raises(MotionFormatError, match="missing fps, morphology_yaml") as err:
        read_npz_motion(bad)
    assert err.value.location.path == str(bad)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(MotionFormatError, match="readable"):
        read_npz_motion(junk)
    with pytest.raises(MotionFormatError, match="unknown motion format"):
        read_motion(tmp_path / "x.txt")
    with pytest.raises(MotionFormatError, match="not found"):
        read_motion(tmp_path / "missing.npz")
    with pytest.raises(MotionFormatError, match="cannot write"):
        write_motion(motion, tmp_path / "x.txt")
