"""Opening any trained run folder as a :class:`~morphkit.retarget.retargeter.Retargeter`, by what it holds.

:func:`load` recognises a run folder by its method's marker (each method's ``checkpoint`` module
says which) and refuses anything else with one clear error. It is the one module of the trainer
layer that knows every method; the methods do not know each other.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

from morphkit.errors import RunError, SourceLocation
from morphkit.retarget.retargeter import Retargeter, WithContacts

__all__ = ["load"]


def load(run: str | os.PathLike[str], *, stage: str | os.PathLike[str] | None = None,
         device: str | torch.device = "cpu", contacts: str = "none",
         target: str | None = None) -> Retargeter:
    """Open a trained run folder as a :class:`Retargeter`, whichever method trained it.

    Args:
        run: An ACE run folder, an ACE retargeter stage folder, or an NKN run folder.
        stage: ACE only: the retargeter stage to use (a folder, or a variant name such as ``ace-wofea``;
            default ``retarget``).
        device: Torch device.
        contacts: Contact-aware export of its motions (:data:`morphkit.synth.CONTACT_MODES`; ``none``: raw).
        target: NKN runs over human skeletons: the skeleton to retarget onto (a training character, a
            bone-length variant name or a skeleton file; default the template).

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
    if AceArtifact.is_run(path):
        if target is not None:
            raise RunError("an ACE run retargets onto its own creature: --target applies to NKN runs over human "
                           "skeletons", location=SourceLocation(str(path)))
        from morphkit.retarget.ace.retarget import AceRetargeter

        return _with(AceRetargeter(path, retarget_dir=stage, device=device), contacts)
    if NknArtifact.is_run(path):
        if stage is not None:
            raise RunError("an NKN run has one retargeter: --stage applies to ACE runs only",
                           location=SourceLocation(str(path)))
        from morphkit.retarget.nkn.retarget import NknRetargeter

        return _with(NknRetargeter(path, device=device, target=target), contacts)
    held = sorted(p.name for p in path.iterdir())[:8] if path.is_dir() else []
    raise RunError(f"not an ACE run folder (no {ace_marker}) nor an NKN run folder (no {nkn_marker})"
                   + (f"; it holds: {', '.join(held)}" if held else "; it is empty or not a folder"),
                   location=SourceLocation(str(path)))


def _with(retargeter: Retargeter, contacts: str) -> Retargeter:
    return retargeter if contacts == "none" else WithContacts(retargeter, contacts)
