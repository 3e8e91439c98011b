"""Opening any trained run folder as a :class:`~morphkit.retarget.retargeter.Retargeter`, by what it holds.

:func:`load` recognises a run folder by its method's marker (each method's ``checkpoint`` module
says which) and refuses anything else with one clear error; :func:`trained_retargeters` lists the
retargeters a folder holds (an ACE run has one per trained variant stage) without loading their
networks. This is the one module of the trainer layer that knows every method; the methods do not
know each other. A run has finished when its :class:`~morphkit.retarget.run.RunProgress` says so.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from morphkit.errors import RunError, SourceLocation
from morphkit.retarget.retargeter import Retargeter, WithContacts
from morphkit.retarget.run import CHECKPOINT_FILE, RUN_FILE, Run, RunProgress

__all__ = ["TrainedRetargeter", "load", "trained_retargeters"]


def load(run: str | os.PathLike[str], *, stage: str | os.PathLike[str] | None = None,
         device: str | torch.device = "cpu", contacts: str = "none",
         target: str | None = None) -> Retargeter:
    """Open a trained run folder as a :class:`Retargeter`, whichever method trained it.

    A retargeter that has not finished training (:attr:`~morphkit.retarget.run.RunProgress.finished`) opens with
    its last checkpoint and a warning saying how far it got.

    Args:
        run: An ACE run folder, an ACE retargeter stage folder, or an NKN run folder.
        stage: ACE only: the retargeter stage to use (a folder, or a variant name such as ``ace-wofea``;
            default ``retarget``).
        device: Torch device.
        contacts: Contact-aware export of its motions (:data:`morphkit.synth.CONTACT_MODES`; ``none``: raw).
        target: NKN runs over human skeletons: the skeleton to retarget onto (a training character, a
            bone-length variant name or a skeleton file; default the template); see :meth:`Retargeter.with_target`.

    Raises:
        RunError: a folder no method recognises (naming what it holds), or a damaged run.
    """
    from morphkit.retarget.ace.checkpoint import META_FILE as ace_marker
    from morphkit.retarget.ace.checkpoint import AceArtifact
    from morphkit.retarget.nkn.checkpoint import META_FILE as nkn_marker
    from morphkit.retarget.nkn.checkpoint import NknArtifact

    path = Path(run)
    if not path.exists():
        raise RunError("no such run folder", location=SourceLocation(str(path)))
    if AceArtifact.is_run(path.parent) and not AceArtifact.is_run(path) and stage is None:
        path, stage = path.parent, path  # a stage folder given directly
    retargeter: Retargeter
    if AceArtifact.is_run(path):
        from morphkit.retarget.ace.retarget import AceRetargeter

        retargeter = AceRetargeter(path, retarget_dir=stage, device=device)
        folder = retargeter.stage
    elif NknArtifact.is_run(path):
        if stage is not None:
            raise RunError("an NKN run has one retargeter: --stage applies to ACE runs only",
                           location=SourceLocation(str(path)))
        from morphkit.retarget.nkn.retarget import NknRetargeter

        retargeter, folder = NknRetargeter(path, device=device), path
    else:
        held = sorted(p.name for p in path.iterdir())[:8] if path.is_dir() else []
        raise RunError(f"not an ACE run folder (no {ace_marker}) nor an NKN run folder (no {nkn_marker})"
                       + (f"; it holds: {', '.join(held)}" if held else "; it is empty or not a folder"),
                       location=SourceLocation(str(path)))
    if target is not None:
        retargeter = retargeter.with_target(target)
    progress = Run.progress(folder)
    if not progress.finished:
        warnings.warn(f"{folder}: {retargeter.label} has trained {progress.epoch} of {progress.epochs} epochs; it "
                      "retargets with its last checkpoint", stacklevel=2)
    return retargeter if contacts == "none" else WithContacts(retargeter, contacts)


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
    """How far its training got (:attr:`~morphkit.retarget.run.RunProgress.finished`, the seed)."""


def trained_retargeters(path: str | os.PathLike[str]) -> list[TrainedRetargeter]:
    """The retargeters of ``path`` that hold a checkpoint, finished or not: every trained variant stage of an ACE
    run, one stage given directly, an NKN run, or those of every run folder inside ``path``.

    Raises:
        RunError: a missing path, a folder that is no run nor holds one, a folder inside an ACE run that is none
            of its stages, an NKN run without a checkpoint, or a damaged checkpoint.
    """
    from morphkit.retarget.ace.checkpoint import AceArtifact
    from morphkit.retarget.ace.variants import AceVariant
    from morphkit.retarget.nkn.checkpoint import LABEL as NKN_LABEL
    from morphkit.retarget.nkn.checkpoint import NknArtifact

    folder = Path(path)
    if not folder.exists():
        raise RunError("no such run folder", location=SourceLocation(str(folder)))
    if AceArtifact.is_run(folder):
        return _ace_stages(folder, list(AceVariant))
    if NknArtifact.is_run(folder):
        if not (folder / CHECKPOINT_FILE).is_file():
            raise RunError("NKN run without a checkpoint (not trained yet)", location=SourceLocation(str(folder)))
        creature = (NknArtifact.header(folder) or {}).get("creature")
        return [TrainedRetargeter(NKN_LABEL, folder, folder, None if creature is None else str(creature),
                                  Run.progress(folder))]
    if (folder / RUN_FILE).is_file() and AceArtifact.is_run(folder.parent):
        variant = next((v for v in AceVariant if v.folder == folder.name), None)
        if variant is None:
            raise RunError(f"not a retargeter stage of an ACE run (stages: {', '.join(v.folder for v in AceVariant)})",
                           location=SourceLocation(str(folder)))
        return _ace_stages(folder.parent, [variant])
    children = sorted(p for p in folder.iterdir() if AceArtifact.is_run(p) or NknArtifact.is_run(p)) \
        if folder.is_dir() else []
    if not children:
        raise RunError("not an ACE or NKN run folder, nor a folder of run folders",
                       location=SourceLocation(str(folder)))
    return [r for child in children for r in trained_retargeters(child)]


def _ace_stages(run: Path, variants: list[Any]) -> list[TrainedRetargeter]:
    """The stages of ``variants`` (:class:`~morphkit.retarget.ace.variants.AceVariant`) in ACE run ``run`` that hold
    a checkpoint."""
    from morphkit.retarget.ace.checkpoint import AceArtifact

    creature = AceArtifact.creature_name(run)
    stages = [(v, run / v.folder) for v in variants]
    return [TrainedRetargeter(v.label, run, stage, creature, Run.progress(stage)) for v, stage in stages
            if (stage / CHECKPOINT_FILE).is_file()]
