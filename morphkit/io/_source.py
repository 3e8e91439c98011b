"""Helpers shared by the description readers and writers: source locations, file reading, mesh paths.

Mesh paths follow one rule across formats so that conversions keep working wherever files land:
readers resolve a relative (or ``package://``) mesh path against the description's folder and
store the result as an absolute path in :attr:`~morphkit.graph.Shape.mesh`; writers that know
their target file write mesh paths relative to the target's folder (:func:`relative_mesh_path`).
When a description is parsed from text without a path, mesh paths are kept as written.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from morphkit.errors import DescriptionError, SourceLocation
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.io.asset_paths import asset_roots, is_inside, outside_allowed

__all__ = ["location", "read_text", "relative_mesh_path", "resolve_mesh_path", "warn_wheeled_without_wheels"]


def location(source: str | None, line: int | None) -> SourceLocation:
    """A :class:`SourceLocation` for ``line`` (1-based) of ``source``."""
    return SourceLocation(source, line)


def read_text(path: str | os.PathLike[str], *, what: str) -> str:
    """Read a UTF-8 description file.

    Args:
        path: File to read.
        what: Format name used in messages ("YAML", "URDF").

    Raises:
        DescriptionError: the file is missing, unreadable or not UTF-8 text.
    """
    p = Path(path)
    where = SourceLocation(str(path))
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise DescriptionError(f"{what} file not found: {path}", location=where) from None
    except OSError as exc:
        raise DescriptionError(f"cannot read {what} file {path}: {exc.strerror or exc}", location=where) from exc
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise DescriptionError(
            f"{what} file is not UTF-8 text (byte {exc.start})", location=SourceLocation(str(path), line)
        ) from exc


def _find_package_file(uri: str, base_dir: Path) -> Path | None:
    """Resolve ``package://pkg/rest`` by searching ``base_dir`` and its parents for a folder ``pkg``."""
    rest = uri[len("package://") :]
    pkg, _, rel = rest.partition("/")
    if not pkg or not rel:
        return None
    for d in (base_dir, *base_dir.parents):
        for root in ((d,) if d.name == pkg else ()) + ((d / pkg,) if (d / pkg).is_dir() else ()):
            candidate = root / rel
            if candidate.exists():
                return candidate
    return None


def resolve_mesh_path(raw: str, source: str | None, *, loc: SourceLocation | None = None) -> str:
    """Resolve a mesh reference written in a description, warning (not failing) if the file is missing.

    ``package://pkg/path`` is searched for upwards from the description's folder (a folder named
    ``pkg``, or a folder containing one); ``file://`` is stripped; relative paths are taken
    relative to the description's folder. A path that resolves outside the description's asset
    roots (:mod:`morphkit.io.asset_paths`) is left out (returned as written) with a warning.

    Args:
        raw: The path as written in the file.
        source: Path of the description, or ``None`` when parsed from text.
        loc: Where the reference was written (for the warning).

    Returns:
        An absolute path when the description's folder is known (or the path is absolute),
        otherwise ``raw`` unchanged; an unresolvable ``package://`` URI is returned unchanged.
    """
    where = f"{loc}: " if loc is not None else ""
    base_dir = Path(source).resolve().parent if source else None
    if raw.startswith("package://"):
        found = _find_package_file(raw, base_dir) if base_dir is not None else None
        if found is None:
            warnings.warn(f"{where}mesh file not found: {raw}", stacklevel=3)
            return raw
        return str(found) if _contained(found, base_dir, raw, where) else raw
    path = raw[len("file://") :] if raw.startswith("file://") else raw
    p = Path(path)
    if not p.is_absolute():
        if base_dir is None:
            return raw
        p = base_dir / p
    p = Path(os.path.normpath(p))
    if base_dir is not None and not _contained(p, base_dir, raw, where):
        return raw
    if not p.exists():
        warnings.warn(f"{where}mesh file not found: {p}", stacklevel=3)
    return str(p)


def _contained(path: Path, base_dir: Path, raw: str, where: str) -> bool:
    """Whether mesh ``path`` may be read: inside the description's asset roots (:mod:`.asset_paths`), or
    outside paths allowed; warns when it is left out."""
    package = raw[len("package://") :].partition("/")[0] if raw.startswith("package://") else None
    if outside_allowed() or is_inside(path, asset_roots(base_dir, package=package)):
        return True
    warnings.warn(f"{where}mesh {raw} resolves to {path}, outside the description's folder and package; left out "
                  "(declare its package folder in MORPHKIT_PACKAGE_PATH, or pass --allow-outside)", stacklevel=4)
    return False


def relative_mesh_path(mesh: str, target: str | os.PathLike[str] | None) -> str:
    """The mesh path to write into a description saved as ``target``.

    Absolute paths become relative to the target's folder (so the written file and its meshes
    can be moved together); URIs and relative paths are written as they are.
    """
    if target is None or "://" in mesh or not os.path.isabs(mesh):
        return mesh
    target_dir = Path(target).resolve().parent
    try:
        return Path(os.path.relpath(mesh, target_dir)).as_posix()
    except ValueError:  # different drives on Windows
        return mesh


def warn_wheeled_without_wheels(m: Morphology, loc: SourceLocation | None, *, how: str) -> Morphology:
    """Warn when a wheeled base names no wheels (allowed: the base drives, but nothing turns with it).

    Args:
        m: The morphology just read.
        loc: Where the base was declared.
        how: How the description names wheels, for the hint (``"wheels: {joints: [...], radius: R}"``).

    Returns:
        ``m``, unchanged.
    """
    if m.base != BaseType.WHEELED or m.wheels is not None:
        return m
    spinning = [j.name for j in m.joints if j.type == JointType.CONTINUOUS]
    hint = f" (continuous joints: {', '.join(spinning)})" if spinning else ""
    where = f"{loc}: " if loc is not None else ""
    warnings.warn(
        f"{where}wheeled base without wheels: the base drives but no joint turns with it; name them with {how}{hint}",
        stacklevel=3,
    )
    return m
