"""Opening any trained run folder as a :class:`~morphkit.retarget.retargeter.Retargeter`, by what it holds.

:func:`load` recognises a run folder by its method's marker (each method's ``checkpoint`` module
says which) and refuses anything else with one clear error; :func:`trained_retargeters` lists the
retargeters a folder holds (an ACE run has one per trained variant stage) without loading their
networks. This is the one module of the trainer layer that knows every method; the methods do not
know each other. A run has finished when its :class:`~morphkit.retarget.training_run.RunProgress` says so.
"""

from __future__ import annotations

import importlib
import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from morphkit.errors import RunError, SourceLocation
from morphkit.retarget.retargeter import Retargeter, WithContacts
from morphkit.retarget.training_run import CHECKPOINT_FILE, RUN_FILE, Run, RunProgress

__all__ = ["METHODS", "Method", "TrainedRetargeter", "load", "method_of", "trained_retargeters"]


@dataclass(frozen=True)
class TrainedRetargeter:
    """A retargeter a run folder holds, found without loading its networks."""

    label: str
    """Its Table-1 name (``ACE``, ``ACEwoFea``, ``ACEwoAdv``, ``ACE+contact``, ``NKN``)."""
    run: Path
    """The run folder (``load(run, stage=stage)`` opens it)."""
    stage: Path
    """The folder of its trained networks: an ACE retargeter stage inside ``run``; ``run`` itself for NKN."""
    creature: str | None
    """The creature it retargets onto (``None``: NKN between human skeletons)."""
    progress: RunProgress
    """How far its training got (:attr:`~morphkit.retarget.training_run.RunProgress.finished`, the seed)."""


@dataclass(frozen=True)
class Method:
    """A method's run folders as this module sees them: how to recognise, open and list them.

    Each entry's functions import the method's package only when called, so listing the methods loads none.
    """

    name: str
    """Its trainer name (``morphkit train NAME``)."""
    folder: str
    """Its run folder in messages (``an ACE run folder``)."""
    checkpoint: str
    """Its module that spells its run folder's files; its ``META_FILE`` marks its run folders."""
    open: Callable[[Path, str | os.PathLike[str] | None, str | torch.device], tuple[Retargeter, Path]]
    """Its :class:`Retargeter` of ``(run, stage, device)`` and the folder whose progress says whether it has
    finished."""
    trained: Callable[[Path], list[TrainedRetargeter]]
    """The retargeters of a run folder that hold a checkpoint."""
    stage_run: Callable[[Path], Path | None] = lambda _: None
    """The run a stage folder given directly belongs to (``None``: none of its stages)."""
    trained_stage: Callable[[Path], list[TrainedRetargeter]] = lambda _: []
    """The retargeter of a folder inside one of its runs (refused where it is none of the run's stages)."""

    def marker(self) -> str:
        """The file that marks its run folders (its checkpoint module imported only now)."""
        return str(importlib.import_module(self.checkpoint).META_FILE)

    def is_run(self, path: Path) -> bool:
        """Whether folder ``path`` is one of its runs."""
        return (path / self.marker()).is_file()


def load(run: str | os.PathLike[str], *, stage: str | os.PathLike[str] | None = None,
         device: str | torch.device = "cpu", contacts: str = "none",
         target: str | None = None) -> Retargeter:
    """Open a trained run folder as a :class:`Retargeter`, whichever method trained it.

    A retargeter that has not finished training (:attr:`~morphkit.retarget.training_run.RunProgress.finished`) opens
    with its last checkpoint and a warning saying how far it got.

    Args:
        run: An ACE run folder, an ACE retargeter stage folder, or an NKN run folder.
        stage: ACE only: the retargeter stage to use (a folder, or a variant name such as ``ace-wofea``;
            default ``retarget``).
        device: Torch device.
        contacts: Contact-aware export of its motions (:data:`morphkit.contact_export.CONTACT_MODES`; ``none``: raw).
        target: NKN runs over human skeletons: the skeleton to retarget onto (a training character, a
            bone-length variant name or a skeleton file; default the template); see :meth:`Retargeter.with_target`.

    Raises:
        RunError: a folder no method recognises (naming what it holds), or a damaged run.
    """
    path = Path(run)
    if not path.exists():
        raise RunError("no such run folder", location=SourceLocation(str(path)))
    owner = next((o for o in (m.stage_run(path) for m in METHODS.values()) if o is not None), None)
    if owner is not None and stage is None:
        path, stage = owner, path  # a stage folder given directly
    method = method_of(path)
    if method is None:
        held = sorted(p.name for p in path.iterdir())[:8] if path.is_dir() else []
        raise RunError("not " + " nor ".join(f"{m.folder} (no {m.marker()})" for m in METHODS.values())
                       + (f"; it holds: {', '.join(held)}" if held else "; it is empty or not a folder"),
                       location=SourceLocation(str(path)))
    retargeter, folder = method.open(path, stage, device)
    if target is not None:
        retargeter = retargeter.with_target(target)
    progress = Run.progress(folder)
    if not progress.finished:
        warnings.warn(f"{folder}: {retargeter.label} has trained {progress.epoch} of {progress.epochs} epochs; it "
                      "retargets with its last checkpoint", stacklevel=2)
    return retargeter if contacts == "none" else WithContacts(retargeter, contacts)


def method_of(path: str | os.PathLike[str]) -> Method | None:
    """The method whose run folder ``path`` is (``None``: no method's)."""
    folder = Path(path)
    return next((m for m in METHODS.values() if m.is_run(folder)), None)


def trained_retargeters(path: str | os.PathLike[str]) -> list[TrainedRetargeter]:
    """The retargeters of ``path`` that hold a checkpoint, finished or not: every trained variant stage of an ACE
    run, one stage given directly, an NKN run, or those of every run folder inside ``path``.

    Raises:
        RunError: a missing path, a folder that is no run nor holds one, a folder inside an ACE run that is none
            of its stages, an NKN run without a checkpoint, or a damaged checkpoint.
    """
    folder = Path(path)
    if not folder.exists():
        raise RunError("no such run folder", location=SourceLocation(str(folder)))
    method = method_of(folder)
    if method is not None:
        return method.trained(folder)
    if (folder / RUN_FILE).is_file():
        owner = next((m for m in METHODS.values() if m.stage_run(folder) is not None), None)
        if owner is not None:
            return owner.trained_stage(folder)
    children = sorted(p for p in folder.iterdir() if method_of(p) is not None) if folder.is_dir() else []
    if not children:
        raise RunError("not an ACE or NKN run folder, nor a folder of run folders",
                       location=SourceLocation(str(folder)))
    return [r for child in children for r in trained_retargeters(child)]


# ---- ACE ------------------------------------------------------------------------------------------


def _ace_open(path: Path, stage: str | os.PathLike[str] | None,
              device: str | torch.device) -> tuple[Retargeter, Path]:
    from morphkit.retarget.ace.retarget import AceRetargeter

    retargeter = AceRetargeter(path, retarget_dir=stage, device=device)
    return retargeter, retargeter.stage


def _ace_stage_run(path: Path) -> Path | None:
    ace = METHODS["ace"]
    return path.parent if ace.is_run(path.parent) and not ace.is_run(path) else None


def _ace_trained(run: Path) -> list[TrainedRetargeter]:
    from morphkit.retarget.ace.variants import AceVariant

    return _ace_stages(run, list(AceVariant))


def _ace_stage(folder: Path) -> list[TrainedRetargeter]:
    """The retargeter of stage ``folder`` of an ACE run (refused when it is none of the run's stages)."""
    from morphkit.retarget.ace.variants import AceVariant

    variant = next((v for v in AceVariant if v.folder == folder.name), None)
    if variant is None:
        raise RunError(f"not a retargeter stage of an ACE run (stages: {', '.join(v.folder for v in AceVariant)})",
                       location=SourceLocation(str(folder)))
    return _ace_stages(folder.parent, [variant])


def _ace_stages(run: Path, variants: list[Any]) -> list[TrainedRetargeter]:
    """The stages of ``variants`` (:class:`~morphkit.retarget.ace.variants.AceVariant`) in ACE run ``run`` that hold
    a checkpoint."""
    from morphkit.retarget.ace.checkpoint import AceArtifact

    creature = AceArtifact.creature_name(run)
    stages = [(v, run / v.folder) for v in variants]
    return [TrainedRetargeter(v.label, run, stage, creature, Run.progress(stage)) for v, stage in stages
            if (stage / CHECKPOINT_FILE).is_file()]


# ---- NKN ------------------------------------------------------------------------------------------


def _nkn_open(path: Path, stage: str | os.PathLike[str] | None,
              device: str | torch.device) -> tuple[Retargeter, Path]:
    from morphkit.retarget.nkn.retarget import NknRetargeter

    if stage is not None:
        raise RunError("an NKN run has one retargeter: --stage applies to ACE runs only",
                       location=SourceLocation(str(path)))
    return NknRetargeter(path, device=device), path


def _nkn_trained(folder: Path) -> list[TrainedRetargeter]:
    from morphkit.retarget.nkn.checkpoint import LABEL, NknArtifact

    if not (folder / CHECKPOINT_FILE).is_file():
        raise RunError("NKN run without a checkpoint (not trained yet)", location=SourceLocation(str(folder)))
    creature = (NknArtifact.header(folder) or {}).get("creature")
    return [TrainedRetargeter(LABEL, folder, folder, None if creature is None else str(creature),
                              Run.progress(folder))]


METHODS: dict[str, Method] = {
    "ace": Method("ace", "an ACE run folder", "morphkit.retarget.ace.checkpoint", _ace_open, _ace_trained,
                  _ace_stage_run, _ace_stage),
    "nkn": Method("nkn", "an NKN run folder", "morphkit.retarget.nkn.checkpoint", _nkn_open, _nkn_trained),
}
"""Every method the trainer layer knows, by trainer name; :func:`load` and :func:`trained_retargeters` ask each
in turn (a new method adds its entry here and nowhere else in this module)."""
