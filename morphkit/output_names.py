"""The one rule for file and folder names morphkit derives from inside its inputs.

A creature's ``name:``, a URDF ``<robot name=...>``, an MJCF model name, a clip's ``name`` field, a BVH file
stem: none of them may steer where morphkit writes. Every output name built from such a name goes through
:func:`safe_stem`, which makes it one plain path component:

- path separators (``/``, ``\\``) split the name; empty, ``.`` and ``..`` parts are dropped and the rest joined
  with ``_`` (``../../escaped`` → ``escaped``, ``/tmp/x`` → ``tmp_x``): never a parent folder, never absolute;
- control and format characters (NUL, newlines, bidirectional overrides, lone surrogates) and the characters
  Windows forbids in names (``<>:"|?*``) become ``_``; unicode letters are kept (``Käfer``, ``蟹``);
- leading dots and spaces are stripped (no hidden file), so are trailing ones (Windows drops them);
- at most :data:`MAX_STEM_BYTES` bytes of UTF-8; a longer name is cut and ends in ``-`` and 8 hex digits of
  its SHA-1, so two long names that differ only past the cut stay two files;
- nothing left gives the caller's default stem (:data:`DEFAULT_STEM` unless it names another).

What a file says about itself (the real name) stays in its metadata (the NPZ ``name`` field, a manifest's
``creature``), never in its path.
"""

from __future__ import annotations

import hashlib
import re
import unicodedata
from collections.abc import Iterable

__all__ = ["DEFAULT_STEM", "MAX_STEM_BYTES", "safe_stem", "unique_stems"]

MAX_STEM_BYTES = 100
"""Longest stem in UTF-8 bytes. A path component may hold 255 bytes (ext4, XFS, APFS; NTFS 255 UTF-16
units), and morphkit appends up to about 60 to a stem: ``_synth_<seed>_<index>.npz``, ``-turntable.gif``,
``synth_<name>_<24 hex>.npz`` in the training cache, and the atomic writer's temporary
``.<stem>.<8 random>.<suffix>``. 100 bytes (100 ASCII letters, 25 to 50 CJK ones) leaves that room twice."""

DEFAULT_STEM = "unnamed"
"""The stem of a name with nothing usable in it (empty, only dots, separators or control characters)."""

_FORBIDDEN = re.compile(r'[<>:"|?*]')  # Windows-reserved: a data set copied there must still open
_SEPARATORS = re.compile(r"[/\\]")


def safe_stem(name: object, default: str = DEFAULT_STEM) -> str:
    """``name`` as one safe path component (see the module docstring for the rule).

    Args:
        name: The name from inside an input (converted with ``str``).
        default: The stem when nothing of ``name`` is left; it must itself be safe.

    Returns:
        A non-empty stem without separators, ``..``, control characters or a leading dot, of at most
        :data:`MAX_STEM_BYTES` UTF-8 bytes.
    """
    text = unicodedata.normalize("NFC", str(name))
    # Control (Cc), format (Cf: bidi overrides that disguise a name), surrogates (Cs: not encodable) and
    # unassigned code points become "_"; private-use characters are letters to whoever uses them.
    text = "".join("_" if unicodedata.category(c) in ("Cc", "Cf", "Cs", "Cn", "Zl", "Zp") else c for c in text)
    text = _FORBIDDEN.sub("_", text)
    parts = [p.strip() for p in _SEPARATORS.split(text)]
    text = "_".join(p for p in parts if p not in ("", ".", ".."))
    text = text.lstrip(". ").rstrip(". ")
    if not text:
        return default
    raw = text.encode("utf-8")
    if len(raw) <= MAX_STEM_BYTES:
        return text
    tag = "-" + hashlib.sha1(str(name).encode("utf-8", "surrogatepass")).hexdigest()[:8]
    cut = raw[: MAX_STEM_BYTES - len(tag)].decode("utf-8", "ignore").rstrip(". ")  # "ignore": a split character
    return (cut or default) + tag


def unique_stems(names: Iterable[object], default: str = DEFAULT_STEM) -> list[str]:
    """:func:`safe_stem` of each name, made distinct: a stem already taken (case-folded, as on a
    case-insensitive disk) gets ``-2``, ``-3``, ... so files of different names never overwrite each other."""
    out: list[str] = []
    taken: set[str] = set()
    for name in names:
        stem = candidate = safe_stem(name, default)
        k = 1
        while candidate.casefold() in taken:
            k += 1
            candidate = f"{stem}-{k}"
        taken.add(candidate.casefold())
        out.append(candidate)
    return out
