"""Every example runs in its --smoke mode, as a user would run it (a subprocess from the repository root)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))
DEDICATED = {"ace_eval": "tests/evaluation", "reproduce_table1": "tests/evaluation"}
"""Examples that need a creature or run folders to start from: their own tests run them."""


def test_every_example_has_a_header_with_its_command():
    assert EXAMPLES
    for path in EXAMPLES:
        doc = path.read_text().split('"""')[1]
        assert f"python examples/{path.name}" in doc, f"{path.name}: the docstring names no command"
        assert "--smoke" in path.read_text(), f"{path.name}: no --smoke mode"


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One motion cache for every example, as on a user's machine: the embedded default human motion and a
    creature's synthesised data are made by the first example that needs them (keys hash their inputs)."""
    path = tmp_path_factory.getbasetemp() / "motion_cache"  # the same folder as tests/test_docs.py's guide test
    path.mkdir(exist_ok=True)
    return path


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_in_smoke_mode(path: Path, tmp_path: Path, cache: Path):
    if path.stem in DEDICATED:
        pytest.skip(f"run on a toy creature by {DEDICATED[path.stem]}")
    env = {**os.environ, "MORPHKIT_CACHE_DIR": str(cache), "PYOPENGL_PLATFORM": "egl"}
    cmd = [sys.executable, str(path), "--smoke", "--out", str(tmp_path / "out")]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "done in" in proc.stdout
    assert "load on device" not in proc.stdout + proc.stderr  # Warp's module-load lines are the CLI's: silenced
    outputs = [p for p in (tmp_path / "out").rglob("*") if p.is_file()]
    assert outputs, "the example wrote nothing"
