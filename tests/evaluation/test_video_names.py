"""Issue 64, part 1, beyond synth: a clip's own ``name`` never steers where evaluate writes its videos, and the
default output names of render and train come from safe stems."""

from __future__ import annotations

import argparse
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from morphkit_testing import spot_like

from morphkit.motion import Motion


def test_evaluate_names_videos_after_safe_stems(tmp_path, monkeypatch):
    import morphkit.render as render
    from morphkit.evaluation.report import render_videos

    written: list[Path] = []

    def write_frames(frames, path, fps):
        written.append(Path(path))
        Path(path).write_bytes(b"gif")

    monkeypatch.setattr(render, "write_frames", write_frames)
    monkeypatch.setattr(render, "iter_side_by_side_frames", lambda *a, **k: iter(()))
    m = spot_like()
    clips = [Motion(m, 30.0, np.tile(m.rest_q(), (3, 1)), n) for n in ("../../../../EVALESC", "EVALESC", "/abs/x")]
    evaluation = SimpleNamespace(clips=clips, results=[SimpleNamespace(method=SimpleNamespace(name="ACE"),
                                                                       shown=clips)])
    folder = tmp_path / "a" / "b" / "report" / "videos"
    paths = render_videos(evaluation, folder, count=3, suffix=".gif", log=lambda line: None)
    assert paths == written == [folder / "EVALESC.gif", folder / "EVALESC-2.gif", folder / "abs_x.gif"]
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*.gif")) == sorted(
        p.relative_to(tmp_path) for p in paths)


def test_render_makes_up_its_file_name_from_safe_stems():
    from morphkit.commands.render import _out

    args = argparse.Namespace(out=None, contact_sheet=False)
    assert _out(args, "../../x", "turntable") == "x-turntable.gif"
    assert _out(args, "/etc/passwd", "../walk") == "etc_passwd-walk.gif"


def test_train_builds_its_default_run_folder_from_a_safe_stem(tmp_path, monkeypatch, capsys):
    import morphkit.retarget.ace.train as ace_train
    from morphkit.cli import main

    src = tmp_path / "evil.yaml"
    text = (Path(__file__).resolve().parents[2] / "morphologies" / "crab" / "crab.yaml").read_text()
    src.write_text("\n".join("name: ../../../TRAINESC" if ln.startswith("name:") else ln for ln in text.splitlines()))
    used: list[Path] = []
    monkeypatch.setattr(ace_train, "train_ace", lambda out, *a, **k: used.append(Path(out)) or "stage")
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    assert main(["train", "ace", str(src), "--preset", "smoke"]) == 0
    assert used == [Path("runs/ace_TRAINESC_smoke")]
    assert [p.relative_to(tmp_path) for p in tmp_path.rglob("*TRAINESC*")] == [Path("a/b/runs/ace_TRAINESC_smoke")]
    capsys.readouterr()
