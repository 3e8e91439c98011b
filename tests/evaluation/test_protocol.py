"""`morphkit evaluate RUN --human-data DIR --split dev|test|all` on a tiny ACE run: the split's clips only, whole,
scored per clip type and long vs short, its "all" row the Table-1 row of the shipped export; bad input is one
clear error with exit code 2."""

from __future__ import annotations

import csv
from collections import Counter
from dataclasses import replace
from pathlib import Path

import pytest
from retarget._ace_fixtures import write_quadruped

from morphkit.cli import main as cli
from morphkit.errors import ConfigError
from morphkit.evaluation.protocol import ProtocolClips, trained_on
from morphkit.io import read_morphology
from morphkit.io.shipped import resolve_morphology
from morphkit.motion import GROUND_MOTION_FEATURES, Pairing, read_motion, write_motion
from morphkit.motion.split import CLIP_TYPES, ClipEntry, folder_split
from morphkit.retarget.ace.config import preset
from morphkit.retarget.ace.train import train_ace
from morphkit.retarget.config import replace_config
from morphkit.retarget.training_data import evaluation_split
from morphkit.synth import SynthConfig, synthesize

TINY = ["prior.epochs=2", "prior.steps_per_epoch=4", "retarget.epochs=2", "retarget.steps_per_epoch=3"]
SHORT = {"01_01": "walk", "01_02": "wave", "02_01": "walk in a circle", "03_01": "salsa dance", "04_01": "walk",
         "05_01": "wave"}
"""Short clips (3 s) and their descriptions: five subjects of short clips."""
LONG = ("06_01", "07_01")
"""Long clips (31 s) of two more subjects (no manifest row: typed from their motion)."""


def _human_clips(folder: Path) -> Path:
    human = read_morphology(resolve_morphology("human"))
    folder.mkdir(parents=True, exist_ok=True)
    for names, seconds in ((list(SHORT), 3.0), (list(LONG), 31.0)):
        cfg = replace(SynthConfig(), rollout_seconds=seconds)
        frames = round(seconds * 30)
        motions = synthesize(human, frames=len(names) * frames, seed=7, config=cfg, progress=False).motions
        for name, m in zip(names, motions, strict=True):
            write_motion(m.replace(name=name), folder / f"{name}.npz")
    with (folder / "MANIFEST.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["file", "category", "cmu_description"])
        w.writerows([f"{n}.npz", "", d] for n, d in SHORT.items())
    return folder


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(a tiny ACE run on a YAML quadruped, trained on the embedded human; a folder of human clips of 7 subjects)."""
    root = tmp_path_factory.mktemp("protocol")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MORPHKIT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "ace_cache"))
        dog = read_morphology(write_quadruped(root))
        stage = train_ace(root / "run", dog, replace_config(preset("smoke"), TINY), progress=False, log=lambda s: None)
    return stage.parent, _human_clips(root / "human")


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_the_protocol_scores_the_split_per_clip_type_and_length(tiny, tmp_path, monkeypatch, capsys):
    run, human = tiny
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(run.parent.parent / "ace_cache"))
    sides = {e.name: e.side for e in folder_split(human)}
    test = sorted(n for n, side in sides.items() if side == "test")
    assert cli(["evaluate", str(run), "--human-data", str(human), "--split", "test", "--videos", "0",
                "--out", str(tmp_path / "test")]) == 0
    printed = capsys.readouterr().out
    assert f"## Protocol: the test split of {human}" in printed
    clips = _rows(tmp_path / "test" / "protocol_clips.csv")
    assert sorted(c["clip"] for c in clips) == test  # the test split's clips, no other subject's
    assert {c["method"] for c in clips} == {"ACE+replan"}  # the shipped export
    assert any(n in test for n in LONG) and any(n not in test for n in LONG)  # long clips on both sides

    # All of it: every clip whole, each group's figures; "all" is Table 1's shipped row.
    assert cli(["evaluate", str(run), "--human-data", str(human), "--split", "all", "--videos", "0",
                "--out", str(tmp_path / "all")]) == 0
    capsys.readouterr()
    table = {r["method"]: r for r in _rows(tmp_path / "all" / "table.csv")}
    assert int(table["ACE+replan"]["frames"]) == 6 * 90 + 2 * 930  # whole clips, not cropped
    per_clip = {c["clip"]: c for c in _rows(tmp_path / "all" / "protocol_clips.csv")}
    assert {n: per_clip[n]["clip_type"] for n in SHORT} == {"01_01": "walk", "01_02": "gesture", "02_01": "turn",
                                                             "03_01": "other", "04_01": "walk", "05_01": "gesture"}
    assert all(per_clip[n]["clip_type"] in ("walk", "turn", "stand") for n in LONG)  # from the motion
    counts = Counter(c["clip_type"] for c in per_clip.values())
    groups = {r["group"]: r for r in _rows(tmp_path / "all" / "protocol.csv")}
    assert list(groups) == ["all", *(t for t in CLIP_TYPES if t in counts), "long (≥ 30 s)", "short"]
    assert {g: int(r["clips"]) for g, r in groups.items()} == {"all": 8, **counts, "long (≥ 30 s)": 2, "short": 6}
    for key, column in _COLUMN.items():  # the quadruped has no arm: no hand figures on either side
        mine, theirs = groups["all"][key], table["ACE+replan"][column]
        assert (mine == theirs == "") or float(mine) == pytest.approx(float(theirs), abs=1e-9), key
    assert groups["all"]["follow_forward"] != ""
    # the turn gain's scale: the data's fastest turn (commanded within the smoke data's ±1 rad/s, with the
    # steps' feedforward), and what copying the human's turns up to it would score
    fastest = float(groups["all"]["fastest_turn"])
    assert 0.5 < fastest < 1.1 and {r["fastest_turn"] for r in groups.values()} == {groups["all"]["fastest_turn"]}
    assert 0.0 < float(groups["all"]["reachable_turn_gain"]) <= 1.0
    assert f"({fastest:.2f} rad/s at most)" in (tmp_path / "all" / "protocol.md").read_text()
    # per clip, the same scale from the clip's own human yaw rate, against a written-out sum
    for name, row in per_clip.items():
        human_motion = read_motion(human / f"{name}.npz")
        yaw = Pairing((), (), 1.0, 1.0).human_psi(human_motion)[:, GROUND_MOTION_FEATURES[2]]
        num = sum(float(y) * min(max(float(y), -fastest), fastest) for y in yaw)
        assert float(row["reachable_turn_gain"]) == pytest.approx(num / float(yaw @ yaw), abs=1e-6), name
    assert "| within reach |" in (tmp_path / "all" / "protocol_clips.md").read_text()
    assert "## Protocol: the all split" in (tmp_path / "all" / "table.md").read_text()


_COLUMN = {"follow": "follow", "follow_hand": "follow hand", "follow_reach": "follow reach",
           "follow_forward": "follow forward", "follow_yaw": "follow yaw", "turn_gain": "turn gain", "drift": "drift",
           "ufr": "UFR"}
"""protocol.csv's columns → table.csv's."""


def test_bad_protocol_input_is_one_clear_error(tiny, tmp_path, monkeypatch, capsys):
    run, human = tiny
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(run.parent.parent / "ace_cache"))
    one = tmp_path / "one_subject"
    one.mkdir()
    for name in ("01_01", "01_02"):
        (one / f"{name}.npz").write_bytes((human / f"{name}.npz").read_bytes())
    cases = [
        (["--human-data", str(human), "--split", "train"], "unknown --split 'train'; choose one of dev, test, all"),
        (["--human-data", str(one), "--split", "test"], "the test split of"),
        (["--split", "test"], "embedded default human motion, which has no subjects"),
        ([], "no runs to evaluate"),
    ]
    for args, message in cases:
        runs = [str(run)] if args else []
        assert cli(["evaluate", *runs, *args, "--videos", "0", "--out", str(tmp_path / "report")]) == 2, args
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and "Traceback" not in err, (args, err)
        assert err.count("\n") == 1


def test_clips_a_run_trained_on_are_named(tmp_path):
    held = evaluation_split()[0]
    clips = ProtocolClips("test", str(tmp_path), [], [], [])
    assert trained_on(clips, None) == [] and trained_on(clips, str(tmp_path / "other")) == []

    class Named:
        def __init__(self, name: str) -> None:
            self.name = name

    names = [held, "99_99", "98_01"]
    entries = [ClipEntry(tmp_path / f"{n}.bvh", n.split("_")[0], 5.0, side, None)
               for n, side in zip(names, ["dev", "dev", "test"], strict=True)]
    clips = ProtocolClips("all", str(tmp_path), [Named(n) for n in names], entries, [None] * 3)
    assert trained_on(clips, str(tmp_path)) == ["99_99", "98_01"]
    # a run trained on the development subjects only (data.human_split) has seen none of the test subjects' clips
    assert trained_on(clips, str(tmp_path), "dev") == ["99_99"]
    assert trained_on(clips, str(tmp_path), "test") == ["98_01"]


def test_training_on_the_development_subjects_leaves_the_test_subjects_out(tiny):
    """``data.human_split``: the dev and test sides of a folder's training clips are its subject split's, apart and
    together every clip."""
    from morphkit.retarget.training_data import DataConfig, human_motions

    _, folder = tiny
    side = {e.name: e.side for e in folder_split(folder)}
    names = {s: {m.name for m in human_motions(folder, DataConfig(human_split=s), cache_dir=None)}
             for s in ("all", "dev", "test")}
    assert names["dev"] and names["test"] and names["dev"] | names["test"] == names["all"] == set(side)
    assert {side[n] for n in names["dev"]} == {"dev"} and {side[n] for n in names["test"]} == {"test"}
    with pytest.raises(ConfigError, match="unknown split 'train'"):
        human_motions(folder, DataConfig(human_split="train"), cache_dir=None)
