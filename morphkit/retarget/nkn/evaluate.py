"""Evaluating NKN against the copy baseline, without paired ground truth (none exists in this data).

Mixamo gave the paper ground-truth retargeted motion; motion capture of one subject does not. So
the numbers here measure what can be measured honestly:

* **cycle error**: A → B → A, mean link-position error of the reconstruction [m] over A's height
  (:attr:`~morphkit.graph.Morphology.characteristic_length`). NKN only: the baseline is exactly invertible.
* **end-effector error** against a *per-limb scaled* source: for end-effector $e$ with chain length
  ratio $r_e$ (target over source, root to the end-effector point along the bones) and leg-length
  ratio $r$, the reference is $\\tilde e(t) = [xy_0 + r\\,(xy(t) - xy_0),\\ r\\,z(t)] + r_e\\,(e^A(t) - root^A(t))$,
  the source root's ground path and height scaled by the legs and each limb's reach by its own
  ratio; the error is the mean distance to it over the target's height. A proxy, not a ground truth:
  a limb scaled as a whole is what the copy baseline produces, so on uniformly scaled limbs the
  baseline is close to it by construction.
* **foot sliding** [m/s]: horizontal foot speed while a foot is within 2 cm of the ground, mean over
  those foot-frames (:func:`morphkit.torch.sliding_speed`); **penetration** [m]: mean depth below the
  ground over all foot-frames (:func:`morphkit.torch.penetration_depth`); **float** [m]: mean height
  of the lowest foot (a floating character slides "less" because it never touches the ground).

:func:`plot_end_effector_heights` draws the paper's Fig.-5-style panels: the height of feet and
hands over time, NKN against the baseline and the scaled source.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

import morphkit.torch as mt
from morphkit.contact_rules import UFR
from morphkit.graph import EndEffectorRole, Morphology
from morphkit.model import compile_model
from morphkit.motion import Motion
from morphkit.output_names import safe_stem
from morphkit.retarget.nkn.features import local_positions
from morphkit.retarget.nkn.fk import SkeletonFK
from morphkit.retarget.nkn.retarget import NknRetargeter
from morphkit.retarget.nkn.skeleton import bone_offsets

__all__ = [
    "Score",
    "chain_lengths",
    "compare_with_baseline",
    "contact_metrics",
    "cycle_error",
    "end_effector_error",
    "end_effector_points",
    "format_scores",
    "plot_end_effector_heights",
    "scaled_reference",
    "score",
    "write_scores",
]

_models: dict[int, tuple[Morphology, object]] = {}


def _model(m: Morphology) -> object:
    hit = _models.get(id(m))
    if hit is None or hit[0] is not m:
        hit = _models[id(m)] = (m, compile_model(m))
    return hit[1]


def end_effector_points(motion: Motion) -> np.ndarray:
    """World end-effector points [T, E, 3] [m] of a motion (morphkit's Warp FK)."""
    q = torch.tensor(motion.q, dtype=torch.float64)
    with torch.no_grad():
        return mt.end_effector_positions(_model(motion.morphology), q).numpy()


def chain_lengths(morphology: Morphology) -> np.ndarray:
    """Length [m] along the bones from the root to each end-effector point, shape [E]."""
    out = []
    for ee in morphology.end_effectors:
        bones = [np.linalg.norm(morphology.joint(n).origin.xyz) for n in morphology.chain(ee.link)]
        out.append(float(sum(bones) + np.linalg.norm(ee.offset)))
    return np.array(out)


def _leg_ratio(source: Morphology, target: Morphology) -> float:
    a, b = source.leg_length, target.leg_length
    return b / a if a > 1e-9 and b > 1e-9 else 1.0


def scaled_reference(source: Motion, target: Morphology) -> np.ndarray:
    """The per-limb scaled source end-effectors $\\tilde e(t)$ [T, E, 3] (see the module docstring)."""
    ee = end_effector_points(source)
    root = source.root_pose()[:, :3]
    r = _leg_ratio(source.morphology, target)
    ratio = chain_lengths(target) / np.maximum(chain_lengths(source.morphology), 1e-9)
    base = np.empty_like(root)
    base[:, :2] = root[0, :2] + r * (root[:, :2] - root[0, :2])
    base[:, 2] = r * root[:, 2]
    return base[:, None] + ratio[None, :, None] * (ee - root[:, None])


def end_effector_error(source: Motion, retargeted: Motion) -> float:
    """Mean distance of the retargeted end-effectors to the scaled source reference, over the target's height."""
    ref = scaled_reference(source, retargeted.morphology)
    got = end_effector_points(retargeted)
    return float(np.linalg.norm(got - ref, axis=-1).mean() / retargeted.morphology.characteristic_length)


def contact_metrics(motion: Motion, *, height_threshold: float = UFR.height) -> dict[str, float]:
    """``sliding`` [m/s] (mean over foot-frames in contact), ``penetration`` [m] and ``float`` [m] of a motion."""
    feet = [i for i, e in enumerate(motion.morphology.end_effectors) if e.role == EndEffectorRole.FOOT]
    if not feet:
        return {"sliding": float("nan"), "penetration": float("nan"), "float": float("nan")}
    P = torch.tensor(end_effector_points(motion))[None]  # [1, T, E, 3]
    speed = mt.sliding_speed(P, motion.fps, feet=feet, height_threshold=height_threshold)[0]  # [T, F]
    heights = P[0, :, feet, 2]
    contact = heights < height_threshold
    pen = mt.penetration_depth(P[0], feet=feet)
    return {"sliding": float(speed[contact].mean()) if bool(contact.any()) else 0.0,
            "penetration": float(pen.mean()), "float": float(heights.min(dim=-1).values.mean())}


def cycle_error(source: Motion, reconstruction: np.ndarray) -> float:
    """Mean link-position error [m] of a cycle's local reconstruction [T, L, 3] over the source's height."""
    fk = SkeletonFK(source.morphology)
    with torch.no_grad():
        P = fk(torch.tensor(source.q, dtype=torch.float64),
               torch.tensor(bone_offsets(source.morphology), dtype=torch.float64)).numpy()
    p = local_positions(P, source.root_pose())
    return float(np.linalg.norm(reconstruction - p, axis=-1).mean() / source.morphology.characteristic_length)


@dataclass(frozen=True)
class Score:
    """One row of the evaluation: a method on one target character, averaged over clips."""

    method: str
    target: str
    seen: bool
    leg_ratio: float
    """Target over source leg length."""
    ee_error: float
    sliding: float
    penetration: float
    floating: float
    cycle: float | None
    clips: int

    def as_dict(self) -> dict[str, object]:
        return {"method": self.method, "target": self.target, "seen": self.seen, "leg_ratio": self.leg_ratio,
                "ee_error": self.ee_error, "sliding": self.sliding, "penetration": self.penetration,
                "float": self.floating, "cycle": self.cycle, "clips": self.clips}


def score(method: str, target: Morphology, seen: bool, sources: Sequence[Motion], outputs: Sequence[Motion],
          cycles: Sequence[np.ndarray] | None = None) -> Score:
    """Average the metrics of ``outputs`` (each retargeted from the matching source) into one :class:`Score`."""
    contacts = [contact_metrics(m) for m in outputs]
    return Score(method, target.name, seen, float(np.mean([_leg_ratio(s.morphology, target) for s in sources])),
                 float(np.mean([end_effector_error(s, m) for s, m in zip(sources, outputs, strict=True)])),
                 float(np.mean([c["sliding"] for c in contacts])), float(np.mean([c["penetration"] for c in contacts])),
                 float(np.mean([c["float"] for c in contacts])),
                 None if cycles is None else float(np.mean([cycle_error(s, c) for s, c in
                                                            zip(sources, cycles, strict=True)])), len(outputs))


def format_scores(rows: Sequence[Score]) -> str:
    """Markdown table of :class:`Score` rows."""
    lines = ["| target | seen | leg ratio | method | EE error ↓ | sliding [m/s] ↓ | penetration [mm] ↓ | "
             "float [mm] | cycle ↓ |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cyc = "—" if r.cycle is None else f"{r.cycle:.4f}"
        lines.append(f"| {r.target} | {'yes' if r.seen else 'no'} | {r.leg_ratio:.2f} | {r.method} | "
                     f"{r.ee_error:.4f} | {r.sliding:.3f} | {1000 * r.penetration:.1f} | "
                     f"{1000 * r.floating:.1f} | {cyc} |")
    return "\n".join(lines)


def write_scores(rows: Sequence[Score], stem: str | os.PathLike[str]) -> str:
    """Write ``stem.md`` and ``stem.csv`` (atomically); returns the markdown."""
    from morphkit.retarget.tables import write_table_files

    return write_table_files(stem, format_scores(rows), [r.as_dict() for r in rows])


def plot_end_effector_heights(source: Motion, results: Mapping[str, Motion], path: str | os.PathLike[str], *,
                              title: str = "") -> Path:
    """Fig.-5-style PNG: height over time of each foot and hand, per method, beside the scaled source.

    Args:
        source: The source clip.
        results: Label → retargeted motion (one target skeleton).
        path: The PNG to write (atomically).
        title: Figure title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from morphkit._atomic import atomic_path

    target = next(iter(results.values())).morphology
    roles = (EndEffectorRole.FOOT, EndEffectorRole.HAND)
    picks = [i for i, e in enumerate(target.end_effectors) if e.role in roles] or list(range(len(target.end_effectors)))
    ref = scaled_reference(source, target)
    t = np.arange(source.frame_count) / source.fps
    fig, axes = plt.subplots(len(picks), 1, figsize=(8, 1.8 * len(picks) + 0.6), sharex=True, squeeze=False)
    styles = ["-", "--", ":", "-."]
    for row, e in enumerate(picks):
        ax = axes[row, 0]
        ax.plot(t, ref[:, e, 2], color="black", lw=1.5, label="source (per-limb scaled)")
        for k, (label, motion) in enumerate(results.items()):
            ax.plot(t, end_effector_points(motion)[:, e, 2], styles[k % len(styles)], lw=1.2, label=label)
        ax.set_ylabel(f"{target.end_effectors[e].name}\nz [m]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(title or f"{source.name} → {target.name}", fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def compare_with_baseline(retargeter: NknRetargeter, clips: Sequence[Motion],
                          targets: Sequence[tuple[Morphology, bool]], *, plot_dir: str | os.PathLike[str] | None = None,
                          plots_per_target: int = 1) -> tuple[list[Score], list[Path]]:
    """NKN and the copy baseline on every ``(target, seen)`` skeleton, plus the source clips' own row.

    Returns:
        ``(rows, plots)``: one :class:`Score` per method and target (the first row: the sources
        themselves), and the Fig.-5-style PNGs written under ``plot_dir`` (when given).
    """
    from morphkit.retarget.nkn.retarget import copy_rotations

    clips = list(clips)
    rows = [score("source", clips[0].morphology, True, clips, clips)]
    plots: list[Path] = []
    for target, seen in targets:
        nkn = [r.motion for r in retargeter.retarget(clips, target)]
        cycles = retargeter.cycle(clips, target)
        copy = [copy_rotations(c, target) for c in clips]
        rows.append(score("NKN", target, seen, clips, nkn, cycles))
        rows.append(score("copy rotations", target, seen, clips, copy))
        if plot_dir is not None:
            for i in range(min(plots_per_target, len(clips))):
                label = "seen" if seen else "unseen"
                ratio = _leg_ratio(clips[i].morphology, target)
                stem = safe_stem(f"{safe_stem(clips[i].name, 'clip')}_to_{safe_stem(target.name, 'target')}")
                path = Path(plot_dir) / f"{stem}.png"
                plots.append(plot_end_effector_heights(
                    clips[i], {"NKN": nkn[i], "copy rotations": copy[i]}, path,
                    title=f"{clips[i].name} → {target.name} ({label}, leg ratio {ratio:.2f})"))
    return rows, plots
