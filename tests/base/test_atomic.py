"""Atomic writes: all or nothing, and ordinary file permissions."""

import os
import stat

import pytest

from morphkit._atomic import atomic_path, atomic_write_text


def test_failed_write_leaves_the_old_file_and_no_temp(tmp_path):
    target = tmp_path / "motion.usda"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        assert tmp.suffix == ".usda" and tmp.parent == tmp_path
        tmp.write_text("half")
        raise RuntimeError("crash mid-write")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["motion.usda"]


def test_new_file_gets_umask_permissions_and_existing_keeps_its_own(tmp_path):
    old = os.umask(0o022)
    try:
        fresh = tmp_path / "a.yaml"
        atomic_write_text(fresh, "x")
        assert stat.S_IMODE(fresh.stat().st_mode) == 0o644
        kept = tmp_path / "b.yaml"
        kept.write_text("y")
        os.chmod(kept, 0o640)
        atomic_write_text(kept, "z")
        assert kept.read_text() == "z" and stat.S_IMODE(kept.stat().st_mode) == 0o640
    finally:
        os.umask(old)


def test_a_folder_that_refuses_new_files_is_named_by_the_target(tmp_path):
    """``convert`` into a read-only folder named its temporary file (``.clip.x1y2.usda``), not OUT."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    candidates = [folder, "/proc", "/sys"]  # root writes into a 0555 folder; /proc and /sys refuse it too
    for candidate in candidates:
        target = os.path.join(candidate, "clip.usda")
        try:
            with atomic_path(target) as tmp:
                tmp.write_text("x")
        except OSError as exc:
            assert exc.filename == target and str(exc).endswith(f": '{target}'"), exc
            assert not os.path.exists(target)
            return
        os.unlink(target)
    pytest.skip("no folder here refuses new files")
