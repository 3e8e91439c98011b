"""Folder manifests: which motion files in a folder belong to the run that wrote it.

A writer of many clips into one folder (``morphkit synth --out DIR``) lists them in
``DIR/manifest.json``; readers of folders (:func:`~morphkit.motion.datasets.expand_motion_paths`, hence
``morphkit map DIR``, :func:`~morphkit.motion.datasets.load_motions` and the trainers' data) then read
exactly those files, so the leftovers of an older, larger run or files a user put beside them are
never mixed in. A manifest whose run has not finished (``"complete": false``) makes readers refuse the
folder. Folders without a manifest are read whole, as before.

The file is JSON: ``{"format": "morphkit-manifest", "version": 1, "complete": bool, "files": [names
relative to the folder, in order], ...}`` plus whatever the writer records about the run.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from morphkit._atomic import atomic_write_text
from morphkit.errors import MotionFormatError, SourceLocation

__all__ = ["MANIFEST_NAME", "manifest_files", "read_manifest", "write_manifest"]

MANIFEST_NAME = "manifest.json"
_FORMAT = "morphkit-manifest"
_VERSION = 1


def read_manifest(folder: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The manifest of ``folder`` (None when it has none, or ``manifest.json`` is someone else's file).

    Raises:
        MotionFormatError: a morphkit manifest that is not valid JSON or lists a path outside the folder.
    """
    path = Path(folder) / MANIFEST_NAME
    if not path.is_file():
        return None
    where = SourceLocation(str(path))
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        if _FORMAT.encode() in path.read_bytes():
            raise MotionFormatError(f"unreadable manifest: {exc}", location=where) from None
        return None
    if not isinstance(data, dict) or data.get("format") != _FORMAT:
        return None
    files = data.get("files")
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        raise MotionFormatError("manifest: 'files' must be a list of file names", location=where)
    for f in files:
        if Path(f).is_absolute() or ".." in Path(f).parts:
            raise MotionFormatError(f"manifest: {f!r} is not a path inside the folder", location=where)
    return data


def manifest_files(folder: str | os.PathLike[str]) -> list[Path] | None:
    """The files ``folder``'s manifest lists, in order (None without a manifest).

    Raises:
        MotionFormatError: the run that writes the folder has not finished, or a listed file is missing.
    """
    data = read_manifest(folder)
    if data is None:
        return None
    where = SourceLocation(str(Path(folder) / MANIFEST_NAME))
    if not data.get("complete", False):
        raise MotionFormatError("the run writing this folder has not finished (or was stopped): "
                                "run it again, or delete the folder", location=where)
    out = [Path(folder) / f for f in data["files"]]
    missing = [str(p.name) for p in out if not p.is_file()]
    if missing:
        raise MotionFormatError(f"manifest lists {len(missing)} missing file(s), e.g. {missing[0]}", location=where)
    return out


def write_manifest(folder: str | os.PathLike[str], files: list[str], *, complete: bool, **info: Any) -> Path:
    """Write ``folder``'s manifest atomically: ``files`` (names inside the folder, in order) and ``info``."""
    path = Path(folder) / MANIFEST_NAME
    data = {"format": _FORMAT, "version": _VERSION, "complete": bool(complete), **info, "files": list(files)}
    atomic_write_text(path, json.dumps(data, indent=1) + "\n")
    return path
