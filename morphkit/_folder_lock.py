"""One writer per folder: an OS-level lock file, held while a command writes there (a trainer's run folder,
``synth``'s data set, ``retarget``'s and ``evaluate``'s output folders).

:func:`hold_run_folder` takes an exclusive ``flock`` on ``RUN/.lock`` and writes the holder (pid and host) into
it; a second process asking for the folder is refused at once with :class:`~morphkit.errors.RunError` naming the
holder. The kernel drops the lock when its process exits, however it exits (a crash, ``kill -9``), so no stale
lock is ever left to clear by hand. Within one process the lock is re-entrant, and a folder inside a held one
(an ACE stage inside its run) counts as held: a train command holds its run for its whole length, the
:class:`~morphkit.retarget.training_run.Run` of each stage nests inside.

``fcntl`` is used directly rather than ``filelock``: filelock truncates the lock file before it has the lock,
which would erase the holder's name that a refused writer reports.
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

from morphkit.errors import RunError, SourceLocation

__all__ = ["LOCK_FILE", "hold_run_folder"]

LOCK_FILE = ".lock"
"""The lock file inside a run folder (it stays after release; only the OS lock on it counts)."""

_held: dict[Path, tuple[int, int]] = {}  # folder -> (fd, holds) of this process
_guard = threading.Lock()


@contextlib.contextmanager
def hold_run_folder(run_dir: str | os.PathLike[str]) -> Iterator[None]:
    """Hold ``run_dir`` (created if missing) for writing until the block ends.

    Raises:
        RunError: another process holds it (naming its pid and host), or the lock file cannot be made.
    """
    folder = Path(run_dir).absolute()
    with _guard:
        owner = next((f for f in (folder, *folder.parents) if f in _held), None)
        if owner is None:
            _held[folder] = (_acquire(folder), 0)
            owner = folder
        fd, holds = _held[owner]
        _held[owner] = (fd, holds + 1)
    try:
        yield
    finally:
        with _guard:
            fd, holds = _held[owner]
            if holds > 1:
                _held[owner] = (fd, holds - 1)
            else:
                del _held[owner]
                os.close(fd)  # closing the last descriptor releases the flock


def _acquire(folder: Path) -> int:
    import fcntl

    path = folder / LOCK_FILE
    try:
        folder.mkdir(parents=True, exist_ok=True)
        # No O_TRUNC: the current holder's name stays readable until this process has the lock.
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise RunError(f"cannot create the run folder's lock file: {exc.strerror or exc}",
                       location=SourceLocation(str(path))) from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        holder = _read_holder(fd)
        os.close(fd)
        if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            raise RunError(f"cannot lock the run folder: {exc.strerror or exc}",
                           location=SourceLocation(str(path))) from None
        raise RunError(f"run folder is in use by another morphkit command ({holder or 'holder unknown'}); wait for "
                       "it to finish or stop it, or use another folder", location=SourceLocation(str(folder))) from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"pid {os.getpid()} on host {socket.gethostname()}\n".encode(), 0)
    return fd


def _read_holder(fd: int) -> str:
    try:
        return os.pread(fd, 200, 0).decode("utf-8", "replace").strip()
    except OSError:
        return ""
