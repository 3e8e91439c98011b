"""A big USD body reads in time near linear in its size, and an error deep in it names its line: each prim's
line is found in an index of the text built once, not by a scan of the text per prim (18 s for 2,000 links)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from _chains import chain_morphology

from morphkit.errors import MorphkitError
from morphkit.io import read_morphology, write_morphology

pytest.importorskip("pxr")


def test_a_2000_link_usd_chain_reads_fast_and_an_error_deep_in_it_names_its_line(tmp_path: Path):
    m, offsets = chain_morphology(2000)
    path = tmp_path / "chain.usda"
    write_morphology(m, path)
    start = time.perf_counter()
    back = read_morphology(path)
    assert time.perf_counter() - start < 8.0  # about 1 s; 18 s with a scan per prim
    np.testing.assert_allclose(back.rest_link_poses()[-1, :3], offsets.sum(axis=0), rtol=0, atol=1e-5)  # float32

    lines = path.read_text().split("\n")
    row = next(i for i, t in enumerate(lines) if t.strip() == 'def PhysicsRevoluteJoint "j1998"')
    low = next(i for i in range(row, len(lines)) if "physics:lowerLimit" in lines[i])
    lines[low] = lines[low].split("=")[0] + "= 80"  # above its upper limit (57.3°)
    path.write_text("\n".join(lines))
    with pytest.raises(MorphkitError, match="j1998") as info:
        read_morphology(path)
    assert info.value.location is not None and info.value.location.line == row + 1
