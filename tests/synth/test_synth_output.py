"""Issue 13, outputs: a run writes (and readers read) only its own files, a file suffix is a file,
outputs are checked before any work, long runs stream with flat memory and are refused when too big."""

from __future__ import annotations

import gc
import json
import os
import weakref
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from morphkit.cli import main

BLOB = """name: blob
base: floating
root: body
links:
  body: {shapes: [{type: sphere, radius: 0.2}]}
  fin: {shapes: [{type: box, size: [0.1, 0.02, 0.2], origin: {xyz: [0, 0, 0.1]}}]}
joints:
  fin: {type: revolute, parent: body, child: fin, axis: [0, 1, 0], origin: {xyz: [0, 0, 0.2]},
        limit: {lower: -0.5, upper: 0.5}}
"""
"""A legless creature with one other joint: the cheapest to synthesise (it glides)."""


@pytest.fixture
def blob(tmp_path: Path) -> Path:
    p = tmp_path / "blob.yaml"
    p.write_text(BLOB)
    return p


def _synth(blob: Path, frames: int, out: Path | str, *extra: str) -> int:
    return main(["synth", str(blob), "--frames", str(frames), "--rollout-seconds", "1", "--out", str(out),
                 "--no-progress", *extra])


def test_a_rerun_with_fewer_frames_leaves_only_its_own_files(blob, tmp_path, capsys):
    from morphkit.motion.datasets import expand_motion_paths, load_motions

    out = tmp_path / "data"
    assert _synth(blob, 90, out) == 0
    # .lock: the folder's one-writer lock (morphkit._folder_lock), which stays; only the OS lock on it counts
    assert sorted(p.name for p in out.iterdir()) == [".lock"] + [f"blob_synth_0_000{i}.npz" for i in range(3)] + [
        "manifest.json"]
    mine = out / "mine.npz"
    mine.write_bytes((out / "blob_synth_0_0002.npz").read_bytes())  # a file of the user's, beside the run's
    assert _synth(blob, 30, out) == 0
    assert sorted(p.name for p in out.iterdir()) == [".lock", "blob_synth_0_0000.npz", "manifest.json", "mine.npz"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] and manifest["files"] == ["blob_synth_0_0000.npz"] and manifest["frames"] == 30
    # what reads a synth folder (morphkit map DIR, the trainers' data) reads this run's files only
    assert expand_motion_paths(out) == [out / "blob_synth_0_0000.npz"]
    clips = load_motions(out, cache_dir=None)
    assert [c.frame_count for c in clips] == [30]
    capsys.readouterr()


def test_an_unfinished_run_is_not_read(blob, tmp_path):
    from morphkit.errors import MotionFormatError
    from morphkit.io import read_morphology
    from morphkit.motion.datasets import expand_motion_paths
    from morphkit.synth import iter_synthesize
    from morphkit.synth.output import SynthWriter

    out = tmp_path / "data"
    writer = SynthWriter(out)
    parts = iter_synthesize(read_morphology(blob), frames=60, seed=0, progress=False)
    writer.write(next(parts))  # stopped here: the manifest still says the run has not finished
    with pytest.raises(MotionFormatError, match="has not finished"):
        expand_motion_paths(out)
    for part in parts:
        writer.write(part)
    writer.close()
    assert len(expand_motion_paths(out)) == 1


def test_an_out_with_a_suffix_is_a_file_or_refused(blob, tmp_path, capsys):
    one = tmp_path / "all.npz"
    assert _synth(blob, 60, one) == 0
    assert one.is_file()
    with np.load(one) as f:
        assert f["q"].shape[0] == 60 and f["clip_starts"].tolist() == [0, 30]
    capsys.readouterr()
    for name, says in (("x.txt", ".txt is not a motion format"), ("x.bvh", "morphkit convert")):
        assert _synth(blob, 60, tmp_path / name) == 2
        assert says in capsys.readouterr().err
        assert not (tmp_path / name).exists()
    dotted = f"{tmp_path / 'run.v2'}{os.sep}"
    assert _synth(blob, 30, dotted) == 0
    assert (tmp_path / "run.v2" / "manifest.json").is_file()


def test_an_unwritable_output_is_refused_before_any_work(blob, tmp_path, capsys, monkeypatch):
    import morphkit.synth

    def never(*args, **kwargs):
        raise AssertionError("synthesis started")

    monkeypatch.setattr(morphkit.synth, "iter_synthesize", never)
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert _synth(blob, 30, afile / "sub") == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --out") and "is not a folder" in err


def test_a_billion_frames_are_refused_with_the_size_estimate(blob, tmp_path, capsys, monkeypatch):
    import morphkit.synth
    from morphkit.io import read_morphology
    from morphkit.synth import output

    def never(*args, **kwargs):
        raise AssertionError("synthesis started")

    monkeypatch.setattr(morphkit.synth, "iter_synthesize", never)
    monkeypatch.setattr(output.shutil, "disk_usage", lambda p: type("U", (), {"free": 50_000_000_000})())
    assert _synth(blob, 10**9, tmp_path / "big") == 2
    err = capsys.readouterr().err
    est = output.estimate_output_bytes(read_morphology(blob), 10**9, 10**9 // 30, 0, single_file=False)
    assert est > 10**11  # the estimate itself is checked against written sizes below
    assert f"the motions would take about {output.format_bytes(est)} and only 50 GB are free" in err
    assert not (tmp_path / "big").exists()
    monkeypatch.setattr(output, "available_memory", lambda: 8_000_000_000)
    assert main(["synth", str(blob), "--frames", str(10**9), "--report", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "in memory, about" in err and "only 8 GB is available" in err


def test_the_size_estimate_bounds_what_is_written(blob, tmp_path, capsys):
    from morphkit.io import read_morphology
    from morphkit.synth.output import estimate_output_bytes

    m = read_morphology(blob)
    folder, one = tmp_path / "data", tmp_path / "all.npz"
    for out in (folder, one):
        assert main(["synth", str(blob), "--frames", "1200", "--rollout-seconds", "10", "--out", str(out),
                     "--no-progress"]) == 0
    written = sum(p.stat().st_size for p in folder.glob("*.npz"))
    est = estimate_output_bytes(m, 1200, 4, 0, single_file=False)
    assert written <= est <= 1.05 * written
    est = estimate_output_bytes(m, 1200, 4, 0, single_file=True)
    assert one.stat().st_size <= est <= 1.05 * one.stat().st_size
    capsys.readouterr()


def test_streamed_synthesis_keeps_memory_flat(blob, tmp_path):
    """Each batch of rollouts is written and let go before the next is made: none stays alive."""
    from morphkit.io import read_morphology
    from morphkit.motion import read_motion
    from morphkit.synth import SynthConfig, iter_synthesize, synthesize
    from morphkit.synth.output import SynthWriter

    m = read_morphology(blob)
    cfg = replace(SynthConfig(), batch=2, rollout_seconds=2.0)
    writer = SynthWriter(tmp_path / "b")
    alive = []
    for part in iter_synthesize(m, frames=960, config=cfg, progress=False):
        writer.write(part)
        alive.append(weakref.ref(part.motions[0].q))
    del part
    writer.close()
    gc.collect()
    assert len(alive) == 8 and not any(r() is not None for r in alive)
    assert len(list((tmp_path / "b").glob("*.npz"))) == 16
    # the streamed rollouts are the ones synthesize makes in one piece
    whole = synthesize(m, frames=960, config=cfg, progress=False)
    for i in (0, 15):
        assert np.array_equal(read_motion(tmp_path / "b" / f"blob_synth_0_{i:04d}.npz").q, whole[i].q)


def test_report_prints_fractions_as_percentages_not_counts():
    """A fraction of 1 used to print as '1 of airborne frames', which reads like a count."""
    from morphkit.synth.report import format_report

    text = format_report({"frames": 300, "foot_sliding_cm_s": 0.5, "penetration_mm": 1.0, "self_collision_frac": 0.0025,
                          "limit_violation_frac": 0.0, "tracking_error": 0.1, "swing_clearance_frac": 1.0,
                          "command_clamped_frac": 0.125})
    assert "100 % of airborne frames" in text
    assert "0.25 % of frames" in text and "12.5 % of frames (to the creature's top speed)" in text
    assert "0 % of frames" in text  # limit violations
