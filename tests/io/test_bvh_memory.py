"""Memory before work on a BVH clip: the header's estimate bounds what reading and converting really take, and
a clip that would not fit is refused in one line, before its frames are read."""

from __future__ import annotations

import time
import tracemalloc

import pytest
from _human_bvh import canonical_clip

from morphkit.errors import MotionFormatError
from morphkit.io.bvh import memory
from morphkit.io.bvh.memory import MAX_BVH_MEMORY, bvh_header_counts, check_bvh_memory, estimate_bvh_memory
from morphkit.motion import read_motion, write_motion


def _clip(tmp_path, frames: int = 20):
    path = tmp_path / f"walk{frames}.bvh"
    write_motion(canonical_clip(frames=frames, fps=120.0), path)
    return path


def _claiming(tmp_path, frames: int):
    """A real clip whose ``Frames:`` line claims ``frames`` (the file itself stays small)."""
    path = _clip(tmp_path)
    text = path.read_text()
    lines = text.split("\n")
    line = next(i for i, t in enumerate(lines) if t.startswith("Frames:"))
    lines[line] = f"Frames: {frames}"
    out = tmp_path / "claims.bvh"
    out.write_text("\n".join(lines))
    return out, line + 1


def test_a_header_claiming_a_huge_clip_is_refused_in_one_line_before_reading(tmp_path, capsys):
    from morphkit.cli import main

    path, line = _claiming(tmp_path, 10**10)
    frames, channels, at = bvh_header_counts(path)
    assert (frames, at) == (10**10, line) and channels == 3 + 3 * 22  # root position + 22 joints' rotations
    start = time.perf_counter()
    with pytest.raises(MotionFormatError) as info:
        read_motion(path)
    assert time.perf_counter() - start < 2.0
    assert info.value.location.line == line
    need = estimate_bvh_memory(frames, channels, path.stat().st_size)
    assert f"{need / 2**30:,.0f} GiB" in str(info.value) and "16 GiB" in str(info.value), info.value
    out = tmp_path / "x.npz"
    assert main(["convert", str(path), str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {path}:{line}: ") and "would need about" in err, err
    assert not out.exists()


def test_the_memory_available_now_is_the_bound_when_smaller(tmp_path, monkeypatch):
    path = _clip(tmp_path)
    check_bvh_memory(path)  # a 20-frame clip fits anywhere
    monkeypatch.setattr(memory, "available_memory", lambda: 1000)
    with pytest.raises(MotionFormatError, match=r"more than 9\.31e-07 GiB \(the memory available now\)"):
        read_motion(path)
    assert memory.MAX_BVH_MEMORY == MAX_BVH_MEMORY == 16 << 30


@pytest.mark.parametrize("out_suffix", [".npz", ".bvh"])
def test_the_estimate_bounds_the_measured_peak(tmp_path, out_suffix):
    """Reading a 3,000-frame clip and writing it back: the traced peak stays under the header's estimate, and
    the estimate is no more than 4× the peak (a bound that refuses clips that would fit is no use)."""
    write_motion(read_motion(_clip(tmp_path)), tmp_path / f"warm{out_suffix}")  # first calls load kernels
    path = _clip(tmp_path, frames=3000)
    frames, channels, _ = bvh_header_counts(path)
    need = estimate_bvh_memory(frames, channels, path.stat().st_size)
    tracemalloc.start()
    try:
        write_motion(read_motion(path), tmp_path / f"back{out_suffix}")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak <= need <= 4 * peak, (peak / 2**20, need / 2**20)


def test_converting_to_usd_counts_pxr_time_samples(tmp_path, capsys):
    """A clip that reading alone might fit, written as USD (pxr keeps every sample), is refused by its USD
    estimate before any frame is read."""
    from morphkit.cli import main
    from morphkit.io.bvh.memory import USD_BYTES_PER_VALUE

    frames = 1_200_000  # 83 M values: 10 GiB to read, 31 GiB to write as USD
    path, line = _claiming(tmp_path, frames)
    _, channels, _ = bvh_header_counts(path)
    need = estimate_bvh_memory(frames, channels, path.stat().st_size, bytes_per_value=USD_BYTES_PER_VALUE)
    assert estimate_bvh_memory(frames, channels, path.stat().st_size) < MAX_BVH_MEMORY < need
    assert main(["convert", str(path), str(tmp_path / "x.usda")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}:{line}: ") and f"about {need / 2**30:.3g} GiB" in err, err
    assert not (tmp_path / "x.usda").exists()
