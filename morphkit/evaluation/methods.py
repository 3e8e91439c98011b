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
from morphkit.retarget.ace.checkpoint import AceArtifact
from morphkit.retarget.ace.variants import AceVariant
from morphkit.retarget.nkn.checkpoint import NknArtifact
from morphkit.retarget.run import CHECKPOINT_FILE, RUN_FILE, Run

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


def _finished(stage: Path, label: str) -> int | None:
    """The seed of a finished stage; ``None`` (with a warning) for one still training."""
    epoch, epochs, seed = Run.progress(stage)
    if epoch < epochs:
        warnings.warn(f"{stage}: {label} has trained {epoch} of {epochs} epochs; left out of the comparison",
                      stacklevel=3)
        return None
    return seed


def _ace_methods(run: Path, variants: Sequence[AceVariant] | None) -> list[Method]:
    creature = str(AceArtifact.creature_name(run))
    out = []
    for variant in variants or AceVariant:
        stage = run / variant.folder
        if not (stage / CHECKPOINT_FILE).is_file():
            continue
        seed = _finished(stage, variant.label)
        if seed is not None:
            out.append(Method(variant.label, run, stage, creature, seed))
    return out


def _nkn_method(run: Path) -> list[Method]:
    meta = NknArtifact.header(run) or {}
    if meta.get("mode") != "cross":
        raise RunError("an NKN run over human skeletons retargets human to human; the comparison needs its "
                       "cross-morphology mode (morphkit train nkn CREATURE)", location=SourceLocation(str(run)))
    if not (run / CHECKPOINT_FILE).is_file():
        raise RunError("NKN run without a checkpoint (not trained yet)", location=SourceLocation(str(run)))
    seed = _finished(run, "NKN")
    return [] if seed is None else [Method("NKN", run, run, str(meta.get("creature")), seed)]


def _is_run(path: Path) -> bool:
    return AceArtifact.is_run(path) or NknArtifact.is_run(path)


def _methods_of(path: Path) -> list[Method]:
    if not path.exists():
        raise RunError("no such run folder", location=SourceLocation(str(path)))
    if AceArtifact.is_run(path):
        return _ace_methods(path, None)
    if NknArtifact.is_run(path):
        return _nkn_method(path)
    if (path / RUN_FILE).is_file() and AceArtifact.is_run(path.parent):
        variant = next((v for v in AceVariant if v.folder == path.name), None)
        if variant is None:
            raise RunError(f"not a retargeter stage of an ACE run (stages: {', '.join(v.folder for v in AceVariant)})",
                           location=SourceLocation(str(path)))
        return _ace_methods(path.parent, [variant])
    children = sorted(p for p in path.iterdir() if _is_run(p)) if path.is_dir() else []
    if not children:
        raise RunError("not an ACE or NKN run folder, nor a folder of run folders", location=SourceLocation(str(path)))
    return [m for child in children for m in _methods_of(child)]


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
