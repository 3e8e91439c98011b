"""Argument types every subcommand uses for numbers and output paths, and the bounds they enforce.

Each is an argparse ``type=``: a value outside its range is refused while parsing, one line
``error: --fps: expected a number from 1 to 1000 fps, got 'inf'`` and exit code 2, before anything
is read or allocated. The bounds and why:

- :data:`SEED_RANGE`: 0 to 2**32 - 1, what every generator seeded from it takes (NumPy refuses negative
  seeds, its legacy generator anything wider than 32 bits).
- :data:`FPS_RANGE`: 1 to 1000 frames per second for rates morphkit produces (synthesis, rendering,
  resampling). Work buffers are sized in frames: a synthesis rollout is ``--rollout-seconds × fps`` frames
  long, allocated before its first frame (``--fps 1e9`` asked for 171 GiB); motion capture runs at 30 to 480.
- :data:`SOURCE_FPS_RANGE`: 1 to 10000, a file's own frame rate, the BVH reader's ``Frame Time`` bound
  (:data:`morphkit.motion.io_bvh.FRAME_TIME_RANGE`, 1e-4 to 1 s).
- :data:`ROLLOUT_SECONDS_RANGE`: above 0 to 600 s; with :data:`FPS_RANGE` a rollout is at most 600,000 frames.
- :data:`BODY_LENGTH_RANGE`: above 0 to 1000 m, a body length given by hand (lengths are divided by it).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = [
    "BODY_LENGTH_RANGE",
    "FPS_RANGE",
    "ROLLOUT_SECONDS_RANGE",
    "SEED_RANGE",
    "SOURCE_FPS_RANGE",
    "body_length",
    "float_in",
    "fps",
    "int_in",
    "out_path",
    "seed",
    "source_fps",
]

SEED_RANGE = (0, 2**32 - 1)
FPS_RANGE = (1.0, 1000.0)
SOURCE_FPS_RANGE = (1.0, 10000.0)
ROLLOUT_SECONDS_RANGE = (0.0, 600.0)
BODY_LENGTH_RANGE = (0.0, 1000.0)


def _num(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def int_in(lo: int, hi: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer from ``lo`` to ``hi`` (inclusive; no upper bound when ``None``)."""
    allowed = f"an integer from {lo} to {hi}" if hi is not None else f"an integer >= {lo}"

    def parse(text: str) -> int:
        try:
            value = int(text.strip())
        except ValueError:
            value = None
        if value is None or value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}")
        return value

    parse.__name__ = "int"
    return parse


def float_in(lo: float, hi: float, *, unit: str = "", lo_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number from ``lo`` to ``hi`` (above ``lo`` when ``lo_open``), in ``unit``."""
    unit = f" {unit}" if unit else ""
    allowed = (f"a number above {_num(lo)} and at most {_num(hi)}{unit}" if lo_open
               else f"a number from {_num(lo)} to {_num(hi)}{unit}")

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
        if not ok:
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}")
        return value

    parse.__name__ = "float"
    return parse


seed = int_in(*SEED_RANGE)
"""A random seed (:data:`SEED_RANGE`)."""
fps = float_in(*FPS_RANGE, unit="fps")
"""A frame rate morphkit produces (:data:`FPS_RANGE`)."""
source_fps = float_in(*SOURCE_FPS_RANGE, unit="fps")
"""A file's own frame rate (:data:`SOURCE_FPS_RANGE`)."""
body_length = float_in(*BODY_LENGTH_RANGE, unit="m", lo_open=True)
"""A body length given by hand (:data:`BODY_LENGTH_RANGE`)."""


def out_path(text: str) -> str:
    """An argparse type for an output path: refuses an empty or blank one (``--out ""`` would otherwise write into
    the working folder, with names nobody asked for)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected an output path, got {text!r} (use . for the working folder)")
    return text
