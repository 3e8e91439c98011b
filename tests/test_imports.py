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


def _private_names_used_across_modules(path: Path) -> list[str]:
    """``from m import _x`` and ``alias._x`` (``alias`` a morphkit module) where ``_x`` is not a module of its own."""
    import ast
    import importlib.util

    def is_module(name: str) -> bool:
        try:
            return importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):
            return False

    tree = ast.parse(path.read_text(), str(path))
    aliases: dict[str, str] = {}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("morphkit"):
            for a in node.names:
                aliases[a.asname or a.name] = f"{node.module}.{a.name}"
                private = a.name.startswith("_") and not a.name.startswith("__")
                if private and not is_module(f"{node.module}.{a.name}"):
                    found.append(f"{path}:{node.lineno}: from {node.module} import {a.name}")
        elif isinstance(node, ast.Import):
            aliases.update({a.asname: a.name for a in node.names if a.asname and a.name.startswith("morphkit")})
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and node.attr.startswith("_") and not node.attr.startswith("__")
                and is_module(aliases[node.value.id]) and not is_module(f"{aliases[node.value.id]}.{node.attr}")):
            found.append(f"{path}:{node.lineno}: {node.value.id}.{node.attr} ({aliases[node.value.id]})")
    return found


def test_no_module_uses_another_modules_private_names():
    """A helper several modules share gets a public name in one module (private modules of a package are fine)."""
    found = [hit for p in sorted((ROOT / "morphkit").rglob("*.py")) for hit in _private_names_used_across_modules(p)]
    assert not found, "\n".join(found)
