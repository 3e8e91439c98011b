"""Can a trained ACE prior move a hand where asked? The frozen π, driven by latents inside G's bound.

For each run, the latents of a 3-s rollout from one of the run's start states are optimised (Adam,
nothing else trained) so that the first hand or tool end-effector's height above the ground follows a
sine between the character data's 10th and 90th percentile heights of it (one period per 3 s); the
table gives the height's RMS error, its correlation with the target and the range it covers. A prior
that reaches the target here while the trained G does not follow the human's hand puts the fault in
G's objective, not in the prior (measured on the main job's run: RMS < 1 mm, correlation 1.00).

    python benchmarks/ace_prior_reach.py runs/ace_spot_quick [RUN ...] [--iterations 150]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def measure(run: Path, iterations: int = 150, seconds: float = 3.0, seed: int = 0) -> dict[str, float]:
    """RMS error [m], correlation and covered range [m] of the optimised hand height of ``run``'s prior."""
    import torch

    from morphkit.graph import EndEffectorRole
    from morphkit.retarget.ace.retarget import AceRetargeter
    from morphkit.retarget.training_data import character_motions
    from morphkit.synth import default_human_motion

    torch.manual_seed(seed)
    model = AceRetargeter(run)
    m, lay, stats = model.creature, model.layout, model.artifact.character_stats
    hands = [i for i, e in enumerate(m.end_effectors) if e.role in (EndEffectorRole.HAND, EndEffectorRole.TOOL)]
    if not hands:
        raise SystemExit(f"{run}: {m.name} has no hand or tool end-effector")
    hand = hands[0]
    data = np.concatenate([c.end_effector_positions()[:, hand, 2]
                           for c in character_motions(m, model.data, progress=False)])
    lo, hi = np.percentile(data, [10, 90])
    human = model.intake(next(iter(default_human_motion(frames=60, seed=seed, fps=model.fps))))
    fmap = model.feature_map(human)  # only its creature side (FK, statistics) is used
    T = round(seconds * model.fps)
    t = torch.arange(T, dtype=torch.float32) / model.fps
    target = float(lo + hi) / 2 + float(hi - lo) / 2 * torch.sin(2 * np.pi * t / seconds)
    x0 = torch.as_tensor(stats.normalize(model.artifact.start_states[:1]), dtype=torch.float32)
    gen = model.generator
    g = torch.zeros(T, gen.z_mean.shape[0], requires_grad=True)
    opt = torch.optim.Adam([g], lr=0.05)
    height = torch.zeros(T)
    for it in range(iterations + 1):  # the last pass measures the final latents
        x, heights = x0, []
        for k in range(T):
            z = gen.latent(g[k : k + 1])
            x = model.prior(z, x)
            d = stats.denormalize(x)
            heights.append(d[0, lay.slice("root_height")][0] + fmap.fk_end_effectors(d)[0, hand, 2])
        height = torch.stack(heights)
        if it < iterations:
            opt.zero_grad()
            (height - target).square().mean().backward()
            opt.step()
    h, y = height.detach().numpy(), target.numpy()
    return {"rms": float(np.sqrt(np.mean((h - y) ** 2))), "corr": float(np.corrcoef(h, y)[0, 1]),
            "low": float(h.min()), "high": float(h.max()), "target_low": float(lo), "target_high": float(hi)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", type=Path, help="ACE run folders")
    p.add_argument("--iterations", type=int, default=150)
    args = p.parse_args(argv)
    print("| run | target range [m] | reached range [m] | RMS error [m] | correlation |")
    print("|---|---|---|---|---|")
    for run in args.runs:
        r = measure(run, iterations=args.iterations)
        print(f"| {run} | {r['target_low']:.2f}–{r['target_high']:.2f} | {r['low']:.2f}–{r['high']:.2f} | "
              f"{r['rms']:.4f} | {r['corr']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
