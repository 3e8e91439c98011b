"""Resumable stages, run in turn or in lanes of forked processes (the runner under ``reproduce_table1``).

A pipeline is a list of :class:`Stage`, each an action with a folder. :func:`run_stages` runs it.

* **Markers.** A stage is done when its folder holds :data:`DONE_FILE`, written atomically once its action
  returned, with the stage's ``key`` (the config and data it depends on). A marker with another key, or a
  damaged one, does not count. A re-run skips the stages done; one interrupted midway runs again and resumes
  from what its action keeps (a training run's checkpoint). A ``downstream`` stage (an evaluation) is redone
  whenever a stage before it ran.
* **Lanes.** Consecutive stages with a ``lane`` form a block. With ``jobs`` ≥ 2, each unfinished lane of the
  block runs in a process of its own, its stages in turn, at most ``jobs`` processes at once, each with
  ``cpu_count // jobs`` torch threads (the lanes share the cores, not oversubscribe them). A finished lane
  forks nothing. Stages without a lane run in the calling process, after the block before them.
* **Why fork.** A stage's action is a closure over the plan (creature, configs, log), which spawn would have
  to pickle; a forked child has it already. The price: a child cannot use the CUDA its parent initialised,
  so lanes run at once on CPU only (:func:`lanes_at_once`).
* **Results.** A lane puts on a queue each stage that ran, then how it ended: ``ok``; ``stopped`` (a run
  exited on a signal, checkpointed); ``error`` (a :class:`~morphkit.errors.MorphkitError` or ``OSError``,
  raised in the parent as :class:`~morphkit.errors.RunError` with the same message); ``crash`` (any other
  exception, raised as ``RuntimeError`` with the lane's traceback). A lane that ends without a word
  (SIGKILL, out of memory) is a ``RunError`` that says to run the command again.
* **Errors.** When a lane fails, the others get one SIGTERM: a training run checkpoints at its next step
  boundary and exits, unmarked, so a re-run resumes it. The failing lane's error is raised, not the stops it
  caused. An error in the parent itself stops the lanes the same way before it propagates.
* **Signals.** Lanes have their own process group, so a terminal's Ctrl-C reaches the parent only. The
  parent (on the main thread) forwards SIGINT and SIGTERM to every lane as SIGTERM, waits for them, and
  raises ``KeyboardInterrupt`` (SIGINT) or ``SystemExit(128 + signal)``. A second Ctrl-C is forwarded too
  and stops the lanes at once, mid-step.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from morphkit._atomic import atomic_write_text
from morphkit.errors import MorphkitError, RunError

__all__ = ["DONE_FILE", "Stage", "lanes_at_once", "run_stages", "stage_done"]

DONE_FILE = "done.json"
"""A stage's completion marker (in its folder)."""


@dataclass(frozen=True)
class Stage:
    """One resumable step of a pipeline."""

    name: str
    folder: Path
    """Where its ``done.json`` goes."""
    action: Callable[[], Any]
    key: dict[str, Any] = field(default_factory=dict)
    """Recorded in ``done.json``; a marker with another key does not count as done (the stage's config and
    data: another preset or override into the same folder is not taken for done)."""
    downstream: bool = False
    """Redo it whenever a stage before it ran in the same :func:`run_stages` call (the evaluation)."""
    lane: str = ""
    """Stages of one lane run in turn; consecutive stages of different lanes may run at once
    (:func:`run_stages` with ``jobs`` ≥ 2). ``""``: runs alone, after everything before it."""


def stage_done(stage: Stage) -> bool:
    """Whether ``stage``'s folder holds a completion marker with its key."""
    marker = stage.folder / DONE_FILE
    if not marker.is_file():
        return False
    try:
        saved = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False  # a damaged marker: redo the stage
    return saved.get("key", {}) == json.loads(json.dumps(stage.key))


def lanes_at_once(jobs: int, device: str | None) -> int:
    """``jobs`` when training on CPU, else 1: a forked lane cannot use the CUDA its parent initialised.

    Args:
        jobs: Lanes wanted at once.
        device: Torch device of training (``None``: CUDA when present, else CPU).
    """
    import torch

    device = device or ("cuda" if torch.cuda.is_available() else "cpu")
    return jobs if torch.device(device).type == "cpu" else 1


def run_stages(stages: Sequence[Stage], *, jobs: int = 1, log: Callable[[str], None] = print) -> list[str]:
    """Run the stages in order, skipping those done (:func:`stage_done`; a ``downstream`` stage is redone
    after any stage ran); write each one's marker when it returns.

    With ``jobs`` ≥ 2, each block of consecutive stages with a ``lane`` runs one process per lane (at most
    ``jobs`` at once; a lane's stages in turn); the stages around the block wait for it. A lane that fails
    stops the others at their next step boundary (SIGTERM: they checkpoint) and its error is raised here.

    Returns:
        The names of the stages that ran (within a block: lane by lane).
    """
    ran: list[str] = []
    numbered = list(enumerate(stages, 1))
    i = 0
    while i < len(numbered):
        block_end = i
        while block_end < len(numbered) and numbered[block_end][1].lane:
            block_end += 1
        lanes: dict[str, list[tuple[int, Stage]]] = {}
        for item in numbered[i:block_end]:
            lanes.setdefault(item[1].lane, []).append(item)
        busy = [items for items in lanes.values() if not all(stage_done(stage) for _, stage in items)]
        if jobs >= 2 and len(busy) >= 2:
            for items in lanes.values():
                if items not in busy:  # finished lanes: their skips are logged here, nothing is forked for them
                    for index, stage in items:
                        _run_stage(stage, index, len(stages), False, log)
            ran += _run_lanes(busy, len(stages), jobs, log)
            i = block_end
            continue
        index, stage = numbered[i]
        if _run_stage(stage, index, len(stages), bool(ran), log):
            ran.append(stage.name)
        i += 1
    return ran


def _run_stage(stage: Stage, index: int, total: int, upstream_ran: bool, log: Callable[[str], None]) -> bool:
    """Run one stage unless done; whether it ran."""
    where = f"[{index}/{total}] {stage.name}"
    if stage_done(stage) and not (stage.downstream and upstream_ran):
        log(f"{where}: done, skipped ({stage.folder})")
        return False
    log(f"{where}: running ({stage.folder})")
    started = time.perf_counter()
    stage.action()
    seconds = time.perf_counter() - started
    stage.folder.mkdir(parents=True, exist_ok=True)
    marker = {
        "stage": stage.name,
        "seconds": round(seconds, 3),
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "key": stage.key,
    }
    atomic_write_text(stage.folder / DONE_FILE, json.dumps(marker, indent=1) + "\n")
    log(f"{where}: done in {seconds:.0f} s")
    return True


def _run_lanes(lanes: list[list[tuple[int, Stage]]], total: int, jobs: int, log: Callable[[str], None]) -> list[str]:
    """Run each lane in a forked process, at most ``jobs`` at once; the names of the stages that ran.

    The lane processes have their own process group, so a Ctrl-C reaches this process only: it sends
    each lane one SIGTERM (they checkpoint at their next step boundary and exit), waits for them, and
    exits as interrupted; a second Ctrl-C is forwarded too and stops them at once.
    """
    import torch

    # fork, not spawn: a stage's action is a closure over the plan, which spawn would have to pickle.
    ctx = multiprocessing.get_context("fork")
    results = ctx.SimpleQueue()
    threads = max(1, (os.cpu_count() or 1) // jobs)

    def lane_main(lane: int, items: list[tuple[int, Stage]]) -> None:
        os.setpgrp()
        signal.signal(signal.SIGINT, signal.default_int_handler)  # not the parent's forwarding handlers
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        torch.set_num_threads(threads)
        try:
            for index, stage in items:
                if _run_stage(stage, index, total, False, log):
                    results.put((lane, "ran", stage.name))
            results.put((lane, "ok", ""))
        except SystemExit as exc:  # a training run stopped by a signal has checkpointed
            results.put((lane, "stopped", str(exc.code)))
        except (MorphkitError, OSError) as exc:
            results.put((lane, "error", str(exc)))
        except BaseException:  # a bug: its traceback goes to the parent
            results.put((lane, "crash", traceback.format_exc()))
        finally:
            sys.stdout.flush()
            sys.stderr.flush()

    log(
        f"training {len(lanes)} lanes at once ({', '.join(items[0][1].lane for items in lanes)}), "
        f"{threads} torch thread{'s' if threads > 1 else ''} each"
    )
    procs: dict[int, Any] = {}
    outcome: dict[int, tuple[str, str]] = {}
    ran: list[str] = []
    signals: list[int] = []
    stopping = False

    def stop_lanes() -> None:
        for proc in procs.values():
            if proc.is_alive():
                os.kill(proc.pid, signal.SIGTERM)

    def forward(signum: int, frame: Any) -> None:
        signals.append(signum)
        stop_lanes()

    def drain() -> None:
        while not results.empty():
            lane, kind, text = results.get()
            if kind == "ran":
                ran.append(text)
            else:
                outcome[lane] = (kind, text)

    handlers = {}
    if threading.current_thread() is threading.main_thread():
        handlers = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        for lane, items in enumerate(lanes):
            while sum(p.is_alive() for p in procs.values()) >= jobs:
                time.sleep(0.5)
            drain()
            if signals or any(kind != "ok" for kind, _ in outcome.values()):
                break
            procs[lane] = ctx.Process(target=lane_main, args=(lane, items))
            procs[lane].start()
        while any(p.is_alive() for p in procs.values()):
            time.sleep(0.5)
            drain()
            if any(kind != "ok" for kind, _ in outcome.values()) and not (stopping or signals):
                stop_lanes()  # one lane failed: the others checkpoint at their next step boundary and exit
                stopping = True
        for proc in procs.values():
            proc.join()
        drain()
    finally:
        if any(p.is_alive() for p in procs.values()):  # leaving on an error of our own: no lane outlives us
            stop_lanes()
            for proc in procs.values():
                proc.join()
        for s, h in handlers.items():
            signal.signal(s, h)
    if signals:
        if signals[0] == signal.SIGINT:
            raise KeyboardInterrupt
        raise SystemExit(128 + signals[0])
    # The cause first: a lane's error or crash, not the lanes stopped because of it.
    said = sorted(outcome.items(), key=lambda item: ("error", "crash", "stopped", "ok").index(item[1][0]))
    for lane, (kind, text) in said:
        if kind == "error":
            raise RunError(text)
        if kind == "crash":
            raise RuntimeError(f"the {lanes[lane][0][1].lane} lane failed:\n{text}")
        if kind == "stopped":
            raise SystemExit(int(text) if text.isdigit() else 1)
    for lane, proc in procs.items():
        if lane not in outcome:  # killed without a word (SIGKILL, out of memory)
            raise RunError(
                f"the {lanes[lane][0][1].lane} lane ended with exit code {proc.exitcode}; "
                "run the same command again to resume it"
            )
    return ran
