"""Descriptions <-> skeleton graph: read and write YAML, URDF, USD, MJCF (MuJoCo) and BVH skeletons.

:func:`read_morphology` and :func:`write_morphology` pick the format from the file suffix.
Each format module is imported only when used, so ``pxr`` (USD) loads only for USD files and
``mujoco`` only for MJCF (``.xml``) files.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from morphkit.errors import DescriptionError, SourceLocation
from morphkit.graph import Morphology
from morphkit.io.shipped import resolve_morphology

__all__ = ["READ_SUFFIXES", "WRITE_SUFFIXES", "read_morphology", "write_morphology"]

READ_SUFFIXES = (".yaml", ".yml", ".urdf", ".usd", ".usda", ".usdc", ".xml", ".bvh")
"""File suffixes :func:`read_morphology` understands."""
WRITE_SUFFIXES = (".yaml", ".yml", ".urdf", ".usd", ".usda", ".usdc", ".xml")
"""File suffixes :func:`write_morphology` understands (BVH holds motion, so it is read-only here)."""


def _reader(suffix: str) -> Callable[[str], Morphology] | None:
    if suffix in (".yaml", ".yml"):
        from morphkit.io.yaml_format import read_yaml

        return read_yaml
    if suffix == ".urdf":
        from morphkit.io.urdf import read_urdf

        return read_urdf
    if suffix in (".usd", ".usda", ".usdc"):
        from morphkit.io.usd import read_usd

        return read_usd
    if suffix == ".xml":
        from morphkit.io.mjcf import read_mjcf

        return read_mjcf
    if suffix == ".bvh":
        from morphkit.io.bvh import read_bvh_skeleton

        return read_bvh_skeleton
    return None


def _writer(suffix: str) -> Callable[[Morphology, str], None] | None:
    if suffix in (".yaml", ".yml"):
        from morphkit.io.yaml_format import write_yaml

        return write_yaml
    if suffix == ".urdf":
        from morphkit.io.urdf import write_urdf

        return write_urdf
    if suffix in (".usd", ".usda", ".usdc"):
        from morphkit.io.usd import write_usd

        return write_usd
    if suffix == ".xml":
        from morphkit.io.mjcf import write_mjcf

        return write_mjcf
    return None


def read_morphology(path: str | os.PathLike[str]) -> Morphology:
    """Read a creature description, choosing the format by suffix.

    Args:
        path: A ``.yaml``/``.yml``, ``.urdf``, ``.usd``/``.usda``/``.usdc``, ``.xml`` (MJCF) or ``.bvh`` file, a
            creature folder ``x/`` holding ``x/x.<ext>``, or the name of a shipped creature (``"spot"``,
            ``"human"``; see :func:`~morphkit.io.shipped.shipped_names`), as the CLI accepts them.

    Raises:
        DescriptionError: unknown suffix (listing the supported ones), missing file, or bad content.
        GraphError: the description is structurally invalid.
    """
    p = Path(path)
    if not p.is_file() and not p.suffix:
        # A folder or a bare name: resolve as the CLI does (its error lists the shipped names).
        p = path = resolve_morphology(path)
    where = SourceLocation(str(path))
    read = _reader(p.suffix.lower())
    if read is None:
        raise DescriptionError(
            f"unknown description format {p.suffix or '(no suffix)'!r}; supported: {', '.join(READ_SUFFIXES)}",
            location=where,
        )
    if not p.is_file():
        what = "is a folder, not a file" if p.is_dir() else "not found"
        raise DescriptionError(f"description file {what}: {path}", location=where)
    return read(str(path))


def write_morphology(m: Morphology, path: str | os.PathLike[str]) -> None:
    """Write ``m`` in the format given by the suffix of ``path`` (atomically).

    Raises:
        DescriptionError: unknown suffix (listing the supported ones), or ``m`` cannot be expressed
            in that format (e.g. a spherical joint in URDF).
    """
    p = Path(path)
    write = _writer(p.suffix.lower())
    if write is None:
        raise DescriptionError(
            f"cannot write {p.suffix or '(no suffix)'!r} files; supported: {', '.join(WRITE_SUFFIXES)}",
            location=SourceLocation(str(path)),
        )
    write(m, str(path))
