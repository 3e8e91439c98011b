"""What a trained ACE run folder holds, and the only place its file names are spelled.

An ACE run folder::

    ace.yaml               creature, human data and the canonical human it was mapped onto, body lengths,
                           Ψ centres, data configuration, mapping, shared prior
    creature.yaml          the character's description (so the run retargets without the original file)
    stats_character.npz    normalisation of x^r        stats_human.npz   normalisation of x^h
    mapping.json           end-effector mapping (Eq. 11) with every KL value
    start_states.npz       character states a retargeting rollout may start from, with their Ψ
    prior/                 the motion prior's Run folder (trainer "ace-prior")
    retarget*/             one Run folder per retargeter variant (:class:`~.variants.AceVariant`)

:class:`AceArtifact` is written once by training (:func:`~.train.prepare`) and read by
retargeting, evaluation and the examples; nothing else opens these files. The pattern is Brax's
``training/agents/ppo/checkpoint.py``: the checkpoint carries what is needed to use it.
"""

from __future__ import annotations

import dataclasses
import json
import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from morphkit._atomic import atomic_path, atomic_write_text
from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.io import read_morphology, write_morphology
from morphkit.motion import CANONICAL_HUMAN, ActiveHand, NormStats, Pairing, canonical_record
from morphkit.retarget.config import config_from_dict, config_to_dict
from morphkit.retarget.training_data import DataConfig
from morphkit.retarget.training_run import required_file
from morphkit.yaml_loader import load_yaml_file, plain_data

__all__ = [
    "AVERAGE_STATE", "BEST_STATE", "META_FILE", "PRIOR_STAGE", "PRIOR_TRAINER", "AceArtifact",
    "retargeting_generator_state",
]

META_FILE = "ace.yaml"
"""The file that makes a folder an ACE run."""
PRIOR_STAGE = "prior"
"""The motion prior's stage folder inside the run (unless the run shares another run's prior)."""
AVERAGE_STATE = "generator_average"
"""The retargeter checkpoint's state of G's weight average (``retarget.generator_average``), when trained with one."""
BEST_STATE = "generator_best"
"""The retargeter checkpoint's state of the G chosen on held-out clips (``retarget.validation_share``), when trained
with them: ``loss``, ``epoch`` and the ``weights`` of G (of its average, where kept) at that epoch."""
PRIOR_TRAINER = "ace-prior"
"""The prior stage's trainer name (its ``run.yaml``)."""
_CREATURE = "creature.yaml"
_CHARACTER_STATS = "stats_character.npz"
_HUMAN_STATS = "stats_human.npz"
_MAPPING = "mapping.json"
_START_STATES = "start_states.npz"
_UNSET: Any = object()


def retargeting_generator_state(states: dict[str, Any]) -> dict[str, Any]:
    """G's weights that retarget, from a retargeter checkpoint's ``states``: those of the epoch chosen on held-out
    clips when the run chose one, else the weight average when the run kept one (a
    ``torch.optim.swa_utils.AveragedModel``'s state: ``module.``-prefixed, with its count), else G."""
    best = states.get(BEST_STATE)
    if best is not None and best["weights"]:
        return best["weights"]
    average = states.get(AVERAGE_STATE)
    if average is None:
        return states["generator"]
    return {k.removeprefix("module."): v for k, v in average.items() if k.startswith("module.")}


def _need(path: Path) -> Path:
    return required_file(path, "an ACE run folder")


def _load_start_states(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``states`` [N, Sr] and their ``psi`` [N, P] from a run's ``start_states.npz``: numbers only, never a pickle.

    Raises:
        RunError: naming the file, where it is no NPZ, lacks an array, holds objects (pickled Python data),
            or its arrays are not two finite 2-D number arrays of one length.
    """
    where = SourceLocation(str(path))
    try:
        f = np.load(path, allow_pickle=False)  # an object array would unpickle code: refused by numpy
        if not isinstance(f, np.lib.npyio.NpzFile):  # a bare .npy array
            raise RunError("damaged start states: not an NPZ archive of 'states' and 'psi'", location=where)
        with f:
            missing = [k for k in ("states", "psi") if k not in f.files]
            if missing:
                raise RunError(f"damaged start states: no array {missing[0]!r}", location=where)
            states, psi = f["states"], f["psi"]
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        text = str(exc)
        if "pickle" in text.lower() or "object" in text.lower():  # numpy's words vary by version
            text = "it holds pickled Python objects; morphkit reads numbers only"
        raise RunError(f"damaged start states: {text}", location=where) from None
    for name, a in (("states", states), ("psi", psi)):
        if a.dtype.kind not in "fiu" or a.ndim != 2 or not np.isfinite(a).all():
            raise RunError(f"damaged start states: {name!r} must be a 2-D array of finite numbers, got "
                           f"{a.dtype} {list(a.shape)}", location=where)
    if len(states) != len(psi) or not len(states):
        raise RunError(f"damaged start states: {len(states)} states but {len(psi)} psi rows", location=where)
    return states, psi


def _read_meta(run: Path) -> dict[str, Any]:
    return plain_data(load_yaml_file(_need(run / META_FILE), what="it", error=RunError)) or {}


@dataclass(eq=False)
class AceArtifact:
    """Everything a trained ACE run needs besides its networks' checkpoints."""

    creature: Morphology
    character_stats: NormStats
    """Normalisation of the character's states x^r."""
    human_stats: NormStats
    """Normalisation of the human's states x^h."""
    pairing: Pairing
    """Ψ's end-effector pairs and body lengths (Eq. 9–11)."""
    mapping: dict[str, Any]
    """The end-effector mapping with its evidence (:meth:`~morphkit.motion.EndEffectorMapping.to_json`)."""
    start_states: np.ndarray
    """[N, Sr] denormalised character states a retargeting rollout may start from."""
    start_psi: np.ndarray
    """[N, 11 + 3k] their Ψ (creature side of :attr:`pairing`)."""
    data: DataConfig
    """Frames, frame rate and seed of the character's synthesised data set."""
    human_data: str | None
    """The human data folder trained on (``None``: the embedded default human motion)."""
    human_skeleton: str
    """Name of the human data's skeleton."""
    prior_dir: str | None = None
    """Another run's prior stage this run shares (``None``: its own ``prior/``)."""
    extra: dict[str, Any] = field(default_factory=dict)
    """Other keys of ``ace.yaml``, kept as they are."""
    canonical_human: dict[str, Any] | None = _UNSET
    """The canonical human the human clips were mapped onto (:func:`~morphkit.motion.canonical_record`:
    ``skeleton``, ``height`` and ``leg_length`` [m]); ``None``: a run trained before the canonical human,
    on its data's own skeleton. Left out, it is the canonical record when :attr:`human_skeleton` is the
    canonical human (every run trained since), else ``None``."""

    def __post_init__(self) -> None:
        if self.canonical_human is _UNSET:
            self.canonical_human = canonical_record() if self.human_skeleton == CANONICAL_HUMAN else None

    @property
    def fps(self) -> float:
        """Frame rate of the run's states [1/s]."""
        return float(self.data.fps)

    @staticmethod
    def is_run(path: str | os.PathLike[str]) -> bool:
        """Whether ``path`` is an ACE run folder."""
        return (Path(path) / META_FILE).is_file()

    @staticmethod
    def creature_name(run_dir: str | os.PathLike[str]) -> str | None:
        """The creature an existing run folder was prepared for (``None``: no run there yet)."""
        run = Path(run_dir)
        return str(_read_meta(run).get("creature")) if AceArtifact.is_run(run) else None

    def prior_stage(self, run_dir: str | os.PathLike[str]) -> Path:
        """The prior's stage folder of the run at ``run_dir``."""
        return Path(self.prior_dir) if self.prior_dir else Path(run_dir) / PRIOR_STAGE

    def _meta(self) -> dict[str, Any]:
        meta: dict[str, Any] = {
            "creature": self.creature.name,
            "human_data": self.human_data,
            "human_skeleton": self.human_skeleton,
            "creature_body_length": self.pairing.creature_length,
            "human_body_length": self.pairing.human_length,
            "fps": float(self.data.fps),
            # every field, so the evaluation rebuilds the data set trained on (and a new option cannot be dropped)
            "data": config_to_dict(self.data),
            "mapping": self.pairing.mapping,
        }
        if self.pairing.centred:
            meta["psi_centre"] = {"creature": list(self.pairing.creature_centre or ()),
                                  "human": list(self.pairing.human_centre or ())}
            if self.pairing.height_centred:  # absent: a run from before the root height was centred
                meta["psi_centre"] |= {"creature_height": self.pairing.creature_height_centre,
                                       "human_height": self.pairing.human_height_centre}
        hand = self.pairing.active_hand
        if hand is not None:
            meta["active_hand"] = {"hands": list(hand.hands), "mirror": list(hand.mirror),
                                   "means": None if hand.means is None else list(hand.means), "softness": hand.softness}
        if self.prior_dir is not None:
            meta["prior_dir"] = self.prior_dir
        if self.canonical_human is not None:
            meta["canonical_human"] = dict(self.canonical_human)
        return {**self.extra, **meta}

    def save(self, run_dir: str | os.PathLike[str]) -> None:
        """Write every file into ``run_dir`` (atomically, file by file; ``ace.yaml`` last)."""
        run = Path(run_dir)
        run.mkdir(parents=True, exist_ok=True)
        write_morphology(self.creature, run / _CREATURE)
        self.character_stats.save(run / _CHARACTER_STATS)
        self.human_stats.save(run / _HUMAN_STATS)
        atomic_write_text(run / _MAPPING, json.dumps(self.mapping, indent=1))
        with atomic_path(run / _START_STATES) as tmp, open(tmp, "wb") as f:
            np.savez(f, states=self.start_states, psi=self.start_psi)
        self.save_meta(run)

    def save_meta(self, run_dir: str | os.PathLike[str]) -> None:
        """Rewrite ``ace.yaml`` only (e.g. after :attr:`prior_dir` changed)."""
        atomic_write_text(Path(run_dir) / META_FILE, yaml.safe_dump(self._meta(), sort_keys=False))

    @staticmethod
    def load(run_dir: str | os.PathLike[str]) -> AceArtifact:
        """Read an ACE run folder.

        Raises:
            RunError: a folder that is not an ACE run, or one with a file missing.
        """
        run = Path(run_dir)
        meta = _read_meta(run)
        try:
            # runs from before full_arm_travel was recorded used the partial travel
            d = {"full_arm_travel": False, **(meta.get("data") or {}), "fps": float(meta["fps"])}
            data = config_from_dict(DataConfig, d, source=str(run / META_FILE))
            mapping = json.loads(_need(run / _MAPPING).read_text())
            hand = meta.get("active_hand")
            pairing = Pairing.from_mapping(mapping["mapping"], float(meta["creature_body_length"]),
                                           float(meta["human_body_length"]), None if not hand else ActiveHand(**hand))
            centre = meta.get("psi_centre")
            if centre:
                pairing = dataclasses.replace(pairing, creature_centre=centre["creature"], human_centre=centre["human"],
                                              creature_height_centre=centre.get("creature_height"),
                                              human_height_centre=centre.get("human_height"))
        except (KeyError, TypeError, ValueError, ConfigError) as exc:
            raise RunError(f"damaged ACE run folder: {exc!r}", location=SourceLocation(str(run / META_FILE))) from exc
        states, psi = _load_start_states(_need(run / _START_STATES))
        known = {"creature", "human_data", "human_skeleton", "creature_body_length", "human_body_length", "fps",
                 "data", "mapping", "prior_dir", "psi_centre", "canonical_human", "active_hand"}
        canonical = meta.get("canonical_human")
        return AceArtifact(
            creature=read_morphology(_need(run / _CREATURE)),
            character_stats=NormStats.load(_need(run / _CHARACTER_STATS)),
            human_stats=NormStats.load(_need(run / _HUMAN_STATS)),
            pairing=pairing,
            mapping=mapping,
            start_states=states,
            start_psi=psi,
            data=data,
            human_data=meta.get("human_data"),
            human_skeleton=str(meta.get("human_skeleton", "")),
            prior_dir=meta.get("prior_dir"),
            extra={k: v for k, v in meta.items() if k not in known},
            canonical_human=dict(canonical) if isinstance(canonical, dict) else None,
        )
