"""How much ACE's discriminator notices a planted foot sliding: its logit change for injected slides.

On real transitions of the run's character data where a foot is planted (ground step under 2 mm,
below 2 cm), that foot's end-effector in the second state is moved along the heading by 7 mm and by
30 mm (the ee slot, and with it what D's foot view reads where it has one,
``retarget.discriminator_feet``); the table gives the mean |Δ logit| and the mean logit change
(negative: "less like the data") over the transitions, per run. The issue that asked for D to see feet
measured 0.02 for 7 mm and 0.09 for 30 mm with the paper's D input.

    python benchmarks/ace_discriminator_feet.py runs/ace_spot_quick runs/ace_spot_quick_dfeet
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

SLIDES_M = (0.007, 0.03)


def _discriminator(stage: Path, state_dim: int):
    import torch

    from morphkit.retarget.ace.config import RetargetConfig
    from morphkit.retarget.ace.model import Discriminator
    from morphkit.retarget.config import read_config

    rc = read_config(RetargetConfig, stage / "config.yaml")
    state = torch.load(stage / "checkpoint.pt", map_location="cpu", weights_only=False)["states"]["discriminator"]
    first = next(v for k, v in state.items() if k.endswith("weight"))
    foot_count = (first.shape[1] - 2 * state_dim) // 3  # runs from before the foot view have none
    disc = Discriminator(state_dim, rc, foot_count)
    disc.load_state_dict(state)
    return disc.eval(), foot_count


def measure(run: Path, transitions: int = 4000, seed: int = 0) -> dict[float, tuple[float, float]]:
    """``slide [m] -> (mean |Δ logit|, mean Δ logit)`` of ``run``'s discriminator."""
    import torch

    from morphkit.motion import character_state_from_motion, character_state_layout, world_end_effectors
    from morphkit.retarget.ace.checkpoint import AceArtifact
    from morphkit.retarget.ace.model import foot_view
    from morphkit.retarget.ace.retarget import read_prior_config
    from morphkit.retarget.ace.train import foot_indices
    from morphkit.retarget.training_data import character_data

    art = AceArtifact.load(run)
    flags = read_prior_config(art.prior_stage(run) / "config.yaml").contact_flags
    m, lay, stats = art.creature, character_state_layout(art.creature, contacts=flags), art.character_stats
    feet = foot_indices(m)
    disc, foot_count = _discriminator(run / "retarget", lay.dim)
    motions, stance = character_data(m, art.data, progress=False)
    states = [character_state_from_motion(c, contacts=f if flags else None) for c, f in zip(motions, stance,
                                                                                            strict=True)]
    pairs = np.concatenate([np.stack([s[:-1], s[1:]], axis=1) for s in states])  # [N, 2, Sr]
    ee = pairs[..., lay.slice("ee_positions")].reshape(*pairs.shape[:2], -1, 3)
    p = world_end_effectors(pairs, lay, ee)[..., feet, :]
    step = np.linalg.norm(p[:, 1, :, :2] - p[:, 0, :, :2], axis=-1)
    planted = (step < 0.002) & (p[:, 1, :, 2] < 0.02)
    rows, cols = np.nonzero(planted)
    pick = np.random.default_rng(seed).choice(len(rows), size=min(transitions, len(rows)), replace=False)
    rows, cols = rows[pick], cols[pick]
    sl = lay.slice("ee_positions")

    def logits(x: np.ndarray) -> np.ndarray:
        t = torch.as_tensor(x, dtype=torch.float32)
        inp = torch.as_tensor(stats.normalize(x), dtype=torch.float32).flatten(1)
        if foot_count:
            inp = torch.cat([inp, foot_view(lay, feet, t[:, 0], t[:, 1])], dim=-1)
        with torch.no_grad():
            return disc(inp).numpy()

    base = logits(pairs[rows])
    out = {}
    for slide in SLIDES_M:
        moved = pairs[rows].copy()
        col = sl.start + 3 * np.asarray(feet)[cols]
        moved[np.arange(len(rows)), 1, col] += slide  # along the heading (x of the heading frame)
        delta = logits(moved) - base
        out[slide] = (float(np.abs(delta).mean()), float(delta.mean()))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", type=Path, help="ACE run folders (a prior and a retarget stage)")
    args = p.parse_args(argv)
    print("| run | D sees feet | " + " | ".join(f"|Δ logit| {1000 * s:.0f} mm (mean Δ)" for s in SLIDES_M) + " |")
    print("|---|---|" + "---|" * len(SLIDES_M))
    for run in args.runs:
        res = measure(run)
        cells = " | ".join(f"{a:.3f} ({d:+.3f})" for a, d in res.values())
        print(f"| {run} | {_sees_feet(run)} | {cells} |")
    return 0


def _sees_feet(run: Path) -> str:
    from morphkit.motion import character_state_layout
    from morphkit.retarget.ace.checkpoint import AceArtifact
    from morphkit.retarget.ace.retarget import read_prior_config

    art = AceArtifact.load(run)
    flags = read_prior_config(art.prior_stage(run) / "config.yaml").contact_flags
    dim = character_state_layout(art.creature, contacts=flags).dim
    return "yes" if _discriminator(run / "retarget", dim)[1] else "no"


if __name__ == "__main__":
    sys.exit(main())
