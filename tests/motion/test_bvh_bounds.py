"""Bounds before work on BVH motion: a frame time that lies is refused (or overridden), a resample that
would not fit is refused before it is computed, and any header a fuzzer writes reads as a finite motion or
one clean MorphkitError."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from morphkit.cli import main
from morphkit.errors import MorphkitError, MotionFormatError
from morphkit.motion import read_motion
from morphkit.motion.io_bvh import read_bvh_motion
from morphkit.motion.motion import MAX_RESAMPLE_BYTES

_HIERARCHY = """HIERARCHY
ROOT hips
{{
  OFFSET 0 0 0
  CHANNELS {root_count} {root_names}
  JOINT leg
  {{
    OFFSET 0 -1 0
    CHANNELS {leg_count} {leg_names}
    End Site
    {{
      OFFSET 0 -1 0
    }}
  }}
}}
MOTION
Frames: {frames}
Frame Time: {frame_time}
"""
_ROOT = "Xposition Yposition Zposition Zrotation Xrotation Yrotation".split()
_LEG = "Zrotation Xrotation Yrotation".split()


def _bvh(path: Path, *, frame_time: str = "0.0333333", frames: int = 60, declared: str | None = None,
         root: int = 6, leg: int = 3, root_count: str | None = None, leg_count: str | None = None) -> Path:
    """A two-joint BVH: ``frames`` frame lines of ``root + leg`` values, its header fields as given."""
    head = _HIERARCHY.format(
        root_count=root_count if root_count is not None else root, root_names=" ".join(_ROOT[:root]),
        leg_count=leg_count if leg_count is not None else leg, leg_names=" ".join((_LEG * 3)[:leg]),
        frames=declared if declared is not None else frames, frame_time=frame_time,
    )
    t = np.arange(frames)[:, None]
    angles = 10 * np.sin(0.1 * t) * np.ones((1, root + leg - min(root, 3)))
    values = np.concatenate([np.full((frames, min(root, 3)), 1.0), angles], axis=1)
    rows = "\n".join(" ".join(f"{v:.4f}" for v in row) for row in values)
    path.write_text(head + rows + "\n")
    return path


@pytest.mark.parametrize("frame_time", ["1000", "1e9", "1e-300", "2", "5e-5"])
def test_a_frame_time_outside_the_range_is_refused_naming_its_line(tmp_path, frame_time):
    path = _bvh(tmp_path / "lies.bvh", frame_time=frame_time)
    start = time.perf_counter()
    with pytest.raises(MotionFormatError, match="Frame Time") as info:
        read_bvh_motion(path, fps=30.0)
    assert time.perf_counter() - start < 30  # refused before the work, not after minutes of it
    assert info.value.location.path == str(path) and info.value.location.line == 18


def test_the_true_frame_rate_replaces_a_frame_time_that_lies(tmp_path, capsys):
    path = _bvh(tmp_path / "lies.bvh", frame_time="1e-300")
    motion = read_bvh_motion(path, source_fps=30.0)
    assert motion.fps == 30.0 and motion.frame_count == 60  # not sixty frames folded into one
    assert read_motion(path, source_fps=30.0, fps=15.0).frame_count == 30
    out = tmp_path / "fixed.npz"
    assert main(["convert", str(path), str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}:18: Frame Time") and "Traceback" not in err
    assert main(["convert", str(path), str(out), "--source-fps", "30"]) == 0
    assert read_motion(out).frame_count == 60
    with pytest.raises(MorphkitError, match="frame rate"):
        read_bvh_motion(path, source_fps=math.nan)


def test_a_resample_that_would_not_fit_is_refused_before_it_is_computed(tmp_path):
    motion = read_bvh_motion(_bvh(tmp_path / "slow.bvh", frame_time="1", frames=60))
    # 59 s at 1e6 fps: 59 million frames of 10 coordinates, 4.4 GiB.
    assert 59e6 * motion.morphology.coordinate_count * 8 > MAX_RESAMPLE_BYTES
    start = time.perf_counter()
    with pytest.raises(MotionFormatError, match="frames"):
        motion.resample(1e6)
    assert time.perf_counter() - start < 5
    assert motion.resample(2.0).frame_count == 119


_FRAME_TIMES = st.sampled_from(["0.0333", "0.0083333", "1", "1e-4", "0", "-0.03", "nan", "inf", "1e9", "1e-300",
                                "abc", "", "0x10", "1e400"])


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    frame_time=_FRAME_TIMES,
    frames=st.integers(0, 40),
    declared=st.one_of(st.none(), st.sampled_from(["0", "1", "41", "-1", "1e3", "99999999999999999999", "x"])),
    root=st.integers(0, 6),
    leg=st.integers(0, 3),
    root_count=st.one_of(st.none(), st.sampled_from(["7", "-1", "2.5", "999"])),
    leg_count=st.one_of(st.none(), st.sampled_from(["0", "4", "x"])),
    fps=st.sampled_from([None, 30.0, 120.0]),
)
def test_fuzzed_headers_read_as_a_finite_motion_or_one_clean_error(tmp_path, frame_time, frames, declared, root, leg,
                                                                   root_count, leg_count, fps):
    path = _bvh(tmp_path / "fuzz.bvh", frame_time=frame_time, frames=frames, declared=declared, root=root, leg=leg,
                root_count=root_count, leg_count=leg_count)
    start = time.perf_counter()
    try:
        motion = read_bvh_motion(path, fps=fps)
    except MorphkitError as exc:
        assert str(exc).strip() and "\n" not in str(exc)
    else:
        assert motion.frame_count >= 1 and np.isfinite(motion.q).all() and math.isfinite(motion.fps)
        lo, hi = 1e-4, 1.0
        assert 1 / hi <= motion.fps <= 1 / lo or fps is not None
    assert time.perf_counter() - start < 60  # a generous guard: every input here is a few hundred bytes
