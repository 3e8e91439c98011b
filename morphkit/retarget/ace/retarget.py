"""Retargeting with a trained ACE run: human clips in, the creature's motions out.

:class:`AceRetargeter` loads a run folder (creature, statistics, mapping, start states, the prior
and a retargeter) and rolls G and π over each human clip, batched over clips. A rollout starts from
the character state (among the run's start states) whose Ψ is nearest the human's first
frame's Ψ; the generated states are decoded into a :class:`~morphkit.motion.Motion` with
:func:`~morphkit.motion.decode_character_states`, placed where the human starts (its root's ground
position and heading).

Clips are first mapped onto the canonical human (:func:`~morphkit.motion.to_canonical`), so a run
retargets mocap of any known convention (CMU-22, CMU Daz, Bandai Namco, Mixamo, LAFAN1) or of a human
shape, whatever skeleton it was trained on: every clip is checked before any is retargeted, and one that
is not a human is refused naming what it lacks. A run trained before the canonical human (no
``canonical_human`` in ``ace.yaml``) on the shipped ``human`` is taken to be canonical (it is); one
trained on another skeleton takes clips of that skeleton only, as it always did.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from morphkit.errors import ConfigError, MotionFormatError, RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion import (
    CANONICAL_HUMAN,
    Motion,
    canonical_human,
    canonical_record,
    character_state_layout,
    decode_character_states,
    human_state_from_motion,
    human_state_layout,
    to_canonical,
)
from morphkit.retarget.ace.checkpoint import PRIOR_TRAINER, AceArtifact, retargeting_generator_state
from morphkit.retarget.ace.config import PriorConfig, RetargetConfig
from morphkit.retarget.ace.model import FeatureMap, Generator, build_vae, rollout
from morphkit.retarget.ace.variants import AceVariant
from morphkit.retarget.checkpoint import load_checkpoint, load_module_state
from morphkit.retarget.config import read_config
from morphkit.retarget.retargeter import RetargetedClip, check_finite
from morphkit.retarget.training_run import CHECKPOINT_FILE, CONFIG_FILE, RUN_FILE, required_file, stage_trainer
from morphkit.rotations import yaw_from_quat

__all__ = ["AceRetargeter", "RetargetedClip", "read_prior_config"]  # RetargetedClip: from the protocol


_STAGE = "a trained ACE stage"


def read_prior_config(path: str | os.PathLike[str]) -> PriorConfig:
    """A prior stage's ``config.yaml`` (one naming a deleted option at its off value reads: ``PriorConfig.retired``)."""
    return read_config(PriorConfig, path)


def _stage_dir(run: Path, stage: str | os.PathLike[str] | None) -> Path:
    if stage is None:
        return run / AceVariant.ACE.folder
    path = Path(stage)
    if path.exists() or os.sep in str(stage):
        return path
    try:
        return run / AceVariant.parse(str(stage)).folder
    except ConfigError:
        return path


class AceRetargeter:
    """A trained ACE run, ready to retarget (``torch.no_grad``, eval mode); a
    :class:`~morphkit.retarget.retargeter.Retargeter`.

    Args:
        run_dir: The ACE run folder (:class:`~.checkpoint.AceArtifact`).
        retarget_dir: The retargeter stage to use: a folder, or a variant's name (default the run's
            ``retarget/``).
        prior_dir: The prior stage (default the run's, or the prior it shares).
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
        self.artifact = AceArtifact.load(self.dir)
        self.creature = self.artifact.creature
        self.pairing = self.artifact.pairing
        self.fps = self.artifact.fps
        self.data = self.artifact.data
        self.human_data = self.artifact.human_data
        self.device = torch.device(device)
        self.mapping: dict[str, str] = self.pairing.mapping
        prior_dir = Path(prior_dir) if prior_dir is not None else self.artifact.prior_stage(self.dir)
        retarget_dir = _stage_dir(self.dir, retarget_dir)
        if stage_trainer(prior_dir) != PRIOR_TRAINER:
            raise RunError("not an ACE prior stage", location=SourceLocation(str(prior_dir / RUN_FILE)))
        trainer = stage_trainer(retarget_dir)
        try:
            self.variant = AceVariant.parse(trainer)
        except ConfigError:
            raise RunError(f"stage of trainer {trainer!r}, not an ACE retargeter",
                           location=SourceLocation(str(retarget_dir / RUN_FILE))) from None
        self.trainer = self.variant.value
        """The stage's trainer name (``ace``, ``ace-wofea``, ...)."""
        self.label = self.variant.label
        self.stage = retarget_dir
        pc = read_prior_config(required_file(prior_dir / CONFIG_FILE, _STAGE))
        self.prior_config = pc
        self.layout = character_state_layout(self.creature)
        rc = read_config(RetargetConfig, required_file(retarget_dir / CONFIG_FILE, _STAGE))
        vae = build_vae(self.layout.dim, pc)
        prior_ckpt = required_file(prior_dir / CHECKPOINT_FILE, _STAGE)
        load_module_state(vae, load_checkpoint(prior_ckpt)["states"]["model"], path=prior_ckpt, what="the prior")
        self.prior = vae.prior.to(self.device).eval()
        self._c_stats, self._h_stats = self.artifact.character_stats, self.artifact.human_stats
        self._h_dim = self._h_stats.mean.shape[0]
        generator_ckpt = required_file(retarget_dir / CHECKPOINT_FILE, _STAGE)
        state = retargeting_generator_state(load_checkpoint(generator_ckpt)["states"])
        if "z_mean" not in state:  # trained before the latent bound: G's output is used as it was trained
            rc = dataclasses.replace(rc, latent_bound=0.0)
            state = {**state, "z_mean": torch.zeros(pc.latent), "z_std": torch.ones(pc.latent)}
        self.generator = Generator(self._h_dim, self.layout.dim, pc.latent, rc)
        load_module_state(self.generator, state, path=generator_ckpt, what="the generator")
        self.generator.to(self.device).eval()
        self.canonical: dict[str, Any] | None = self.artifact.canonical_human
        """The canonical human clips are mapped onto (``None``: clips must be of the run's own skeleton)."""
        if (self.canonical is None and self.artifact.human_skeleton == CANONICAL_HUMAN
                and self._h_dim == human_state_layout(canonical_human()).dim):
            self.canonical = canonical_record()  # trained before the record, on the canonical human itself

    def with_target(self, target: Morphology | str) -> AceRetargeter:
        """This retargeter: an ACE run retargets onto its own creature only.

        Raises:
            RunError: ``target`` is not the run's creature (by name).
        """
        if (target if isinstance(target, str) else target.name) != self.creature.name:
            raise RunError("an ACE run retargets onto its own creature: --target applies to NKN runs over human "
                           "skeletons", location=SourceLocation(str(self.dir)))
        return self

    def intake(self, clip: Motion) -> Motion:
        """``clip`` as the run reads it: on the canonical human (unless the run predates it).

        Raises:
            MotionFormatError: a clip that is not a human (naming what is missing).
        """
        return to_canonical(clip) if self.canonical is not None else clip

    def feature_map(self, human_layout_of: Motion) -> FeatureMap:
        """The run's Ψ pairing, for clips of ``human_layout_of``'s skeleton."""
        return FeatureMap(self.creature, self.layout, human_state_layout(human_layout_of.morphology), self._c_stats,
                          self._h_stats, self.pairing)

    def _human_states(self, clip: Motion) -> np.ndarray:
        if abs(clip.fps - self.fps) > 1e-6:
            clip = clip.resample(self.fps)
        x = human_state_from_motion(clip)
        if x.shape[1] != self._h_dim:
            raise MotionFormatError(
                f"clip {clip.name!r} has human states of {x.shape[1]} dims; this run was trained on "
                f"{self._h_dim} ({self.artifact.human_skeleton!r} skeleton)"
            )
        return x

    @torch.no_grad()
    def retarget(self, clips: Sequence[Motion], *, batch_size: int = 64) -> list[RetargetedClip]:
        """Retarget human clips (any length; any human skeleton, see the module docstring), batched.

        Raises:
            MotionFormatError: a clip that is not a human, or (a run from before the canonical human)
                a clip of another skeleton than the run's.
            ConfigError: no clips.
        """
        if not clips:
            raise ConfigError("no clips to retarget")
        clips = [self.intake(c) for c in clips]  # every clip checked before any is retargeted
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
        nearest = np.argmin(((self.artifact.start_psi[None] - psi_h[:, None]) ** 2).sum(-1), axis=1)
        x0 = torch.as_tensor(self._c_stats.normalize(self.artifact.start_states[nearest]), dtype=torch.float32,
                             device=self.device)
        _, gen = rollout(self.generator, self.prior, x_h, x0)
        gen_np = self._c_stats.denormalize(gen.double().cpu().numpy())
        result = []
        for clip, n, x in zip(clips, lengths, gen_np, strict=True):
            root = clip.root_pose()[0]
            start = (root[0], root[1], float(yaw_from_quat(root[3:])))
            motion, clamp = decode_character_states(x[:n], self.creature, self.fps, initial_pose=start,
                                                    name=f"{clip.name}_{self.creature.name}", layout=self.layout)
            check_finite(motion, run=self.dir, clip=clip.name)
            result.append(RetargetedClip(clip, motion, x[:n], clamp))
        return result
