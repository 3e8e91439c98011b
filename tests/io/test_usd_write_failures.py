"""USD writes that fail, fail: ``convert`` to USD on a full disk is one short ``error:`` line naming OUT,
exit 2, and no file (it was a flood of pxr errors naming the temporary file)."""

from __future__ import annotations

import pytest
from _full_disk import MORPHKIT, assert_failed_cleanly, run_on_full_disk
from _human_bvh import canonical_clip

from morphkit.motion import write_motion

LIMIT = 3000
"""Bytes a file may grow to on the 'full disk'; each USD file below is larger."""


@pytest.mark.parametrize(("out_name", "extra"), [("clip.usda", []), ("clip.usdc", []),
                                                 ("skeleton.usda", ["--description-only"])])
def test_convert_to_usd_on_a_full_disk_is_one_line_and_no_file(tmp_path, out_name, extra):
    from morphkit.cli import main

    clip = tmp_path / "clip.bvh"
    write_motion(canonical_clip(frames=20), clip)
    roomy = tmp_path / f"roomy_{out_name}"
    assert main(["convert", str(clip), str(roomy), *extra]) == 0  # also fills the kernel cache
    assert roomy.stat().st_size > 4 * LIMIT
    out = tmp_path / "full" / out_name
    out.parent.mkdir()
    result = run_on_full_disk([*MORPHKIT, "convert", str(clip), str(out), *extra], limit=LIMIT, cwd=tmp_path)
    line = assert_failed_cleanly(result, out)
    assert "USD could not write the file" in line and "File too large" in line, line
    assert line.count("File too large") <= 2, line  # each of pxr's messages once

