"""Asset paths stay inside a description's folder or a declared package: ``package://etc/passwd``, ``../../``
meshes and MJCF includes outside the model are left out (meshes, with a warning) or refused (MJCF), unless
outside paths are allowed."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest

from morphkit.cli import main
from morphkit.errors import DescriptionError
from morphkit.io.asset_paths import allow_outside
from morphkit.io.urdf import read_urdf

_URDF = ('<robot name="r"><link name="a"/><link name="b"><visual><geometry><mesh filename="{}"/></geometry></visual>'
         '</link><joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>')


def _urdf(folder: Path, mesh: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "r.urdf"
    path.write_text(_URDF.format(mesh))
    return path


def _mesh(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("solid x\nendsolid x\n")
    return path


@pytest.mark.skipif(not Path("/etc/passwd").is_file(), reason="needs /etc/passwd to probe")
def test_package_uri_never_walks_up_to_etc(tmp_path):
    path = _urdf(tmp_path / "robot", "package://etc/passwd")
    with pytest.warns(UserWarning, match="outside the description's folder"):
        m = read_urdf(path)
    assert m.link("b").shapes[0].mesh == "package://etc/passwd"  # left out: never /etc/passwd


def test_relative_meshes_outside_the_folder_are_left_out_unless_allowed(tmp_path, monkeypatch):
    secret = _mesh(tmp_path / "secret" / "m.stl")
    path = _urdf(tmp_path / "models" / "robot", "../../secret/m.stl")
    with pytest.warns(UserWarning, match=r"\.\./\.\./secret/m\.stl resolves to .*outside"):
        assert read_urdf(path).link("b").shapes[0].mesh == "../../secret/m.stl"
    with allow_outside(), warnings.catch_warnings():
        warnings.simplefilter("error")
        assert Path(read_urdf(path).link("b").shapes[0].mesh) == secret
    monkeypatch.setenv("MORPHKIT_PACKAGE_PATH", str(tmp_path / "secret"))  # a declared package root
    assert Path(read_urdf(path).link("b").shapes[0].mesh) == secret


def test_meshes_inside_the_folder_or_its_package_are_read(tmp_path):
    pkg = tmp_path / "my_robot"
    (pkg / "package.xml").parent.mkdir()
    (pkg / "package.xml").write_text("<package/>")
    inside = _mesh(pkg / "urdf" / "meshes" / "m.stl")
    beside = _mesh(pkg / "meshes" / "n.stl")
    for mesh, want in (("meshes/m.stl", inside), ("../meshes/n.stl", beside),
                       ("package://my_robot/meshes/n.stl", beside)):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert Path(read_urdf(_urdf(pkg / "urdf", mesh)).link("b").shapes[0].mesh) == want


def test_cli_allow_outside_flag(tmp_path, capsys):
    _mesh(tmp_path / "secret" / "m.stl")
    path = _urdf(tmp_path / "models" / "robot", "../../secret/m.stl")
    assert main(["info", str(path)]) == 0
    assert "outside the description's folder" in capsys.readouterr().err
    assert main(["info", str(path), "--allow-outside"]) == 0
    assert "outside" not in capsys.readouterr().err


def test_mjcf_includes_and_assets_outside_the_model_are_refused_and_meshes_left_out(tmp_path):
    pytest.importorskip("mujoco")
    from morphkit.io.mjcf import read_mjcf

    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "body.xml").write_text(
        '<mujoco><worldbody><body name="b"><freejoint/><geom type="sphere" size="0.1"/></body></worldbody></mujoco>')
    model = tmp_path / "model" / "m.xml"
    model.parent.mkdir()
    model.write_text('<mujoco>\n  <include file="../shared/body.xml"/>\n</mujoco>\n')
    with pytest.raises(DescriptionError, match="outside the model's folder") as info:
        read_mjcf(model)
    assert info.value.location.path == str(model.resolve()) and info.value.location.line == 2
    with allow_outside():
        assert read_mjcf(model).link_count >= 1
    model.write_text('<mujoco>\n<asset>\n<texture name="t" type="2d" file="/etc/passwd"/>\n</asset>\n</mujoco>\n')
    with pytest.raises(DescriptionError, match="/etc/passwd"):
        read_mjcf(model)
    # A mesh outside is left out, as a missing one is: its geom goes, the body stays.
    model.write_text('<mujoco>\n<asset>\n<mesh name="m" file="../shared/m.stl"/>\n</asset>\n<worldbody>\n'
                     '<body name="b"><freejoint/><geom type="sphere" size="0.1"/><geom type="mesh" mesh="m"/></body>\n'
                     '</worldbody>\n</mujoco>\n')
    _mesh(tmp_path / "shared" / "m.stl")
    with pytest.warns(UserWarning, match=r"m\.xml:3: mesh \.\./shared/m\.stl resolves to .*outside") as record:
        m = read_mjcf(model)
    assert m.link("b") is not None and any("not found" in str(w.message) for w in record)
    assert os.environ.get("MORPHKIT_ALLOW_OUTSIDE") is None
