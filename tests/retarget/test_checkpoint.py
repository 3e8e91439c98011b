"""Checkpoint files: safe loading, clear errors for truncated and foreign files, every RNG restored."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
import torch

from morphkit.errors import RunError
from morphkit.retarget.checkpoint import load_checkpoint, rng_state, save_checkpoint, set_rng_state


class _Pickled:
    """An arbitrary object: a weights_only load must refuse it."""


def _payload() -> dict:
    model = torch.nn.Linear(3, 2)
    opt = torch.optim.Adam(model.parameters())
    model(torch.ones(1, 3)).sum().backward()
    opt.step()
    return {"states": {"model": model.state_dict(), "optimizer": opt.state_dict()}, "rng": [rng_state()]}


def test_save_load_round_trip_is_weights_only(tmp_path: Path):
    """A checkpoint with model, optimiser and RNG states loads with torch.load(weights_only=True)."""
    path = save_checkpoint(tmp_path / "ck.pt", _payload())
    raw = torch.load(path, weights_only=True)
    assert raw["format"] == "morphkit-checkpoint"
    assert set(load_checkpoint(path)["states"]) == {"model", "optimizer"}
    assert [p.name for p in tmp_path.iterdir()] == ["ck.pt"]  # no temporary file left behind


@pytest.mark.parametrize("kind", ["truncated", "garbage", "foreign", "pickled", "newer", "missing"])
def test_bad_checkpoints_raise_run_error_naming_the_file(tmp_path: Path, kind: str):
    """Truncated, non-torch, foreign, object-holding, newer and missing files are RunErrors naming the file."""
    path = tmp_path / "ck.pt"
    if kind == "truncated":
        save_checkpoint(path, _payload())
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    elif kind == "garbage":
        path.write_text("not a checkpoint")
    elif kind == "foreign":
        torch.save({"model": {}}, path)
    elif kind == "pickled":
        torch.save({"format": "morphkit-checkpoint", "version": 1, "obj": _Pickled()}, path)
    elif kind == "newer":
        torch.save({"format": "morphkit-checkpoint", "version": 99}, path)
    words = {
        "truncated": "truncated",
        "garbage": "not a torch checkpoint",
        "foreign": "not a morphkit checkpoint",
        "pickled": "objects a safe load refuses .*_Pickled",
        "newer": "newer",
        "missing": "not found",
    }[kind]
    with pytest.raises(RunError, match=words) as info:
        load_checkpoint(path)
    assert str(path) in str(info.value)


def test_rng_state_restores_every_generator():
    """After set_rng_state, torch, Python, NumPy (global and Generator) and a torch Generator repeat their draws."""
    np_rng, gen = np.random.default_rng(3), torch.Generator().manual_seed(4)

    def draw() -> list:
        return [
            torch.rand(3).tolist(),
            random.random(),
            np.random.rand(2).tolist(),  # noqa: NPY002 - the legacy global state is part of what is saved
            np_rng.normal(size=2).tolist(),
            torch.rand(2, generator=gen).tolist(),
        ]

    state = rng_state(numpy_generator=np_rng, torch_generator=gen)
    first = draw()
    set_rng_state(state, numpy_generator=np_rng, torch_generator=gen)
    assert draw() == first
