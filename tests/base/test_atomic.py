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
