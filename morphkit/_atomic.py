"""Atomic writes: write to a temporary file beside the target, then rename into place.

A crash or a bad input never leaves a half-written file where a user's file was.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "check_writable"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    The temporary name keeps the target's suffix, so format-sniffing writers (USD, imageio)
    still see the right extension. An ``OSError`` while writing (a full disk) names ``path``, not the
    temporary file.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent)
    except OSError as exc:  # a read-only folder: name the user's file, not the temporary name tried
        raise type(exc)(exc.errno, exc.strerror or str(exc), os.fspath(path)) from None
    os.close(fd)
    tmp_path = Path(tmp)
    # mkstemp creates 0600; give the file the mode a plain open() would (an existing file keeps its own).
    mode = target.stat().st_mode & 0o777 if target.exists() else 0o666 & ~_umask()
    os.chmod(tmp_path, mode)
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except OSError as exc:
        # Name the user's file, not the temporary one (or none, as a full disk's write error does).
        if exc.filename is None or os.fspath(exc.filename) == os.fspath(tmp_path):
            raise type(exc)(exc.errno, exc.strerror or str(exc), os.fspath(path)) from exc
        raise
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def check_writable(path: str | os.PathLike[str]) -> None:
    """Raise unless :func:`atomic_path` could write ``path``: call it before work whose result goes there.

    ``path`` must not be a folder, and a file must be creatable in its folder (or, where that folder does
    not exist yet, in the nearest one above it, which :func:`atomic_path` would create it from). A probe
    file is created and removed; no folder is created.

    Raises:
        OSError: ``IsADirectoryError``, ``NotADirectoryError`` or the error creating the probe (for example
            ``PermissionError``), with ``filename`` set to ``path``.
    """
    target = Path(path)
    if target.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file", os.fspath(path))
    folder = target.absolute().parent
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    if not folder.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, f"{folder} is not a folder", os.fspath(path))
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".probe", dir=folder)
    except OSError as exc:
        raise type(exc)(exc.errno, f"cannot write in {folder}: {exc.strerror or exc}", os.fspath(path)) from None
    os.close(fd)
    os.unlink(probe)


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
