"""Training NKN: adversarial cycle consistency through the FK layer (§4.2, Eq. 8–16, App. E).

Two modes share one loop:

* **skeletons** (the paper): sources and targets are skeletons of one topology with different bone
  lengths. Per batch item a 60-frame clip of character A, a target skeleton B drawn from every
  training character (B := A with probability 0.2), and a real clip of B for the discriminator;
  $\\hat x^B = f(x^A, \\bar s^B)$, $\\hat x^A = f(\\hat x^B, \\bar s^A)$ with one shared network.
* **cross** (ACE §7.3, after Aberman et al. 2020): human → any creature. Two networks,
  $f_{hr}$ (human to creature, the creature's FK) and $f_{rh}$ (back, the human's FK); the cycle
  $x^h \\to \\hat x^r \\to \\hat x^h$ and the adversarial term on $\\hat x^r$ against the creature's
  synthesised motion; the reconstruction (B = A) loss is removed, since the domains differ.

G's loss: cycle + same-skeleton square loss + λ·twist + ω·smoothing + β·adversarial. D's step runs
only while the running mean of $g(\\hat x^B)$ (decay 0.99, from 0.5) is above 0.3 (App. E, as the
release). Both networks: Adam (β1 = 0.5), gradients clipped at global norm 25.

The run folder's files are :class:`~.checkpoint.NknArtifact`'s (written here once, by :func:`prepare`), beside
the training Run's (trainer ``nkn`` or ``nkn-cross``).

Re-running the same command resumes exactly (:class:`~morphkit.retarget.training_run.Run`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from morphkit.errors import RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.motion import NormStats
from morphkit.retarget.distributed import is_main_process
from morphkit.retarget.networks import frozen_parameters
from morphkit.retarget.nkn.checkpoint import META_FILE, TRAINERS, NknArtifact
from morphkit.retarget.nkn.config import NknConfig
from morphkit.retarget.nkn.data import Character, ClipBank, offset_stats, training_characters
from morphkit.retarget.nkn.losses import (
    discriminator_loss,
    generator_adversarial_loss,
    smoothing_loss,
    squared_error,
    twist_loss,
)
from morphkit.retarget.nkn.model import NknGenerator, motion_differences
from morphkit.retarget.nkn.networks import build_networks, cpu_threads
from morphkit.retarget.training_data import HumanData, as_folders, character_motions
from morphkit.retarget.training_run import Run

__all__ = ["NknSetup", "prepare", "train_nkn"]


@dataclass(eq=False)
class NknSetup:
    """What a run trains on, prepared once per run folder."""

    mode: str
    """``"skeletons"`` or ``"cross"``."""
    template: Morphology
    characters: list[Character]
    source: ClipBank
    source_features: NormStats
    source_offsets: NormStats
    creature: Character | None = None
    target: ClipBank | None = None
    target_features: NormStats | None = None
    target_offsets: NormStats | None = None


def _joint_mean(character: Character) -> np.ndarray:
    return np.concatenate([c.q for c in character.clips]).mean(axis=0)


def prepare(
    run_dir: str | os.PathLike[str],
    cfg: NknConfig,
    *,
    human_data: HumanData | None = None,
    creature: Morphology | None = None,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = False,
    log: Callable[[str], None] = print,
) -> NknSetup:
    """Load the characters (and the creature's synthesised motion), fit normalisation, write the run's files.

    Raises:
        RunError: a run folder of another mode or creature.
    """
    run = Path(run_dir)
    mode = "skeletons" if creature is None else "cross"
    meta = NknArtifact.header(run)
    if meta is not None:
        mine = None if creature is None else creature.name
        if meta.get("mode") != mode or meta.get("creature") != mine:
            raise RunError(f"run folder is an NKN {meta.get('mode')} run (creature {meta.get('creature')!r}), "
                           f"not {mode} (creature {mine!r}); use another run folder",
                           location=SourceLocation(str(run / META_FILE)))
    characters = training_characters(human_data, cfg.data, progress=progress, log=log)
    if creature is not None:  # cross mode: sources are the characters with motion only
        characters = [c for c in characters if c.clips]
    template = characters[0].morphology
    source = ClipBank(characters, template, cfg.clip_frames, fk_backend=cfg.fk_backend)
    feats, offs = source.stats(min_std=cfg.feature_min_std), offset_stats(characters, min_std=cfg.offset_min_std)
    with_clips = [c for c in characters if c.clips]
    log(f"characters: {len(with_clips)} with motion ({sum(len(c.clips) for c in with_clips)} clips, "
        f"{source.x.shape[0]} frames), {len(characters) - len(with_clips)} target-only variants")
    setup = NknSetup(mode, template, characters, source, feats, offs)
    if creature is not None:
        target = Character(creature, character_motions(creature, cfg.data, cache_dir=cache_dir, progress=progress,
                                                       log=log), "creature")
        setup.creature = target
        setup.target = ClipBank([target], creature, cfg.clip_frames, fk_backend=cfg.fk_backend)
        setup.target_features = setup.target.stats(min_std=cfg.feature_min_std)
        setup.target_offsets = offset_stats([target], min_std=cfg.offset_min_std)
    if is_main_process():
        NknArtifact(mode, template, {c.name: c.morphology for c in characters}, feats, offs, float(cfg.data.fps),
                    [os.fspath(f) for f in as_folders(human_data)] or None,
                    [{"name": c.name, "origin": c.origin, "clips": len(c.clips),
                      "frames": int(sum(m.frame_count for m in c.clips)),
                      "leg_length": float(c.morphology.leg_length)} for c in characters],
                    creature=None if setup.creature is None else creature,
                    target_features=setup.target_features, target_offsets=setup.target_offsets).save(run)
    return setup


def train_nkn(
    run_dir: str | os.PathLike[str],
    cfg: NknConfig,
    *,
    human_data: HumanData | None = None,
    creature: Morphology | None = None,
    device: str | torch.device | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
    threads: int | None = 1,
) -> Path:
    """Prepare the data and train (or resume, or find finished) an NKN run; returns the run folder.

    Args:
        run_dir: The run folder.
        cfg: The configuration (:func:`~morphkit.retarget.nkn.config.preset`).
        human_data: A human motion folder (default: the embedded default human and its variants).
        creature: Cross-morphology mode: retarget the human skeletons onto this creature.
        device: Torch device.
        progress: Progress bars.
        log: Where progress lines go.
        threads: torch's intra-op CPU threads while training (see :func:`cpu_threads`).
    """
    with cpu_threads(threads):
        return _train(Path(run_dir), cfg, human_data, creature, device, progress, log)


def _train(run: Path, cfg: NknConfig, human_data: HumanData | None, creature: Morphology | None,
           device: str | torch.device | None, progress: bool, log: Callable[[str], None]) -> Path:
    setup = prepare(run, cfg, human_data=human_data, creature=creature, progress=progress, log=log)
    trainer = TRAINERS[0] if creature is None else TRAINERS[1]
    log(f"training {trainer}: {run}")
    with Run(run, trainer=trainer, config=cfg, creature=None if creature is None else creature.name, seed=cfg.seed,
             device=device, progress=progress) as r:
        nets = build_networks(cfg, setup.template, setup.source_features, setup.source_offsets,
                              creature, setup.target_features, setup.target_offsets,
                              None if setup.creature is None else _joint_mean(setup.creature))
        for net in nets.values():
            net.to(r.device)
        models = {name: r.wrap(net) for name, net in nets.items()}
        g_params = [p for name, net in nets.items() if name != "discriminator" for p in net.parameters()]
        opt_g = torch.optim.Adam(g_params, lr=cfg.lr, betas=cfg.betas)
        opt_d = torch.optim.Adam(nets["discriminator"].parameters(), lr=cfg.lr, betas=cfg.betas)
        r.track(**nets, optimizer_g=opt_g, optimizer_d=opt_d)
        r.extra.setdefault("d_fake_score", 0.5)
        step = _skeleton_step if creature is None else _cross_step
        for _ in r.epochs(cfg.epochs):
            for net in nets.values():
                net.train()
            for _ in r.steps(cfg.steps_per_epoch):
                row = step(r, setup, cfg, nets, models, opt_g, opt_d, g_params)
                r.log(**row)
    return run


def _adversarial(r: Run, cfg: NknConfig, disc: torch.nn.Module, d_model: torch.nn.Module, opt_d: torch.optim.Optimizer,
                 real: torch.Tensor, fake: torch.Tensor, cond: torch.Tensor) -> tuple[torch.Tensor, dict[str, Any]]:
    """The D step (when the running D(fake) score allows it) and G's adversarial loss, on selected clips."""
    row: dict[str, Any] = {}
    with torch.no_grad():
        score_now = torch.sigmoid(d_model(fake.detach(), cond)).mean()
    decay = cfg.d_score_decay
    r.extra["d_fake_score"] = decay * float(r.extra["d_fake_score"]) + (1.0 - decay) * float(score_now)
    d_step = r.extra["d_fake_score"] > cfg.d_margin
    if d_step:
        real_logits = d_model(real, cond, input_dropout=True)
        fake_logits = d_model(fake.detach(), cond, input_dropout=True)
        loss_d = discriminator_loss(real_logits, fake_logits)
        opt_d.zero_grad(set_to_none=True)
        loss_d.backward()
        torch.nn.utils.clip_grad_norm_(disc.parameters(), cfg.clip_norm)
        opt_d.step()
        row |= {"loss_d": loss_d.detach(), "d_real": torch.sigmoid(real_logits).mean().detach()}
    with frozen_parameters(disc):
        adv = generator_adversarial_loss(d_model(fake, cond))
    row |= {"d_fake": score_now, "d_fake_score": r.extra["d_fake_score"], "d_step": float(d_step)}
    return adv, row


def _skeleton_step(r: Run, setup: NknSetup, cfg: NknConfig, nets: dict, models: dict, opt_g: torch.optim.Optimizer,
                   opt_d: torch.optim.Optimizer, g_params: list) -> dict[str, Any]:
    dev, gen_rng, bank = r.device, r.generator, setup.source
    gen: NknGenerator = nets["generator"]
    side = gen.side
    b = cfg.batch_size
    xa_raw, a = bank.sample(b, gen_rng)
    b_idx = torch.randint(len(bank.characters), (b,), generator=gen_rng)
    flip = torch.rand(b, generator=gen_rng) < cfg.same_skeleton_prob
    b_idx = torch.where(flip, a, b_idx)
    real_raw = bank.sample_of(b_idx, gen_rng)
    same = (b_idx == a).to(dev)
    off_a, off_b = bank.offsets[a].to(dev), bank.offsets[b_idx].to(dev)
    xa = side.normalize_features(xa_raw.to(dev))

    out_b = models["generator"](xa, off_b)  # Eq. 8
    out_a = models["generator"](out_b.x, off_a)  # Eq. 9
    L3 = 3 * side.link_count
    cycle_local = squared_error(out_a.x[..., :L3], xa[..., :L3])
    cycle_global = squared_error(out_a.x[..., L3:], xa[..., L3:])
    same_local = squared_error(out_b.x[..., :L3], xa[..., :L3], same)
    same_global = squared_error(out_b.x[..., L3:], xa[..., L3:], same)
    alpha = math.radians(cfg.twist_alpha_deg)
    axes = side.head.twist_axes
    twist = 0.5 * (twist_loss(out_b.quats, axes, alpha) + twist_loss(out_a.quats, axes, alpha))
    smooth = 0.5 * (smoothing_loss(out_b.v) + smoothing_loss(out_a.v))
    adv = xa.new_zeros(())
    row: dict[str, Any] = {}
    mask = (~same) & bank.has_clips[b_idx].to(dev)
    if cfg.adversarial and int(mask.sum()) >= 2:
        p_real, v_real = side.split(real_raw.to(dev)[mask])
        real = motion_differences(p_real, v_real)
        fake = motion_differences(out_b.p[mask], out_b.v[mask])
        cond = side.normalize_offsets(off_b[mask])
        adv, row = _adversarial(r, cfg, nets["discriminator"], models["discriminator"], opt_d, real, fake, cond)
    loss = (cycle_local + cycle_global + same_local + same_global + cfg.twist_weight * twist
            + cfg.smooth_weight * smooth + cfg.beta * adv)
    opt_g.zero_grad(set_to_none=True)
    loss.backward()
    grad_norm = torch.nn.utils.clip_grad_norm_(g_params, cfg.clip_norm)
    opt_g.step()
    return {**row, "loss_g": loss.detach(), "cycle": (cycle_local + cycle_global).detach(),
            "cycle_local": cycle_local.detach(), "cycle_global": cycle_global.detach(),
            "same_skeleton": (same_local + same_global).detach(), "twist": twist.detach(), "smooth": smooth.detach(),
            "adv_g": adv.detach(), "grad_norm_g": grad_norm.detach()}


def _cross_step(r: Run, setup: NknSetup, cfg: NknConfig, nets: dict, models: dict, opt_g: torch.optim.Optimizer,
                opt_d: torch.optim.Optimizer, g_params: list) -> dict[str, Any]:
    dev, gen_rng = r.device, r.generator
    forward: NknGenerator = nets["generator"]
    inverse: NknGenerator = nets["inverse"]
    human, creature = inverse.side, forward.side
    target = setup.target
    assert target is not None
    b = cfg.batch_size
    xh_raw, h = setup.source.sample(b, gen_rng)
    real_raw, _ = target.sample(b, gen_rng)
    off_h = setup.source.offsets[h].to(dev)
    off_r = target.offsets[0].to(dev).expand(b, -1, -1)
    xh = human.normalize_features(xh_raw.to(dev))

    out_r = models["generator"](xh, off_r)
    out_h = models["inverse"](out_r.x, off_h)
    L3 = 3 * human.link_count
    cycle_local = squared_error(out_h.x[..., :L3], xh[..., :L3])
    cycle_global = squared_error(out_h.x[..., L3:], xh[..., L3:])
    alpha = math.radians(cfg.twist_alpha_deg)
    twist = 0.5 * (twist_loss(out_r.quats, creature.head.twist_axes, alpha)
                   + twist_loss(out_h.quats, human.head.twist_axes, alpha))
    smooth = 0.5 * (smoothing_loss(out_r.v) + smoothing_loss(out_h.v))
    adv = xh.new_zeros(())
    row: dict[str, Any] = {}
    if cfg.adversarial and b >= 2:
        p_real, v_real = creature.split(real_raw.to(dev))
        real = motion_differences(p_real, v_real)
        fake = motion_differences(out_r.p, out_r.v)
        cond = creature.normalize_offsets(off_r)
        adv, row = _adversarial(r, cfg, nets["discriminator"], models["discriminator"], opt_d, real, fake, cond)
    loss = cycle_local + cycle_global + cfg.twist_weight * twist + cfg.smooth_weight * smooth + cfg.beta * adv
    opt_g.zero_grad(set_to_none=True)
    loss.backward()
    grad_norm = torch.nn.utils.clip_grad_norm_(g_params, cfg.clip_norm)
    opt_g.step()
    return {**row, "loss_g": loss.detach(), "cycle": (cycle_local + cycle_global).detach(),
            "cycle_local": cycle_local.detach(), "cycle_global": cycle_global.detach(), "twist": twist.detach(),
            "smooth": smooth.detach(), "adv_g": adv.detach(), "grad_norm_g": grad_norm.detach()}
