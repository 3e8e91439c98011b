"""``morphkit convert IN OUT``: convert a creature description or a motion between formats, by extension.

A motion (any ``.bvh``; an ``.npz`` with ``q``; a USD file with time samples) written to ``.bvh``,
``.npz`` or ``.usd``/``.usda``/``.usdc`` converts as a motion; everything else converts the
description (a BVH file's skeleton, for instance, to ``.yaml`` or ``.urdf``). With ``--canonical`` a
human clip is written mapped onto the canonical human (``morphkit.motion.to_canonical``), the skeleton
every trainer reads human motion on. A motion written to ``.qpos.npy`` is MuJoCo's ``qpos`` [T, nq] for
replay in the MJCF model the creature was read from (or ``--mjcf MODEL.xml``; without either, the creature's
MJCF is written beside it as ``<name>.xml``).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from morphkit.commands import _args

MOTION_SUFFIXES = (".bvh", ".npz", ".usd", ".usda", ".usdc")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "convert",
        help="convert a description (.yaml/.urdf/.usd[a|c]/.xml/.bvh) or a motion (.bvh/.npz/.usd[a|c]; "
        "to .qpos.npy for MuJoCo) by extension",
    )
    p.add_argument("input", metavar="IN", help="description or motion file, or a shipped creature name")
    p.add_argument("output", type=_args.out_path, metavar="OUT", help="output file; its extension picks the format")
    p.add_argument("--fps", type=_args.fps, default=None, help="resample a motion to this frame rate (1 to 1000)")
    p.add_argument("--source-fps", type=_args.source_fps, default=None, metavar="FPS",
                   help="the motion file's true frame rate, replacing its own (a BVH Frame Time that lies)")
    p.add_argument(
        "--description-only", action="store_true", help="convert only the skeleton of a motion file, not its frames"
    )
    p.add_argument("--canonical", action="store_true",
                   help="write a human clip mapped onto the canonical human (the skeleton trainers read humans on)")
    p.add_argument("--convention", metavar="YAML",
                   help="with --canonical: a convention table for the clip's skeleton, tried before the shipped ones")
    p.add_argument("--mjcf", metavar="MODEL.xml",
                   help="with OUT ending in .qpos.npy: the MuJoCo model to replay in "
                   "(default: the creature's own MJCF)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from morphkit.errors import ConfigError
    from morphkit.io import WRITE_SUFFIXES, read_morphology, write_morphology
    from morphkit.io.shipped import resolve_morphology

    out_suffix = Path(args.output).suffix.lower()
    if args.output.lower().endswith(".qpos.npy"):
        return _qpos(args)
    if args.mjcf:
        raise ConfigError("--mjcf needs OUT ending in .qpos.npy")
    if out_suffix not in (*WRITE_SUFFIXES, *MOTION_SUFFIXES):
        supported = ", ".join(dict.fromkeys((*WRITE_SUFFIXES, *MOTION_SUFFIXES)))
        shown = out_suffix or "(no suffix)"
        raise ConfigError(f"{args.output}: unknown output format {shown!r}; supported: {supported}")
    src = resolve_morphology(args.input)
    if args.canonical or args.convention:
        return _canonical(args, src, out_suffix)
    if not args.description_only and out_suffix in MOTION_SUFFIXES:
        # Motion io lives a layer up (morphkit.motion); imported only when a motion is converted.
        from morphkit.motion import is_motion_file, read_motion, write_motion

        if is_motion_file(src):
            if Path(src).suffix.lower() == ".bvh" and out_suffix in (".usd", ".usda", ".usdc"):
                from morphkit.io.bvh.memory import USD_BYTES_PER_VALUE, check_bvh_memory

                # pxr holds every time sample as its own value: the clip must fit that, checked before reading.
                check_bvh_memory(src, bytes_per_value=USD_BYTES_PER_VALUE)
            motion = read_motion(src, **_rates(args))
            write_motion(motion, args.output)
            print(f"wrote {args.output} ({motion.morphology.name}: {len(motion.q)} frames at {motion.fps:g} fps)")
            return 0
    m = read_morphology(src)
    write_morphology(m, args.output)
    print(f"wrote {args.output} ({m.name}: {m.link_count} links, {m.joint_count} joints)")
    return 0


def _canonical(args: argparse.Namespace, src: Path, out_suffix: str) -> int:
    from morphkit.errors import ConfigError
    from morphkit.motion import is_motion_file, read_canonical_motion, read_skeleton_map, write_motion

    if not args.canonical:
        raise ConfigError("--convention needs --canonical")
    if args.description_only or out_suffix not in MOTION_SUFFIXES:
        raise ConfigError(f"--canonical writes a motion: OUT must end in one of {', '.join(MOTION_SUFFIXES)}")
    if not is_motion_file(src):
        raise ConfigError(f"{args.input}: --canonical needs a motion file (.bvh, .npz with q, USD with time samples)")
    if os.path.exists(args.output) and os.path.samefile(src, args.output):
        raise ConfigError(f"{args.output}: OUT is IN; the clip would be overwritten")
    maps = [read_skeleton_map(args.convention)] if args.convention else None
    motion = read_canonical_motion(src, maps=maps, fps=args.fps)
    write_motion(motion, args.output)
    print(f"wrote {args.output} ({motion.morphology.name}, the canonical human: {len(motion.q)} frames at "
          f"{motion.fps:g} fps)")
    return 0


def _qpos(args: argparse.Namespace) -> int:
    """A motion as MuJoCo ``qpos`` [T, nq] (``.qpos.npy``) for replay in its MJCF model."""
    import io

    import numpy as np

    from morphkit._atomic import atomic_write_bytes, atomic_write_text
    from morphkit.errors import ConfigError
    from morphkit.io.mjcf import dump_mjcf, mujoco_model, qpos_from_q
    from morphkit.io.shipped import resolve_morphology
    from morphkit.motion import is_motion_file, read_motion

    src = resolve_morphology(args.input)
    if not is_motion_file(src):
        raise ConfigError(f"{args.input}: a .qpos.npy output needs a motion file (.bvh, .npz with q, USD)")
    motion = read_motion(src, **_rates(args))
    m = motion.morphology
    model_path = args.mjcf or (m.source if m.source and m.source.lower().endswith(".xml") else None)
    if model_path is None:
        model_path = args.output[: -len(".qpos.npy")] + ".xml"
        atomic_write_text(model_path, dump_mjcf(m, target=model_path))
        print(f"wrote {model_path} (the MuJoCo model of {m.name})")
    qpos = qpos_from_q(m, motion.q, mujoco_model(model_path))
    buf = io.BytesIO()
    np.save(buf, qpos)
    atomic_write_bytes(args.output, buf.getvalue())
    print(f"wrote {args.output} (MuJoCo qpos {list(qpos.shape)} for {model_path}, {motion.fps:g} fps)")
    return 0


def _rates(args: argparse.Namespace) -> dict[str, float]:
    """``read_motion`` options of ``--fps`` (resample) and ``--source-fps`` (the file's true rate)."""
    return {k: v for k, v in (("fps", args.fps), ("source_fps", args.source_fps)) if v is not None}
