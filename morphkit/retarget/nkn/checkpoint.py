"""What a trained NKN run folder holds, and the only place its file names are spelled.

An NKN run folder::

    nkn.yaml                   mode, creature, human data, frame rate, template, the characters
    template.yaml              the source topology's skeleton
    skeletons/NAME.yaml        every training character's skeleton (the *seen* characters; NAME through
                               morphkit.output_names.safe_stem, the name itself in nkn.yaml and the file)
    source_features.npz        normalisation of the source side's features and bone offsets
    source_offsets.npz
    creature.yaml              cross-morphology mode: the creature, and its side's normalisation
    target_features.npz
    target_offsets.npz
    config.yaml, checkpoint.pt, run.yaml, metrics.csv   the training Run (:class:`~morphkit.retarget.training_run.Run`)

:class:`NknArtifact` is written once by :func:`~.train.prepare` and read by
:class:`~.retarget.NknRetargeter` and the evaluation; nothing else opens these files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from morphkit._atomic import atomic_write_text
from morphkit.errors import RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.io import read_morphology, write_morphology
from morphkit.motion import NormStats
from morphkit.output_names import safe_stem
from morphkit.retarget.training_run import required_file
from morphkit.yaml_loader import load_yaml_file, plain_data

__all__ = ["LABEL", "META_FILE", "TRAINERS", "NknArtifact"]

META_FILE = "nkn.yaml"
"""The file that makes a folder an NKN run."""
LABEL = "NKN"
"""An NKN run's retargeter's name in a comparison (Table 1)."""
_TEMPLATE = "template.yaml"
_SKELETONS = "skeletons"
_CREATURE = "creature.yaml"
_STATS = ("source_features.npz", "source_offsets.npz", "target_features.npz", "target_offsets.npz")


def _need(path: Path) -> Path:
    return required_file(path, "an NKN run folder")


def _skeleton_file(run: Path, name: str) -> Path:
    """``skeletons/<safe stem>.yaml`` of a character; a run written before names were made safe spelled a plain
    one-component name as it was, which is still read."""
    path = run / _SKELETONS / f"{safe_stem(name, default='skeleton')}.yaml"
    old = run / _SKELETONS / f"{name}.yaml"
    if not path.is_file() and Path(name).name == name and name not in ("", ".", "..") and old.is_file():
        return old
    return path


TRAINERS = ("nkn", "nkn-cross")
"""Trainer names of the two modes' Runs (same-topology, cross-morphology)."""


@dataclass(eq=False)
class NknArtifact:
    """Everything a trained NKN run needs besides its networks' checkpoint."""

    mode: str
    """``"skeletons"`` (the paper's same-topology mode) or ``"cross"`` (onto a creature)."""
    template: Morphology
    """The source topology's skeleton."""
    skeletons: dict[str, Morphology]
    """The training characters' skeletons by name."""
    source_features: NormStats
    source_offsets: NormStats
    """Normalisation of the source side (features and bone offsets)."""
    fps: float
    """Frame rate trained at [1/s]."""
    human_data: list[str] | None
    """The human data folders trained on (``None``: the embedded default)."""
    characters: list[dict[str, Any]]
    """Per character: name, origin, clips, frames, leg length (as written in ``nkn.yaml``)."""
    creature: Morphology | None = None
    """Cross mode: the creature."""
    target_features: NormStats | None = None
    target_offsets: NormStats | None = None
    """Cross mode: normalisation of the creature's side."""

    @staticmethod
    def is_run(path: str | os.PathLike[str]) -> bool:
        """Whether ``path`` is an NKN run folder."""
        return (Path(path) / META_FILE).is_file()

    @staticmethod
    def header(run_dir: str | os.PathLike[str]) -> dict[str, Any] | None:
        """``nkn.yaml`` of an existing run folder (``None``: no run there yet)."""
        path = Path(run_dir) / META_FILE
        if not path.is_file():
            return None
        return plain_data(load_yaml_file(path, what="it", error=RunError)) or {}

    def save(self, run_dir: str | os.PathLike[str]) -> None:
        """Write every file into ``run_dir`` (atomically, file by file; ``nkn.yaml`` last)."""
        run = Path(run_dir)
        (run / _SKELETONS).mkdir(parents=True, exist_ok=True)
        write_morphology(self.template, run / _TEMPLATE)
        stems: dict[str, str] = {}
        for name, skeleton in self.skeletons.items():
            stem = safe_stem(name, default="skeleton")  # a character's name never steers the path
            if stems.setdefault(stem.casefold(), name) != name:
                raise RunError(f"characters {stems[stem.casefold()]!r} and {name!r} would share the file "
                               f"{_SKELETONS}/{stem}.yaml: rename one", location=SourceLocation(str(run)))
            write_morphology(skeleton, run / _SKELETONS / f"{stem}.yaml")
        self.source_features.save(run / _STATS[0])
        self.source_offsets.save(run / _STATS[1])
        if self.creature is not None:
            if self.target_features is None or self.target_offsets is None:
                raise RunError("a cross-morphology NKN run needs its creature's statistics",
                               location=SourceLocation(str(run)))
            write_morphology(self.creature, run / _CREATURE)
            self.target_features.save(run / _STATS[2])
            self.target_offsets.save(run / _STATS[3])
        meta = {
            "mode": self.mode,
            "creature": None if self.creature is None else self.creature.name,
            "human_data": self.human_data or None,
            "fps": float(self.fps),
            "template": self.template.name,
            "characters": self.characters,
        }
        atomic_write_text(run / META_FILE, yaml.safe_dump(meta, sort_keys=False))

    @staticmethod
    def load(run_dir: str | os.PathLike[str]) -> NknArtifact:
        """Read an NKN run folder.

        Raises:
            RunError: a folder that is not an NKN run, or one with a file missing.
        """
        run = Path(run_dir)
        _need(run / META_FILE)
        meta = NknArtifact.header(run) or {}
        try:
            mode, fps, characters = str(meta["mode"]), float(meta["fps"]), list(meta["characters"])
            names = [str(c["name"]) for c in characters]
        except (KeyError, TypeError, ValueError) as exc:
            raise RunError(f"damaged NKN run folder: {exc!r}", location=SourceLocation(str(run / META_FILE))) from exc
        cross = mode == "cross"
        return NknArtifact(
            mode=mode,
            template=read_morphology(_need(run / _TEMPLATE)),
            skeletons={n: read_morphology(_need(_skeleton_file(run, n))) for n in names},
            source_features=NormStats.load(_need(run / _STATS[0])),
            source_offsets=NormStats.load(_need(run / _STATS[1])),
            fps=fps,
            human_data=meta.get("human_data"),
            characters=characters,
            creature=read_morphology(_need(run / _CREATURE)) if cross else None,
            target_features=NormStats.load(_need(run / _STATS[2])) if cross else None,
            target_offsets=NormStats.load(_need(run / _STATS[3])) if cross else None,
        )
