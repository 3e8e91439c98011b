"""Folder manifests: readers of a folder read exactly the files its manifest lists."""

from __future__ import annotations

import json

import pytest

from morphkit.errors import MotionFormatError
from morphkit.motion.datasets import expand_motion_paths
from morphkit.motion.manifest import MANIFEST_NAME, manifest_files, read_manifest, write_manifest


def _touch(folder, *names):
    folder.mkdir(parents=True, exist_ok=True)
    for n in names:
        (folder / n).write_bytes(b"")


def test_a_folder_without_manifest_is_read_whole(tmp_path):
    _touch(tmp_path, "b.npz", "a.bvh", "notes.txt")
    _touch(tmp_path / "sub", "c.npz")
    assert expand_motion_paths(tmp_path) == [tmp_path / "a.bvh", tmp_path / "b.npz", tmp_path / "sub" / "c.npz"]
    assert manifest_files(tmp_path) is None


def test_the_manifest_decides_which_files_and_their_order(tmp_path):
    _touch(tmp_path, "r_0000.npz", "r_0001.npz", "r_0002.npz", "user.npz")
    write_manifest(tmp_path, ["r_0001.npz", "r_0000.npz"], complete=True, creature="x")
    assert expand_motion_paths(tmp_path) == [tmp_path / "r_0001.npz", tmp_path / "r_0000.npz"]
    assert read_manifest(tmp_path)["creature"] == "x"


def test_a_sub_folder_manifest_filters_only_its_own_files(tmp_path):
    _touch(tmp_path, "top.npz")
    _touch(tmp_path / "run", "new.npz", "stale.npz")
    write_manifest(tmp_path / "run", ["new.npz"], complete=True)
    assert expand_motion_paths(tmp_path) == [tmp_path / "run" / "new.npz", tmp_path / "top.npz"]


def test_unfinished_and_broken_manifests_are_errors(tmp_path):
    _touch(tmp_path, "a.npz")
    write_manifest(tmp_path, ["a.npz"], complete=False)
    with pytest.raises(MotionFormatError, match="has not finished") as e:
        expand_motion_paths(tmp_path)
    assert MANIFEST_NAME in str(e.value)
    write_manifest(tmp_path, ["a.npz", "gone.npz"], complete=True)
    with pytest.raises(MotionFormatError, match="missing file"):
        expand_motion_paths(tmp_path)
    write_manifest(tmp_path, ["../a.npz"], complete=True)
    with pytest.raises(MotionFormatError, match="not a path inside"):
        expand_motion_paths(tmp_path)


def test_someone_elses_manifest_json_is_ignored(tmp_path):
    _touch(tmp_path, "a.npz")
    (tmp_path / MANIFEST_NAME).write_text(json.dumps({"name": "my-package", "files": ["x"]}))
    assert read_manifest(tmp_path) is None
    assert expand_motion_paths(tmp_path) == [tmp_path / "a.npz"]
