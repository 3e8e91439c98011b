"""Run.is_finished and Run.progress on real tiny run folders: unfinished, finished, damaged, missing."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
import torch

from morphkit.errors import RunError
from morphkit.retarget import MLP, Run


@dataclass(frozen=True)
class Cfg:
    """A minimal trainer config: two epochs."""

    seed: int = 3
    epochs: int = 2


def _train(folder: Path, epochs: int) -> None:
    """Train the first ``epochs`` of the config's two (resuming what the folder holds)."""
    with Run(folder, trainer="t", config=Cfg(), creature="c", device="cpu", progress=False, tensorboard=False) as run:
        model = MLP(2, (4,), 1)
        opt = torch.optim.SGD(model.parameters(), lr=0.1)
        run.track(model=model, optimizer=opt)
        x = torch.linspace(-1, 1, 16).view(8, 2)
        for _ in run.epochs(epochs):
            for idx in run.batches(8, 4):
                loss = model(x[idx]).square().mean()
                opt.zero_grad()
                loss.backward()
                opt.step()


def test_a_run_is_finished_once_it_reached_its_configured_epochs(tmp_path: Path):
    run = tmp_path / "run"
    _train(run, 1)
    assert Run.progress(run) == (1, 2, 3)
    assert not Run.is_finished(run)
    _train(run, 2)
    assert Run.progress(run) == (2, 2, 3)
    assert Run.is_finished(run)


def test_a_damaged_checkpoint_or_no_folder_is_not_finished(tmp_path: Path):
    run = tmp_path / "run"
    _train(run, 2)
    checkpoint = run / "checkpoint.pt"
    checkpoint.write_bytes(checkpoint.read_bytes()[:100])  # truncated
    assert not Run.is_finished(run)
    with pytest.raises(RunError, match="truncated or damaged"):
        Run.progress(run)
    assert not Run.is_finished(tmp_path / "missing")
    with pytest.raises(RunError, match="checkpoint not found"):
        Run.progress(tmp_path / "missing")


def test_a_folder_opened_but_not_trained_or_without_its_config_is_not_finished(tmp_path: Path):
    run = tmp_path / "run"
    _train(run, 0)  # run.yaml and config.yaml, no checkpoint
    assert (run / "config.yaml").is_file() and not Run.is_finished(run)
    _train(run, 2)
    (run / "config.yaml").unlink()
    assert not Run.is_finished(run)
    with pytest.raises(RunError, match="cannot read the run's config"):
        Run.progress(run)
