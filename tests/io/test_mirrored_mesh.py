"""Mirrored meshes (a negative scale factor) read as Pinocchio, pybullet and MuJoCo read them: the mesh reflected."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from morphkit.errors import GraphError
from morphkit.io.urdf import parse_urdf

trimesh = pytest.importorskip("trimesh")


def _box_off_axis(folder: Path) -> Path:
    """A box spanning y in [0.1, 0.3]: mirrored in y it spans [-0.3, -0.1]."""
    mesh = trimesh.creation.box(extents=[0.1, 0.2, 0.05])
    mesh.apply_translation([0.0, 0.2, 0.0])
    path = folder / "half.stl"
    mesh.export(path)
    return path


def _urdf(mesh: Path, scale: str) -> str:
    return f"""<robot name="mirror">
  <link name="base"><visual><geometry><mesh filename="{mesh}" scale="{scale}"/></geometry></visual></link>
  <link name="arm"><visual><geometry><mesh filename="{mesh}" scale="{scale}"/></geometry></visual></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <origin xyz="0.5 0 0"/><limit lower="-1" upper="1"/></joint>
</robot>"""


def test_a_mirrored_mesh_reads_and_is_drawn_reflected(tmp_path: Path) -> None:
    from morphkit.render.scene import shape_trimesh

    mesh = _box_off_axis(tmp_path)
    m = parse_urdf(_urdf(mesh, "1 -1 1"), source=str(tmp_path / "mirror.urdf"))
    shape = m.links[1].shapes[0]
    assert shape.scale == (1.0, -1.0, 1.0)
    drawn = shape_trimesh(shape, source=str(tmp_path / "mirror.urdf"))
    np.testing.assert_allclose(drawn.bounds[:, 1], [-0.3, -0.1], atol=1e-9)
    assert drawn.volume > 0  # faces turned with the reflection: outward normals, a solid the renderer lights


def test_a_mirrored_mesh_compiles_in_mujoco_as_the_reflection(tmp_path: Path) -> None:
    mujoco = pytest.importorskip("mujoco")
    mesh = _box_off_axis(tmp_path)
    xml = (f'<mujoco><asset><mesh name="b" file="{mesh}" scale="1 -1 1"/></asset><worldbody><body>'
           '<geom type="mesh" mesh="b"/></body></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    # MuJoCo recentres the mesh on its centroid and keeps the offset in the geom: the centroid is mirrored.
    np.testing.assert_allclose(model.geom_pos[0], [0.0, -0.2, 0.0], atol=1e-6)


def test_a_zero_scale_is_still_refused_at_its_line(tmp_path: Path) -> None:
    with pytest.raises(GraphError, match="scale must be non-zero") as info:
        parse_urdf(_urdf(_box_off_axis(tmp_path), "1 0 1"), source=str(tmp_path / "mirror.urdf"))
    assert info.value.location is not None and info.value.location.line is not None
