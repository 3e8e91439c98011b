"""`import morphkit` stays light, and the layer contract holds."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_import_morphkit_loads_no_heavy_dependencies():
    """Importing morphkit (and its graph and io facades) loads no torch, pxr or pyrender."""
    code = (
        "import sys, morphkit, morphkit.graph, morphkit.io, morphkit.cli;"
        "heavy = [m for m in ('torch', 'pxr', 'pyrender', 'warp') if m in sys.modules];"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == ""


def test_import_layers_contract():
    """import-linter's contracts in pyproject.toml (imports only point down) are kept."""
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(exe).exists():
        pytest.skip("import-linter is not installed (pip install -e '.[dev]')")
    out = subprocess.run([exe, "--no-cache"], check=False, capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
