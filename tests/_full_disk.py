"""Run a command as if its disk were full: a file-size limit (``RLIMIT_FSIZE``) makes every write past
``limit`` bytes fail with ``EFBIG``, as ``ENOSPC`` would on a full disk. No root, no mount; the limit is
inherited by the command's own children (ffmpeg)."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

MORPHKIT = [sys.executable, "-m", "morphkit.cli"]
"""The morphkit CLI of the interpreter running the tests."""


def run_on_full_disk(args: Sequence[str], *, limit: int, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run ``args`` in ``cwd`` with writes past ``limit`` bytes failing (``EFBIG``, not a ``SIGXFSZ`` kill)."""

    def limit_file_size() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run(list(args), check=False, cwd=cwd, capture_output=True, text=True, preexec_fn=limit_file_size,
                          env=env, timeout=300)


def assert_failed_cleanly(result: subprocess.CompletedProcess[str], out: Path) -> str:
    """Exit 2 with one ``error:`` line naming ``out`` and no traceback; nothing (no temporary file) left
    in ``out``'s folder. Returns the error line."""
    lines = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
    assert result.returncode == 2, result.stderr[-2000:]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr[-2000:]
    assert "Traceback" not in result.stderr and len(lines[0]) < 400, lines[0][:1000]
    assert str(out) in lines[0] and "/." not in lines[0], lines[0]  # names OUT, not a temporary file
    assert "wrote" not in result.stdout
    assert list(out.parent.iterdir()) == [], list(out.parent.iterdir())
    return lines[0]
