"""A run's ``start_states.npz`` is read as numbers only: a pickled (object) array, a missing array or a bad shape
is one line naming the file, from the library and from ``morphkit retarget``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import spot_like

from morphkit.cli import main
from morphkit.errors import RunError
from morphkit.motion import Motion, NormStats, Pairing, write_motion
from morphkit.retarget.ace.checkpoint import AceArtifact
from morphkit.retarget.training_data import DataConfig


def _run(folder: Path) -> Path:
    """A minimal ACE run folder (no networks): enough for :meth:`AceArtifact.load`."""
    AceArtifact(
        creature=spot_like(), character_stats=NormStats(np.zeros(3), np.ones(3)),
        human_stats=NormStats(np.zeros(3), np.ones(3)), pairing=Pairing.from_mapping({"fl_foot": "lfoot"}, 1.0, 1.0),
        mapping={"mapping": {"fl_foot": "lfoot"}}, start_states=np.arange(6.0).reshape(2, 3),
        start_psi=np.zeros((2, 14)), data=DataConfig(), human_data=None, human_skeleton="test",
    ).save(folder)
    return folder


def test_a_good_run_reads_its_start_states(tmp_path: Path):
    art = AceArtifact.load(_run(tmp_path / "run"))
    assert np.array_equal(art.start_states, np.arange(6.0).reshape(2, 3)) and art.start_psi.shape == (2, 14)


@pytest.mark.parametrize(("arrays", "words"), [
    ({"states": np.array([{"x": 1}, None], dtype=object), "psi": np.zeros((2, 14))}, "holds pickled Python objects"),
    ({"states": np.zeros((2, 3))}, "no array 'psi'"),
    ({"states": np.zeros(3), "psi": np.zeros((2, 14))}, "'states' must be a 2-D array of finite numbers"),
    ({"states": np.array([["a", "b"]]), "psi": np.zeros((1, 14))}, "'states' must be a 2-D array"),
    ({"states": np.zeros((2, 3)), "psi": np.zeros((3, 14))}, "2 states but 3 psi rows"),
])
def test_damaged_start_states_are_a_run_error_naming_the_file(tmp_path: Path, arrays: dict, words: str):
    run = _run(tmp_path / "run")
    np.savez(run / "start_states.npz", **arrays)
    with pytest.raises(RunError, match=words) as info:
        AceArtifact.load(run)
    assert info.value.location is not None and info.value.location.path == str(run / "start_states.npz")


def test_a_file_that_is_no_npz_is_a_run_error(tmp_path: Path):
    run = _run(tmp_path / "run")
    (run / "start_states.npz").write_bytes(b"\x80\x04K\x01.")  # a pickle, not an NPZ
    with pytest.raises(RunError, match="damaged start states: it holds pickled Python objects; morphkit reads numbers"):
        AceArtifact.load(run)
    with open(run / "start_states.npz", "wb") as f:
        np.save(f, np.zeros((2, 3)))  # one bare array
    with pytest.raises(RunError, match="not an NPZ archive"):
        AceArtifact.load(run)


def test_the_cli_says_one_line_and_exits_2(tmp_path: Path, capsys):
    run = _run(tmp_path / "run")
    np.savez(run / "start_states.npz", states=np.array([object()] * 2, dtype=object), psi=np.zeros((2, 14)))
    m = spot_like()
    clip = tmp_path / "walk.npz"
    write_motion(Motion(m, 30.0, np.tile(m.rest_q(), (4, 1)), "walk"), clip)
    code = main(["retarget", "--run", str(run), "--motion", str(clip), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"error: {run / 'start_states.npz'}: damaged start states: it holds pickled") \
        and err.count("\n") == 1
    assert not (tmp_path / "out").exists()
