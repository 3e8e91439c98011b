"""Same file, same robot: a description read by a relative path, an absolute path or through a symbolic link
gives one morphology, meshes included; a mesh that cannot be found is always a warning.

(An MJCF read by a relative path once lost every mesh, its folder joined twice, with no warning.)
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from _compare import assert_morphology_equal

from morphkit.graph import Morphology, ShapeType
from morphkit.io import read_morphology, write_morphology

pytest.importorskip("mujoco")
trimesh = pytest.importorskip("trimesh")

BOX = (0.2, 0.1, 0.05)
"""Extents [m] of the body mesh written for the model."""
CONE = (0.04, 0.12)
"""Radius and height [m] of the foot mesh."""

MJCF = """<mujoco model="tiny">
  <compiler meshdir="meshes"/>
  <asset>
    <mesh name="body" file="body.stl"/>
    <mesh name="foot" file="foot.obj" scale="1 1 2"/>
  </asset>
  <worldbody>
    <body name="base" pos="0 0 0.3">
      <freejoint/>
      <geom type="mesh" mesh="body"/>
      <body name="leg" pos="0.1 0 0">
        <joint name="hip" type="hinge" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
        <body name="foot" pos="0 0 -0.2">
          <joint name="ankle" type="hinge" axis="0 1 0" range="-0.5 0.5"/>
          <geom type="mesh" mesh="foot" pos="0 0 -0.05"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _model(root: Path) -> Path:
    """``root/models/tiny/robot.xml`` with its meshes under ``meshes/``."""
    folder = root / "models" / "tiny"
    (folder / "meshes").mkdir(parents=True)
    trimesh.creation.box(extents=BOX).export(folder / "meshes" / "body.stl")
    trimesh.creation.cone(radius=CONE[0], height=CONE[1]).export(folder / "meshes" / "foot.obj")
    (folder / "robot.xml").write_text(MJCF)
    return folder / "robot.xml"


def _ways(path: Path, root: Path) -> dict[str, str]:
    """The description by a relative path (from ``root``), absolute, through a linked file and a linked folder."""
    (root / "elsewhere").mkdir()
    (root / "elsewhere" / f"link{path.suffix}").symlink_to(path)
    (root / "linked").symlink_to(path.parent, target_is_directory=True)
    return {
        "relative": os.path.relpath(path, root),
        "absolute": str(path),
        "linked file": str(Path("elsewhere") / f"link{path.suffix}"),
        "linked folder": str(Path("linked") / path.name),
    }


def _meshes(m: Morphology) -> list[tuple[str, np.ndarray]]:
    """(link, extents of the mesh file's vertices × scale) of every mesh shape."""
    out = []
    for link in m.links:
        for s in link.shapes:
            if s.type == ShapeType.MESH:
                assert s.mesh is not None and os.path.isabs(s.mesh), s.mesh
                out.append((link.name, trimesh.load(s.mesh, force="mesh").extents * np.asarray(s.scale)))
    return out


def _read_quietly(path: str) -> Morphology:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a mesh lost on the way would warn
        return read_morphology(path)


def test_an_mjcf_is_one_robot_by_every_path(tmp_path, monkeypatch):
    model = _model(tmp_path)
    monkeypatch.chdir(tmp_path)
    ways = _ways(model, tmp_path)
    read = {way: _read_quietly(p) for way, p in ways.items()}
    truth = [("base", np.array(BOX)), ("foot", np.array([2 * CONE[0], 2 * CONE[0], 2 * CONE[1]]))]
    for way, m in read.items():
        got = _meshes(m)
        assert [link for link, _ in got] == [link for link, _ in truth], way
        for (_, extents), (_, expected) in zip(got, truth, strict=True):
            np.testing.assert_allclose(extents, expected, atol=1e-6, err_msg=way)
        assert_morphology_equal(read["absolute"], m)
        np.testing.assert_allclose(m.rest_link_poses(), read["absolute"].rest_link_poses(), atol=1e-12)


@pytest.mark.parametrize("suffix", [".urdf", ".yaml", ".usda"])
def test_other_formats_are_one_robot_by_every_path(tmp_path, monkeypatch, suffix):
    """The same morphology written as URDF, YAML and USD beside its meshes reads alike every way."""
    model = _model(tmp_path)
    written = model.with_name(f"robot{suffix}")
    m = read_morphology(model)
    write_morphology(m, written)
    monkeypatch.chdir(tmp_path)
    for way, path in _ways(written, tmp_path).items():
        got = _read_quietly(path)
        assert [link for link, _ in _meshes(got)] == ["base", "foot"], way
        assert_morphology_equal(m, got, check_name=False)


def test_a_missing_mesh_warns_by_every_path(tmp_path, monkeypatch):
    model = _model(tmp_path)
    (model.parent / "meshes" / "foot.obj").unlink()
    monkeypatch.chdir(tmp_path)
    for way, path in _ways(model, tmp_path).items():
        with pytest.warns(UserWarning, match=r"1 mesh file\(s\) not found \(first: foot.obj\)"):
            m = read_morphology(path)
        assert [link for link, _ in _meshes(m)] == ["base"], way


def test_a_model_compiled_elsewhere_keeps_its_meshes_or_warns(tmp_path, monkeypatch):
    """``morphology_from_mjmodel`` on a model the caller compiled from a relative path (MuJoCo stores its mesh
    paths relative to the working folder) finds the meshes; where a file is gone, it warns."""
    import mujoco

    from morphkit.io.mjcf import morphology_from_mjmodel

    model = _model(tmp_path)
    monkeypatch.chdir(tmp_path)
    rel = os.path.relpath(model, tmp_path)
    compiled = mujoco.MjModel.from_xml_path(rel)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = morphology_from_mjmodel(compiled, source=rel)
    assert_morphology_equal(read_morphology(model), m)
    (model.parent / "meshes" / "body.stl").unlink()
    with pytest.warns(UserWarning, match=r"mesh file not found: .*body\.stl"):
        morphology_from_mjmodel(compiled, source=rel)
