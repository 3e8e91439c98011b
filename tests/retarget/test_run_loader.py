"""The method registry of ``morphkit.retarget.run_loader``: run folders are recognised by asking each method in turn."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

from morphkit.errors import RunError
from morphkit.retarget import run_loader
from morphkit.retarget.training_run import RunProgress


def test_every_method_is_registered_under_its_trainer_name_with_its_marker():
    from morphkit.retarget.ace.checkpoint import META_FILE as ACE_META
    from morphkit.retarget.nkn.checkpoint import META_FILE as NKN_META

    assert {name: m.name for name, m in run_loader.METHODS.items()} == {"ace": "ace", "nkn": "nkn"}
    assert (run_loader.METHODS["ace"].marker(), run_loader.METHODS["nkn"].marker()) == (ACE_META, NKN_META)


def test_method_of_names_the_method_whose_marker_a_folder_holds(tmp_path: Path):
    for name, method in run_loader.METHODS.items():
        folder = tmp_path / name
        folder.mkdir()
        (folder / method.marker()).write_text("{}\n")
        assert run_loader.method_of(folder) is method
    assert run_loader.method_of(tmp_path) is None


def test_a_registered_method_is_found_and_listed_without_changing_load(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch):
    run = tmp_path / "runs" / "toy_seed0"
    run.mkdir(parents=True)
    (run / "toy.yaml").write_text("trainer: toy\n")
    found = run_loader.TrainedRetargeter("Toy", run, run, None, RunProgress(2, 2, 0))
    checkpoint = types.ModuleType("toy_checkpoint")
    checkpoint.META_FILE = "toy.yaml"  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "toy_checkpoint", checkpoint)
    toy = run_loader.Method("toy", "a toy run folder", "toy_checkpoint",
                      lambda p, stage, device: pytest.fail("not opened here"), lambda p: [found])
    monkeypatch.setitem(run_loader.METHODS, "toy", toy)

    assert run_loader.method_of(run) is toy
    assert run_loader.trained_retargeters(run) == [found]
    assert run_loader.trained_retargeters(run.parent) == [found]  # a folder of runs asks every method
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(RunError, match=r"not an ACE run folder \(no .*\) nor an NKN run folder \(no .*\) nor a toy "
                                       r"run folder \(no toy\.yaml\)"):
        run_loader.load(empty)
