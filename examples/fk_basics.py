"""Kinematics in PyTorch: forward kinematics, gradients and contact queries of any creature.

Compiles a creature (Spot by default), runs batched FK through the Warp kernels, checks the gradient
of an end-effector against central differences and against the pure-torch reference FK, reaches a
target with the gripper by gradient descent on ``q``, and measures ground contact on a motion built
by hand, where the answers are known: a body that glides forward at 0.5 m/s with frozen legs slides
its planted feet at 0.5 m/s, and a body lowered 3 cm below its standing height pushes its feet 3 cm
into the ground. Writes the reached pose (``reach.npz``) and the numbers (``fk_basics.json``).

    python examples/fk_basics.py                      # Spot
    python examples/fk_basics.py --creature crab --out runs/fk_basics_crab
    python examples/fk_basics.py --smoke              # seconds: the test suite's mode
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--creature", default="spot", help="shipped name or description file (default spot)")
    p.add_argument("--out", metavar="DIR", default="runs/fk_basics", help="output folder (default runs/fk_basics)")
    p.add_argument("--batch", type=int, default=4096, help="poses in the FK batch (default 4096)")
    p.add_argument("--smoke", action="store_true", help="a small batch and few optimisation steps")
    args = p.parse_args(argv)

    from morphkit.cli import run_command

    return run_command(run, args)


def run(args: argparse.Namespace) -> int:
    import torch

    import morphkit.torch as mt
    from morphkit.io import read_morphology
    from morphkit.kernels import foot_indices
    from morphkit.model import compile_model
    from morphkit.motion import Motion, write_motion
    from morphkit.torch.reference import end_effectors_reference, fk_reference

    started = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    creature = read_morphology(args.creature)
    model = compile_model(creature)  # flat arrays for the kernels; float32 on the CPU by default
    C = creature.coordinate_count
    feet = [int(i) for i in foot_indices(model)]
    rest = torch.as_tensor(creature.rest_q(), dtype=torch.float32)  # the base at the origin
    if feet and creature.base_coordinate_count == 7:  # stand it on the ground: lowest foot at z = 0
        rest[2] -= mt.end_effector_positions(model, rest)[feet, 2].min()
    numbers: dict[str, float] = {}

    # 1. Batched FK: random poses within the joint limits, every link's world pose [B, L, 7].
    gen = torch.Generator().manual_seed(0)
    lower, upper = (torch.as_tensor(b, dtype=torch.float32) for b in creature.coordinate_limits)
    lower, upper = torch.where(lower.isfinite(), lower, -3.0), torch.where(upper.isfinite(), upper, 3.0)
    B = 256 if args.smoke else args.batch
    q = lower + (upper - lower) * torch.rand(B, C, generator=gen)
    q[:, : creature.base_coordinate_count] = rest[: creature.base_coordinate_count]  # the base at rest
    Ts = mt.fk(model, q)
    print(f"{creature.name}: q [{B}, {C}] -> Ts_world_link {list(Ts.shape)} (xyz, then an xyzw quaternion)")

    # 2. Gradients flow from end-effector points back to q (Warp adjoints), and match central differences.
    q64 = q[:4].double().requires_grad_(True)
    points = mt.end_effector_positions(model, q64)  # [4, E, 3] in the world frame; float64 in, float64 out
    points[..., 2].sum().backward()  # d(sum of end-effector heights)/dq
    h = 1e-6
    fd = torch.zeros(C, dtype=torch.float64)
    with torch.no_grad():
        for i in range(C):
            dq = torch.zeros_like(q64)
            dq[:, i] = h
            fd[i] = (mt.end_effector_positions(model, q64 + dq)[..., 2].sum() -
                     mt.end_effector_positions(model, q64 - dq)[..., 2].sum()) / (2 * h)
    grad = q64.grad.sum(0)  # the poses are independent: the gradient of the batch sum, per coordinate
    numbers["grad_vs_central_difference"] = float((grad - fd).abs().max())
    print(f"d(end-effector heights)/dq over all {C} coordinates: largest |autograd - central differences| = "
          f"{numbers['grad_vs_central_difference']:.1e} (gradient norm {float(grad.norm()):.2f})")

    # 3. The pure-torch reference FK (plain autograd: double backward, gradients w.r.t. bone offsets) agrees.
    ref = end_effectors_reference(model, fk_reference(model, q64.detach()))[..., :3]
    numbers["warp_vs_reference_m"] = float((ref - points.detach()).abs().max())
    print(f"Warp FK vs the pure-torch reference: {numbers['warp_vs_reference_m']:.2e} m")

    # 4. Reach: move a hand (or tool, else a foot) to a point 15 cm away, by Adam on the joint coordinates.
    roles = [e.role.name for e in creature.end_effectors]
    target_ee = next((i for i, r in enumerate(roles) if r in ("HAND", "TOOL")), feet[0] if feet else 0)
    start = mt.end_effector_positions(model, rest)[target_ee].detach()
    goal = start + torch.tensor([-0.05, 0.10, -0.10])
    q_opt = rest.clone().requires_grad_(True)
    opt = torch.optim.Adam([q_opt], lr=0.05)
    steps = 80 if args.smoke else 200
    for _ in range(steps):
        opt.zero_grad()
        loss = (mt.end_effector_positions(model, q_opt)[target_ee] - goal).square().sum()
        loss.backward()
        q_opt.grad[: creature.base_coordinate_count] = 0  # keep the base where it stands
        opt.step()
        with torch.no_grad():
            q_opt.clamp_(torch.as_tensor(creature.coordinate_limits[0], dtype=torch.float32),
                         torch.as_tensor(creature.coordinate_limits[1], dtype=torch.float32))
    reached = float((mt.end_effector_positions(model, q_opt.detach())[target_ee] - goal).norm())
    numbers["reach_error_m"] = reached
    name = creature.end_effectors[target_ee].name
    print(f"reach: {name} from {float((goal - start).norm()) * 100:.1f} cm away to {reached * 100:.2f} cm "
          f"in {steps} Adam steps")
    write_motion(Motion(creature, 30.0, q_opt.detach().numpy()[None], "reach"), out / "reach.npz")

    # 5. Contact on a motion built by hand: 1 s at 30 fps, legs frozen at rest, the base gliding forward
    #    at 0.5 m/s and sinking 3 cm over the second half.
    if feet and creature.base_coordinate_count == 7:
        T, fps = 30, 30.0
        motion = rest.repeat(T, 1)
        motion[:, 0] += 0.5 * torch.arange(T) / fps
        motion[T // 2:, 2] -= 0.03
        P = mt.end_effector_positions(model, motion)  # [T, E, 3]
        standing = float(mt.foot_heights(P[:1], feet=feet).min())
        depth = mt.penetration_depth(P, feet=feet)  # [T, F]
        slide = mt.sliding_speed(P, fps, feet=feet, height_threshold=standing + 0.02)  # [T, F]
        numbers["sliding_m_s"] = float(slide[1: T // 2].mean())
        numbers["penetration_m"] = float(depth[-1].max())
        numbers["rest_foot_height_m"] = standing
        print(f"sliding while planted: {numbers['sliding_m_s']:.3f} m/s (the body glides at 0.500)")
        print(f"penetration after sinking 3 cm: {numbers['penetration_m'] * 100:.2f} cm "
              f"(feet stood {standing * 100:.2f} cm above the ground)")
        # Penetration is differentiable too: its gradient lifts the base.
        q_last = motion[-1].clone().requires_grad_(True)
        mt.penetration_depth(mt.end_effector_positions(model, q_last), feet=feet).sum().backward()
        print(f"d(penetration)/d(base z) = {float(q_last.grad[2]):+.2f} (one per foot in the ground, negated)")

    (out / "fk_basics.json").write_text(json.dumps(numbers, indent=2) + "\n")
    print(f"done in {time.perf_counter() - started:.1f} s: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
