"""NKN training throughput: clips/s at given presets, and the share of a step spent in the FK layer.

For each preset and FK backend (morphkit's Warp FK with the bone-offset correction, the pure-torch
reference FK) it times full training steps (both cycle passes, D and G updates) on synthetic clips of
the shipped human and bone-length variants, then times the FK layer alone on the same calls (one per
decoder frame of each pass, forward and backward): the FK share is that time over the step's.

    python benchmarks/nkn.py                              # default and paper sizes, both backends
    python benchmarks/nkn.py --presets quick --steps 3 --json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--presets", default="default,paper")
    p.add_argument("--backends", default="warp,reference")
    p.add_argument("--steps", type=int, default=4, help="timed steps per case (after one warm-up step)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)

    import torch

    sys.path.insert(0, str(ROOT / "tests" / "retarget"))
    from _nkn_fixtures import write_skeleton_clips

    from morphkit.retarget.config import replace_config
    from morphkit.retarget.nkn import preset
    from morphkit.retarget.nkn import train as T
    from morphkit.retarget.nkn.networks import build_networks
    from morphkit.retarget.training_run import Run

    torch.set_num_threads(args.threads)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        data = write_skeleton_clips(Path(tmp) / "data", clips=3, frames=130)
        for name in args.presets.split(","):
            for backend in args.backends.split(","):
                cfg = replace_config(preset(name), {"fk_backend": backend, "data.train_variants": 2})
                setup = T.prepare(Path(tmp) / f"{name}_{backend}", cfg, human_data=data, log=lambda s: None)
                with Run(Path(tmp) / f"{name}_{backend}", trainer="nkn", config=cfg, progress=False,
                         tensorboard=False, handle_signals=False) as r:
                    nets = build_networks(cfg, setup.template, setup.source_features, setup.source_offsets)
                    g_params = list(nets["generator"].parameters())
                    opt_g = torch.optim.Adam(g_params, lr=cfg.lr, betas=cfg.betas)
                    opt_d = torch.optim.Adam(nets["discriminator"].parameters(), lr=cfg.lr, betas=cfg.betas)
                    r.extra["d_fake_score"] = 0.5
                    times = []
                    for i in range(args.steps + 1):
                        t0 = time.perf_counter()
                        T._skeleton_step(r, setup, cfg, nets, nets, opt_g, opt_d, g_params)
                        if i:
                            times.append(time.perf_counter() - t0)
                    step = sum(times) / len(times)
                    fk = nets["generator"].side.fk
                    B, frames = cfg.batch_size, cfg.clip_frames
                    q = torch.randn(B, 1, setup.template.coordinate_count, requires_grad=True)
                    off = setup.source.offsets[:1].expand(B, -1, -1)[:, None]
                    t0 = time.perf_counter()
                    total = 0.0
                    for _ in range(2 * frames):  # one call per decoder frame, two passes
                        total = total + fk(q, off).sum()
                    total.backward()
                    fk_time = time.perf_counter() - t0
                rows.append({"preset": name, "fk": backend, "hidden": cfg.hidden, "batch": B, "frames": frames,
                             "step_s": step, "clips_per_s": B / step, "fk_s": fk_time, "fk_share": fk_time / step})
                if not args.json:
                    print(f"{name:8s} {backend:9s} hidden {cfg.hidden:4d}  {step:6.2f} s/step  {B / step:6.1f} clips/s"
                          f"  FK {fk_time:5.2f} s ({100 * fk_time / step:4.1f} %)", flush=True)
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
