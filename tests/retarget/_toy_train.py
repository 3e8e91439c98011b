"""A tiny seeded trainer for the resume and torchrun tests: an MLP with dropout on fixed random data.

Every step draws from every RNG the run owns (torch global through dropout, the run's torch
generator, its NumPy generator, Python's random), so an exact resume has to restore them all.

    python tests/retarget/_toy_train.py RUN_DIR [--kill-at STEP] [--term-at STEP] [--checkpoint-every N]
    torchrun --standalone --nproc_per_node 2 tests/retarget/_toy_train.py RUN_DIR --hash-dir DIR
"""

from __future__ import annotations

import argparse
import faulthandler
import hashlib
import os
import random
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

import torch

from morphkit.retarget import MLP, Run


@dataclass(frozen=True)
class ToyConfig:
    """The toy trainer's config."""

    seed: int = 0
    epochs: int = 3
    samples: int = 96
    batch_size: int = 8
    lr: float = 1e-2


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("run_dir")
    parser.add_argument("--kill-at", type=int, help="SIGKILL this process when starting this global step")
    parser.add_argument("--term-at", type=int, help="rank 0 sends itself SIGTERM during this global step")
    parser.add_argument("--checkpoint-every", type=int)
    parser.add_argument("--hash-dir", help="each rank writes its parameters' SHA-256 here")
    parser.add_argument("--samples", type=int, default=ToyConfig.samples)
    parser.add_argument("--give-up-after", type=float, help="seconds: print every thread's stack to stderr and exit 1")
    args = parser.parse_args()
    if args.give_up_after:
        # A watchdog in the process itself: a hung rank says where it waits and ends, so no orphan outlives the test.
        faulthandler.dump_traceback_later(args.give_up_after, exit=True)
    torch.set_num_threads(1)
    cfg = ToyConfig(samples=args.samples)
    with Run(
        args.run_dir, trainer="toy", config=cfg, creature="blob", device="cpu", checkpoint_every=args.checkpoint_every
    ) as run:
        data = torch.Generator().manual_seed(123)
        x = torch.randn(cfg.samples, 4, generator=data)
        y = x.sum(1, keepdim=True).sin()
        model = run.wrap(MLP(4, (16,), 1, dropout=0.2))
        opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
        sched = torch.optim.lr_scheduler.StepLR(opt, step_size=5, gamma=0.9)
        run.track(model=model, optimizer=opt, scheduler=sched)
        for epoch in run.epochs(cfg.epochs):
            for idx in run.batches(cfg.samples, cfg.batch_size):
                if run.global_step == args.kill_at:
                    os.kill(os.getpid(), signal.SIGKILL)
                if run.global_step == args.term_at and run.is_main:
                    os.kill(os.getpid(), signal.SIGTERM)
                noise = torch.as_tensor(run.np_rng.normal(size=(len(idx), 1)), dtype=torch.float32)
                shift = torch.randn(len(idx), 4, generator=run.generator)
                loss = ((model(x[idx] + 1e-3 * shift) - y[idx] - 0.01 * noise) ** 2).mean() + 1e-3 * random.random()
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
                run.log(loss=loss, lr=sched.get_last_lr()[0])
            run.extra["epochs_done"] = epoch + 1
        params = torch.cat([p.detach().flatten() for p in model.parameters()])
        if run.is_main:
            torch.save(params, Path(args.run_dir) / "final.pt")
        if args.hash_dir:
            digest = hashlib.sha256(params.numpy().tobytes()).hexdigest()
            Path(args.hash_dir, f"rank{run.context.rank}.txt").write_text(digest)
        rank = run.context.rank
    if args.hash_dir:  # the native threads left once the run closed (Gloo's, if its group outlived the run)
        threads = sorted(Path(f"/proc/self/task/{t}/comm").read_text().strip() for t in os.listdir("/proc/self/task"))
        Path(args.hash_dir, f"threads{rank}.txt").write_text("\n".join(threads))
    assert "warp" not in sys.modules, "the trainer layer imported warp"
    return 0


if __name__ == "__main__":
    sys.exit(main())
