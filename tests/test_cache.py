"""The one cache folder: every user's sub-folder lies under ``$MORPHKIT_CACHE_DIR`` (default ``~/.cache/morphkit``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from morphkit._version import __version__
from morphkit.cache import CACHE_ENV, cache_dir


def test_every_cache_user_follows_the_one_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    from morphkit.kernels.fk import kernel_cache_dir
    from morphkit.motion.datasets import default_cache_dir

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    assert cache_dir() == tmp_path
    assert default_cache_dir() == tmp_path / "motions"
    assert kernel_cache_dir() == tmp_path / __version__ / "kernels"
    monkeypatch.delenv(CACHE_ENV)
    assert default_cache_dir() == Path.home() / ".cache" / "morphkit" / "motions"
