"""ACE throughput: training transitions/s of the prior step and the adversarial step beside the machine's
FLOP bound, and retargeting frames/s streamed and batched.

Targets (issue 10): the prior step at ``paper`` sizes, B = 1024, reaches >= 60 % of the bound
(``torch.mm``'s GFLOP/s measured in the same run × the step's matmul FLOPs); retargeting >= 1,000
frames/s for one clip streamed frame by frame and >= 20,000 frames/s batched over 64 clips, on 2 CPU
cores. The adversarial step's bound counts the networks' matmuls only (the FK through Warp and the
gradient penalty's double backward are extra work), so its ratio is a floor.

Run: ``python benchmarks/ace.py [--creature spot] [--json] [--quick]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from typing import Any


def _mm_gflops(n: int = 1024, repeats: int = 20) -> float:
    import torch

    a, b = torch.randn(n, n), torch.randn(n, n)
    for _ in range(3):
        a @ b
    t = time.perf_counter()
    for _ in range(repeats):
        a @ b
    return 2 * n**3 * repeats / (time.perf_counter() - t) / 1e9


def _timed(fn: Any, repeats: int) -> float:
    fn()
    t = time.perf_counter()
    for _ in range(repeats):
        fn()
    return (time.perf_counter() - t) / repeats


def _prior_step(state_dim: int, preset: str, batch: int, repeats: int, gflops: float) -> dict[str, Any]:
    import torch
    from torch.nn import functional as F

    from morphkit.retarget.ace.config import preset as get_preset
    from morphkit.retarget.ace.model import build_vae
    from morphkit.retarget.ace.networks import kl_divergence
    from morphkit.retarget.networks import matmul_flops

    cfg = get_preset(preset).prior
    vae = build_vae(state_dim, cfg)
    opt = torch.optim.Adam(vae.parameters(), 1e-4)
    x0, x1 = torch.randn(batch, state_dim), torch.randn(batch, state_dim)

    def step() -> None:
        out = vae(x0, x1)
        loss = F.mse_loss(out.x, x1) + cfg.kl_beta * kl_divergence(out.mu, out.logvar)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    s = _timed(step, repeats)
    flops = matmul_flops(vae, batch, backward=True)
    return {"stage": "prior step", "preset": preset, "batch": batch, "transitions_per_s": batch / s,
            "achieved_gflops": flops / s / 1e9, "bound_fraction": flops / s / 1e9 / gflops}


def _adversarial_step(data: Any, preset: str, batch: int, repeats: int, gflops: float) -> dict[str, Any]:
    import torch
    from torch.nn import functional as F

    from morphkit.metrics import feature_loss
    from morphkit.retarget.ace import train as T
    from morphkit.retarget.ace.config import preset as get_preset
    from morphkit.retarget.ace.model import Discriminator, Generator, build_vae, rollout
    from morphkit.retarget.networks import matmul_flops

    cfg = get_preset(preset)
    rc = cfg.retarget
    fm = data.features
    sr, sh = fm.creature_layout.dim, fm.human_layout.dim
    prior = T.frozen_prior(build_vae(sr, cfg.prior))
    gen, disc = Generator(sh, sr, cfg.prior.latent, rc), Discriminator(sr, rc)
    opt_g, opt_d = torch.optim.Adam(gen.parameters()), torch.optim.Adam(disc.parameters())
    window = rc.window
    x_h, x0 = torch.randn(batch, window, sh), torch.randn(batch, sr)
    real = torch.randn(batch * window, 2 * sr)

    def step() -> None:
        prev, fake = rollout(gen, prior, x_h, x0, tbptt=rc.tbptt)
        ft = torch.cat([prev, fake], -1).flatten(0, 1)
        d_real, gp = T.gradient_penalty(disc, real)
        loss_d = F.softplus(-d_real).mean() + F.softplus(disc(ft.detach())).mean() + 0.5 * rc.w_gp * gp
        opt_d.zero_grad(set_to_none=True)
        loss_d.backward()
        opt_d.step()
        psi_r = fm.psi_of_fixed(fm.creature_with_fk(fake)[0])
        loss_g = F.softplus(-T.disc_logits(disc, disc, ft)).mean() + feature_loss(fm.human_psi(x_h), psi_r)
        opt_g.zero_grad(set_to_none=True)
        loss_g.backward()
        opt_g.step()

    s = _timed(step, repeats)
    n = batch * window
    # G and π forward + backward over the rollout, D on reals (with GP ≈ 2 more passes) and fakes twice.
    flops = matmul_flops(gen, n, backward=True) + matmul_flops(prior, n, backward=True) \
        + matmul_flops(disc, n) * 3 * 4
    return {"stage": "adversarial step", "preset": preset, "batch": f"{batch}×{window}", "transitions_per_s": n / s,
            "achieved_gflops": flops / s / 1e9, "bound_fraction": flops / s / 1e9 / gflops}


def _retargeting(run_dir: str, clips: list, repeats: int) -> list[dict[str, Any]]:
    import torch

    from morphkit.retarget.ace.retarget import AceRetargeter

    model = AceRetargeter(run_dir)
    torch.set_grad_enabled(False)
    one = clips[:1]
    streamed = _timed(lambda: model.retarget(one, batch_size=1), repeats)
    batched_clips = (clips * (64 // len(clips) + 1))[:64]
    batched = _timed(lambda: model.retarget(batched_clips, batch_size=64), 1)
    f1 = one[0].frame_count
    f64 = sum(c.frame_count for c in batched_clips)
    return [
        {"stage": "retarget, 1 clip frame by frame", "frames_per_s": f1 / streamed, "target": 1000},
        {"stage": "retarget, 64 clips batched", "frames_per_s": f64 / batched, "target": 20000},
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--creature", default="spot")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--quick", action="store_true", help="fewer repeats, no paper-size adversarial step")
    args = parser.parse_args(argv)
    import tempfile

    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.retarget.ace import train as T
    from morphkit.retarget.ace.config import preset

    repeats = 3 if args.quick else 10
    with contextlib.redirect_stdout(sys.stderr), tempfile.TemporaryDirectory() as tmp:
        gflops = _mm_gflops()
        creature = read_morphology(resolve_morphology(args.creature))
        cfg = preset("smoke")
        T.train_ace(tmp, creature, cfg, progress=False, log=lambda s: None)
        data = T.prepare(tmp, creature, cfg, progress=False, log=lambda s: None)
        sr = data.features.creature_layout.dim
        rows = [_prior_step(sr, "default", 1024, repeats, gflops), _prior_step(sr, "paper", 1024, repeats, gflops),
                _adversarial_step(data, "default", 64, max(repeats // 3, 1), gflops)]
        if not args.quick:
            rows.append(_adversarial_step(data, "paper", 64, 2, gflops))
        rows += _retargeting(tmp, data.human[:8], repeats)
    if args.json:
        print(json.dumps({"mm_gflops": gflops, "rows": rows}, indent=1))
        return 0
    print(f"torch.mm: {gflops:.1f} GFLOP/s (1024², this machine, this run)")
    print("| stage | preset | batch | transitions/s | GFLOP/s | of the bound |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        if "transitions_per_s" in r:
            print(f"| {r['stage']} | {r['preset']} | {r['batch']} | {r['transitions_per_s']:,.0f} | "
                  f"{r['achieved_gflops']:.1f} | {100 * r['bound_fraction']:.0f}% |")
    print("\n| retargeting | frames/s | target |")
    print("|---|---|---|")
    for r in rows:
        if "frames_per_s" in r:
            print(f"| {r['stage']} | {r['frames_per_s']:,.0f} | ≥ {r['target']:,} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
