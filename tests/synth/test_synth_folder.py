"""Issue 64, parts 1 and 4: a synth folder has one writer and holds one data set; names from inside the
description never steer the path; what a killed run left is removed and named by the next."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from morphkit.cli import main

BLOB = """name: {name}
base: floating
root: body
links:
  body: {{shapes: [{{type: sphere, radius: 0.2}}]}}
  fin: {{shapes: [{{type: box, size: [0.1, 0.02, 0.2], origin: {{xyz: [0, 0, 0.1]}}}}]}}
joints:
  fin: {{type: revolute, parent: body, child: fin, axis: [0, 1, 0], origin: {{xyz: [0, 0, 0.2]}},
        limit: {{lower: -0.5, upper: 0.5}}}}
"""


def _creature(folder: Path, name: str) -> Path:
    path = folder / f"c{abs(hash(name))}.yaml"
    path.write_text(BLOB.format(name=json.dumps(name)))
    return path


def _synth(src: Path, out: Path | str, *extra: str) -> int:
    return main(["synth", str(src), "--frames", "2", "--rollout-seconds", "1", "--out", str(out), "--no-progress",
                 *extra])


@pytest.mark.parametrize("name", ["../../escaped", "{root}/ABSESC"])
def test_a_hostile_name_writes_inside_out_and_stays_in_the_metadata(tmp_path, name, capsys):
    import numpy as np

    name = name.replace("{root}", str(tmp_path))
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    src = _creature(work, name)
    out = work / "out" / "ds"
    assert _synth(src, out) == 0
    assert sorted(p.name for p in tmp_path.rglob("*") if p.suffix == ".npz") == [
        f"{'escaped' if name.startswith('..') else str(tmp_path).strip('/').replace('/', '_') + '_ABSESC'}"
        "_synth_0_0000.npz"]
    (npz,) = out.glob("*.npz")
    with np.load(npz) as f:
        assert str(f["name"]) == f"{name}_synth_0_0000"  # the real name, in the file
    assert json.loads((out / "manifest.json").read_text())["creature"] == name
    capsys.readouterr()


def test_an_urdf_robot_name_writes_inside_out(tmp_path, capsys):
    text = (Path(__file__).resolve().parents[2] / "morphologies" / "spot" / "spot.urdf").read_text()
    src = tmp_path / "a" / "b" / "evil.urdf"
    src.parent.mkdir(parents=True)
    src.write_text(text.replace('<robot name="spot">', '<robot name="../../URDFESC">'))
    assert _synth(src, src.parent / "out") == 0
    assert [p.relative_to(tmp_path) for p in tmp_path.rglob("*URDFESC*")] == [
        Path("a/b/out/URDFESC_synth_0_0000.npz")]
    capsys.readouterr()


def test_a_second_writer_is_refused_while_the_first_holds_the_folder(tmp_path, capsys):
    out = tmp_path / "ds"
    holder = textwrap.dedent("""
        import sys, time
        from morphkit._folder_lock import hold_run_folder
        with hold_run_folder(sys.argv[1]):
            print("held", flush=True)
            time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", holder, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert _synth(_creature(tmp_path, "blob"), out) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {out}: run folder is in use") and f"pid {proc.pid}" in err
        assert err.count("\n") == 1 and not list(out.glob("*.npz"))
    finally:
        proc.kill()
        proc.wait()


def test_another_creatures_data_set_is_refused_without_force(tmp_path, capsys):
    out = tmp_path / "ds"
    assert _synth(_creature(tmp_path, "first"), out) == 0
    second = _creature(tmp_path, "second")
    capsys.readouterr()
    assert _synth(second, out) == 2
    err = capsys.readouterr().err
    assert err == (f"error: --out {out}: holds the synth data set of 'first' (1 file(s) listed in its manifest.json), "
                   "not one of 'second'; a folder holds one data set: give --force to replace it, or another folder\n")
    assert sorted(p.name for p in out.glob("*.npz")) == ["first_synth_0_0000.npz"]
    assert _synth(second, out, "--force") == 0
    assert sorted(p.name for p in out.glob("*.npz")) == ["second_synth_0_0000.npz"]
    assert json.loads((out / "manifest.json").read_text())["files"] == ["second_synth_0_0000.npz"]
    capsys.readouterr()


def test_a_killed_runs_leftovers_are_removed_and_named(tmp_path, capsys):
    from morphkit.motion.manifest import write_manifest

    out = tmp_path / "ds"
    out.mkdir()
    # what a run killed mid-write leaves: its manifest not finished, a rollout it listed, one it had not listed
    # yet, and the atomic writer's temporary files; beside them a file of the user's
    write_manifest(out, ["blob_synth_0_0007.npz"], complete=False, creature="blob", seed=0)
    for name in ("blob_synth_0_0007.npz", "blob_synth_0_0008.npz", ".blob_synth_0_0009.ab12_xyz.npz",
                 ".manifest.k3j4h5g6.json", "mine.npz", ".mine.ab12cd34.npz"):
        (out / name).write_bytes(b"x")
    assert _synth(_creature(tmp_path, "blob"), out) == 0
    err = capsys.readouterr().err
    assert ("warning: " + f"{out}: removed 2 temporary file(s) a stopped run left: "
            ".blob_synth_0_0009.ab12_xyz.npz, .manifest.k3j4h5g6.json") in err
    assert sorted(p.name for p in out.iterdir()) == [".lock", ".mine.ab12cd34.npz", "blob_synth_0_0000.npz",
                                                     "manifest.json", "mine.npz"]


@pytest.mark.parametrize("flags", [["--seed", "-1"], ["--fps", "inf"], ["--fps", "1e9"], ["--rollout-seconds", "inf"]])
def test_the_issues_flags_are_refused_before_any_work(tmp_path, flags, capsys):
    out = tmp_path / "ds"
    assert main(["synth", str(_creature(tmp_path, "blob")), "--frames", "2", "--out", str(out), *flags]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {flags[0]}: expected ") and f"got {flags[1]!r}" in err
    assert not out.exists()
