"""morphkit's cache folder: the one root of everything it can regenerate (kernel sources, converted motion,
synthesised data).

``$MORPHKIT_CACHE_DIR`` when set, else ``~/.cache/morphkit``; each user keeps its own sub-folder.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["CACHE_ENV", "cache_dir"]

CACHE_ENV = "MORPHKIT_CACHE_DIR"
"""The environment variable that moves the cache folder."""


def cache_dir(*parts: str) -> Path:
    """The cache folder, or its sub-folder ``parts`` (``cache_dir("motions")``); read from the environment at
    each call, so a test or a forked worker that sets :data:`CACHE_ENV` is followed. Nothing is created."""
    root = os.environ.get(CACHE_ENV)
    return (Path(root) if root else Path.home() / ".cache" / "morphkit").joinpath(*parts)
