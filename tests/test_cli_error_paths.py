"""Error paths the CLI can reach end as one line ``error: FILE: ...`` and exit 2: a full disk names the user's
file (never a temporary one), an allocation that fails, a checkpoint that does not fit its config."""

from __future__ import annotations

import argparse
import errno
from pathlib import Path

import numpy as np
import pytest
import torch
from morphkit_testing import spot_like

import morphkit.motion.io_npz as io_npz
from morphkit.cli import main, run_command
from morphkit.errors import RunError
from morphkit.motion import Motion, write_motion
from morphkit.retarget.checkpoint import load_checkpoint, load_module_state, save_checkpoint


def _clip(path: Path) -> Path:
    m = spot_like()
    write_motion(Motion(m, 30.0, np.tile(m.rest_q(), (4, 1)), "walk"), path)
    return path


def test_a_full_disk_names_the_output_file_not_a_temporary_one(tmp_path, monkeypatch, capsys):
    src = _clip(tmp_path / "walk.bvh")

    def full(*args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")  # as a write() on a full disk: no file name

    monkeypatch.setattr(io_npz.np, "savez", full)
    out = tmp_path / "out" / "walk.npz"
    assert main(["convert", str(src), str(out)]) == 2
    assert capsys.readouterr().err == f"error: {out}: No space left on device\n"
    assert list((tmp_path / "out").iterdir()) == []  # no temporary file left behind


def test_a_checkpoint_the_disk_cannot_take_is_an_oserror_naming_it(tmp_path, monkeypatch):
    def fails(*args: object, **kwargs: object) -> None:
        raise RuntimeError("[enforce fail at inline_container.cc:783] . PytorchStreamWriter failed writing file "
                           "data/0: file write failed")

    monkeypatch.setattr(torch, "save", fails)
    path = tmp_path / "checkpoint.pt"
    with pytest.raises(OSError, match="file write failed") as info:
        save_checkpoint(path, {"states": {}})
    assert info.value.filename == str(path) and list(tmp_path.iterdir()) == []


def test_an_allocation_that_fails_is_one_line(capsys):
    def huge(args: argparse.Namespace) -> int:
        raise MemoryError("Unable to allocate 70.0 GiB for an array with shape (100000000, 175)")

    assert run_command(huge, argparse.Namespace()) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: out of memory (Unable to allocate 70.0 GiB") and err.count("\n") == 1


def test_a_checkpoint_that_does_not_fit_its_config_names_the_file(tmp_path):
    path = tmp_path / "checkpoint.pt"
    trained = torch.nn.Sequential(torch.nn.Linear(3, 8), torch.nn.ELU(), torch.nn.Linear(8, 2))
    save_checkpoint(path, {"states": {"model": trained.state_dict()}})
    edited = torch.nn.Sequential(torch.nn.Linear(3, 16), torch.nn.ELU(), torch.nn.Linear(16, 2))  # hidden 8 -> 16
    with pytest.raises(RunError, match=r"size mismatch for 0\.weight") as info:
        load_module_state(edited, load_checkpoint(path)["states"]["model"], path=path, what="the generator")
    assert str(info.value).startswith(f"{path}: checkpoint state of the generator does not fit")
    assert "\n" not in str(info.value)
