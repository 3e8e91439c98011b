"""One writer per run folder: a second process is refused with one line naming the holder; the lock goes
with its process, however that process ends."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

from morphkit.cli import main
from morphkit.errors import RunError
from morphkit.retarget import Run


@dataclass(frozen=True)
class Cfg:
    """A minimal trainer config."""

    seed: int = 1
    epochs: int = 2


_HOLDER = textwrap.dedent("""
    import sys, time
    from morphkit.retarget.folder_lock import hold_run_folder
    from morphkit.errors import RunError
    try:
        with hold_run_folder(sys.argv[1]):
            print("held", flush=True)
            time.sleep(float(sys.argv[2]))
    except RunError as exc:
        print(f"refused: {exc}", flush=True)
""")


def _holder(folder: Path, seconds: float = 120.0) -> subprocess.Popen:
    """Another process holding ``folder`` (or refused it): its first line says which."""
    return subprocess.Popen([sys.executable, "-c", _HOLDER, str(folder), str(seconds)], stdout=subprocess.PIPE,
                            text=True)


def _run(folder: Path) -> Run:
    return Run(folder, trainer="t", config=Cfg(), creature="c", device="cpu", progress=False, tensorboard=False,
               handle_signals=False)


def test_a_second_writer_is_refused_naming_the_holder_and_a_killed_holder_lets_go(tmp_path, capsys):
    proc = _holder(tmp_path / "run")
    try:
        assert proc.stdout.readline().strip() == "held"
        with pytest.raises(RunError, match=f"pid {proc.pid} on host {socket.gethostname()}"):
            _run(tmp_path / "run")
        assert not (tmp_path / "run" / "config.yaml").exists()  # the config check and write are under the lock
        code = main(["train", "nkn", "--preset", "smoke", "--out", str(tmp_path / "run"), "--no-progress"])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and err.startswith(f"error: {tmp_path / 'run'}: run folder is in use")
        assert f"pid {proc.pid}" in err
    finally:
        proc.send_signal(signal.SIGKILL)  # a crash: no cleanup runs
        proc.wait()
    _run(tmp_path / "run").close()
    assert (tmp_path / "run" / "config.yaml").is_file()


def test_a_run_holds_its_folder_until_closed_and_its_stages_nest(tmp_path):
    run = _run(tmp_path / "run")
    try:
        stage = _run(tmp_path / "run" / "prior")  # one process: a stage inside its run is no second writer
        stage.close()
        proc = _holder(tmp_path / "run", 0)
        assert proc.stdout.readline().startswith("refused: ") and proc.wait() == 0
    finally:
        run.close()
    proc = _holder(tmp_path / "run", 0)
    assert proc.stdout.readline().strip() == "held" and proc.wait() == 0
