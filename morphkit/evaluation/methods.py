"""The methods of a comparison: every finished retargeter of the given run folders, by Table-1 name.

An ACE run folder gives one method per finished retargeter stage (one per
:class:`~morphkit.retarget.ace.variants.AceVariant`: ACE, ACEwoFea, ACEwoAdv, ACE+contact); a stage
folder given directly gives that stage only. An NKN run folder of the cross-morphology mode gives
NKN. A folder that holds run folders gives all of theirs. Runs of one method and several seeds are
averaged in the report.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from morphkit.errors import RunError, SourceLocation
from morphkit.retarget.run_loader import trained_retargeters

__all__ = ["METHOD_ORDER", "Method", "find_methods", "method_order"]

METHOD_ORDER = ("ACE", "ACE+replan", "ACE+lock", "NKN", "NKN+replan", "NKN+lock", "ACEwoFea", "ACEwoAdv", "ACE+contact")
"""Row order of the table (the paper's Table 1 with the contact-aware exports of ACE and NKN beside their
raw rows, then morphkit's ACE+contact); other names follow."""


@dataclass(frozen=True)
class Method:
    """One trained retargeter (open it with :func:`morphkit.retarget.load` ``(run, stage=stage)``)."""

    name: str
    """Table-1 name: ``ACE``, ``ACEwoFea``, ``ACEwoAdv``, ``ACE+contact`` or ``NKN``."""
    run: Path
    """The run folder."""
    stage: Path
    """The folder of the trained networks (ACE: a retargeter stage inside ``run``; NKN: ``run``)."""
    creature: str
    seed: int


def method_order(name: str) -> tuple[int, str]:
    """Sort key of a method name: :data:`METHOD_ORDER` first, then alphabetical."""
    return (METHOD_ORDER.index(name), "") if name in METHOD_ORDER else (len(METHOD_ORDER), name)


def _methods_of(path: Path) -> list[Method]:
    out = []
    for found in trained_retargeters(path):
        if found.creature is None:
            raise RunError("an NKN run over human skeletons retargets human to human; the comparison needs its "
                           "cross-morphology mode (morphkit train nkn CREATURE)",
                           location=SourceLocation(str(found.run)))
        progress = found.progress
        if not progress.finished:
            warnings.warn(f"{found.stage}: {found.label} has trained {progress.epoch} of {progress.epochs} epochs; "
                          "left out of the comparison", stacklevel=3)
            continue
        out.append(Method(found.label, found.run, found.stage, found.creature, progress.seed))
    return out


def find_methods(paths: Sequence[str | os.PathLike[str]]) -> list[Method]:
    """Every finished retargeter of ``paths`` (run folders, ACE stage folders, folders of run folders),
    sorted by :func:`method_order`, then seed.

    Raises:
        RunError: a missing path, a folder that is no run, an NKN run of the skeletons mode, runs of
            different creatures, or no finished retargeter at all.
    """
    methods: list[Method] = []
    seen: set[Path] = set()
    for p in paths:
        for m in _methods_of(Path(p)):
            if m.stage.resolve() not in seen:
                seen.add(m.stage.resolve())
                methods.append(m)
    if not methods:
        raise RunError("no finished retargeter in the given run folders",
                       location=SourceLocation(os.fspath(paths[0])) if paths else None)
    first = methods[0]
    for m in methods[1:]:
        if m.creature != first.creature:
            raise RunError(f"run of creature {m.creature!r}, but {first.run} is of {first.creature!r}: one "
                           "comparison holds runs of one creature", location=SourceLocation(str(m.run)))
    return sorted(methods, key=lambda m: (method_order(m.name), m.seed, str(m.stage)))
