"""``morphkit synth``: files, JSON report, located errors."""

from __future__ import annotations

import json

from morphkit.cli import main
from morphkit.synth.report import REPORT_KEYS


def test_synth_writes_a_folder_and_reports_json(tmp_path, capsys):
    out = tmp_path / "crab_data"
    code = main(["synth", "crab", "--frames", "120", "--rollout-seconds", "2", "--seed", "1", "--out", str(out),
                 "--report", "--json", "--no-progress"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert list(report)[: len(REPORT_KEYS)] == list(REPORT_KEYS)
    assert report["frames"] == 120
    assert sorted(p.name for p in out.iterdir()) == [".lock", "crab_synth_1_0000.npz", "crab_synth_1_0001.npz",
                                                     "manifest.json"]  # .lock: the folder's one-writer lock
    assert report["files"] == [str(out / "crab_synth_1_0000.npz"), str(out / "crab_synth_1_0001.npz")]


def test_synth_text_output_and_single_file(tmp_path, capsys):
    out = tmp_path / "stretch.npz"
    assert main(["synth", "stretch", "--frames", "60", "--out", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "stretch: 60 frames" in text and out.is_file()


def test_synth_rejects_bad_input(tmp_path, capsys):
    assert main(["synth", "crab", "--frames", "0", "--out", str(tmp_path / "x")]) == 2
    assert "--frames" in capsys.readouterr().err
    assert main(["synth", "crab", "--frames", "10"]) == 2  # neither --out nor --report
    assert "nothing to do" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nbase: floating\nroot: body\nlinks:\n  body: {}\n  leg: {}\n"
                   "joints:\n  j: {type: hinge, parent: body, child: leg}\n")
    assert main(["synth", str(bad), "--frames", "10", "--report"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "bad.yaml" in err
