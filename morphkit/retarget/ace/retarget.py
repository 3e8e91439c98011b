"""Retargeting with a trained ACE run: human clips in, the creature's motions out.

:class:`AceRetargeter` loads a run folder (creature, statistics, mapping, start states, the prior
and a retargeter) and rolls G and π over each human clip, batched over clips. A rollout starts from
the character state (among the run's ``start_states.npz``) whose Ψ is nearest the human's first
frame's Ψ; the generated states are decoded into a :class:`~morphkit.motion.Motion` with
:func:`~morphkit.motion.decode_character_states`, placed where the human starts (its root's ground
position and heading).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import yaml

from morphkit.errors import ConfigError, MotionFormatError, RunError, SourceLocation
from morphkit.io import read_morphology
from morphkit.motion import (
    ClampReport,
    Motion,
    NormStats,
    character_state_layout,
    decode_character_states,
    human_state_from_motion,
    human_state_layout,
)
from morphkit.retarget.ace.config import PriorConfig, RetargetConfig
from morphkit.retarget.ace.model import FeatureMap, Generator, build_vae
from morphkit.retarget.ace.train import META_FILE, rollout
from morphkit.retarget.checkpoint import load_checkpoint
from morphkit.retarget.config import read_config
from morphkit.retarget.run import CHECKPOINT_FILE, CONFIG_FILE, RUN_FILE
from morphkit.rotations import yaw_from_quat

__all__ = ["AceRetargeter", "RetargetedClip"]


@dataclass(frozen=True)
class RetargetedClip:
    """One retargeted clip: the creature's motion, its states and what decoding clamped."""

    source: Motion
    motion: Motion
    states: np.ndarray
    """[T, Sr] generated character states (denormalised)."""
    clamp: ClampReport


def _need(path: Path) -> Path:
    if not path.exists():
        raise RunError(f"not an ACE run folder: {path.name} is missing", location=SourceLocation(str(path.parent)))
    return path


def _stage_trainer(stage: Path) -> str:
    meta = yaml.safe_load(_need(stage / RUN_FILE).read_text()) or {}
    return str(meta.get("trainer", ""))


class AceRetargeter:
    """A trained ACE run, ready to retarget (``torch.no_grad``, eval mode).

    Args:
        run_dir: The ACE run folder (see :mod:`morphkit.retarget.ace.train`).
        retarget_dir: The retargeter stage to use (default ``run_dir/retarget``; an ablation's folder).
        prior_dir: The prior stage (default ``run_dir/prior``).
        device: Torch device.

    Raises:
        RunError: a folder that is not an ACE run, a stage of another trainer, or a damaged checkpoint.
    """

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        *,
        retarget_dir: str | os.PathLike[str] | None = None,
        prior_dir: str | os.PathLike[str] | None = None,
        device: str | torch.device = "cpu",
    ) -> None:
        self.dir = Path(run_dir)
        meta = yaml.safe_load(_need(self.dir / META_FILE).read_text()) or {}
        self.meta = meta
        self.creature = read_morphology(_need(self.dir / "creature.yaml"))
        self.fps = float(meta["fps"])
        self.device = torch.device(device)
        c_stats = NormStats.load(_need(self.dir / "stats_character.npz"))
        h_stats = NormStats.load(_need(self.dir / "stats_human.npz"))
        mapping = json.loads(_need(self.dir / "mapping.json").read_text())["mapping"]
        self.mapping: dict[str, str] = dict(mapping)
        self.layout = character_state_layout(self.creature)
        with np.load(_need(self.dir / "start_states.npz")) as f:
            self.start_states, self.start_psi = f["states"], f["psi"]
        if prior_dir is None:
            prior_dir = meta.get("prior_dir") or self.dir / "prior"
        prior_dir = Path(prior_dir)
        retarget_dir = Path(retarget_dir) if retarget_dir is not None else self.dir / "retarget"
        if not _stage_trainer(prior_dir).startswith("ace-prior"):
            raise RunError("not an ACE prior stage", location=SourceLocation(str(prior_dir / RUN_FILE)))
        trainer = _stage_trainer(retarget_dir)
        if not trainer.startswith("ace"):
            raise RunError(f"stage of trainer {trainer!r}, not an ACE retargeter",
                           location=SourceLocation(str(retarget_dir / RUN_FILE)))
        self.trainer = trainer
        pc = read_config(PriorConfig, _need(prior_dir / CONFIG_FILE))
        rc = read_config(RetargetConfig, _need(retarget_dir / CONFIG_FILE))
        vae = build_vae(self.layout.dim, pc)
        vae.load_state_dict(load_checkpoint(_need(prior_dir / CHECKPOINT_FILE))["states"]["model"])
        self.prior = vae.prior.to(self.device).eval()
        self._c_stats, self._h_stats = c_stats, h_stats
        self._h_dim = h_stats.mean.shape[0]
        self.generator = Generator(self._h_dim, self.layout.dim, pc.latent, rc)
        self.generator.load_state_dict(load_checkpoint(_need(retarget_dir / CHECKPOINT_FILE))["states"]["generator"])
        self.generator.to(self.device).eval()
        self._human_length = float(meta["human_body_length"])
        self._creature_length = float(meta["creature_body_length"])

    def feature_map(self, human_layout_of: Motion) -> FeatureMap:
        """The run's Ψ pairing, for clips of ``human_layout_of``'s skeleton."""
        return FeatureMap(self.creature, self.layout, human_state_layout(human_layout_of.morphology), self._c_stats,
                          self._h_stats, tuple(self.mapping), tuple(self.mapping.values()), self._creature_length,
                          self._human_length)

    def _human_states(self, clip: Motion) -> np.ndarray:
        if abs(clip.fps - self.fps) > 1e-6:
            clip = clip.resample(self.fps)
        x = human_state_from_motion(clip)
        if x.shape[1] != self._h_dim:
            raise MotionFormatError(
                f"clip {clip.name!r} has human states of {x.shape[1]} dims; this run was trained on "
                f"{self._h_dim} ({self.meta.get('human_skeleton')!r} skeleton)"
            )
        return x

    @torch.no_grad()
    def retarget(self, clips: Sequence[Motion], *, batch_size: int = 64) -> list[RetargetedClip]:
        """Retarget human clips (any length, same skeleton as the run's human data), batched.

        Raises:
            MotionFormatError: a clip of another human skeleton.
            ConfigError: no clips.
        """
        if not clips:
            raise ConfigError("no clips to retarget")
        out: list[RetargetedClip] = []
        for lo in range(0, len(clips), batch_size):
            out += self._batch(list(clips[lo : lo + batch_size]))
        return out

    def _batch(self, clips: list[Motion]) -> list[RetargetedClip]:
        clips = [c.resample(self.fps) if abs(c.fps - self.fps) > 1e-6 else c for c in clips]
        states = [self._human_states(c) for c in clips]
        lengths = [s.shape[0] for s in states]
        T = max(lengths)
        # Clips shorter than the longest repeat their last frame; their tails are cut off afterwards.
        padded = np.stack([np.concatenate([s, np.repeat(s[-1:], T - s.shape[0], 0)]) for s in states])
        x_h = torch.as_tensor(self._h_stats.normalize(padded), dtype=torch.float32, device=self.device)
        fmap = self.feature_map(clips[0])
        psi_h = fmap.human_psi(x_h[:, 0]).cpu().numpy()
        nearest = np.argmin(((self.start_psi[None] - psi_h[:, None]) ** 2).sum(-1), axis=1)
        x0 = torch.as_tensor(self._c_stats.normalize(self.start_states[nearest]), dtype=torch.float32,
                             device=self.device)
        _, gen = rollout(self.generator, self.prior, x_h, x0)
        gen_np = self._c_stats.denormalize(gen.double().cpu().numpy())
        result = []
        for clip, n, x in zip(clips, lengths, gen_np, strict=True):
            root = clip.root_pose()[0]
            start = (root[0], root[1], float(yaw_from_quat(root[3:])))
            motion, clamp = decode_character_states(x[:n], self.creature, self.fps, initial_pose=start,
                                                    name=f"{clip.name}_{self.creature.name}")
            result.append(RetargetedClip(clip, motion, x[:n], clamp))
        return result
