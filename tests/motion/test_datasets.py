"""Cached loading by content and name hash and the windowed state dataset."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from morphkit_testing import spot_like

import morphkit.motion as motion_pkg
from morphkit.errors import ConfigError, MotionFormatError
from morphkit.motion import Motion, NormStats, character_state_from_motion, write_motion
from morphkit.motion.datasets import MotionDataset, expand_motion_paths, load_motions


def _clips(tmp_path: Path) -> list[Path]:
    m = spot_like()
    rng = np.random.default_rng(0)
    paths = []
    for k, frames in enumerate((12, 7, 3)):
        q = np.tile(m.rest_q(), (frames, 1))
        q[:, 0] = np.linspace(0.0, 1.0, frames)
        q[:, 7:] += rng.normal(0.0, 0.1, (frames, m.coordinate_count - 7))
        path = tmp_path / "data" / f"clip{k}.bvh"
        path.parent.mkdir(exist_ok=True)
        write_motion(Motion(m, 30.0, q, f"clip{k}"), path)
        paths.append(path)
    return paths


def test_load_motions_caches_by_content(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    paths = _clips(tmp_path)
    cache = tmp_path / "cache"
    first = load_motions(tmp_path / "data", cache_dir=cache, morphology=spot_like())
    assert [m.name for m in first] == ["clip0", "clip1", "clip2"]
    assert len(list(cache.glob("*.npz"))) == 3

    def no_parsing(*args: object, **kwargs: object) -> None:
        raise AssertionError("a cached clip was parsed again")

    monkeypatch.setattr(motion_pkg, "read_motion", no_parsing)
    # A moved copy (same name, same content): still a cache hit.
    (tmp_path / "moved").mkdir()
    shutil.copy(paths[0], tmp_path / "moved" / "clip0.bvh")
    moved = load_motions(tmp_path / "moved", cache_dir=cache, morphology=spot_like())
    assert moved[0].name == "clip0"
    np.testing.assert_array_equal(moved[0].q, first[0].q)
    monkeypatch.undo()
    # A renamed copy has the same content but its own name: its own entry, not clip0's name.
    shutil.copy(paths[0], tmp_path / "data" / "renamed.bvh")
    again = load_motions(expand_motion_paths(tmp_path / "data"), cache_dir=cache, morphology=spot_like())
    assert [m.name for m in again] == ["clip0", "clip1", "clip2", "renamed"]
    np.testing.assert_array_equal(again[3].q, first[0].q)
    assert len(list(cache.glob("*.npz"))) == 4
    # Other options are another key.
    load_motions(paths[0], cache_dir=cache, morphology=spot_like(), fps=15.0)
    assert len(list(cache.glob("*.npz"))) == 5
    with pytest.raises(MotionFormatError, match="no such"):
        load_motions(tmp_path / "nope", cache_dir=cache)


def test_windowed_dataset(tmp_path: Path) -> None:
    paths = _clips(tmp_path)
    ds = MotionDataset.from_files(paths, window=4, stride=2, kind="character", cache_dir=tmp_path / "c",
                                  morphology=spot_like())
    # 12 frames -> starts 0, 2, 4, 6, 8; 7 frames -> 0, 2; 3 frames -> none.
    assert len(ds) == 7
    item = ds[5]
    assert item["clip"] == 1 and item["start"] == 0
    assert item["state"].shape == (4, ds.layout.dim) and item["state"].dtype == torch.float32
    raw = character_state_from_motion(ds.motions[1])[0:4]
    np.testing.assert_allclose(ds.stats.denormalize(item["state"].double().numpy()), raw, atol=1e-5)
    # What NKN needs beside the states: coordinates, root poses and the clip's bone offsets.
    np.testing.assert_allclose(item["q"].numpy(), ds.motions[1].q[0:4], atol=1e-6)
    np.testing.assert_allclose(item["root_pose"].numpy(), ds.motions[1].root_pose()[0:4], atol=1e-6)
    m = ds.motions[1].morphology
    assert item["offsets"].shape == (m.joint_count, 3)
    np.testing.assert_allclose(item["offsets"][m.joint_index("fl_hx")].numpy(), m.joint("fl_hx").origin.xyz, atol=1e-7)
    allx = np.concatenate(ds.states)
    np.testing.assert_allclose(ds.stats.mean, allx.mean(0))
    loader = torch.utils.data.DataLoader(ds, batch_size=3, shuffle=False)
    batch = next(iter(loader))
    assert batch["state"].shape == (3, 4, ds.layout.dim)
    # Cached states are reused, and given statistics are kept (a validation set).
    again = MotionDataset.from_files(paths, window=2, kind="character", cache_dir=tmp_path / "c", stats=ds.stats,
                                     morphology=spot_like())
    assert again.stats is ds.stats
    np.testing.assert_allclose(again.states[0], ds.states[0])
    human = MotionDataset(ds.motions, window=1, kind="human")
    assert human.layout.kind == "human" and len(human) == 22
    ds.save_stats(tmp_path / "stats.npz")
    np.testing.assert_array_equal(NormStats.load(tmp_path / "stats.npz").std, ds.stats.std)


def test_dataset_rejects_bad_configuration(tmp_path: Path) -> None:
    m = spot_like()
    clip = Motion(m, 30.0, np.tile(m.rest_q(), (5, 1)))
    with pytest.raises(ConfigError, match="kind"):
        MotionDataset([clip], window=2, kind="robot")
    with pytest.raises(ConfigError, match="window"):
        MotionDataset([clip], window=0)
    with pytest.raises(ConfigError, match="at least one"):
        MotionDataset([], window=2)
    with pytest.raises(ConfigError, match="dimension"):
        MotionDataset([clip], window=2, stats=NormStats(np.zeros(3), np.ones(3)))
