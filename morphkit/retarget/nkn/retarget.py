"""Retargeting with a trained NKN run, and the copy-rotations baseline (§5 "Baseline methods").

:class:`NknRetargeter` (a :class:`~morphkit.retarget.retargeter.Retargeter`) loads a run folder and
retargets clips online (the encoder and decoder are
causal: frame ``t`` depends on frames ``≤ t`` only). The network's local output is placed in the
world by integrating its global motion (:func:`~.features.integrate_global_motion`) from where the
source clip starts (its root's ground position and heading). The release's test-time fix-ups (the
signs of the predicted velocities forced to the input's) are not applied.

:func:`copy_rotations` is the paper's best baseline with the issue's refinement: every joint
rotation and the root orientation copied, the root's ground displacement and height scaled by the
leg-length ratio of target and source.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from morphkit.errors import ConfigError, MotionFormatError, RunError, SourceLocation
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.io import read_morphology
from morphkit.motion import Motion
from morphkit.retarget.checkpoint import load_checkpoint, load_module_state
from morphkit.retarget.config import read_config
from morphkit.retarget.nkn.checkpoint import LABEL, TRAINERS, NknArtifact
from morphkit.retarget.nkn.config import NknConfig
from morphkit.retarget.nkn.features import GLOBAL_DIM, global_motion, integrate_global_motion, local_positions
from morphkit.retarget.nkn.fk import SkeletonFK
from morphkit.retarget.nkn.mapping import find_link_map, map_motion
from morphkit.retarget.nkn.model import GeneratorOutput
from morphkit.retarget.nkn.networks import build_networks, cpu_threads
from morphkit.retarget.nkn.skeleton import (
    EVALUATION_VARIANTS,
    bone_offsets,
    check_same_topology,
    scale_limbs,
    topology_difference,
)
from morphkit.retarget.retargeter import RetargetedClip, check_finite
from morphkit.retarget.training_data import DataConfig
from morphkit.retarget.training_run import CHECKPOINT_FILE, CONFIG_FILE, RUN_FILE, required_file, stage_trainer
from morphkit.rotations import quat_from_yaw, quat_multiply, quat_normalize, yaw_from_quat

__all__ = ["GLOBAL_MOTION_BOUND", "NknRetargeter", "copy_rotations", "world_motion"]

GLOBAL_MOTION_BOUND = 6.0
"""NKN's predicted global motion (root velocity, yaw rate) is clipped to this many standard deviations of
the training data's about its mean before it is integrated (ours: finite output by construction; a
clip far outside the training data once gave a non-finite root at frame 585)."""


_RUN = "an NKN run folder"


def world_motion(target: Morphology, q_local: np.ndarray, v: np.ndarray, fps: float, *,
                 start_xy: tuple[float, float] = (0.0, 0.0), start_yaw: float = 0.0, name: str = "") -> Motion:
    """A :class:`~morphkit.motion.Motion` of ``target`` from local coordinates [T, C] and global motion [T, 4].

    The base's ground position and heading come from integrating ``v``; a floating base keeps its
    local height and its orientation in the heading axes; ball-joint quaternions are normalised.
    """
    q = np.array(q_local, dtype=float, copy=True)
    xy, yaw = integrate_global_motion(v, fps, start_xy=start_xy, start_yaw=start_yaw)
    if target.base == BaseType.FLOATING:
        q[:, :2] = xy
        q[:, 3:7] = quat_normalize(quat_multiply(quat_from_yaw(yaw), q[:, 3:7]))
    elif target.base in (BaseType.PLANAR, BaseType.WHEELED):
        q[:, :2] = xy
        q[:, 2] = yaw
    for j, s in zip(target.joints, target.joint_q_start[:-1], strict=True):
        if j.type == JointType.SPHERICAL and not target.is_driven(j):
            q[:, s : s + 4] = quat_normalize(q[:, s : s + 4])
    return Motion(target, fps, q, name)


def copy_rotations(clip: Motion, target: Morphology, *, name: str | None = None) -> Motion:
    """The copy baseline: ``clip``'s coordinates on ``target`` (same topology), the root's ground
    displacement and height scaled by the leg-length ratio $r = \\ell_B / \\ell_A$.

    Raises:
        MotionFormatError: ``target`` is of another topology than the clip's skeleton.
    """
    check_same_topology(clip.morphology, target, what="target")
    q = np.array(clip.q, dtype=float, copy=True)
    if target.base == BaseType.FLOATING:
        source_leg, target_leg = clip.morphology.leg_length, target.leg_length
        r = target_leg / source_leg if source_leg > 1e-9 and target_leg > 1e-9 else 1.0
        q[:, :2] = q[0, :2] + r * (q[:, :2] - q[0, :2])
        q[:, 2] *= r
    elif target.base in (BaseType.PLANAR, BaseType.WHEELED):
        pass  # the base moves on the ground; there is no leg to scale by
    return Motion(target, clip.fps, q, name or f"{clip.name}_copy_{target.name}")


class NknRetargeter:
    """A trained NKN run, ready to retarget (``torch.no_grad``, eval mode).

    Args:
        run_dir: The run folder (see :mod:`morphkit.retarget.nkn.train`).
        device: Torch device.
        threads: torch's CPU threads while retargeting (:func:`~.networks.cpu_threads`; ``None``: unchanged).

    Raises:
        RunError: a folder that is not an NKN run, or a damaged checkpoint.
    """

    def __init__(self, run_dir: str | os.PathLike[str], *, device: str | torch.device = "cpu",
                 threads: int | None = 1, target: Morphology | str | None = None) -> None:
        self.dir = Path(run_dir)
        self.threads = threads
        self.artifact = NknArtifact.load(self.dir)
        trainer = stage_trainer(self.dir, _RUN)
        if trainer not in TRAINERS:
            raise RunError(f"run of trainer {trainer!r}, not NKN", location=SourceLocation(str(self.dir / RUN_FILE)))
        self.mode = self.artifact.mode
        self.fps = self.artifact.fps
        self.device = torch.device(device)
        self.config = read_config(NknConfig, required_file(self.dir / CONFIG_FILE, _RUN))
        self.template = self.artifact.template
        self.skeletons: dict[str, Morphology] = dict(self.artifact.skeletons)
        """The training characters' skeletons by name (the *seen* characters)."""
        self.creature: Morphology | None = self.artifact.creature
        self.label = LABEL
        self.target: Morphology | None = None
        """What :meth:`retarget` retargets onto when not told (skeletons mode: the template unless set)."""
        self.pairing = None
        nd = self.config.data
        self.data = DataConfig(character_frames=nd.character_frames, fps=self.fps, synth_seed=nd.synth_seed,
                               human_frames=nd.human_frames)
        self.human_data: str | None = (self.artifact.human_data or [None])[0]
        stats = [self.artifact.source_features, self.artifact.source_offsets]
        if self.creature is not None:
            stats += [self.artifact.target_features, self.artifact.target_offsets]
        nets = build_networks(self.config, self.template, stats[0], stats[1], self.creature,
                              *(stats[2:] if self.creature is not None else ()))
        checkpoint = required_file(self.dir / CHECKPOINT_FILE, _RUN)
        states = load_checkpoint(checkpoint)["states"]
        for name, net in nets.items():
            load_module_state(net, states[name], path=checkpoint, what=f"the {name}")
            net.to(self.device).eval()
        self.generator = nets["generator"]
        self.inverse = nets.get("inverse")
        self._source_fk = SkeletonFK(self.template)
        if target is not None:
            self.target = self.resolve_target(target)

    def with_target(self, target: Morphology | str) -> NknRetargeter:
        """This run retargeting onto ``target`` when not told otherwise (:meth:`resolve_target`; a cross-morphology
        run: its creature only); the networks are shared.

        Raises:
            ConfigError: an unknown name, or another target than a cross-morphology run's creature.
            MotionFormatError: a skeleton of another topology.
        """
        other = copy.copy(self)
        other.target = self.resolve_target(target)
        return other

    def resolve_target(self, target: Morphology | str) -> Morphology:
        """A target skeleton from a name — a training character's, or a bone-length variant of the template
        (:data:`~.skeleton.EVALUATION_VARIANTS`) — a description or BVH file, or a morphology.

        Raises:
            ConfigError: an unknown name, or a target for a cross-morphology run.
            MotionFormatError: a skeleton of another topology.
        """
        if isinstance(target, str) and self.creature is None and target not in self.skeletons:
            if target in EVALUATION_VARIANTS:
                return scale_limbs(self.template, EVALUATION_VARIANTS[target], name=target)
            if Path(target).suffix:
                return self._target(read_morphology(target))
            known = [*self.skeletons, *EVALUATION_VARIANTS]
            raise ConfigError(f"unknown target {target!r}: a training character, a bone-length variant or a "
                              f"skeleton file; names: {', '.join(known)}")
        return self._target(target)

    def _target(self, target: Morphology | str | None) -> Morphology:
        if self.creature is not None:
            if target is not None and (target if isinstance(target, str) else target.name) != self.creature.name:
                raise ConfigError(f"this run retargets onto {self.creature.name!r} only")
            return self.creature
        if target is None:
            return self.template
        if isinstance(target, str):
            if target not in self.skeletons:
                raise ConfigError(f"unknown skeleton {target!r}; expected one of: {', '.join(self.skeletons)}")
            return self.skeletons[target]
        check_same_topology(self.template, target, what="target")
        return target

    def _inputs(self, clips: Sequence[Motion], side_stats: torch.nn.Module) -> tuple[torch.Tensor, list[int]]:
        feats, lengths = [], []
        for clip in clips:
            check_same_topology(self.template, clip.morphology, what=f"clip {clip.name!r}")
            if abs(clip.fps - self.fps) > 1e-6:
                raise MotionFormatError(f"clip {clip.name!r} is at {clip.fps} fps; this run was trained at {self.fps}")
            q = torch.tensor(clip.q, dtype=torch.float64)
            off = torch.tensor(bone_offsets(clip.morphology), dtype=torch.float64)
            P = self._source_fk(q, off).numpy()
            root = clip.root_pose()
            p, v = local_positions(P, root), global_motion(root, clip.fps)
            feats.append(np.concatenate([p.reshape(len(p), -1), v], axis=1))
            lengths.append(clip.frame_count)
        T = max(lengths)
        # Clips shorter than the longest repeat their last frame; the network is causal, so tails are cut off after.
        padded = np.stack([np.concatenate([f, np.repeat(f[-1:], T - f.shape[0], 0)]) for f in feats])
        x = torch.as_tensor(padded, dtype=torch.float32, device=self.device)
        return side_stats.normalize_features(x), lengths

    @torch.no_grad()
    def _run(self, clips: Sequence[Motion], target: Morphology) -> tuple[GeneratorOutput, list[int]]:
        source_side = self.inverse.side if self.inverse is not None else self.generator.side
        with cpu_threads(self.threads):
            x, lengths = self._inputs(clips, source_side)
            off = torch.as_tensor(bone_offsets(target), dtype=torch.float32, device=self.device)
            return self.generator(x, off.expand(x.shape[0], -1, -1)), lengths

    def retarget(self, clips: Sequence[Motion], target: Morphology | str | None = None, *,
                 batch_size: int = 32) -> list[RetargetedClip]:
        """Retarget clips of the run's source topology onto ``target`` (a skeleton of that topology,
        the name of a training character, or the run's creature; default: the template / creature).
        Clips at another frame rate are resampled to the run's.

        Raises:
            ConfigError: no clips, or an unknown target name.
            MotionFormatError: a clip or target of another topology.
        """
        if not clips:
            raise ConfigError("no clips to retarget")
        tgt = self._target(target if target is not None else self.target)
        clips = [self.intake(c) for c in clips]  # every clip checked before any is retargeted
        clips = [c if abs(c.fps - self.fps) < 1e-6 else c.resample(self.fps) for c in clips]
        out: list[RetargetedClip] = []
        for lo in range(0, len(clips), batch_size):
            batch = list(clips[lo : lo + batch_size])
            result, lengths = self._run(batch, tgt)
            q = result.q.double().cpu().numpy()
            v = self._bounded(result.v.double().cpu().numpy())
            for i, (clip, n) in enumerate(zip(batch, lengths, strict=True)):
                root = clip.root_pose()[0]
                motion = world_motion(tgt, q[i, :n], v[i, :n], self.fps, start_xy=(root[0], root[1]),
                                      start_yaw=float(yaw_from_quat(root[3:])), name=f"{clip.name}_nkn_{tgt.name}")
                out.append(RetargetedClip(clip, check_finite(motion, run=self.dir, clip=clip.name)))
        return out

    def intake(self, clip: Motion) -> Motion:
        """``clip`` on the run's topology, through a shipped link map where it is of another one (e.g. a clip
        on the canonical human, as the evaluation reads them, for a run over CMU's 22 joints).

        Raises:
            MotionFormatError: a clip of another topology that no shipped link map fits (naming the difference).
        """
        if topology_difference(self.template, clip.morphology) is None:
            return clip
        link_map = find_link_map(clip.morphology, self.template)
        if link_map is None:
            check_same_topology(self.template, clip.morphology, what=f"clip {clip.name!r}")
        return map_motion(clip, self.template, link_map, skeleton_name=clip.morphology.name)

    def _bounded(self, v: np.ndarray) -> np.ndarray:
        """Global motion [..., 4] clipped to :data:`GLOBAL_MOTION_BOUND` standard deviations of the output
        side's training data about its mean (integrated, an unbounded velocity leaves the world)."""
        side = self.generator.side
        mean = side.x_mean[-GLOBAL_DIM:].double().cpu().numpy()
        std = side.x_std[-GLOBAL_DIM:].double().cpu().numpy()
        return np.clip(np.nan_to_num(v, nan=0.0), mean - GLOBAL_MOTION_BOUND * std, mean + GLOBAL_MOTION_BOUND * std)

    @torch.no_grad()
    def cycle(self, clips: Sequence[Motion], target: Morphology | str | None = None) -> list[np.ndarray]:
        """The cycle A → B → A of each clip: local link positions [T, L, 3] [m] of the reconstruction."""
        tgt = self._target(target)
        result, lengths = self._run(clips, tgt)
        back_net = self.inverse if self.inverse is not None else self.generator
        out = []
        with cpu_threads(self.threads):
            for i, (clip, n) in enumerate(zip(clips, lengths, strict=True)):
                off = torch.as_tensor(bone_offsets(clip.morphology), dtype=torch.float32, device=self.device)
                back = back_net(result.x[i : i + 1, :n], off[None])
                out.append(back.p[0].double().cpu().numpy())
        return out
