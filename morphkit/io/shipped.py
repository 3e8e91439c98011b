"""The creatures that ship with morphkit, found by name.

Each shipped creature is a folder ``<name>/`` holding one description ``<name>.<ext>``
(``.yaml``, ``.urdf``, ``.usda``, ...) and a README. The folders live at the repository root
(``morphologies/``) in a checkout or an editable install, and inside the package
(``morphkit/_morphologies/``) in a wheel; both places are searched, the package first.

Example:
    >>> from morphkit.io.shipped import resolve_morphology
    >>> resolve_morphology("spot").name
    'spot.urdf'
"""

from __future__ import annotations

import os
from pathlib import Path

from morphkit.errors import DescriptionError, SourceLocation

__all__ = ["SHIPPED_SUFFIXES", "resolve_morphology", "shipped_dirs", "shipped_names", "shipped_path"]

SHIPPED_SUFFIXES: tuple[str, ...] = (".yaml", ".yml", ".urdf", ".usda", ".usdc", ".usd")
"""Description suffixes a shipped creature may use, in order of preference."""

_PACKAGE_DIR = Path(__file__).resolve().parent.parent


def shipped_dirs() -> tuple[Path, ...]:
    """Folders that hold shipped creatures and exist on this install (wheel location first)."""
    candidates = [_PACKAGE_DIR / "_morphologies"]
    # The repository root only counts in a checkout (it holds pyproject.toml), never a stray
    # ``morphologies`` folder beside an installed package in site-packages.
    if (_PACKAGE_DIR.parent / "pyproject.toml").is_file():
        candidates.append(_PACKAGE_DIR.parent / "morphologies")
    return tuple(d for d in candidates if d.is_dir())


def _description_in(folder: Path) -> Path | None:
    """The description ``<folder name>.<suffix>`` inside ``folder``, if there is one."""
    for suffix in SHIPPED_SUFFIXES:
        candidate = folder / f"{folder.name}{suffix}"
        if candidate.is_file():
            return candidate
    return None


def _shipped_index() -> dict[str, Path]:
    index: dict[str, Path] = {}
    for root in shipped_dirs():
        for folder in sorted(root.iterdir()):
            if folder.is_dir() and folder.name not in index:
                description = _description_in(folder)
                if description is not None:
                    index[folder.name] = description
    return index


def shipped_names() -> tuple[str, ...]:
    """Names of the shipped creatures, sorted (e.g. ``('crab', 'human', 'spot', 'stretch')``)."""
    return tuple(sorted(_shipped_index()))


def shipped_path(name: str) -> Path:
    """Path of the description file of shipped creature ``name``.

    Raises:
        DescriptionError: ``name`` is not a shipped creature (the message lists the shipped names).
    """
    index = _shipped_index()
    try:
        return index[name]
    except (KeyError, TypeError):
        shipped = ", ".join(sorted(index)) or "none found"
        raise DescriptionError(f"no shipped creature {name!r} (shipped: {shipped})") from None


def resolve_morphology(name_or_path: str | os.PathLike[str]) -> Path:
    """Turn a user's argument into a description path.

    A path that exists wins: a file is returned as is, and a folder ``x/`` holding ``x/x.<ext>``
    (a creature folder) resolves to that description. Otherwise the argument is looked up
    among the shipped creature names (so an unrelated folder called ``spot/`` in the working
    directory does not hide the shipped ``spot``).

    Raises:
        DescriptionError: neither an existing path nor a shipped name (the message lists the
            shipped names).
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.is_dir():
        description = _description_in(path)
        if description is not None:
            return description
        if os.fspath(name_or_path) in _shipped_index():
            return _shipped_index()[os.fspath(name_or_path)]
        raise DescriptionError(
            f"folder holds no description named {path.name}.<ext> ({', '.join(SHIPPED_SUFFIXES)})",
            location=SourceLocation(str(name_or_path)),
        )
    index = _shipped_index()
    text = os.fspath(name_or_path)
    if text in index:
        return index[text]
    shipped = ", ".join(sorted(index)) or "none found"
    raise DescriptionError(
        f"no such file, and no shipped creature of that name (shipped: {shipped})",
        location=SourceLocation(text),
    )
