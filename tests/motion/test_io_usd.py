"""USD motion files: write -> read round trips to 1e-5, with and without the stored coordinates."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _motion_compare import assert_q_close, reference_link_positions
from morphkit_testing import TEST_CREATURES, random_q

from morphkit.errors import MotionFormatError
from morphkit.motion import Motion, read_motion, write_motion
from morphkit.motion._fk import compiled_model
from morphkit.motion.io_usd import q_from_link_poses, read_usd_motion, write_usd_motion

pytest.importorskip("pxr")


@pytest.mark.parametrize("name", ["every_joint_floating", "every_joint_planar", "wheeled", "mimic", "spot_like"])
@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_usd_write_read_round_trip(name: str, suffix: str, tmp_path: Path) -> None:
    m = TEST_CREATURES[name]()
    motion = Motion(m, 25.0, random_q(compiled_model(m), 9, seed=2), f"{name}_clip")
    path = tmp_path / f"motion{suffix}"
    write_motion(motion, path)
    back = read_motion(path)
    assert back.fps == 25.0 and back.frame_count == 9 and back.name == f"{name}_clip"
    assert back.morphology.coordinate_names == m.coordinate_names
    assert_q_close(m, back.q, motion.q, atol=1e-5)
    np.testing.assert_allclose(reference_link_positions(back), reference_link_positions(motion), atol=1e-5)


@pytest.mark.parametrize("name", ["every_joint_floating", "wheeled", "spot_like"])
def test_usd_motion_from_link_transforms_alone(name: str, tmp_path: Path) -> None:
    """Remove the stored coordinates: q comes back from the time-sampled link transforms."""
    from pxr import Usd

    m = TEST_CREATURES[name]()
    motion = Motion(m, 30.0, random_q(compiled_model(m), 6, seed=4), name)
    path = tmp_path / "m.usda"
    write_usd_motion(motion, path)
    stage = Usd.Stage.Open(str(path))
    stage.GetDefaultPrim().RemoveProperty("morphkit:motion:q")
    stage.GetRootLayer().Save()
    back = read_usd_motion(path)
    np.testing.assert_allclose(reference_link_positions(back), reference_link_positions(motion), atol=1e-5)
    text = path.read_text()
    assert "timeSamples" in text and "timeCodesPerSecond = 30" in text


def test_q_from_link_poses_inverts_fk() -> None:
    m = TEST_CREATURES["every_joint_fixed"]()
    motion = Motion(m, 30.0, random_q(compiled_model(m), 20, seed=9))
    q = q_from_link_poses(m, motion.link_poses())
    assert_q_close(m, q, motion.q, atol=1e-9)


def test_usd_errors(tmp_path: Path) -> None:
    m = TEST_CREATURES["planar_arm"]()
    motion = Motion(m, 30.0, np.zeros((2, m.coordinate_count)))
    with pytest.raises(MotionFormatError, match="suffix"):
        write_usd_motion(motion, tmp_path / "x.txt")
    from morphkit.io.usd import write_usd

    write_usd(m, tmp_path / "still.usda")
    with pytest.raises(MotionFormatError, match="no motion"):
        read_usd_motion(tmp_path / "still.usda")


def test_usd_skel_view_reproduces_the_link_poses(tmp_path: Path) -> None:
    from pxr import Usd, UsdSkel

    m = TEST_CREATURES["spot_like"]()
    motion = Motion(m, 30.0, random_q(compiled_model(m), 4, seed=6), "skel")
    path = tmp_path / "skel.usda"
    write_usd_motion(motion, path)
    stage = Usd.Stage.Open(str(path))
    cache = UsdSkel.Cache()
    root = UsdSkel.Root(stage.GetPrimAtPath(f"/{m.name}_skel"))
    cache.Populate(root, Usd.PrimDefaultPredicate)
    query = cache.GetSkelQuery(UsdSkel.Skeleton(stage.GetPrimAtPath(f"/{m.name}_skel/Skeleton")))
    assert query
    poses = motion.link_poses()
    for t in range(motion.frame_count):
        mats = query.ComputeJointSkelTransforms(t)
        pos = np.array([[mat.ExtractTranslation()[k] for k in range(3)] for mat in mats])
        np.testing.assert_allclose(pos, poses[t, :, :3], atol=1e-5)
    # The articulation reads back unchanged next to the skeleton.
    assert read_usd_motion(path).morphology.link_names == m.link_names


def test_is_motion_file(tmp_path: Path) -> None:
    from morphkit.io.usd import write_usd
    from morphkit.motion import is_motion_file

    m = TEST_CREATURES["planar_arm"]()
    motion = Motion(m, 30.0, np.zeros((3, m.coordinate_count)))
    for suffix in (".usda", ".npz", ".bvh"):
        write_motion(motion, tmp_path / f"m{suffix}")
        assert is_motion_file(tmp_path / f"m{suffix}"), suffix
    write_usd(m, tmp_path / "d.usda")
    assert not is_motion_file(tmp_path / "d.usda")
    assert not is_motion_file(tmp_path / "missing.bvh")
    (tmp_path / "junk.usda").write_text("not usd")
    assert not is_motion_file(tmp_path / "junk.usda")
