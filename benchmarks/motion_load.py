"""Loading the CMU human set: first load (BVH parse, Euler to quaternions, axes, grounding, ACE
human states) and cached load (content-hash ``.npz`` cache), targets 30 s and 3 s.

Run: ``MORPHKIT_DATA=../shared/data python benchmarks/motion_load.py [--kind human|character|none]
[--folder human/cmu] [--json]``. The cache goes to a fresh temporary folder, so "first" is
really first; the Warp FK kernel of the skeleton may be compiled once before timing starts
(``--include-compile`` times that too).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

TARGET_FIRST_S = 30.0
TARGET_CACHED_S = 3.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--folder", default="human/cmu", help="folder under $MORPHKIT_DATA (default human/cmu)")
    parser.add_argument("--kind", default="human", choices=("human", "character", "none"),
                        help="also compute (and cache) these ACE states (default human)")
    parser.add_argument("--include-compile", action="store_true",
                        help="do not warm the FK kernel first (a cold Warp cache then adds its compile time)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    args = parser.parse_args(argv)

    root = os.environ.get("MORPHKIT_DATA")
    if not root:
        sys.stderr.write("set MORPHKIT_DATA to the data folder (../shared/data)\n")
        return 2
    folder = Path(root) / args.folder
    files = sorted(folder.glob("*.bvh"))
    if not files:
        sys.stderr.write(f"no .bvh files in {folder}\n")
        return 2

    from morphkit.motion import read_bvh_motion
    from morphkit.motion.datasets import MotionDataset, load_motions

    compile_s = 0.0
    if not args.include_compile:
        t = time.perf_counter()
        read_bvh_motion(files[0]).end_effector_positions()  # generates/loads the skeleton's FK kernel
        compile_s = time.perf_counter() - t

    def load(cache: Path) -> tuple[float, int]:
        t = time.perf_counter()
        if args.kind == "none":
            motions = load_motions(files, cache_dir=cache)
            frames = sum(m.frame_count for m in motions)
        else:
            ds = MotionDataset.from_files(files, window=2, kind=args.kind, cache_dir=cache)
            frames = ds.frame_count
        return time.perf_counter() - t, frames

    with tempfile.TemporaryDirectory(prefix="morphkit-motion-cache-") as tmp:
        first_s, frames = load(Path(tmp))
        cached_s, _ = load(Path(tmp))
    result = {
        "clips": len(files),
        "frames": frames,
        "states": args.kind,
        "kernel_warmup_s": round(compile_s, 3),
        "first_load_s": round(first_s, 3),
        "cached_load_s": round(cached_s, 3),
        "target_first_s": TARGET_FIRST_S,
        "target_cached_s": TARGET_CACHED_S,
        "first_ok": first_s <= TARGET_FIRST_S,
        "cached_ok": cached_s <= TARGET_CACHED_S,
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"{len(files)} clips, {frames} frames ({args.folder}, states: {args.kind})")
        print(f"  FK kernel warm-up   {compile_s:7.2f} s")
        print(f"  first load          {first_s:7.2f} s   (target {TARGET_FIRST_S:.0f} s) "
              f"{'ok' if result['first_ok'] else 'SLOW'}")
        print(f"  cached load         {cached_s:7.2f} s   (target {TARGET_CACHED_S:.0f} s) "
              f"{'ok' if result['cached_ok'] else 'SLOW'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
