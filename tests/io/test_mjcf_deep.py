"""The MJCF writer nests bodies without recursion: a chain longer than Python's recursion limit is written, and a
chain MuJoCo can read comes back with its tip where it was."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from _chains import chain_morphology

from morphkit.io import read_morphology
from morphkit.io.mjcf import dump_mjcf, write_mjcf


def test_a_chain_longer_than_the_recursion_limit_is_written_nested_in_order():
    m, offsets = chain_morphology(1500)
    assert m.link_count > sys.getrecursionlimit()
    root = ET.fromstring(dump_mjcf(m))
    body, names, tip = root.find("worldbody"), [], np.zeros(3)
    while (body := body.find("body")) is not None:  # down the nesting, one body inside the other
        names.append(body.get("name"))
        tip += np.array(body.get("pos", "0 0 0").split(), dtype=float)
    assert names == [f"l{i}" for i in range(1501)]
    np.testing.assert_allclose(tip, offsets.sum(axis=0), rtol=0, atol=1e-6)  # positions written with 9 digits


def test_a_written_chain_reads_back_with_its_tip_in_place(tmp_path: Path):
    pytest.importorskip("mujoco")
    m, offsets = chain_morphology(300)
    write_mjcf(m, tmp_path / "chain.xml")
    back = read_morphology(tmp_path / "chain.xml")
    assert back.link_count == m.link_count
    np.testing.assert_allclose(back.rest_link_poses()[-1, :3], offsets.sum(axis=0), rtol=0, atol=1e-6)
