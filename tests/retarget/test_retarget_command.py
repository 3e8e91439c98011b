"""``morphkit retarget``'s outputs: each named from its own input, never two inputs into one file, and
output paths checked before any work (a stand-in retargeter: naming is the command's, not a method's)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import spot_like

import morphkit.retarget as retarget_pkg
from morphkit.cli import main
from morphkit.motion import Motion, read_motion, write_motion
from morphkit.retarget.retargeter import RetargetedClip


class _Echo:
    """A retargeter that returns each clip as its own output (with a mark of which clip it was)."""

    creature = spot_like()
    calls = 0

    def intake(self, clip: Motion) -> Motion:
        return clip

    def retarget(self, clips: list[Motion]) -> list[RetargetedClip]:
        type(self).calls += 1
        return [RetargetedClip(source=c, motion=c) for c in clips]


@pytest.fixture()
def echo(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> type[_Echo]:
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(retarget_pkg, "load", lambda *a, **k: _Echo())
    _Echo.calls = 0
    return _Echo


def _clip(path: Path, shift: float) -> Path:
    m = spot_like()
    q = np.tile(m.rest_q(), (5, 1))
    q[:, 0] = np.linspace(0.0, 1.0, 5) + shift
    path.parent.mkdir(parents=True, exist_ok=True)
    write_motion(Motion(m, 30.0, q, "walk"), path)
    return path


def _retarget(motion: list[Path], out: Path) -> int:
    return main(["retarget", "--run", "unused", "--motion", *map(str, motion), "--out", str(out),
                 "--formats", "npz", "--contacts", "none"])


def test_identical_clips_under_different_names_give_two_outputs_with_their_own_names(echo, tmp_path):
    walk = _clip(tmp_path / "in" / "01_01.npz", 0.0)
    shutil.copy(walk, tmp_path / "in" / "my_walk.npz")  # byte-identical, another name
    assert _retarget([tmp_path / "in"], tmp_path / "out") == 0
    outs = sorted(p.name for p in (tmp_path / "out").iterdir() if p.name != ".lock")  # the folder's one-writer lock
    assert outs == ["01_01.npz", "my_walk.npz"]
    assert read_motion(tmp_path / "out" / "my_walk.npz").name == "my_walk"
    # A second run goes through the cache: the renamed copy still keeps its own name.
    shutil.rmtree(tmp_path / "out")
    assert _retarget([tmp_path / "in" / "my_walk.npz"], tmp_path / "out") == 0
    assert [p.name for p in (tmp_path / "out").iterdir() if p.name != ".lock"] == ["my_walk.npz"]


def test_two_inputs_that_would_write_one_output_are_refused_before_any_work(echo, tmp_path, capsys):
    a = _clip(tmp_path / "a" / "walk.npz", 0.0)
    b = _clip(tmp_path / "b" / "walk.npz", 1.0)  # other content, same name
    assert _retarget([a, b], tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and str(a) in err and str(b) in err and "same output" in err
    assert echo.calls == 0 and not (tmp_path / "out").exists()


def test_an_output_path_that_is_an_existing_file_is_refused_before_any_work(echo, tmp_path, capsys):
    a = _clip(tmp_path / "a" / "walk.npz", 0.0)
    (tmp_path / "taken").write_text("mine")
    assert _retarget([a], tmp_path / "taken") == 2
    assert "existing file" in capsys.readouterr().err
    assert (tmp_path / "taken").read_text() == "mine" and echo.calls == 0
