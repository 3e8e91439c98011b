"""The trainer layer's own rules: torch only (never Warp directly) and no creature named in its code."""

from __future__ import annotations

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "morphkit" / "retarget"
SHIPPED = ("spot", "crab", "stretch")  # "human" is the source side of every retargeter, not a creature choice


def _sources() -> list[Path]:
    files = sorted(PACKAGE.rglob("*.py"))
    assert files, PACKAGE
    return files


def test_no_module_imports_warp():
    """No module under morphkit/retarget imports warp (the kernels are reached through morphkit.torch)."""
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            assert not any(n == "warp" or n.startswith("warp.") for n in names), f"{path}:{node.lineno}"


def test_no_shipped_creature_is_named():
    """Trainer code is creature-agnostic: no shipped creature's name appears in it."""
    pattern = re.compile(rf"\b({'|'.join(SHIPPED)})\b", re.IGNORECASE)
    for path in _sources():
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            assert not pattern.search(line), f"{path}:{number}: {line.strip()}"
