"""NKN's targets on a trained same-topology run: what a user of NKN can deliver, against the copy baseline.

Two tables, on a run trained over CMU's 22 joints (``examples/nkn_train.py --human-data …/cmu …``):

1. **Unseen bone-length variants** (short legs, long legs, long arms & short legs, tall), the held-out
   CMU clips cut into 4-second pieces: finite output; how the end-effector heights (head, hands, feet)
   follow the source's (mean Pearson correlation, :func:`morphkit.metrics.pearson_follow`, over the
   end-effectors the source moves by more than 1 cm, see :data:`STILL`); PhysDiff's
   Float and Penetrate (median over clips, mm) and GMD's skating ratio — raw and through the
   contact-aware export ``lock`` (:func:`morphkit.contact_export.lock_feet`).
2. **A paired truth** (the paper's Mixamo protocol, §5): five CMU trials exist in both ``human/cmu``
   (22 joints, 30 fps) and ``human/cmu_daz`` (43 joints, 120 fps), the same performance. The Daz clip is
   re-expressed on the 22 joints with its own bone lengths (``cmu_daz43`` onto the canonical human, then
   ``canonical_human_to_cmu22``); NKN and copy retarget the 22-joint clip onto that skeleton; the error is
   the mean link-position distance to the Daz clip over the skeleton's height, per limb group. The two
   captures are aligned once (best lag within ±4/120 s, best ground-plane rotation and shift of the
   root paths, source against truth), the same for every method. The trials must be kept out of the
   run's training (``--set 'data.held_out=["05_01","06_01","07_03","08_08","13_32"]'``).

    python benchmarks/nkn_targets.py runs/nkn_cmu_second_default --data ../shared/data
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

TRIALS = ("05_01", "06_01", "07_03", "08_08", "13_32")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("run", help="a trained NKN run over CMU's 22 joints")
    p.add_argument("--data", required=True, help="the data folder (holds human/cmu and human/cmu_daz)")
    p.add_argument("--clips", type=int, default=24, help="4-second held-out pieces for table 1 (default 24)")
    p.add_argument("--plots", metavar="DIR", help="write Fig.-5-style plots of the first piece here")
    args = p.parse_args(argv)
    started = time.perf_counter()
    from morphkit.retarget.nkn import NknRetargeter

    model = NknRetargeter(args.run)
    held = set(model.config.data.held_out)
    missing = [t for t in TRIALS if t not in held]
    if missing:
        print(f"note: trials {', '.join(missing)} were not held out of this run's training", file=sys.stderr)
    print(variant_table(model, Path(args.data), args.clips, args.plots))
    print()
    print(paired_table(model, Path(args.data)))
    print(f"\n{time.perf_counter() - started:.0f} s")
    return 0


STILL = 0.01
"""A source end-effector whose height varies less than this [m] (standard deviation over the piece: a
planted foot) has no movement to follow; its correlation is left out for every method alike (a foot
held on the ground would otherwise be scored by how well it copies millimetres of capture noise)."""


def _ee_heights(motion) -> dict[str, np.ndarray]:
    from morphkit.graph import EndEffectorRole

    roles = (EndEffectorRole.HEAD, EndEffectorRole.HAND, EndEffectorRole.FOOT)
    z = motion.end_effector_positions()[..., 2]
    return {e.name: z[:, i] for i, e in enumerate(motion.morphology.end_effectors) if e.role in roles}


def _follow(source, motion) -> float:
    """Mean Pearson correlation of the moving source end-effectors' heights with the motion's."""
    from morphkit.metrics import follow_score

    src = {k: v for k, v in _ee_heights(source).items() if v.std() > STILL}
    return follow_score(src, {k: v for k, v in _ee_heights(motion).items() if k in src}).mean if src else float("nan")


def variant_table(model, data: Path, clips: int, plots: str | None) -> str:
    """Table 1 of the module docstring (markdown)."""
    from morphkit.contact_export import lock_feet
    from morphkit.metrics import physdiff_figures, skating_ratio
    from morphkit.retarget.nkn.data import evaluation_pieces
    from morphkit.retarget.nkn.evaluate import plot_end_effector_heights
    from morphkit.retarget.nkn.retarget import copy_rotations
    from morphkit.retarget.nkn.skeleton import EVALUATION_VARIANTS, scale_limbs

    pieces = evaluation_pieces(data / "human" / "cmu", model.config.data, limit=clips)
    rows = ["| target | method | finite | EE-height follow ↑ | Float mm (median) ↓ | Penetrate mm (median) ↓ | "
            "skating ↓ |", "|---|---|---|---|---|---|---|"]
    for name, scales in EVALUATION_VARIANTS.items():
        target = scale_limbs(model.template, scales, name=name)
        nkn = [r.motion for r in model.retarget(pieces, target)]
        copy = [copy_rotations(c, target) for c in pieces]
        methods = {"copy": copy, "copy+lock": [lock_feet(m) for m in copy],
                   "NKN": nkn, "NKN+lock": [lock_feet(m) for m in nkn]}
        if plots:
            plot_end_effector_heights(pieces[0], {k: v[0] for k, v in methods.items()},
                                      Path(plots) / f"{pieces[0].name}_to_{name}.png")
        for label, motions in methods.items():
            finite = sum(bool(np.isfinite(m.q).all()) for m in motions)
            follow = np.nanmean([_follow(s, m) for s, m in zip(pieces, motions, strict=True)])
            phys = [physdiff_figures(m) for m in motions]
            rows.append(f"| {name} | {label} | {finite}/{len(motions)} | {follow:.3f} | "
                        f"{np.median([f.float_mm for f in phys]):.1f} | "
                        f"{np.median([f.penetrate_mm for f in phys]):.1f} | "
                        f"{np.mean([skating_ratio(m) for m in motions]):.3f} |")
    return "\n".join(rows)


def daz_on_template(path: Path, template, name: str):
    """The Daz clip (frame 0, its T-pose, dropped) on the template's 22 joints with its own bone lengths."""
    from morphkit.motion import canonical_human, read_motion
    from morphkit.motion.canonical import find_skeleton_map, map_skeleton_motion
    from morphkit.retarget.nkn.mapping import find_link_map, map_motion

    daz = read_motion(path).slice(1)
    canon = canonical_human()
    table = find_skeleton_map(daz.morphology, canon)
    on_canon = map_skeleton_motion(daz, canon, table, skeleton_name=name)
    return map_motion(on_canon, template, find_link_map(on_canon.morphology, template), skeleton_name=name)


def _align(source, truth):
    """``truth`` sampled at ``source``'s frames (best lag), and the ground-plane rotation R [2, 2] and shift
    [2] that put it on ``source``'s root path: ``(truth_motion, frames_of_source, R, shift)``."""
    from morphkit.motion import Motion

    best = None
    for lag in range(-4, 5):
        times = np.arange(source.frame_count) / source.fps + lag / 120.0
        ok = (times >= 0) & (times <= truth.duration)
        tt = Motion(truth.morphology, source.fps, truth.sample(times[ok]), truth.name)
        pa, pb = source.root_pose()[ok, :2], tt.root_pose()[:, :2]
        H = (pb - pb.mean(0)).T @ (pa - pa.mean(0))
        U, _, Vt = np.linalg.svd(H)
        R = Vt.T @ np.diag([1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
        shift = pa.mean(0) - pb.mean(0) @ R.T
        err = float(np.linalg.norm(pa - (pb @ R.T + shift), axis=-1).mean())
        if best is None or err < best[0]:
            best = (err, tt, ok, R, shift)
    assert best is not None
    return best[1:]


def paired_table(model, data: Path) -> str:
    """Table 2 of the module docstring (markdown)."""
    from morphkit.contact_export import lock_feet
    from morphkit.motion import read_motion
    from morphkit.retarget.nkn.retarget import copy_rotations
    from morphkit.retarget.nkn.skeleton import GROUPS, limb_groups

    rows = ["| trial | method | " + " | ".join(f"{g} world ↓" for g in GROUPS) + " | all world ↓ | "
            "all root-relative ↓ |", "|---|---|" + "---|" * (len(GROUPS) + 2)]
    totals: dict[str, list[np.ndarray]] = {}
    for trial in TRIALS:
        source = read_motion(data / "human" / "cmu" / f"{trial}.bvh").resample(model.fps)
        truth = daz_on_template(data / "human" / "cmu_daz" / f"cmu_{trial}.bvh", model.template, f"daz_{trial}")
        target = truth.morphology
        truth, ok, R, shift = _align(source, truth)
        P_true = truth.link_positions()
        P_true[..., :2] = P_true[..., :2] @ R.T + shift
        height = target.characteristic_length
        joints, _ = limb_groups(target)
        links = {g: [target.link_index(target.joints[j].child) for j in idx] for g, idx in joints.items()}
        nkn = model.retarget([source], target)[0].motion
        methods = {"copy": copy_rotations(source, target), "NKN": nkn, "NKN+lock": lock_feet(nkn)}
        for label, motion in methods.items():
            P = motion.link_positions()[ok]
            d = np.linalg.norm(P - P_true, axis=-1) / height  # [T, L]
            rel = np.linalg.norm((P - P[:, :1]) - (P_true - P_true[:, :1]), axis=-1) / height
            cells = [float(d[:, links[g]].mean()) if links[g] else float("nan") for g in GROUPS]
            values = np.array([*cells, d.mean(), rel.mean()])
            totals.setdefault(label, []).append(values)
            rows.append(f"| {trial} | {label} | " + " | ".join(f"{v:.4f}" for v in values) + " |")
    for label, values in totals.items():
        rows.append(f"| **mean** | {label} | " + " | ".join(f"{v:.4f}" for v in np.mean(values, axis=0)) + " |")
    return "\n".join(rows)


if __name__ == "__main__":
    raise SystemExit(main())
