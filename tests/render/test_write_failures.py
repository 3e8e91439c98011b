"""Writes that fail, fail: a video or image that cannot be written completely (a full disk) is one
``error:`` line and exit 2, and leaves no file; the same write with room succeeds."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from _full_disk import MORPHKIT, assert_failed_cleanly, run_on_full_disk

LIMIT = 4096
"""Bytes a file may grow to on the 'full disk'; every output below is larger (6 frames of noise)."""

WRITE = textwrap.dedent("""
    import subprocess, sys
    import numpy as np
    from morphkit.cli import run_command
    from morphkit.render import write_frames
    if sys.argv[2] == "errno":
        # ffmpeg sees EFBIG (as ENOSPC on a full disk) instead of being killed by SIGXFSZ.
        _popen = subprocess.Popen
        subprocess.Popen = lambda *a, **k: _popen(*a, **{**k, "restore_signals": False})
    frames = np.random.default_rng(0).integers(0, 256, (6, 48, 64, 3), dtype=np.uint8)
    def write(args):
        write_frames(iter(frames), sys.argv[1], fps=10.0)
        print("wrote", sys.argv[1])
    sys.exit(run_command(write, None))
""")


def _ffmpeg() -> bool:
    from morphkit.render import ffmpeg_available

    return ffmpeg_available()


@pytest.mark.parametrize(
    ("suffix", "ffmpeg_sees"),
    [(".mp4", "signal"), (".mp4", "errno"), (".webm", "errno"), (".gif", "errno"), (".png", "errno")],
)
def test_a_frame_writer_on_a_full_disk_fails_with_one_line_and_no_file(tmp_path, suffix, ffmpeg_sees):
    """Every format, whether ffmpeg is killed by the limit or sees a write error (its trailer, say)."""
    if suffix in (".mp4", ".webm") and not _ffmpeg():
        pytest.skip("no ffmpeg (pip install imageio-ffmpeg)")
    script = tmp_path / "write.py"
    script.write_text(WRITE)
    roomy, full = tmp_path / "roomy", tmp_path / "full"
    roomy.mkdir()
    full.mkdir()
    ok = subprocess.run([sys.executable, str(script), str(roomy / f"clip{suffix}"), ffmpeg_sees],
                        check=False, capture_output=True, text=True, timeout=300)
    assert ok.returncode == 0 and ok.stderr == "", ok.stderr
    assert (roomy / f"clip{suffix}").stat().st_size > LIMIT
    out = full / f"clip{suffix}"
    result = run_on_full_disk([sys.executable, str(script), str(out), ffmpeg_sees], limit=LIMIT, cwd=tmp_path)
    line = assert_failed_cleanly(result, out)
    if ffmpeg_sees == "errno":
        assert "File too large" in line, line  # the write error itself, from ffmpeg or Python


def test_a_video_that_ffmpeg_cannot_encode_is_refused(tmp_path):
    """An ffmpeg failure that is no disk error (a WebM of H.264 was once written as a 262-byte husk):
    every video ffmpeg reports failing raises, naming the output; written videos read back whole."""
    import imageio.v2 as imageio

    from morphkit.render import write_frames

    if not _ffmpeg():
        pytest.skip("no ffmpeg (pip install imageio-ffmpeg)")
    frames = np.random.default_rng(1).integers(0, 256, (5, 47, 63, 3), dtype=np.uint8)
    for suffix in (".mp4", ".webm", ".mkv", ".mov", ".avi"):
        out = write_frames(iter(frames), tmp_path / f"v{suffix}", fps=10.0)
        reader = imageio.get_reader(out, format="FFMPEG")
        assert reader.count_frames() == 5 and reader.get_data(0).shape == (48, 64, 3), suffix
        reader.close()
    with pytest.raises(OSError, match="ffmpeg could not write the video") as info:
        write_frames(iter(frames), tmp_path / "bad.mp4", fps=1e-9)  # no frame rate ffmpeg accepts
    assert info.value.filename == str(tmp_path / "bad.mp4")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".") or p.name.startswith("bad")]


def test_render_on_a_full_disk_exits_2_and_leaves_nothing(tmp_path):
    """``morphkit render spot --out full/tt.mp4`` used to print 'wrote' over a truncated video."""
    from morphkit.cli import main

    pytest.importorskip("pyrender")
    try:
        from morphkit.render._gl import offscreen_renderer

        with offscreen_renderer(8, 8):
            pass
    except Exception as exc:  # no EGL/OSMesa here
        pytest.skip(f"no offscreen GL: {exc}")
    suffixes = [".gif", *([".mp4"] if _ffmpeg() else [])]
    args = ["render", "spot", "--frames", "3", "--size", "64x48"]
    assert main([*args, "--out", str(tmp_path / "warm.gif")]) == 0  # also fills the kernel cache
    for suffix in suffixes:
        out = tmp_path / "full" / f"tt{suffix}"
        out.parent.mkdir(exist_ok=True)
        result = run_on_full_disk([*MORPHKIT, *args, "--out", str(out)], limit=2048, cwd=tmp_path)
        assert_failed_cleanly(result, out)
