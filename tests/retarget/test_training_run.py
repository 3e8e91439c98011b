"""The Run object in one process: folder identity, config checks, data order, signals, logs, state loading."""

from __future__ import annotations

import os
import signal
from dataclasses import dataclass
from pathlib import Path

import pytest
import torch

from morphkit.errors import RunError
from morphkit.retarget import MLP, MetricsLog, Run, read_metrics


@dataclass(frozen=True)
class Cfg:
    """A minimal trainer config."""

    seed: int = 1
    epochs: int = 2
    lr: float = 0.1


def _run(path: Path, **kw) -> Run:
    kw.setdefault("trainer", "t")
    kw.setdefault("config", Cfg())
    kw.setdefault("creature", "c")
    return Run(path, device="cpu", progress=False, tensorboard=kw.pop("tensorboard", False), **kw)


def _train(run: Run, *, samples: int = 12, batch: int = 4, term_at: int | None = None) -> torch.nn.Module:
    model = MLP(2, (4,), 1)
    opt = torch.optim.SGD(model.parameters(), lr=run.config.lr)
    run.track(model=model, optimizer=opt)
    x = torch.linspace(-1, 1, samples * 2).view(samples, 2)
    for _ in run.epochs(run.config.epochs):
        for idx in run.batches(samples, batch):
            if run.global_step == term_at:
                os.kill(os.getpid(), signal.SIGTERM)
            loss = model(x[idx]).square().mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            run.log(loss=loss)
    return model


def test_folder_of_another_trainer_or_creature_is_refused(tmp_path: Path):
    """Reopening a run folder with another trainer name or creature raises a RunError naming both."""
    _run(tmp_path).close()
    assert (tmp_path / "run.yaml").exists() and (tmp_path / "config.yaml").exists()
    with pytest.raises(RunError, match="belongs to trainer 't', not 'u'") as info:
        _run(tmp_path, trainer="u")
    assert str(tmp_path / "run.yaml") in str(info.value)
    with pytest.raises(RunError, match="belongs to creature 'c', not 'spider'"):
        _run(tmp_path, creature="spider")


def test_a_checkpoint_without_its_run_files_is_refused(tmp_path: Path):
    """A checkpoint left alone in a folder (its run.yaml/config.yaml gone) is not resumed blindly."""
    with _run(tmp_path) as run:
        _train(run)
    (tmp_path / "run.yaml").unlink()
    with pytest.raises(RunError, match=r"checkpoint without run\.yaml") as info:
        _run(tmp_path)
    assert str(tmp_path / "checkpoint.pt") in str(info.value)


def test_changed_config_is_refused_unless_allowed(tmp_path: Path):
    """A different config is refused, naming the field; allow_changes lets it through and saves it."""
    _run(tmp_path).close()
    with pytest.raises(RunError, match=r"lr: saved 0\.1, given 0\.2"):
        _run(tmp_path, config=Cfg(lr=0.2))
    _run(tmp_path, config=Cfg(epochs=5), allow_changes=["epochs"]).close()
    assert "epochs: 5" in (tmp_path / "config.yaml").read_text()


def test_batch_order_depends_on_seed_and_epoch_only(tmp_path: Path):
    """Each epoch's permutation is a function of (seed, epoch); batches of an epoch are disjoint."""
    with _run(tmp_path / "a") as a, _run(tmp_path / "b") as b:
        assert torch.equal(a.batch_order(50, 3), b.batch_order(50, 3))
        assert not torch.equal(a.batch_order(50, 0), a.batch_order(50, 1))
        assert sorted(a.batch_order(50, 2).tolist()) == list(range(50))
        for _ in a.epochs(1):
            seen = torch.cat(list(a.batches(10, 3)))
        assert len(seen) == 9 and len(set(seen.tolist())) == 9


def test_sigterm_checkpoints_at_the_step_boundary_and_resume_matches(tmp_path: Path):
    """SIGTERM mid-epoch: checkpoint at the next step boundary, exit 143; resuming equals an uninterrupted run."""
    with _run(tmp_path / "ref") as run:
        ref = _train(run)
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(SystemExit) as info, _run(tmp_path / "cut") as run:
        _train(run, term_at=4)
    assert info.value.code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == before
    ckpt = torch.load(tmp_path / "cut" / "checkpoint.pt", weights_only=True)
    assert ckpt["position"] == {"epoch": 1, "step": 2, "global_step": 5, "seed": 1, "world_size": 1}
    assert ckpt["metrics_rows"] == 5 and set(ckpt["states"]) == {"model", "optimizer"}
    with _run(tmp_path / "cut") as run:
        assert run.resumed and (run.epoch, run.step) == (1, 2)
        resumed = _train(run)
    for p, q in zip(ref.parameters(), resumed.parameters(), strict=True):
        assert torch.equal(p, q)
    _, rows = read_metrics(tmp_path / "cut" / "metrics.csv")
    assert [r["global_step"] for r in rows] == [1, 2, 3, 4, 5, 6]


def test_track_refuses_missing_or_misshapen_state(tmp_path: Path):
    """Resuming into an object the checkpoint lacks, or of another shape, is a RunError."""
    with _run(tmp_path) as run:
        run.track(model=MLP(2, (4,), 1))
        run.checkpoint()
    with _run(tmp_path) as run, pytest.raises(RunError, match=r"no state for 'critic' .*has: model"):
        run.track(critic=MLP(2, (4,), 1))
    with _run(tmp_path) as run, pytest.raises(RunError, match="does not fit the MLP"):
        run.track(model=MLP(2, (5,), 1))


def test_metrics_log_columns_truncation_and_tensorboard(tmp_path: Path):
    """New columns widen the header once; keep_rows and a half-written last line are cut; events are written."""
    log = MetricsLog(tmp_path)
    log.write({"global_step": 1, "loss": 1.0})
    log.write({"global_step": 2, "loss": 0.5, "kl": torch.tensor(0.25)})
    log.close()
    columns, rows = read_metrics(tmp_path / "metrics.csv")
    assert columns == ["global_step", "loss", "kl"] and rows[0]["kl"] is None and rows[1]["kl"] == 0.25
    with open(tmp_path / "metrics.csv", "a") as f:
        f.write("3,0.2")  # a row cut short by a kill
    MetricsLog(tmp_path, tensorboard=False).close()
    assert len(read_metrics(tmp_path / "metrics.csv")[1]) == 2
    MetricsLog(tmp_path, keep_rows=1, tensorboard=False).close()
    assert (tmp_path / "metrics.csv").read_text().splitlines()[1:] == ["1,1.0,"]
    assert any((tmp_path / "tensorboard").glob("events.out.tfevents.*"))
