"""Where a description's assets (meshes, MJCF includes) may come from: its own folder or a declared package.

A description names other files: URDF ``package://`` and relative meshes, YAML and USD meshes, MJCF includes
and asset files. Followed blindly, ``package://etc/passwd`` walks up to ``/`` and ``../../`` leaves the model's
folder. An asset path is accepted when it resolves (symbolic links followed) inside one of the description's
*asset roots*:

* the description's own folder;
* the ROS package that holds it: the nearest folder above it with a ``package.xml``;
* for ``package://PKG/...``: a folder named ``PKG`` that holds the description, or a ``PKG`` folder with a
  ``package.xml`` beside a folder above it (a sibling package of a workspace);
* every folder of ``MORPHKIT_PACKAGE_PATH`` and ``ROS_PACKAGE_PATH`` (``os.pathsep``-separated), declared roots.

Anything else is left out with a warning naming the file (meshes, MJCF meshes too), or refused (MJCF includes,
textures, height fields and skins: a model cannot be read without them), unless outside paths are allowed
(:func:`allow_outside`, the CLI's ``--allow-outside``, or ``MORPHKIT_ALLOW_OUTSIDE=1``).
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

from morphkit.errors import DescriptionError, SourceLocation

__all__ = [
    "PACKAGE_PATH_VARIABLES",
    "allow_outside",
    "asset_roots",
    "check_mjcf_files",
    "is_inside",
    "outside_allowed",
]

PACKAGE_PATH_VARIABLES = ("MORPHKIT_PACKAGE_PATH", "ROS_PACKAGE_PATH")
"""Environment variables whose folders are declared asset roots."""

_ALLOW = contextvars.ContextVar("morphkit_allow_outside", default=False)


@contextlib.contextmanager
def allow_outside(allowed: bool = True) -> Iterator[None]:
    """Within the block, accept asset paths outside a description's roots (``--allow-outside``)."""
    token = _ALLOW.set(allowed)
    try:
        yield
    finally:
        _ALLOW.reset(token)


def outside_allowed() -> bool:
    """Whether asset paths outside the roots are accepted here (:func:`allow_outside`, ``MORPHKIT_ALLOW_OUTSIDE``)."""
    return _ALLOW.get() or os.environ.get("MORPHKIT_ALLOW_OUTSIDE", "") not in ("", "0")


def asset_roots(description_dir: str | os.PathLike[str], *, package: str | None = None) -> list[Path]:
    """The folders assets of a description in ``description_dir`` may resolve into (see the module docstring).

    Args:
        description_dir: The description's folder.
        package: The ``PKG`` of a ``package://PKG/...`` reference, when resolving one.
    """
    folder = Path(description_dir).resolve()
    roots = [folder]
    above = (folder, *folder.parents)
    ros = next((d for d in above if (d / "package.xml").is_file()), None)
    if ros is not None:
        roots.append(ros)
    if package:
        roots += [d for d in above if d.name == package]
        roots += [d / package for d in above[1:] if (d / package / "package.xml").is_file()]
    for variable in PACKAGE_PATH_VARIABLES:
        roots += [Path(p).resolve() for p in os.environ.get(variable, "").split(os.pathsep) if p.strip()]
    return roots


def is_inside(path: str | os.PathLike[str], roots: Iterable[Path]) -> bool:
    """Whether ``path`` resolves (links followed, ``..`` folded) inside one of ``roots``."""
    real = Path(path).resolve()
    return any(real.is_relative_to(root) for root in roots if root != Path(root.anchor))


_MESH_DIR_TAGS = ("mesh", "hfield", "skin")


def check_mjcf_files(path: str | os.PathLike[str]) -> list[Path]:
    """Check an MJCF model's includes and asset files against its asset roots, before MuJoCo reads them.

    Paths follow MuJoCo's rules: includes relative to the main model's folder, meshes, height fields and skins
    under ``<compiler meshdir>`` (else ``assetdir``), textures under ``texturedir`` (else ``assetdir``).

    Returns:
        The mesh files outside the roots (each warned about), for the reader to leave out as it leaves out
        missing ones; empty where outside paths are allowed.

    Raises:
        DescriptionError: an include, texture, height field or skin outside the roots (a model cannot be
            read without it), at its line.
    """
    if outside_allowed():
        return []
    from lxml import etree

    model = Path(path)
    base = model.resolve().parent
    roots = asset_roots(base)
    parser = etree.XMLParser(recover=True, resolve_entities=False, no_network=True, load_dtd=False)
    dirs = {"meshdir": "", "texturedir": "", "assetdir": ""}
    todo, seen, meshes = [model.resolve()], set(), []
    while todo:
        current = todo.pop(0)
        if current in seen or not current.is_file():
            continue  # a missing file is MuJoCo's to report
        seen.add(current)
        root = etree.parse(str(current), parser).getroot()
        if root is None:
            continue
        for compiler in root.iter("compiler"):
            dirs.update({k: compiler.get(k) for k in dirs if compiler.get(k) is not None})
        for el in root.iter():
            name = el.get("file") if isinstance(el.tag, str) else None
            if name is None:
                continue
            if el.tag in _MESH_DIR_TAGS:
                folder = dirs["meshdir"] or dirs["assetdir"]
            elif el.tag == "texture":
                folder = dirs["texturedir"] or dirs["assetdir"]
            else:
                folder = ""
            target = Path(os.path.normpath(base / folder / name))
            if is_inside(target, roots):
                if el.tag == "include":
                    todo.append(target)
                continue
            where = SourceLocation(str(current), el.sourceline)
            if el.tag != "mesh":
                raise DescriptionError(
                    f"<{el.tag} file={name!r}> resolves to {target}, outside the model's folder and package; refused "
                    "(declare its package folder in MORPHKIT_PACKAGE_PATH, or pass --allow-outside)", location=where)
            meshes.append(target)
            warnings.warn(f"{where}: mesh {name} resolves to {target}, outside the model's folder and package; left "
                          "out (declare its package folder in MORPHKIT_PACKAGE_PATH, or pass --allow-outside)",
                          stacklevel=3)
    return meshes
