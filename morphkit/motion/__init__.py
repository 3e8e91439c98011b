"""Motion data: the :class:`Motion` container, BVH/USD/NPZ motion files, the canonical human every human
clip is mapped onto (:mod:`~morphkit.motion.canonical`), ACE states and Ψ with the state codec (encode
and decode; NumPy, and torch twins through the FK kernels), the KL end-effector mapping, left-right
mirroring of a clip, and windowed datasets.

Importing this package loads NumPy and PyYAML only; FK (Warp), USD (``pxr``) and PyTorch
(:class:`MotionDataset`) load when first used.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from morphkit.errors import MotionFormatError, SourceLocation
from morphkit.motion._fk import compiled_model as compiled_model
from morphkit.motion.canonical import CANONICAL_HUMAN as CANONICAL_HUMAN
from morphkit.motion.canonical import SkeletonMap as SkeletonMap
from morphkit.motion.canonical import canonical_human as canonical_human
from morphkit.motion.canonical import canonical_record as canonical_record
from morphkit.motion.canonical import guess_skeleton_map as guess_skeleton_map
from morphkit.motion.canonical import is_canonical as is_canonical
from morphkit.motion.canonical import read_canonical_motion as read_canonical_motion
from morphkit.motion.canonical import read_skeleton_map as read_skeleton_map
from morphkit.motion.canonical import skeleton_maps as skeleton_maps
from morphkit.motion.canonical import to_canonical as to_canonical
from morphkit.motion.codec import ClampReport as ClampReport
from morphkit.motion.codec import character_state_from_q as character_state_from_q
from morphkit.motion.codec import decode_character_states as decode_character_states
from morphkit.motion.codec import ground_path as ground_path
from morphkit.motion.codec import human_state_from_q as human_state_from_q
from morphkit.motion.codec import stance_flags_of as stance_flags_of
from morphkit.motion.codec import world_end_effectors as world_end_effectors
from morphkit.motion.ee_mapping import EndEffectorMapping as EndEffectorMapping
from morphkit.motion.ee_mapping import Gaussian as Gaussian
from morphkit.motion.ee_mapping import ee_distributions as ee_distributions
from morphkit.motion.ee_mapping import fit_gaussian as fit_gaussian
from morphkit.motion.ee_mapping import kl_divergence as kl_divergence
from morphkit.motion.ee_mapping import map_end_effectors as map_end_effectors
from morphkit.motion.ee_mapping import read_override as read_override
from morphkit.motion.features import ACTIVE_HAND as ACTIVE_HAND
from morphkit.motion.features import GROUND_MOTION_FEATURES as GROUND_MOTION_FEATURES
from morphkit.motion.features import ROOT_FEATURE_DIM as ROOT_FEATURE_DIM
from morphkit.motion.features import ActiveHand as ActiveHand
from morphkit.motion.features import Pairing as Pairing
from morphkit.motion.features import feature_dim as feature_dim
from morphkit.motion.features import features as features
from morphkit.motion.features import motion_features as motion_features
from morphkit.motion.io_bvh import bvh_to_motion as bvh_to_motion
from morphkit.motion.io_bvh import ground_motion as ground_motion
from morphkit.motion.io_bvh import motion_to_bvh as motion_to_bvh
from morphkit.motion.io_bvh import read_bvh_motion as read_bvh_motion
from morphkit.motion.io_bvh import write_bvh_motion as write_bvh_motion
from morphkit.motion.io_commands import write_robot_commands
from morphkit.motion.io_npz import read_npz_motion as read_npz_motion
from morphkit.motion.io_npz import write_npz_motion as write_npz_motion
from morphkit.motion.mirror import MIRRORED_SUFFIX as MIRRORED_SUFFIX
from morphkit.motion.mirror import mirror_motion as mirror_motion
from morphkit.motion.mirror import mirror_partners as mirror_partners
from morphkit.motion.motion import Motion as Motion
from morphkit.motion.scale import measured_body_length as measured_body_length
from morphkit.motion.scale import standing_height as standing_height
from morphkit.motion.states import NormStats as NormStats
from morphkit.motion.states import StateLayout as StateLayout
from morphkit.motion.states import character_state as character_state
from morphkit.motion.states import character_state_from_motion as character_state_from_motion
from morphkit.motion.states import character_state_layout as character_state_layout
from morphkit.motion.states import derive_character_state as derive_character_state
from morphkit.motion.states import foot_contact_flags as foot_contact_flags
from morphkit.motion.states import foot_names as foot_names
from morphkit.motion.states import heading_frame as heading_frame
from morphkit.motion.states import human_state as human_state
from morphkit.motion.states import human_state_from_motion as human_state_from_motion
from morphkit.motion.states import human_state_layout as human_state_layout

__all__ = [
    "ACTIVE_HAND",
    "CANONICAL_HUMAN",
    "GROUND_MOTION_FEATURES",
    "MIRRORED_SUFFIX",
    "MOTION_READ_SUFFIXES",
    "MOTION_WRITE_SUFFIXES",
    "ROOT_FEATURE_DIM",
    "ActiveHand",
    "ClampReport",
    "EndEffectorMapping",
    "Gaussian",
    "Motion",
    "MotionDataset",
    "NormStats",
    "Pairing",
    "SkeletonMap",
    "StateLayout",
    "bvh_to_motion",
    "canonical_human",
    "canonical_record",
    "character_state",
    "character_state_from_motion",
    "character_state_from_q",
    "character_state_layout",
    "compiled_model",
    "decode_character_states",
    "derive_character_state",
    "ee_distributions",
    "feature_dim",
    "features",
    "fit_gaussian",
    "foot_contact_flags",
    "foot_names",
    "ground_motion",
    "ground_path",
    "guess_skeleton_map",
    "heading_frame",
    "human_state",
    "human_state_from_motion",
    "human_state_from_q",
    "human_state_layout",
    "is_canonical",
    "is_motion_file",
    "kl_divergence",
    "load_motions",
    "map_end_effectors",
    "measured_body_length",
    "mirror_motion",
    "mirror_partners",
    "motion_features",
    "motion_to_bvh",
    "read_bvh_motion",
    "read_canonical_motion",
    "read_motion",
    "read_npz_motion",
    "read_override",
    "read_skeleton_map",
    "read_usd_motion",
    "skeleton_maps",
    "stance_flags_of",
    "standing_height",
    "to_canonical",
    "world_end_effectors",
    "write_bvh_motion",
    "write_motion",
    "write_motion_files",
    "write_npz_motion",
    "write_usd_motion",
]

MOTION_READ_SUFFIXES = (".bvh", ".npz", ".usd", ".usda", ".usdc")
"""File suffixes :func:`read_motion` understands."""
MOTION_WRITE_SUFFIXES = (".bvh", ".npz", ".usd", ".usda", ".usdc")
"""File suffixes :func:`write_motion` understands."""

_LAZY = {
    "MotionDataset": "morphkit.motion.datasets",
    "load_motions": "morphkit.motion.datasets",
    "read_usd_motion": "morphkit.motion.io_usd",
    "write_usd_motion": "morphkit.motion.io_usd",
}


def __getattr__(name: str) -> Any:
    # torch (datasets) and pxr (USD) load only when these names are used.
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'morphkit.motion' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)


def is_motion_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` holds a motion (not only a description): any ``.bvh``; an ``.npz`` with a
    ``q`` array; a USD file with time samples (``morphkit:motion:q`` or an authored time range).

    Lets ``morphkit convert`` tell ``walk.bvh -> walk.usda`` (a motion) from ``spot.urdf ->
    spot.usda`` (a description). Unreadable files answer ``False``.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if not p.is_file():
        return False
    if suffix == ".bvh":
        return True
    if suffix == ".npz":
        import numpy as np

        try:
            with np.load(p, allow_pickle=False) as data:
                return "q" in data.files
        except (OSError, ValueError, EOFError):
            return False
    if suffix in (".usd", ".usda", ".usdc"):
        from morphkit.motion.io_usd import usd_has_motion

        return usd_has_motion(p)
    return False


def read_motion(path: str | os.PathLike[str], **options: Any) -> Motion:
    """Read a motion file, choosing the format by suffix.

    Args:
        path: A ``.bvh``, ``.npz`` or ``.usd``/``.usda``/``.usdc`` file.
        **options: Passed to the format's reader (e.g. ``fps=``, ``scale=``, ``facing=`` for BVH;
            ``fps=`` resamples any format; ``source_fps=`` replaces the file's own frame rate, for files
            that lie).

    Raises:
        MotionFormatError: unknown suffix (listing the supported ones), missing file, or bad content.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    where = SourceLocation(str(path))
    if suffix not in MOTION_READ_SUFFIXES:
        raise MotionFormatError(
            f"unknown motion format {p.suffix or '(no suffix)'!r}; supported: {', '.join(MOTION_READ_SUFFIXES)}",
            location=where,
        )
    if not p.is_file():
        what = "is a folder, not a file" if p.is_dir() else "not found"
        raise MotionFormatError(f"motion file {what}: {path}", location=where)
    if suffix == ".bvh":
        return read_bvh_motion(path, **options)
    fps = options.pop("fps", None)
    source_fps = options.pop("source_fps", None)
    if options:
        raise MotionFormatError(f"unknown option(s) for {suffix} motions: {', '.join(options)}", location=where)
    if suffix == ".npz":
        motion = read_npz_motion(path)
    else:
        from morphkit.motion.io_usd import read_usd_motion

        motion = read_usd_motion(path)
    if source_fps is not None:
        motion = motion.replace(fps=source_fps)
    return motion.resample(fps) if fps is not None else motion


def write_motion(motion: Motion, path: str | os.PathLike[str], **options: Any) -> None:
    """Write a motion in the format given by the suffix of ``path`` (atomically).

    Raises:
        MotionFormatError: unknown suffix (listing the supported ones).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".bvh":
        write_bvh_motion(motion, path, **options)
    elif suffix == ".npz":
        write_npz_motion(motion, path, **options)
    elif suffix in (".usd", ".usda", ".usdc"):
        from morphkit.motion.io_usd import write_usd_motion

        write_usd_motion(motion, path, **options)
    else:
        raise MotionFormatError(
            f"cannot write {p.suffix or '(no suffix)'!r} motions; supported: {', '.join(MOTION_WRITE_SUFFIXES)}",
            location=SourceLocation(str(path)),
        )


def write_motion_files(
    motion: Motion, stem: str | os.PathLike[str], formats: Sequence[str] = (".npz", ".bvh", ".csv")
) -> list[Path]:
    """Write ``motion`` once per format, each to ``stem`` + its suffix (atomically, as each writer does).

    Args:
        motion: The motion.
        stem: The output path without a suffix (``out/clips/walk``); missing folders are created.
        formats: Suffixes, with or without the dot: those of :func:`write_motion` (``.npz``, ``.bvh``,
            ``.usd``, ``.usda``, ``.usdc``) and ``.csv``, robot commands
            (:func:`~morphkit.motion.io_commands.write_robot_commands`).

    Returns:
        The files written, in the order of ``formats``.

    Raises:
        MotionFormatError: an unknown format, before anything is written.
    """
    suffixes = ["." + f.lstrip(".") for f in formats]
    known = (*MOTION_WRITE_SUFFIXES, ".csv")
    for suffix in suffixes:
        if suffix.lower() not in known:
            raise MotionFormatError(f"cannot write {suffix!r} files; supported: {', '.join(known)}")
    paths = []
    for suffix in suffixes:
        path = Path(f"{os.fspath(stem)}{suffix}")
        if suffix.lower() == ".csv":
            write_robot_commands(motion, path)
        else:
            write_motion(motion, path)
        paths.append(path)
    return paths
