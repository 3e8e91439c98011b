"""A training run: one folder that holds the config, the checkpoint and the logs, and resumes exactly.

Layout of a run folder::

    run.yaml          trainer name, creature, config class (checked when the folder is reopened)
    config.yaml       the trainer's config (morphkit.retarget.config.write_config)
    checkpoint.pt     the whole training state, replaced atomically (morphkit.retarget.checkpoint)
    metrics.csv       one row per Run.log call
    .lock             held (flock) by the one process writing the folder (morphkit._folder_lock)
    tensorboard/      TensorBoard event files

:class:`Run` owns the position in training (epoch, step within the epoch, global step), every
random number generator, the data order and the stop-on-signal logic. A trainer writes its loop
around :meth:`Run.epochs` and :meth:`Run.batches`; opening a folder that holds a checkpoint
resumes it, and the resumed run computes bit for bit what the uninterrupted one would have:

* the batch order of epoch ``e`` is a permutation seeded by ``(seed, e)`` alone, so resuming at
  step ``k`` of an epoch takes the same batches as an uninterrupted run;
* the checkpoint holds the tracked models', optimisers' and schedulers' state dicts, every RNG
  state of every rank, the position, and :attr:`Run.extra` (small trainer state);
* a checkpoint is written at the end of every epoch, every ``checkpoint_every`` steps if asked,
  and at the next step boundary after SIGINT or SIGTERM, after which the process exits with
  code 128 + signal number (a kill loses at most the steps since the last checkpoint);
* ``metrics.csv`` rows and TensorBoard events logged after the checkpoint are dropped on resume.

Under ``torchrun`` every rank opens the same folder and reads the same checkpoint; rank 0
writes files and shows the progress bar; :meth:`Run.batches` gives each rank its own slice of
the global batch; :meth:`Run.wrap` puts a model into DistributedDataParallel.
"""

from __future__ import annotations

import contextlib
import logging
import os
import random
import signal
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Generic, NamedTuple, Protocol, TypeVar

import numpy as np
import torch
import yaml
from torch import nn

from morphkit._atomic import atomic_write_text
from morphkit._folder_lock import hold_run_folder
from morphkit._version import __version__
from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.retarget.checkpoint import load_checkpoint, rng_state, save_checkpoint, set_rng_state
from morphkit.retarget.config import config_diff, config_to_dict, read_config, write_config
from morphkit.retarget.distributed import (
    DistributedContext,
    all_gather_objects,
    all_reduce_max,
    all_reduce_mean,
    init_distributed,
    leave_group,
    release_group,
    unwrap,
    wrap_ddp,
)
from morphkit.retarget.logs import MetricsLog
from morphkit.yaml_loader import load_yaml_file

__all__ = [
    "CHECKPOINT_FILE", "CONFIG_FILE", "RUN_FILE", "Run", "RunProgress", "Stateful", "derive_seed", "required_file",
    "stage_trainer",
]

log = logging.getLogger(__name__)

C = TypeVar("C")

RUN_FILE = "run.yaml"
"""Identity of a run folder: trainer, creature, config class."""
CONFIG_FILE = "config.yaml"
"""The trainer config of a run folder."""
CHECKPOINT_FILE = "checkpoint.pt"
"""The (latest) checkpoint of a run folder."""

_TAG_RANK, _TAG_ORDER = 0x52414E4B, 0x4F524452  # seed-derivation domains: per-rank RNGs, per-epoch data order


class Stateful(Protocol):
    """Anything with ``state_dict``/``load_state_dict`` (modules, optimisers, LR schedulers, GradScaler)."""

    def state_dict(self) -> dict[str, Any]:
        """The object's state (tensors and builtins)."""
        ...

    def load_state_dict(self, state_dict: dict[str, Any], /) -> Any:
        """Put a state from :meth:`state_dict` back."""
        ...


class RunProgress(NamedTuple):
    """Where a run folder's training stands (:meth:`Run.progress`)."""

    epoch: int
    """Epochs trained (the checkpoint's position)."""
    epochs: int
    """Epochs its ``config.yaml`` asks for."""
    seed: int
    """The run's seed."""

    @property
    def finished(self) -> bool:
        """The one definition of a finished run: it has trained the epochs its config asks for."""
        return self.epoch >= self.epochs


def required_file(path: Path, kind: str) -> Path:
    """``path`` when it exists; else :class:`RunError` saying its folder is not ``kind`` ("an ACE run folder").

    Raises:
        RunError: ``path`` is missing, naming it and its folder.
    """
    if not path.exists():
        raise RunError(f"not {kind}: {path.name} is missing", location=SourceLocation(str(path.parent)))
    return path


def stage_trainer(folder: Path, kind: str = "a trained stage") -> str:
    """The trainer name a run folder's ``run.yaml`` records (``""`` when it names none).

    Raises:
        RunError: no ``run.yaml`` (the folder is not ``kind``).
    """
    path = required_file(folder / RUN_FILE, kind)
    return str((load_yaml_file(path, what="the run identity", error=RunError) or {}).get("trainer", ""))


def derive_seed(*words: int) -> int:
    """A 63-bit seed from integers (``derive_seed(seed, epoch)``), via NumPy's SeedSequence."""
    sequence = np.random.SeedSequence([int(w) & 0xFFFFFFFFFFFFFFFF for w in words])
    return int(sequence.generate_state(1, np.uint64)[0]) >> 1


class Run(Generic[C]):
    """A resumable, seeded, optionally distributed training run in one folder.

    Create the Run *before* building models (it seeds every RNG), then build models and
    optimisers, :meth:`track` them (which loads their state when resuming), and loop::

        with Run(out, trainer="ace-prior", config=cfg, creature=name) as run:
            model = run.wrap(Prior(cfg))
            opt = torch.optim.Adam(model.parameters(), cfg.lr)
            run.track(model=model, optimizer=opt)
            for epoch in run.epochs(cfg.epochs):
                for idx in run.batches(len(data), cfg.batch_size):
                    loss = ...; opt.zero_grad(); loss.backward(); opt.step()
                    run.log(loss=loss)

    Args:
        run_dir: The run folder (created if missing).
        trainer: Trainer name; reopening the folder with another one raises :class:`RunError`.
        config: The trainer's frozen config dataclass; written to ``config.yaml``. Reopening with a
            config that differs in any field outside ``allow_changes`` raises :class:`RunError`.
        creature: Creature name (any string identifying the character); checked like ``trainer``.
        seed: Root seed; defaults to ``config.seed`` when the config has one, else 0.
        device: Training device (see :func:`~morphkit.retarget.distributed.init_distributed`).
        allow_changes: Config fields that may differ on resume (e.g. ``("epochs",)``); the new
            values are written to ``config.yaml``.
        checkpoint_every: Also checkpoint every this many global steps (``None``: per epoch only).
        progress: Show a tqdm progress bar with ETA (rank 0, on a terminal).
        tensorboard: Write TensorBoard event files beside ``metrics.csv``.
        deterministic: Ask torch for deterministic algorithms (``warn_only``; restored on
            :meth:`close`) and set the cuBLAS workspace variable; bit-identical resume on CPU needs
            nothing else.
        handle_signals: Turn SIGINT/SIGTERM into checkpoint-and-exit at the next step boundary.
    """

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        *,
        trainer: str,
        config: C,
        creature: str | None = None,
        seed: int | None = None,
        device: str | torch.device | None = None,
        allow_changes: Iterable[str] = (),
        checkpoint_every: int | None = None,
        progress: bool = True,
        tensorboard: bool = True,
        deterministic: bool = True,
        handle_signals: bool = True,
    ) -> None:
        self.dir = Path(run_dir)
        self.trainer, self.creature = trainer, creature
        self.seed = int(seed if seed is not None else getattr(config, "seed", 0))
        self.checkpoint_every = checkpoint_every
        self._deterministic_before = (
            torch.are_deterministic_algorithms_enabled(),
            torch.is_deterministic_algorithms_warn_only_enabled(),
        )
        if deterministic:
            os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
            torch.use_deterministic_algorithms(True, warn_only=True)
        joined = torch.distributed.is_available() and torch.distributed.is_initialized()
        self.context: DistributedContext = init_distributed(device)
        # A group that existed before this run (a trainer running several stages) outlives it.
        self._owns_group = self.context.is_distributed and not joined
        # One writer per folder (rank 0 writes): the config check and write below happen under the lock.
        self._lock = contextlib.ExitStack()
        if self.context.is_main:
            self._lock.enter_context(hold_run_folder(self.dir))
        try:
            self.config: C = self._open_folder(config, set(allow_changes))

            rank_seed = derive_seed(self.seed, _TAG_RANK, self.context.rank)
            random.seed(rank_seed)
            np.random.seed(rank_seed & 0xFFFFFFFF)  # noqa: NPY002 - seeded for code that still uses it
            torch.manual_seed(rank_seed)
            self.np_rng: np.random.Generator = np.random.default_rng(rank_seed)
            """NumPy generator owned by the run (saved in checkpoints): draw NumPy randomness from it."""
            self.generator: torch.Generator = torch.Generator().manual_seed(rank_seed ^ 0x5A5A5A5A)
            """CPU torch generator owned by the run (saved in checkpoints), for ``generator=`` arguments."""

            self.epoch = self.step = self.global_step = 0
            self.extra: dict[str, Any] = {}
            """Small trainer state saved in the checkpoint (tensors and builtins only), e.g. an EMA score."""
            self._tracked: dict[str, Stateful] = {}
            self._wrapped: list[nn.Module] = []
            self._checkpoint = self._read_checkpoint()
            if self._checkpoint is not None:
                pos = self._checkpoint["position"]
                self.epoch, self.step, self.global_step = pos["epoch"], pos["step"], pos["global_step"]
                self.extra = dict(self._checkpoint.get("extra", {}))
            self.metrics = MetricsLog(
                self.dir,
                keep_rows=self._checkpoint["metrics_rows"] if self._checkpoint is not None else 0,
                purge_step=self.global_step + 1 if self._checkpoint is not None else 0,
                tensorboard=tensorboard,
                enabled=self.context.is_main,
            )
            self._rng_pending = self._checkpoint is not None
            self._epoch_count: int | None = None
            self._in_step = False
            self._progress, self._bar = progress and self.context.is_main, None
            self._stop_signal: int | None = None
            self._saved_at: tuple[int, int, int] | None = None
            self._previous_handlers: dict[int, Any] = {}
            if handle_signals and threading.current_thread() is threading.main_thread():
                for signum in (signal.SIGINT, signal.SIGTERM):
                    self._previous_handlers[signum] = signal.signal(signum, self._on_signal)
        except BaseException:
            self._lock.close()
            raise

    # ----------------------------------------------------------------------------- properties

    @property
    def device(self) -> torch.device:
        """The device this rank trains on."""
        return self.context.device

    @property
    def is_main(self) -> bool:
        """Rank 0 (the process that writes files)."""
        return self.context.is_main

    @property
    def resumed(self) -> bool:
        """The folder held a checkpoint when the run was opened."""
        return self._checkpoint is not None

    @property
    def checkpoint_path(self) -> Path:
        """Where the checkpoint is (or will be) written."""
        return self.dir / CHECKPOINT_FILE

    # ------------------------------------------------------------------- a folder, unopened

    @staticmethod
    def progress(run_dir: str | os.PathLike[str]) -> RunProgress:
        """``(epoch reached, epochs configured, seed)`` of a run folder, read without opening it (its
        :attr:`~RunProgress.finished` is the one answer to "has this run finished?").

        The epoch and seed come from its checkpoint, the epochs from the ``epochs`` field of its
        ``config.yaml`` (0 when the config has none).

        Raises:
            RunError: The checkpoint or the config is missing, damaged or holds no position.
        """
        folder = Path(run_dir)
        position = load_checkpoint(folder / CHECKPOINT_FILE).get("position")
        config_file = folder / CONFIG_FILE
        config = load_yaml_file(config_file, what="the run's config", error=RunError) or {}
        try:
            epochs = int(config.get("epochs", 0))
            return RunProgress(int(position["epoch"]), epochs, int(position.get("seed", 0)))
        except (AttributeError, KeyError, TypeError, ValueError) as exc:  # not a mapping, or not numbers
            raise RunError(f"no training position or epoch count: {exc}", location=SourceLocation(str(folder))) from exc

    @staticmethod
    def is_finished(run_dir: str | os.PathLike[str]) -> bool:
        """Whether a run folder's checkpoint has reached the epochs of its ``config.yaml`` (:meth:`progress`).

        ``False`` for a run still training, and for a missing folder, checkpoint or config or a damaged one.
        """
        try:
            return Run.progress(run_dir).finished
        except RunError:
            return False

    # ------------------------------------------------------------------------------- modules

    def wrap(self, module: nn.Module) -> nn.Module:
        """``module`` moved to :attr:`device`, in DistributedDataParallel under torchrun."""
        wrapped = wrap_ddp(module, self.context)
        self._wrapped.append(wrapped)
        return wrapped

    def track(self, **objects: Stateful) -> None:
        """Save these objects' state dicts in every checkpoint; load them now when resuming.

        Models may be DDP-wrapped (the inner module's state is saved, so a checkpoint loads into
        an unwrapped model too). Call it once everything is built, before :meth:`epochs`.
        """
        for name, obj in objects.items():
            self._tracked[name] = obj
            if self._checkpoint is None:
                continue
            states = self._checkpoint["states"]
            if name not in states:
                raise RunError(
                    f"checkpoint has no state for {name!r} (it has: {', '.join(states) or 'none'})",
                    location=SourceLocation(str(self.checkpoint_path)),
                )
            target = unwrap(obj) if isinstance(obj, nn.Module) else obj
            try:
                target.load_state_dict(states[name])
            except (RuntimeError, ValueError, KeyError) as exc:
                raise RunError(
                    f"checkpoint state for {name!r} does not fit the {type(target).__name__} built now: "
                    f"{str(exc).splitlines()[0]}",
                    location=SourceLocation(str(self.checkpoint_path)),
                ) from exc

    # ---------------------------------------------------------------------------------- loop

    def epochs(self, count: int) -> Iterator[int]:
        """Yield epoch numbers from the saved position up to ``count`` − 1; checkpoint after each.

        On the first iteration of a resumed run, the RNG states of the checkpoint are restored
        (after model construction and :meth:`track`, exactly where the interrupted run was).
        """
        self._epoch_count = count
        self._restore_rng()
        while self.epoch < count:
            self._check_stop()
            yield self.epoch
            self.epoch, self.step = self.epoch + 1, 0
            self.checkpoint()
        self._check_stop()
        self._close_bar()

    def steps(self, count: int) -> Iterator[int]:
        """Yield step numbers within the current epoch, from the saved position up to ``count`` − 1.

        After each step (when the loop asks for the next one) the position advances; a pending
        SIGINT/SIGTERM checkpoints and exits here; ``checkpoint_every`` checkpoints are written here.
        """
        self._restore_rng()
        bar = self._progress_bar(count)
        while self.step < count:
            self._in_step = True
            yield self.step
            self._in_step = False
            self.step += 1
            self.global_step += 1
            if bar is not None:
                bar.update(1)
            self._check_stop()
            every = self.checkpoint_every
            if every and self.global_step % every == 0 and self.step < count:
                self.checkpoint()

    def batches(self, sample_count: int, batch_size: int) -> Iterator[torch.Tensor]:
        """Yield this rank's sample indices for each remaining step of the current epoch.

        The epoch's order is :meth:`batch_order`; step ``k`` takes the global batch
        ``order[k·B·W : (k+1)·B·W]`` (``B = batch_size`` per rank, ``W`` ranks) and rank ``r`` its
        slice ``[r·B, (r+1)·B)``; the incomplete last global batch is dropped.

        Returns:
            An iterator of int64 index tensors of shape [batch_size].
        """
        global_batch = batch_size * self.context.world_size
        count = sample_count // global_batch
        if count == 0:
            raise ConfigError(
                f"{sample_count} samples do not fill one batch of {batch_size}"
                + (f" × {self.context.world_size} ranks" if self.context.is_distributed else "")
            )
        order = self.batch_order(sample_count)
        lo = self.context.rank * batch_size
        for step in self.steps(count):
            yield order[step * global_batch + lo : step * global_batch + lo + batch_size]

    def batch_order(self, sample_count: int, epoch: int | None = None) -> torch.Tensor:
        """The permutation of ``range(sample_count)`` for ``epoch`` (default: the current one), shape [N].

        Seeded by ``(seed, epoch)`` only, so it is the same on every rank, in every process.
        """
        e = self.epoch if epoch is None else epoch
        gen = torch.Generator().manual_seed(derive_seed(self.seed, _TAG_ORDER, e))
        return torch.randperm(sample_count, generator=gen)

    # ------------------------------------------------------------------------------- logging

    def log(self, **values: Any) -> None:
        """Record scalars (numbers or 0-d tensors) in ``metrics.csv`` and TensorBoard (rank 0).

        Each row also gets ``epoch`` (0-based), ``step`` and ``global_step``: the numbers of
        optimiser steps completed in the epoch and in the run, counting the one in progress (so a
        value logged inside the first step has 1, and one logged after an epoch's last step shares
        that step's numbers). ``global_step`` is the TensorBoard step.
        """
        if not self.context.is_main:
            return
        done = 1 if self._in_step else 0
        row = {"epoch": self.epoch, "step": self.step + done, "global_step": self.global_step + done, **values}
        self.metrics.write(row)
        if self._bar is not None:
            shown = {k: f"{v.item() if hasattr(v, 'item') else v:.4g}" for k, v in values.items()}
            self._bar.set_postfix(shown, refresh=False)

    def mean(self, value: torch.Tensor | float) -> float:
        """The mean of ``value`` over all ranks (a collective: call it on every rank)."""
        return float(all_reduce_mean(value, self.context).item())

    # ---------------------------------------------------------------------------- checkpoint

    def checkpoint(self) -> Path:
        """Write the checkpoint now (a collective under torchrun: every rank calls it; rank 0 writes)."""
        rngs = all_gather_objects(rng_state(numpy_generator=self.np_rng, torch_generator=self.generator), self.context)
        if self.context.is_main:
            states = {
                name: (unwrap(obj) if isinstance(obj, nn.Module) else obj).state_dict()
                for name, obj in self._tracked.items()
            }
            payload = {
                "trainer": self.trainer,
                "creature": self.creature,
                "morphkit": __version__,
                "config": config_to_dict(self.config),
                "position": {
                    "epoch": self.epoch,
                    "step": self.step,
                    "global_step": self.global_step,
                    "seed": self.seed,
                    "world_size": self.context.world_size,
                },
                "states": states,
                "rng": rngs,
                "extra": self.extra,
                "metrics_rows": self.metrics.rows,
            }
            save_checkpoint(self.checkpoint_path, payload)
            self.metrics.flush()
        self.context.barrier()
        self._saved_at = (self.epoch, self.step, self.global_step)
        return self.checkpoint_path

    def close(self, *, wait_for_ranks: bool = True) -> None:
        """Close logs and progress bar; restore signal handlers and determinism; leave a process group it joined.

        Leaving the group, the wrapped modules let go of it
        (:func:`~morphkit.retarget.distributed.release_group`) and every rank waits for the others
        (``wait_for_ranks``, skipped when closing on an error, which the other ranks may never reach), so it
        is torn down here on every rank (:func:`~morphkit.retarget.distributed.leave_group`).
        In a group the run did not create, the wrapped modules let go of it all the same.
        """
        self._close_bar()
        self.metrics.close()
        for signum, handler in self._previous_handlers.items():
            signal.signal(signum, handler)
        self._previous_handlers = {}
        enabled, warn_only = self._deterministic_before
        torch.use_deterministic_algorithms(enabled, warn_only=warn_only)
        if self.context.is_distributed and torch.distributed.is_initialized():
            # Released even in a group that outlives the run: a wrapper left holding it is collected
            # whenever Python gets to it, possibly after the group is gone.
            for obj in [*self._tracked.values(), *self._wrapped]:
                if isinstance(obj, nn.Module):
                    release_group(obj)
            if self._owns_group:
                leave_group(self.context, wait_for_ranks=wait_for_ranks)
                self._owns_group = False
        self._lock.close()

    def __enter__(self) -> Run[C]:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        self.close(wait_for_ranks=exc_type is None)

    # ------------------------------------------------------------------------------ internals

    def _open_folder(self, config: C, allow_changes: set[str]) -> C:
        run_file, config_file = self.dir / RUN_FILE, self.dir / CONFIG_FILE
        identity = {
            "trainer": self.trainer,
            "creature": self.creature,
            "config_class": f"{type(config).__module__}.{type(config).__qualname__}",
        }
        if (self.dir / CHECKPOINT_FILE).exists() and not (run_file.exists() and config_file.exists()):
            # E.g. a SIGTERM checkpoint that landed in a folder deleted under the run: nothing says what it is.
            missing = " and ".join(f.name for f in (run_file, config_file) if not f.exists())
            raise RunError(
                f"a checkpoint without {missing}: not a complete run folder; use another folder",
                location=SourceLocation(str(self.dir / CHECKPOINT_FILE)),
            )
        if run_file.exists():
            saved = load_yaml_file(run_file, what="the run identity", error=RunError) or {}
            for key in ("trainer", "creature"):
                if saved.get(key) != identity[key]:
                    raise RunError(
                        f"run folder belongs to {key} {saved.get(key)!r}, not {identity[key]!r}; "
                        "use another run folder",
                        location=SourceLocation(str(run_file)),
                    )
        if config_file.exists():
            saved_config = read_config(type(config), config_file)
            diff = {k: v for k, v in config_diff(saved_config, config).items() if k not in allow_changes}
            if diff:
                listed = "; ".join(f"{k}: saved {a!r}, given {b!r}" for k, (a, b) in diff.items())
                raise RunError(
                    f"config differs from the one this run was started with ({listed}); "
                    "use another run folder or the saved config",
                    location=SourceLocation(str(config_file)),
                )
        if self.context.is_main:
            self.dir.mkdir(parents=True, exist_ok=True)
            if not run_file.exists():
                text = yaml.safe_dump({**identity, "morphkit": __version__}, sort_keys=False)
                atomic_write_text(run_file, "# morphkit training run\n" + text)
            write_config(config_file, config)
        return config

    def _read_checkpoint(self) -> dict[str, Any] | None:
        if not self.checkpoint_path.exists():
            return None
        ckpt = load_checkpoint(self.checkpoint_path)
        where = SourceLocation(str(self.checkpoint_path))
        for key, mine in (("trainer", self.trainer), ("creature", self.creature)):
            if ckpt.get(key) != mine:
                raise RunError(f"checkpoint is of {key} {ckpt.get(key)!r}, not {mine!r}", location=where)
        if "position" not in ckpt or "states" not in ckpt:
            raise RunError("checkpoint has no training position or states", location=where)
        saved_world = ckpt["position"].get("world_size", 1)
        if saved_world != self.context.world_size:
            log.warning(
                "resuming a %d-process run with %d processes: the data order and RNG streams change",
                saved_world,
                self.context.world_size,
            )
        return ckpt

    def _restore_rng(self) -> None:
        if not self._rng_pending:
            return
        self._rng_pending = False
        rngs = self._checkpoint["rng"] if self._checkpoint is not None else []
        if self.context.rank < len(rngs):
            set_rng_state(rngs[self.context.rank], numpy_generator=self.np_rng, torch_generator=self.generator)

    def _on_signal(self, signum: int, frame: Any) -> None:
        if self._stop_signal is not None:  # a second signal: stop waiting for the step to end
            signal.signal(signum, self._previous_handlers.get(signum, signal.SIG_DFL))
            signal.raise_signal(signum)
            return
        self._stop_signal = signum
        log.warning("signal %d: checkpointing at the next step boundary, then exiting", signum)

    def _check_stop(self) -> None:
        signum = int(all_reduce_max(self._stop_signal or 0, self.context))
        if signum:
            if self._saved_at != (self.epoch, self.step, self.global_step):
                self.checkpoint()
            self.close()
            raise SystemExit(128 + signum)

    def _progress_bar(self, steps_per_epoch: int) -> Any:
        if not self._progress:
            return None
        if self._bar is None:
            from tqdm.auto import tqdm

            epochs = self._epoch_count or self.epoch + 1
            self._bar = tqdm(
                total=epochs * steps_per_epoch,
                initial=self.epoch * steps_per_epoch + self.step,
                unit="step",
                dynamic_ncols=True,
                disable=None,  # off when stderr is not a terminal
            )
        self._bar.set_description(f"{self.trainer} epoch {self.epoch + 1}/{self._epoch_count or '?'}")
        return self._bar

    def _close_bar(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
