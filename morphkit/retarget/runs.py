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
from morphkit.retarget.retargeter import Retargeter

__all__ = ["load"]


def load(run: str | os.PathLike[str], *, stage: str | os.PathLike[str] | None = None,
         device: str | torch.device = "cpu") -> Retargeter:
    """Open a trained run folder as a :class:`Retargeter`, whichever method trained it.

    Args:
        run: An ACE run folder, an ACE retargeter stage folder, or an NKN run folder.
        stage: ACE only: the retargeter stage to use (a folder, or a variant name such as ``ace-wofea``;
            default ``retarget``).
        device: Torch device.

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
        from morphkit.retarget.ace.retarget import AceRetargeter

        return AceRetargeter(path, retarget_dir=stage, device=device)
    if NknArtifact.is_run(path):
        if stage is not None:
            raise RunError("an NKN run has one retargeter: --stage applies to ACE runs only",
                           location=SourceLocation(str(path)))
        from morphkit.retarget.nkn.retarget import NknRetargeter

        return NknRetargeter(path, device=device)
    held = sorted(p.name for p in path.iterdir())[:8] if path.is_dir() else []
    raise RunError(f"not an ACE run folder (no {ace_marker}) nor an NKN run folder (no {nkn_marker})"
                   + (f"; it holds: {', '.join(held)}" if held else "; it is empty or not a folder"),
                   location=SourceLocation(str(path)))
