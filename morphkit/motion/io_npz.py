"""Motions as NumPy ``.npz`` files: the coordinates plus the morphology, self-contained.

Keys: ``q`` [T, C] float64, ``fps`` (scalar), ``name`` (string), ``morphology_yaml`` (the
morphology as YAML creature text, :func:`morphkit.io.yaml_format.dump_yaml`) and
``format_version`` (1). Any extra arrays are ignored by the reader.
"""

from __future__ import annotations

import os
import zipfile

import numpy as np

from morphkit._atomic import atomic_path
from morphkit.errors import MotionFormatError, SourceLocation
from morphkit.graph import Morphology
from morphkit.io.yaml_format import dump_yaml, parse_yaml
from morphkit.motion.motion import Motion

__all__ = ["FORMAT_VERSION", "read_npz_motion", "read_npz_motion_with_extra", "write_npz_motion"]

FORMAT_VERSION = 1

_REQUIRED = ("q", "fps", "morphology_yaml")

_yaml_cache: dict[str, Morphology] = {}
"""Parsed morphologies by YAML text: clips of one subject share one skeleton, parse it once."""


def write_npz_motion(motion: Motion, path: str | os.PathLike[str], **extra: np.ndarray) -> None:
    """Write ``motion`` (and optional ``extra`` arrays) to ``path`` as ``.npz``, atomically."""
    reserved = set(extra) & {*_REQUIRED, "name", "format_version"}
    if reserved:
        raise MotionFormatError(f"extra arrays may not use the reserved keys {sorted(reserved)}")
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(
            f,
            q=motion.q,
            fps=np.float64(motion.fps),
            name=np.str_(motion.name),
            morphology_yaml=np.str_(dump_yaml(motion.morphology)),
            format_version=np.int64(FORMAT_VERSION),
            **extra,
        )


def read_npz_motion(path: str | os.PathLike[str]) -> Motion:
    """Read a motion written by :func:`write_npz_motion`.

    Raises:
        MotionFormatError: not an npz archive, a missing key, or coordinates that do not fit the
            stored morphology.
        DescriptionError: the stored morphology text is invalid (located in ``<path>#morphology_yaml``).
    """
    return read_npz_motion_with_extra(path)[0]


def read_npz_motion_with_extra(path: str | os.PathLike[str]) -> tuple[Motion, dict[str, np.ndarray]]:
    """Like :func:`read_npz_motion`, also returning the extra arrays stored beside the motion."""
    where = SourceLocation(str(path))
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in _REQUIRED if k not in data.files]
            if missing:
                raise MotionFormatError(f"not a morphkit motion: missing {', '.join(missing)}", location=where)
            version = int(data["format_version"]) if "format_version" in data.files else FORMAT_VERSION
            if version > FORMAT_VERSION:
                raise MotionFormatError(
                    f"motion format version {version} is newer than this morphkit reads ({FORMAT_VERSION})",
                    location=where,
                )
            q = np.asarray(data["q"], dtype=np.float64)
            fps = float(data["fps"])
            name = str(data["name"]) if "name" in data.files else os.path.splitext(os.path.basename(path))[0]
            text = str(data["morphology_yaml"])
            extra = {k: np.asarray(data[k]) for k in data.files if k not in {*_REQUIRED, "name", "format_version"}}
    except (zipfile.BadZipFile, ValueError, EOFError, TypeError) as exc:
        raise MotionFormatError(f"not a readable .npz motion: {exc}", location=where) from None
    morphology = _yaml_cache.get(text)
    if morphology is None:
        morphology = parse_yaml(text, source=f"{path}#morphology_yaml")
        if len(_yaml_cache) > 256:
            _yaml_cache.clear()
        _yaml_cache[text] = morphology
    try:
        motion = Motion(morphology, fps, q, name)
    except MotionFormatError as exc:
        raise MotionFormatError(exc.message, location=where) from None
    return motion, extra
