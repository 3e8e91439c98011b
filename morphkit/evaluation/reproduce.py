"""Reproduce ACE's Table 1 for one creature: train every method, evaluate them on held-out clips, report.

Stages, in order (``OUT`` is the creature's folder)::

    data                  the creature's synthesised data set (cached by content hash)  OUT/runs/data/
    prior                 ACE's motion prior, trained once                              OUT/runs/ace_seed0/prior/
    ACE, ACEwoFea,        the ACE retargeters of seed s, all from that prior            OUT/runs/ace_seed<s>/retarget*/
    ACEwoAdv, ACE+contact
    NKN                   NKN's cross-morphology mode, seed s                           OUT/runs/nkn_seed<s>/
    evaluate              Table 1, charts, videos, index.html                           OUT/report/

With ``jobs`` ≥ 2 (the default), the ACE lane (prior, then the ACE retargeters) and the NKN lane
(NKN of every seed) train at once, each in its own process with its share of the CPU threads:
they depend only on the data stage, and the evaluation waits for both. NKN's lane then shows no
progress bar (two bars would overwrite each other); its stage lines and ``metrics.csv`` say where it is.

:mod:`~morphkit.evaluation.stages` runs the stages (its notes: lanes, markers, errors, Ctrl-C).
A stage is done when its folder holds ``done.json`` (written atomically once it finished) recording
the same configuration; a re-run skips it. A stage interrupted midway resumes exactly where it
stopped (its run folder's checkpoint). The evaluation is redone whenever a stage before it ran or
its options changed. Another preset or override into the same folder is not taken for done: its
training stage reopens the run folder, which refuses a different config (use another ``--out``).

NKN trains on the same human data, the same synthesised creature frames and at the same frame rate
as ACE (its ``data.human_frames``, ``data.character_frames``, ``data.synth_seed`` and ``data.fps``
are set to ACE's), so the two see the same motion. Seeds vary the retargeters and NKN; the prior is
seed 0's (trained once, as the paper's ablations share it).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from morphkit._atomic import atomic_write_text
from morphkit._folder_lock import hold_run_folder
from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.evaluation.evaluate import evaluate_methods, reference_for
from morphkit.evaluation.methods import find_methods
from morphkit.evaluation.protocol import group_rows, split_for, write_protocol
from morphkit.evaluation.report import write_report

# Re-exported (stage_done is not used here): the runner's names stay importable from where they were first.
from morphkit.evaluation.stages import DONE_FILE, Stage, lanes_at_once, run_stages, stage_done  # noqa: F401
from morphkit.graph import Morphology
from morphkit.motion.split import SPLITS
from morphkit.output_names import safe_stem
from morphkit.retarget.ace.checkpoint import PRIOR_STAGE
from morphkit.retarget.ace.config import AceConfig
from morphkit.retarget.ace.config import preset as ace_preset
from morphkit.retarget.ace.train import prepare, train_ace, train_prior
from morphkit.retarget.ace.variants import AceVariant
from morphkit.retarget.config import config_to_dict, replace_config
from morphkit.retarget.nkn import NknConfig, train_nkn
from morphkit.retarget.nkn import preset as nkn_preset
from morphkit.retarget.training_data import character_motions, synthesis_options

__all__ = ["NKN_BUDGET", "ReproduceConfig", "evaluate_runs", "plan_stages", "reproduce_table1"]



@dataclass(frozen=True)
class ReproduceConfig:
    """What :func:`reproduce_table1` trains and how it reports."""

    preset: str = "default"
    """ACE and NKN preset (``smoke``, ``quick``, ``default``, ``paper``)."""
    seeds: int = 1
    """Seeds 0 … seeds − 1 of every retargeter and of NKN."""
    contact_weight: float = 2.0
    """``retarget.w_contact`` of ACE+contact (foot sliding [m/s] + 10 × penetration [m], as ``--contact-weight``).
    Measured on a quadruped (``default``, CMU held-out): 1 gives UFR 12.1 %, 2 gives 4.4 %, at L_fea 2.71 / 2.73."""
    ace_overrides: tuple[str, ...] = ()
    """``KEY=VALUE`` overrides of the ACE config (as ``morphkit train --set``)."""
    nkn_overrides: tuple[str, ...] = ()
    """``KEY=VALUE`` overrides of the NKN config, applied after the shared data fields."""
    clips: int | None = None
    """Evaluate on the first this many held-out clips (``None``: all)."""
    videos: int = 3
    """Clips with a side-by-side video."""
    video_suffix: str | None = None
    """``.mp4``, ``.gif`` or ``.png`` (a contact sheet); default ``.mp4`` when ffmpeg is there, else ``.gif``."""
    video_seconds: float = 8.0
    """Longest video [s]."""
    video_size: tuple[int, int] = (240, 240)
    """Size of each video panel, width × height in pixels."""
    device: str | None = None
    """Torch device of training (default: CUDA when present, else CPU)."""
    jobs: int = 2
    """Lanes trained at once on CPU (ours): 2 trains NKN beside the prior and ACE retargeters, 1 runs every
    stage in turn. Each lane process takes ``cpu_count // jobs`` torch threads (at least 1). Training on
    CUDA runs the stages in turn (a forked process cannot use the CUDA its parent initialised)."""
    progress: bool = True
    """Training progress bars."""


def _ace_config(cfg: ReproduceConfig, seed: int) -> AceConfig:
    return replace_config(ace_preset(cfg.preset), [*cfg.ace_overrides, f"seed={seed}"])


NKN_BUDGET: dict[str, dict[str, Any]] = {"default": {"epochs": 8}}
"""Table 1's NKN training length per preset, where it differs from the NKN preset's (ours): the NKN
``default`` preset's 2,000 steps take ≈ 47 min on 2 CPU cores, over the 60 min a whole character may
take; 800 steps (≈ 15–20 min) fit beside the prior and four ACE retargeters. ``--nkn-set epochs=20``
trains the full preset."""


def _nkn_config(cfg: ReproduceConfig, ace: AceConfig, seed: int) -> NknConfig:
    shared = {
        "seed": seed,
        "data.human_frames": ace.data.human_frames,
        "data.fps": ace.data.fps,
        "data.character_frames": ace.data.character_frames,
        "data.synth_seed": ace.data.synth_seed,
        **{f"data.{name}": value for name, value in synthesis_options(ace.data).items()},
        **NKN_BUDGET.get(cfg.preset, {}),
    }
    base = replace_config(nkn_preset(cfg.preset), shared)
    return replace_config(base, list(cfg.nkn_overrides)) if cfg.nkn_overrides else base


def _prior_key(cfg: AceConfig, human_data: str | None) -> dict[str, Any]:
    """What the prior depends on: its data, mapping rule, seed and its own config (not the retargeters')."""
    return {
        "data": config_to_dict(cfg.data),
        "prior": config_to_dict(cfg.prior),
        "seed": cfg.seed,
        "kl_only_mapping": cfg.kl_only_mapping,
        "human_data": human_data,
    }


def evaluate_runs(
    runs: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str] | None = None,
    *,
    human_data: str | os.PathLike[str] | None = None,
    clips: int | None = None,
    videos: int = 3,
    video_suffix: str | None = None,
    video_seconds: float = 8.0,
    video_size: tuple[int, int] = (240, 240),
    device: str = "cpu",
    split: str | None = None,
    log: Callable[[str], None] = print,
) -> Path:
    """Evaluate every finished retargeter of ``runs`` on held-out clips and write the report into ``out``.

    Args:
        runs: Run folders (ACE, NKN cross-morphology), ACE stage folders or folders of run folders.
        out: The report folder (default ``evaluation_<creature>``).
        human_data: Human motion folder whose evaluation split is retargeted (default: the runs' own
            human data; the embedded default's evaluation clips when they were trained on it).
        clips: Use the first this many clips (``None``: all).
        videos: Clips with a side-by-side video (0: none).
        video_suffix: ``.mp4``, ``.gif`` or ``.png`` (see :func:`~morphkit.evaluation.report.render_videos`).
        video_seconds: Longest video [s].
        video_size: Size of each video panel, width × height in pixels.
        device: Torch device of the retargeters.
        split: The protocol (:mod:`~morphkit.evaluation.protocol`): ``dev``, ``test`` or ``all`` of
            ``human_data``'s subject split instead of its held-out list, scored also per clip type and length
            (``protocol.md/.csv``, appended to ``table.md``; per clip ``protocol_clips.csv``).
        log: Where progress lines go.

    Returns:
        The report folder.

    Raises:
        RunError: a missing or foreign run folder, runs of different creatures.
        MotionFormatError: evaluation clips of another human skeleton than the runs were trained on.
        ConfigError: ``clips`` < 1, ``videos`` < 0, ``video_seconds`` <= 0, an unknown or empty ``split``.
    """
    if clips is not None and clips < 1:
        raise ConfigError(f"--clips must be at least 1, got {clips}")
    if videos < 0 or not video_seconds > 0:
        raise ConfigError(f"--videos must be >= 0 and --video-seconds > 0, got {videos} and {video_seconds}")
    if split is not None and split not in SPLITS:
        raise ConfigError(f"unknown --split {split!r}; choose one of {', '.join(SPLITS)}")
    methods = find_methods(runs)
    log(
        f"{len(methods)} retargeters of {methods[0].creature}: "
        + ", ".join(f"{m.name} (seed {m.seed})" for m in methods)
    )
    protocol, seen = split_for(methods, split, human_data=human_data, limit=clips) if split is not None else (None, [])
    if protocol is not None:
        log(f"protocol: the {split} split of {protocol.folder}: {len(protocol.motions)} clips")
        reference, chosen = reference_for(methods, human_data=protocol.folder, clips=protocol.motions)
    else:
        reference, chosen = reference_for(methods, human_data=human_data, limit=clips)
    keep = len(chosen) if protocol is not None else videos  # the protocol scores every clip's motions again
    evaluation = evaluate_methods(methods, chosen, reference, keep=keep, device=device, log=log)
    # the creature's name never steers the path (morphkit.output_names)
    folder = Path(out) if out is not None else Path(safe_stem(f"evaluation_{safe_stem(methods[0].creature)}"))
    with hold_run_folder(folder):  # one writer per report folder
        write_report(
            evaluation,
            folder,
            videos=videos,
            video_suffix=video_suffix,
            video_seconds=video_seconds,
            video_size=video_size,
            log=log,
        )
        if protocol is not None:
            rows, per_clip = group_rows(evaluation, protocol)
            markdown = write_protocol(rows, per_clip, folder, split=protocol.split, source=protocol.folder,
                                      seen=len(seen))
            table = folder / "table.md"
            atomic_write_text(table, table.read_text(encoding="utf-8") + "\n" + markdown + "\n")
    if evaluation.failed:
        raise RunError(f"report written, but {len(evaluation.failed)} method(s) failed: "
                       + "; ".join(f"{k}: {v}" for k, v in evaluation.failed.items()), location=SourceLocation(
                           os.fspath(folder / "index.html")))
    return folder


def plan_stages(
    creature: Morphology,
    out: str | os.PathLike[str],
    cfg: ReproduceConfig,
    *,
    human_data: str | os.PathLike[str] | None = None,
    log: Callable[[str], None] = print,
) -> list[Stage]:
    """The stages of :func:`reproduce_table1` (see the module docs), nothing run yet.

    Raises:
        ConfigError: an unknown preset or override, fewer than one seed or job.
    """
    if cfg.seeds < 1 or cfg.jobs < 1:
        raise ConfigError(f"--seeds and --jobs must be at least 1, got {cfg.seeds} and {cfg.jobs}")
    root, runs = Path(out), Path(out) / "runs"
    quiet = {"progress": cfg.progress, "log": log}
    base = _ace_config(cfg, 0)
    _nkn_config(cfg, base, 0)  # unknown NKN overrides fail before anything trains
    prior_run = runs / "ace_seed0"
    nkn_bar = (
        cfg.progress and lanes_at_once(cfg.jobs, cfg.device) < 2
    )  # beside the ACE lane's bar, a second would overwrite it

    def data() -> None:
        motions = character_motions(creature, base.data, progress=cfg.progress, log=log)
        log(f"{creature.name}: {len(motions)} clips, {sum(m.frame_count for m in motions)} frames")

    def prior() -> None:
        prepared = prepare(prior_run, creature, base, human_data=human_data, **quiet)
        train_prior(prior_run / PRIOR_STAGE, prepared, base, device=cfg.device, progress=cfg.progress)

    source = None if human_data is None else os.fspath(human_data)
    stages = [
        Stage("data", runs / "data", data, {"data": config_to_dict(base.data)}),
        Stage("prior", prior_run / PRIOR_STAGE, prior, _prior_key(base, source), lane="ACE"),
    ]
    names: list[str] = []
    for seed in range(cfg.seeds):
        ace = _ace_config(cfg, seed)
        run = runs / f"ace_seed{seed}"
        shared_prior = None if seed == 0 else prior_run / PRIOR_STAGE
        for variant in AceVariant:
            contact = variant is AceVariant.ACE_CONTACT
            c = replace_config(ace, {"retarget.w_contact": cfg.contact_weight}) if contact else ace
            folder = run / variant.folder

            def train(
                c: AceConfig = c, run: Path = run, variant: AceVariant = variant, p: Path | None = shared_prior
            ) -> None:
                train_ace(
                    run, creature, c, variant=variant, human_data=human_data, prior_dir=p, device=cfg.device, **quiet
                )

            key = {"config": config_to_dict(c), "variant": variant.value, "human_data": source}
            stages.append(Stage(f"{variant.label} seed {seed}", folder, train, key, lane="ACE"))
            names.append(os.fspath(folder.relative_to(root)))
        nkn_run = runs / f"nkn_seed{seed}"
        ncfg = _nkn_config(cfg, ace, seed)

        def nkn(ncfg: NknConfig = ncfg, nkn_run: Path = nkn_run) -> None:
            train_nkn(
                nkn_run, ncfg, human_data=human_data, creature=creature, device=cfg.device, progress=nkn_bar, log=log
            )

        key = {"config": config_to_dict(ncfg), "human_data": source}
        stages.append(Stage(f"NKN seed {seed}", nkn_run, nkn, key, lane="NKN"))
        names.append(os.fspath(nkn_run.relative_to(root)))

    def evaluate() -> None:
        evaluate_runs(
            [runs / f"{kind}_seed{s}" for s in range(cfg.seeds) for kind in ("ace", "nkn")],
            root / "report",
            human_data=human_data,
            clips=cfg.clips,
            videos=cfg.videos,
            video_suffix=cfg.video_suffix,
            video_seconds=cfg.video_seconds,
            video_size=cfg.video_size,
            log=log,
        )

    report = {
        "stages": names,
        "human_data": source,
        "clips": cfg.clips,
        "videos": cfg.videos,
        "video_suffix": cfg.video_suffix,
        "video_seconds": cfg.video_seconds,
        "video_size": list(cfg.video_size),
    }
    stages.append(Stage("evaluate", root / "report", evaluate, report, downstream=True))
    return stages


def reproduce_table1(
    creature: Morphology,
    out: str | os.PathLike[str],
    cfg: ReproduceConfig,
    *,
    human_data: str | os.PathLike[str] | None = None,
    log: Callable[[str], None] = print,
) -> str:
    """Train, evaluate and report every method of Table 1 for ``creature`` under ``out`` (resumable).

    Args:
        creature: The character.
        out: Its folder: ``runs/`` (every run folder) and ``report/``.
        cfg: Preset, seeds, overrides, report options.
        human_data: Human motion folder (its held-out split is the evaluation set); ``None``: the
            embedded default human motion.
        log: Where progress lines go.

    Returns:
        Table 1 as markdown (``out/report/table.md``).
    """
    started = time.perf_counter()
    stages = plan_stages(creature, out, cfg, human_data=human_data, log=log)
    run_stages(stages, jobs=lanes_at_once(cfg.jobs, cfg.device), log=log)
    recorded = 0.0
    for stage in stages:
        try:
            recorded += float(json.loads((stage.folder / DONE_FILE).read_text())["seconds"])
        except (OSError, ValueError, KeyError):
            pass
    log(
        f"{creature.name}: {time.perf_counter() - started:.0f} s this time; {recorded:.0f} s of stage time in all "
        f"({recorded / 60:.1f} min, lanes added up)"
    )
    return (Path(out) / "report" / "table.md").read_text(encoding="utf-8")
