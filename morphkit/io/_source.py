"""Helpers shared by the description readers and writers: source locations, file reading, mesh paths.

Mesh paths follow one rule across formats so that conversions keep working wherever files land:
readers resolve a relative (or ``package://``) mesh path against the description's folder and
store the result as an absolute path in :attr:`~morphkit.graph.Shape.mesh`; writers that know
their target file write mesh paths relative to the target's folder (:func:`relative_mesh_path`).
When a description is parsed from text without a path, mesh paths are kept as written.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from morphkit.errors import DescriptionError, SourceLocation
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.io.asset_paths import asset_roots, is_inside, outside_allowed

__all__ = ["location", "mesh_warnings", "parse_xml", "read_text", "relative_mesh_path", "resolve_mesh_path",
           "warn_wheeled_without_wheels"]

_ENTITY_DECL = re.compile(r"<!ENTITY", re.IGNORECASE)
_XML_DECL = re.compile(r"^(\ufeff?\s*<\?xml[^>]*?)\s+encoding\s*=\s*(['\"])[^'\"]*\2")


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


def parse_xml(text: str, source: str | None, *, what: str = "URDF") -> Any:
    """Parse XML text with a hardened lxml parser (no entities, DTDs, network or huge trees); the root element.

    Args:
        text: The document.
        source: Path it came from (for error locations).
        what: Format name used in messages ("URDF", "SRDF").

    Raises:
        DescriptionError: malformed XML, or a document that declares or references entities (XML bombs,
            external entities are refused before any parser expands them), at its line.
    """
    from lxml import etree

    where = SourceLocation(source)
    m = _ENTITY_DECL.search(text)
    if m is not None:
        raise DescriptionError(
            "refusing an XML document that declares entities (<!ENTITY ...>): entity expansion and "
            f"external entities are not allowed in {what} files",
            location=where.at_line(text.count("\n", 0, m.start()) + 1),
        )
    # lxml refuses str input that carries an encoding declaration; we hand it UTF-8 bytes instead.
    data = _XML_DECL.sub(r"\1", text, count=1).encode("utf-8", errors="replace")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False,
                             remove_comments=True, remove_pis=True)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if isinstance(exc.lineno, int) and exc.lineno > 0 else None
        msg = exc.msg or str(exc)
        raise DescriptionError(f"malformed XML: {msg}", location=where.at_line(line)) from exc
    except (etree.LxmlError, ValueError, LookupError) as exc:
        raise DescriptionError(f"malformed XML: {exc}", location=where) from exc
    if root is None:
        raise DescriptionError("empty XML document", location=where)
    dtd = root.getroottree().docinfo.internalDTD
    if dtd is not None and any(True for _ in dtd.iterentities()):
        raise DescriptionError("refusing an XML document that declares entities", location=where)
    for el in root.iter():
        if not isinstance(el.tag, str):  # entity references, or anything else that is not an element
            raise DescriptionError(
                f"refusing XML entity references in a {what} file", location=where.at_line(el.sourceline)
            )
    return root


def _package_parts(uri: str) -> tuple[str, str]:
    """``(pkg, rest)`` of ``package://pkg/rest``; leading slashes skipped, as Pinocchio reads them (example-robot-data's
    ``talos_full_v2.urdf`` writes ``package:///example-robot-data/...``)."""
    pkg, _, rel = uri[len("package://") :].lstrip("/").partition("/")
    return pkg, rel


def _find_package_file(uri: str, base_dir: Path) -> Path | None:
    """Resolve ``package://pkg/rest`` by searching ``base_dir`` and its parents for a folder ``pkg``."""
    pkg, rel = _package_parts(uri)
    if not pkg or not rel:
        return None
    for d in (base_dir, *base_dir.parents):
        for root in ((d,) if d.name == pkg else ()) + ((d / pkg,) if (d / pkg).is_dir() else ()):
            candidate = root / rel
            if candidate.exists():
                return candidate
    return None


_MESH_NOTES: contextvars.ContextVar[dict[str, list[tuple[str, str]]] | None] = contextvars.ContextVar(
    "morphkit_mesh_notes", default=None)
"""Inside :func:`mesh_warnings`: per kind (``missing``, ``outside``), the ``(where, path)`` of each mesh."""


@contextlib.contextmanager
def mesh_warnings(source: str | None) -> Iterator[None]:
    """Within the block, meshes :func:`resolve_mesh_path` cannot find or leaves out are told in one warning per
    kind for the whole file (a URDF written on another machine names hundreds of absolute paths), not one each.

    A single mesh keeps its own message (with its line); several give ``N mesh files not found, e.g. ...``. Nothing
    is said when the block raises (the error is what matters).
    """
    notes: dict[str, list[tuple[str, str]]] = {"missing": [], "outside": []}
    token = _MESH_NOTES.set(notes)
    try:
        yield
    finally:
        _MESH_NOTES.reset(token)
    file = f"{source}: " if source else ""
    missing, outside = notes["missing"], notes["outside"]
    if len(missing) == 1:
        warnings.warn(f"{missing[0][0]}mesh file not found: {missing[0][1]}", stacklevel=3)
    elif missing:
        where, first = missing[0]
        warnings.warn(f"{where or file}{len(missing)} mesh files not found, e.g. {first}; their shapes are kept as "
                      "paths without geometry (drawn as the link's other shapes or a stand-in)", stacklevel=3)
    if len(outside) == 1:
        warnings.warn(outside[0][1], stacklevel=3)
    elif outside:
        where, first = outside[0]
        warnings.warn(f"{where or file}{len(outside)} meshes resolve outside the description's folder and package, "
                      f"e.g. {first.split(' resolves to ')[0].removeprefix(where + 'mesh ')}; left out (declare their "
                      "package folder in MORPHKIT_PACKAGE_PATH, or pass --allow-outside)", stacklevel=3)


def _note(kind: str, where: str, text: str) -> None:
    """A missing mesh (``text`` its path) or one left out (``text`` the whole message): collected inside
    :func:`mesh_warnings`, else warned at once."""
    notes = _MESH_NOTES.get()
    if notes is not None:
        notes[kind].append((where, text))
    else:
        warnings.warn(f"{where}mesh file not found: {text}" if kind == "missing" else text, stacklevel=4)


def resolve_mesh_path(raw: str, source: str | None, *, loc: SourceLocation | None = None) -> str:
    """Resolve a mesh reference written in a description, warning (not failing) if the file is missing.

    ``package://pkg/path`` is searched for upwards from the description's folder (a folder named
    ``pkg``, or a folder containing one); ``file://`` is stripped; relative paths are taken
    relative to the description's folder. A path that resolves outside the description's asset
    roots (:mod:`morphkit.io.asset_paths`) is left out (returned as written) with a warning; one that does not
    exist there either (an absolute path from the machine the file was written on) is told as not found.
    Inside :func:`mesh_warnings` the warnings are gathered into one per file.

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
            _note("missing", where, raw)
            return raw
        return str(found) if _contained(found, base_dir, raw, where) else raw  # type: ignore[arg-type]
    path = raw[len("file://") :] if raw.startswith("file://") else raw
    p = Path(path)
    if not p.is_absolute():
        if base_dir is None:
            return raw
        p = base_dir / p
    p = Path(os.path.normpath(p))
    if not p.exists():
        _note("missing", where, str(p))
        return str(p) if base_dir is None or _inside(p, base_dir, raw) else raw
    if base_dir is not None and not _contained(p, base_dir, raw, where):
        return raw
    return str(p)


def _inside(path: Path, base_dir: Path, raw: str) -> bool:
    """Whether mesh ``path`` may be read: inside the description's asset roots (:mod:`.asset_paths`), or outside
    paths allowed."""
    package = _package_parts(raw)[0] if raw.startswith("package://") else None
    return outside_allowed() or is_inside(path, asset_roots(base_dir, package=package))


def _contained(path: Path, base_dir: Path, raw: str, where: str) -> bool:
    """:func:`_inside`, warning when the mesh is left out."""
    if _inside(path, base_dir, raw):
        return True
    _note("outside", where, f"{where}mesh {raw} resolves to {path}, outside the description's folder and package; "
          "left out (declare its package folder in MORPHKIT_PACKAGE_PATH, or pass --allow-outside)")
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
