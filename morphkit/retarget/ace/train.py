"""Training ACE: data preparation, the motion prior (§4) and the adversarial retargeter (§5).

The run folder's files are :class:`~.checkpoint.AceArtifact`'s (written here once, by :func:`prepare`). The
losses are :mod:`~.losses`' (the loss helpers are re-exported here, where earlier code imports them); this
module only orchestrates: data, optimisers, steps, checkpoints.

Each stage is a :class:`~morphkit.retarget.training_run.Run` and resumes exactly: re-running the same
command continues where it stopped; a finished stage is skipped. A prior can be shared: ablations
point ``prior_dir`` at another run's ``prior/`` (train the prior once, three retargeters from it).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.graph import Morphology
from morphkit.metrics import diversity, feature_loss, fid, matched_reference
from morphkit.motion import (
    EndEffectorMapping,
    Motion,
    NormStats,
    Pairing,
    character_state_from_motion,
    character_state_layout,
    ee_distributions,
    human_state_from_motion,
    human_state_layout,
    map_end_effectors,
    measured_body_length,
)
from morphkit.retarget.ace.checkpoint import (
    AVERAGE_STATE,
    BEST_STATE,
    META_FILE,
    PRIOR_STAGE,
    PRIOR_TRAINER,
    AceArtifact,
)
from morphkit.retarget.ace.config import AceConfig, PriorConfig, RetargetConfig
from morphkit.retarget.ace.losses import (
    Figures,
    GeneratorTerms,
    disc_logits,
    discriminator_loss,
    feature_weights,
    generator_loss,
    gradient_penalty,
    hand_blocks,
    hand_spread_factors,
    hand_velocity_term,
    prior_foot_term,
    prior_loss,
    spread_ground_motion_factor,
)
from morphkit.retarget.ace.model import Discriminator, FeatureMap, Generator, build_vae, foot_indices, rollout
from morphkit.retarget.ace.networks import MotionVAE
from morphkit.retarget.ace.variants import AceVariant
from morphkit.retarget.distributed import average_gradients, broadcast_parameters, is_main_process, joined_group
from morphkit.retarget.training_data import StateWindows, character_data, human_motions, validation_split
from morphkit.retarget.training_run import Run

__all__ = [
    "AceData",
    "BestGenerator",
    "EpochScore",
    "Validation",
    "disc_logits",
    "feature_weights",
    "foot_indices",
    "frozen_prior",
    "generator_average",
    "gradient_penalty",
    "hand_blocks",
    "hand_spread_factors",
    "hand_velocity_term",
    "latent_range",
    "linear_decay",
    "prepare",
    "prior_foot_term",
    "sampling_probability",
    "spread_ground_motion_factor",
    "tail_end_effectors",
    "train_ace",
    "train_prior",
    "train_retargeter",
]

START_STATES = 512
"""Character states kept in a run as rollout starts for retargeting (chosen by Ψ nearest the human's first frame)."""


@dataclass(eq=False)
class AceData:
    """What both stages train on, prepared once per run folder."""

    creature: Morphology
    character: list[Motion]
    human: list[Motion]
    character_states: list[np.ndarray]
    human_states: list[np.ndarray]
    features: FeatureMap
    mapping: EndEffectorMapping


def _check_creature(m: Morphology) -> None:
    if not m.end_effectors:
        raise ConfigError(f"creature {m.name!r} has no end-effectors: ACE's feature loss needs some to map")


def prepare(
    run_dir: str | os.PathLike[str],
    creature: Morphology,
    cfg: AceConfig,
    *,
    human_data: str | os.PathLike[str] | None = None,
    mapping_override: dict[str, str] | None = None,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> AceData:
    """Load (or synthesise) both data sets, fit normalisation, map end-effectors; write them to the run.

    Reopening a run folder of another creature raises :class:`RunError`.
    """
    _check_creature(creature)
    run = Path(run_dir)
    existing = AceArtifact.creature_name(run)
    if existing is not None and existing != creature.name:
        raise RunError(f"run folder is of creature {existing!r}, not {creature.name!r}",
                       location=SourceLocation(str(run / META_FILE)))
    character, _ = character_data(creature, cfg.data, cache_dir=cache_dir, progress=progress, log=log)
    human = human_motions(human_data, cfg.data)
    human_m = human[0].morphology
    if not human_m.end_effectors:
        raise ConfigError(f"human skeleton {human_m.name!r} has no end-effectors")
    log(f"human data: {len(human)} clips, {sum(m.frame_count for m in human)} frames"
        f"{' (half of them mirror images)' if cfg.data.human_mirror else ''}"
        f" ({'embedded default' if human_data is None else human_data})")
    c_states = [character_state_from_motion(m) for m in character]
    h_states = [human_state_from_motion(m) for m in human]
    c_len, h_len = measured_body_length(creature, character), measured_body_length(human_m, human)
    c_dist = ee_distributions(character, length=c_len, max_frames_per_clip=300)
    tails = [] if cfg.pair_tails else [t for t in tail_end_effectors(creature) if t not in (mapping_override or {})]
    if tails and len(tails) < len(c_dist):
        c_dist = {k: v for k, v in c_dist.items() if k not in tails}
        log(f"left out of Ψ (a tail is not a hand; pair_tails): {', '.join(tails)}")
    h_dist = ee_distributions(human, length=h_len, max_frames_per_clip=300)
    roles = None if cfg.kl_only_mapping else ({e.name: e.role for e in creature.end_effectors},
                                              {e.name: e.role for e in human_m.end_effectors})
    mapping = map_end_effectors(c_dist, h_dist, override=mapping_override, roles=roles, active_hand=cfg.active_hand)
    c_stats = NormStats.fit(c_states)
    h_stats = NormStats.fit(h_states, layout=human_state_layout(human_m), field_floor=cfg.human_std_floor)
    pairing = Pairing.from_mapping(mapping.mapping, c_len, h_len, mapping.active_hand)
    if cfg.centre_features:
        pairing = pairing.with_centres(character, human)
    fmap = FeatureMap(creature, character_state_layout(creature), human_state_layout(human_m), c_stats, h_stats,
                      pairing)
    if is_main_process():
        starts, start_psi = _start_states(c_states, fmap, cfg.seed)
        AceArtifact(creature, c_stats, h_stats, pairing, mapping.to_json(), starts, start_psi, cfg.data,
                    None if human_data is None else os.fspath(human_data), human_m.name).save(run)
    log("end-effector mapping (KL, Eq. 11): " + ", ".join(f"{c} -> {h}" for c, h in mapping.mapping.items()))
    return AceData(creature, character, human, c_states, h_states, fmap, mapping)


def tail_end_effectors(m: Morphology) -> list[str]:
    """The creature's tool end-effectors that are tails: named like a tail (:func:`morphkit.body.roles.name_hint`
    ``skip``) or at rest on the midline (within 2 % of the body's size) behind the root."""
    from morphkit.body.roles import name_hint
    from morphkit.graph import EndEffectorRole

    points = m.rest_points()[m.link_count:]
    size = max(float(np.abs(m.rest_points()).max()), 1e-6)
    return [e.name for e, p in zip(m.end_effectors, points, strict=True) if e.role == EndEffectorRole.TOOL and (
        "skip" in (name_hint(e.name), name_hint(e.link)) or (p[0] < 0.0 and abs(p[1]) < 0.02 * size))]


def _start_states(states: Sequence[np.ndarray], fmap: FeatureMap, seed: int) -> tuple[np.ndarray, np.ndarray]:
    flat = np.concatenate(list(states), axis=0)
    rng = np.random.default_rng(seed)
    pick = rng.choice(flat.shape[0], size=min(START_STATES, flat.shape[0]), replace=False)
    x = flat[np.sort(pick)]
    return x, fmap.pairing.creature_psi_of_states(x, fmap.creature_layout)


# ---- stage 1: the motion prior ----------------------------------------------------------------


def sampling_probability(cfg: PriorConfig, epoch: int) -> float:
    """Probability that a rollout step conditions on the model's own prediction (MotionVAE's schedule)."""
    teacher = round(cfg.teacher_fraction * cfg.epochs)
    ramp = round(cfg.ramp_fraction * cfg.epochs)
    if epoch < teacher:
        return 0.0
    if ramp <= 0 or epoch >= teacher + ramp:
        return 1.0
    return (epoch - teacher + 1) / (ramp + 1)


def linear_decay(opt: torch.optim.Optimizer, final_fraction: float, steps: int) -> torch.optim.lr_scheduler.LambdaLR:
    """Scale ``opt``'s learning rates linearly from 1 to ``final_fraction`` over ``steps`` scheduler steps,
    then hold them."""
    total = max(steps, 1)
    return torch.optim.lr_scheduler.LambdaLR(opt, lambda s: 1.0 + (final_fraction - 1.0) * min(s / total, 1.0))


def train_prior(
    prior_dir: str | os.PathLike[str],
    data: AceData,
    cfg: AceConfig,
    *,
    device: str | torch.device | None = None,
    progress: bool = True,
) -> MotionVAE:
    """Train (or resume, or load when finished) the encoder c and prior π on the character's states (Eq. 1–2).

    Each step rolls the VAE over windows of ``rollout`` + 1 frames; a step's condition is its own
    detached prediction with :func:`sampling_probability`, else the data (scheduled sampling).
    """
    pc = cfg.prior
    windows = StateWindows.build(data.character_states, pc.rollout + 1, data.features.creature_stats)
    feet = foot_indices(data.creature)
    with Run(prior_dir, trainer=PRIOR_TRAINER, config=pc, creature=data.creature.name, seed=cfg.seed, device=device,
             progress=progress) as run:
        vae = build_vae(windows.states.shape[1], pc).to(run.device)
        model = run.wrap(vae)
        opt = torch.optim.Adam(vae.parameters(), lr=pc.lr)
        sched = linear_decay(opt, pc.lr_final / pc.lr, pc.epochs * pc.steps_per_epoch)
        run.track(model=vae, optimizer=opt, scheduler=sched)
        for epoch in run.epochs(pc.epochs):
            p_own = sampling_probability(pc, epoch)
            model.train()
            for _ in run.steps(pc.steps_per_epoch):
                idx = torch.randint(len(windows), (pc.batch_size,), generator=run.generator)
                loss, figures = prior_loss(model, windows.windows(idx, run.device), p_own, run.generator,
                                           data.features, feet, pc)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                sched.step()
                run.log(**figures, p_own=p_own, lr=sched.get_last_lr()[0])
    vae.eval()
    return vae


# ---- stage 2: the retargeter ------------------------------------------------------------------


def frozen_prior(vae: MotionVAE) -> torch.nn.Module:
    """π of a trained VAE in eval mode with its parameters frozen (the retargeting stage never trains it)."""
    prior = vae.prior.eval()
    for p in prior.parameters():
        p.requires_grad_(False)
    return prior


@torch.no_grad()
def latent_range(vae: MotionVAE, transitions: StateWindows, *, batch: int = 8192) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean and standard deviation [Z] of the encoder's posterior means over every data transition
    (normalised two-frame windows), on the encoder's device."""
    device = next(vae.encoder.parameters()).device
    encoder = vae.encoder.eval()
    mus = []
    for lo in range(0, len(transitions), batch):
        w = transitions.windows(torch.arange(lo, min(lo + batch, len(transitions))), device)
        mus.append(encoder(w[:, 0], w[:, 1])[0])
    mu = torch.cat(mus)
    return mu.mean(0), mu.std(0).clamp_min(1e-6)


def train_retargeter(
    retarget_dir: str | os.PathLike[str],
    data: AceData,
    vae: MotionVAE,
    cfg: AceConfig,
    *,
    variant: AceVariant | str = AceVariant.ACE,
    device: str | torch.device | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> Generator:
    """Train (or resume, or load when finished) G and D (Eq. 3–10) from a trained prior π (kept frozen).

    Args:
        variant: The retargeter (:class:`~.variants.AceVariant`); its ablation flags are set in the
            retarget config, so the stage's ``config.yaml`` records what was trained.
        log: Where the G chosen on held-out clips is reported (``retarget.validation_share``).
    """
    variant = AceVariant.parse(variant)
    rc: RetargetConfig = variant.configure(cfg.retarget)
    fmap = data.features
    human_states, held_out = data.human_states, None
    if rc.validation_share != 0:  # a negative share is refused by the split
        train_idx, val_idx = validation_split([m.name for m in data.human], rc.validation_share, cfg.seed)
        if val_idx:
            human_states = [data.human_states[i] for i in train_idx]
            held_out = [data.human_states[i] for i in val_idx]
        else:
            log("one human clip: none to hold out, so the last epoch's G retargets (retarget.validation_share)")
    humans = StateWindows.build(human_states, rc.window, fmap.human_stats)
    reals = StateWindows.build(data.character_states, 2, fmap.creature_stats)
    starts = StateWindows.build(data.character_states, 1, fmap.creature_stats)
    sh, sr = humans.states.shape[1], reals.states.shape[1]
    with Run(retarget_dir, trainer=variant.value, config=rc, creature=data.creature.name, seed=cfg.seed, device=device,
             progress=progress) as run:
        dev = run.device
        prior = frozen_prior(vae.to(dev))
        gen = Generator(sh, sr, vae.prior.latent_features, rc).to(dev)
        gen.set_latent_range(*latent_range(vae, reals))
        disc = Discriminator(sr, rc).to(dev)
        stats = fmap.creature_stats
        terms = GeneratorTerms.build(rc, fmap, data.creature, human_states, data.character_states, cfg.data.fps, dev)
        if terms.note is not None:
            log(terms.note)
        # Not DDP: its hooks miss the gradient penalty's double backward; gradients are averaged by hand.
        for module in (gen, disc):
            broadcast_parameters(module, run.context)
        g_model, d_model = gen, disc
        opt_g = torch.optim.Adam(gen.parameters(), lr=rc.lr_generator, betas=rc.betas)
        opt_d = torch.optim.Adam(disc.parameters(), lr=rc.lr_discriminator, betas=rc.betas)
        run.track(generator=gen, discriminator=disc, optimizer_g=opt_g, optimizer_d=opt_d)
        average = generator_average(gen, rc.generator_average)
        if average is not None:  # off: runs from before it resume as they were
            run.track(**{AVERAGE_STATE: average})
        best = validation = None
        if held_out is not None:
            validation = Validation.build(held_out, starts, rc.window, fmap, dev, seed=cfg.seed,
                                          character_states=data.character_states)
            best = BestGenerator()
            run.track(**{BEST_STATE: best})
        for epoch in run.epochs(rc.epochs):
            for _ in run.steps(rc.steps_per_epoch):
                b = rc.batch_size
                x_h = humans.windows(torch.randint(len(humans), (b,), generator=run.generator), dev)
                x0 = starts.windows(torch.randint(len(starts), (b,), generator=run.generator), dev)[:, 0]
                prev, fake = rollout(g_model, prior, x_h, x0, tbptt=rc.tbptt)
                fixed, gap = fmap.creature_with_fk(fake)  # what is exported: ee from FK of the joints
                if rc.discriminate_exported:
                    shown = stats.normalize(fixed)
                    prev = torch.cat([x0[:, None], shown[:, :-1]], dim=1)
                else:
                    shown = fake
                fake_t = torch.cat([prev, shown], dim=-1).flatten(0, 1)  # [B·T, 2 Sr]
                row: Figures = {}
                if rc.adversarial:
                    for _ in range(rc.discriminator_steps):
                        pair = reals.windows(torch.randint(len(reals), (fake_t.shape[0],), generator=run.generator),
                                             dev)
                        loss_d, row = discriminator_loss(d_model, pair.flatten(1), fake_t, rc.w_gp)
                        opt_d.zero_grad(set_to_none=True)
                        loss_d.backward()
                        average_gradients(disc, run.context)
                        opt_d.step()
                loss_g, figures = generator_loss(terms, x_h, fixed, fake_t,
                                                 lambda t: disc_logits(d_model, disc, t))
                opt_g.zero_grad(set_to_none=True)
                loss_g.backward()
                average_gradients(gen, run.context)
                opt_g.step()
                if average is not None:
                    average.update_parameters(gen)
                run.log(**row, **figures, ee_fk_gap=gap.mean())
            if validation is not None and best is not None:
                retargeting = gen if average is None else average.module
                score = validation.score(retargeting, prior)
                best.offer(score.feature_loss, retargeting, epoch,
                           rank=score.rank(validation, rc) if rc.choose_inside_data else None)
                run.log(validation_feature_loss=score.feature_loss, validation_fid=score.fid,
                        validation_div=score.div, best_epoch=best.epoch)
                log(f"epoch {epoch + 1}: held-out L_fea {score.feature_loss:.3f}, matched FID {score.fid:.3f}, "
                    f"DIV {score.div:.3f} (the data's DIV {validation.data_div:.3f}, FID of the data against itself "
                    f"{validation.data_fid:.3f}){'' if score.inside(validation, rc) else ' - outside the data'}")
    final = gen if average is None else average.module
    if best is not None and best.weights:
        final.load_state_dict(best.weights)
        log(f"G chosen on {len(held_out or [])} held-out human clips: epoch {best.epoch + 1} of {rc.epochs} "
            f"(L_fea {best.loss:.3f}{'' if best.rank is None else f', matched FID {best.rank[2]:.3f}'})")
        if rc.choose_inside_data and validation is not None and best.rank is not None and best.rank[0] > 0:
            log(f"warning: no epoch's held-out output lay inside {data.creature.name}'s data (matched FID <= "
                f"{rc.inside_fid:g}, DIV within {rc.inside_div_band[0]:g}-{rc.inside_div_band[1]:g}x the data's "
                f"{validation.data_div:.3f}): the epoch nearest it retargets ({best.rank[1]:.2f}x its bounds); "
                "look at its clips")
    final.eval()
    return final


@dataclass(eq=False)
class Validation:
    """Fixed windows of held-out human clips and fixed character start states that G is scored on after each epoch
    (``retarget.validation_share``); drawn once from ``seed``, never from the run's random stream, so a resumed
    run scores as the uninterrupted one."""

    human: torch.Tensor
    """Normalised human windows [N, T, Sh]."""
    start: torch.Tensor
    """Normalised character start states [N, Sr]."""
    features: FeatureMap
    reference: np.ndarray | None = None
    """Ψ of the character's data frames resampled to the held-out humans' root speed and yaw rate
    (:func:`~morphkit.metrics.matched_reference`), [N·T, D]: what the matched FID and DIV compare with."""
    data_div: float = float("nan")
    """DIV of :attr:`reference` (the data's own spread)."""
    data_fid: float = float("nan")
    """FID between :attr:`reference` and a second draw of it: the data's FID against itself, the floor."""
    seed: int = 0

    WINDOWS = 256
    """Windows scored (ours: the validation clips' windows drawn at random, at most this many)."""

    @staticmethod
    def build(per_clip: Sequence[np.ndarray], starts: StateWindows, window: int, fmap: FeatureMap,
              device: torch.device, *, seed: int, character_states: Sequence[np.ndarray] | None = None) -> Validation:
        """The held-out windows; with ``character_states`` (raw, per clip) also the matched reference the FID and
        DIV of :meth:`score` compare with."""
        windows = StateWindows.build(per_clip, window, fmap.human_stats)
        draw = torch.Generator().manual_seed(seed)
        n = min(Validation.WINDOWS, len(windows))
        human = windows.windows(torch.randperm(len(windows), generator=draw)[:n], device)
        start = starts.windows(torch.randint(len(starts), (n,), generator=draw), device)[:, 0]
        if character_states is None:
            return Validation(human, start, fmap, seed=seed)
        data_psi = np.asarray(fmap.pairing.creature_psi_of_states(np.concatenate(list(character_states), axis=0),
                                                                   fmap.creature_layout))
        human_psi = fmap.human_psi(human).detach().cpu().numpy().reshape(-1, data_psi.shape[1])
        reference = matched_reference(data_psi, human_psi, seed=seed)[0]
        again = matched_reference(data_psi, human_psi, seed=seed + 1)[0]
        return Validation(human, start, fmap, reference, float(diversity(reference, rng=seed)),
                          float(fid(reference, again)), seed)

    @torch.no_grad()
    def score(self, generator: torch.nn.Module, prior: torch.nn.Module) -> EpochScore:
        """L_fea (Eq. 9, unweighted), and with a :attr:`reference` the matched FID and DIV, of ``generator``'s
        rollouts over the windows."""
        _, fake = rollout(generator, prior, self.human, self.start)
        fmap = self.features
        fixed, _ = fmap.creature_with_fk(fake)
        psi = fmap.psi_of_fixed(fixed)
        loss = float(feature_loss(fmap.human_psi(self.human), psi))
        if self.reference is None:
            return EpochScore(loss, float("nan"), float("nan"))
        rows = psi.detach().cpu().numpy().reshape(-1, psi.shape[-1])
        if not np.isfinite(rows).all():
            return EpochScore(loss, float("inf"), float("nan"))
        return EpochScore(loss, float(fid(self.reference, rows)), float(diversity(rows, rng=self.seed)))

    @torch.no_grad()
    def feature_loss(self, generator: torch.nn.Module, prior: torch.nn.Module) -> float:
        """L_fea (Eq. 9, unweighted) of ``generator``'s rollouts over the windows (:meth:`score`'s first figure)."""
        return self.score(generator, prior).feature_loss


@dataclass(frozen=True)
class EpochScore:
    """G's figures on the held-out windows after one epoch (:meth:`Validation.score`)."""

    feature_loss: float
    """L_fea (Eq. 9)."""
    fid: float
    """Matched FID against the character's data (NaN without a reference)."""
    div: float
    """DIV of the output (NaN without a reference)."""

    def inside(self, validation: Validation, rc: RetargetConfig) -> bool:
        """Whether the output lies inside the data: matched FID at most ``rc.inside_fid``, DIV within
        ``rc.inside_div_band`` × the data's (no reference: True, nothing to say otherwise)."""
        if validation.reference is None:
            return True
        lo, hi = rc.inside_div_band
        return bool(self.fid <= rc.inside_fid and lo * validation.data_div <= self.div <= hi * validation.data_div)

    def rank(self, validation: Validation, rc: RetargetConfig) -> tuple[float, float, float]:
        """Order of the epochs (lower first): inside the data before outside; inside by L_fea, outside by how far
        outside (:meth:`outside_by`)."""
        if self.inside(validation, rc):
            return (0.0, self.feature_loss, self.fid)
        return (1.0, self.outside_by(validation, rc), self.fid)

    def outside_by(self, validation: Validation, rc: RetargetConfig) -> float:
        """How far outside the data, in units of the bounds: the largest of FID / ``inside_fid`` and DIV's ratio to
        the nearer edge of ``inside_div_band`` × the data's DIV (1 on the boundary; NaN figures: infinity)."""
        lo, hi = rc.inside_div_band
        d = validation.data_div
        if not (np.isfinite(self.fid) and np.isfinite(self.div)) or self.div <= 0:
            return float("inf")
        return float(max(self.fid / rc.inside_fid, lo * d / self.div, self.div / (hi * d)))


class BestGenerator:
    """G's weights at the best epoch so far (a checkpointed state): the lowest validation feature loss, or the lowest
    ``rank`` where one is given (:meth:`EpochScore.rank`)."""

    def __init__(self) -> None:
        self.loss = float("inf")
        self.epoch = -1
        self.weights: dict[str, torch.Tensor] = {}
        self.rank: tuple[float, ...] | None = None

    def offer(self, loss: float, generator: torch.nn.Module, epoch: int, *,
              rank: tuple[float, ...] | None = None) -> None:
        """Keep ``generator``'s weights if ``rank`` (default ``(loss,)``) is the lowest yet (ties keep the earlier
        epoch)."""
        key = (loss,) if rank is None else tuple(rank)
        current = (self.loss,) if self.rank is None or rank is None else self.rank
        if self.epoch < 0 or key < current:
            self.loss, self.epoch, self.rank = loss, epoch, None if rank is None else key
            self.weights = {k: v.detach().clone() for k, v in generator.state_dict().items()}

    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"loss": self.loss, "epoch": self.epoch, "weights": self.weights}
        if self.rank is not None:
            out["rank"] = list(self.rank)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.loss, self.epoch, self.weights = float(state["loss"]), int(state["epoch"]), dict(state["weights"])
        self.rank = tuple(float(v) for v in state["rank"]) if state.get("rank") is not None else None


def generator_average(gen: torch.nn.Module, decay: float) -> AveragedModel | None:
    """An exponential moving average of ``gen``'s parameters (``None`` for ``decay`` 0: off).

    Its buffers (the latent range) are copied once: they are set before training and never change.
    """
    if decay <= 0.0:
        return None
    if decay >= 1.0:
        raise ConfigError(f"retarget.generator_average must lie in [0, 1), got {decay}")
    return AveragedModel(gen, multi_avg_fn=get_ema_multi_avg_fn(decay))


def train_ace(
    run_dir: str | os.PathLike[str],
    creature: Morphology,
    cfg: AceConfig,
    *,
    variant: AceVariant | str = AceVariant.ACE,
    human_data: str | os.PathLike[str] | None = None,
    mapping_override: dict[str, str] | None = None,
    prior_dir: str | os.PathLike[str] | None = None,
    device: str | torch.device | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> Path:
    """Prepare the data, train (or resume, or skip) the prior, then the retargeter ``variant``.

    Returns:
        The retargeter's stage folder.
    """
    variant = AceVariant.parse(variant)
    variant.configure(cfg.retarget)  # a contradicting ablation flag is refused before anything trains
    run = Path(run_dir)
    # One process group for every stage under torchrun (a Run that created it would destroy it).
    with joined_group(device):
        data = prepare(run, creature, cfg, human_data=human_data, mapping_override=mapping_override, progress=progress,
                       log=log)
        if prior_dir is not None and is_main_process():
            # A shared prior is recorded, so retargeting with this run finds it.
            artifact = AceArtifact.load(run)
            artifact.prior_dir = os.fspath(Path(prior_dir).resolve())
            artifact.save_meta(run)
        prior = Path(prior_dir) if prior_dir is not None else run / PRIOR_STAGE
        log(f"motion prior: {prior}")
        vae = train_prior(prior, data, cfg, device=device, progress=progress)
        stage = run / variant.folder
        log(f"retargeter ({variant.value}): {stage}")
        train_retargeter(stage, data, vae, cfg, variant=variant, device=device, progress=progress,
                         log=log if is_main_process() else lambda s: None)
        return stage
