"""The protocol's subject split never puts a subject on both sides, is a function of the subjects alone (no random
state, no file order), keeps long clips on both sides; clip types come from the manifest's words, else the root's
motion; bad input is one clear error. On synthetic file lists always, on the real CMU manifest with MORPHKIT_DATA."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphkit.errors import ConfigError
from morphkit.motion import Motion, canonical_human
from morphkit.motion.split import (
    LONG_CLIP_SECONDS,
    clip_subject,
    clip_type_from_motion,
    clip_type_from_words,
    folder_split,
    split_clips,
    subject_sides,
)
from morphkit.rotations import quat_from_yaw

DATA = Path(os.environ["MORPHKIT_DATA"]) / "human" / "cmu" if os.environ.get("MORPHKIT_DATA") else None


def _write_bvh_header(path: Path, frames: int, frame_time: float = 1 / 30) -> None:
    """A file whose header says its length (the split reads no more of a BVH file than that)."""
    path.write_text(f"HIERARCHY\nROOT root\n{{\n}}\nMOTION\nFrames: {frames}\nFrame Time: {frame_time}\n")


def _folder(tmp_path: Path, clips: dict[str, float], manifest: dict[str, tuple[str, str]] | None = None) -> Path:
    """``clips``: stem → seconds (BVH headers at 30 fps); ``manifest``: stem → (category, description)."""
    for stem, seconds in clips.items():
        _write_bvh_header(tmp_path / f"{stem}.bvh", round(seconds * 30))
    if manifest is not None:
        with (tmp_path / "MANIFEST.csv").open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["file", "category", "cmu_description"])
            w.writerows([f"{stem}.bvh", cat, desc] for stem, (cat, desc) in manifest.items())
    return tmp_path


def _check_split(entries: list) -> None:
    sides: dict[str, set[str]] = {}
    for e in entries:
        sides.setdefault(e.subject, set()).add(e.side)
    assert all(len(s) == 1 for s in sides.values()), "a subject on both sides"
    long = {e.subject for e in entries if e.long}
    if len(long) >= 2:
        assert {e.side for e in entries if e.long} == {"dev", "test"}


subjects = st.lists(st.text("0123456789abcdef", min_size=1, max_size=4), min_size=1, max_size=40, unique=True)


@settings(max_examples=200, deadline=None)
@given(subjects=subjects, data=st.data())
def test_no_subject_on_both_sides_and_long_clips_on_both(subjects, data):
    long = {s: data.draw(st.booleans()) for s in subjects}
    sides = subject_sides(long)
    assert set(sides) == set(subjects) and set(sides.values()) <= {"dev", "test"}
    for group in (True, False):
        members = [s for s in subjects if long[s] is group]
        tested = [s for s in members if sides[s] == "test"]
        if len(members) >= 2:  # both sides of every group of two or more
            assert 0 < len(tested) < len(members)
        else:
            assert not tested
    # The order subjects come in changes nothing, nor do other subjects' lengths outside the group.
    assert subject_sides(dict(reversed(list(long.items())))) == sides


@settings(max_examples=50, deadline=None)
@given(names=st.lists(st.from_regex(r"[0-9]{1,3}_[0-9]{2}", fullmatch=True), min_size=2, max_size=30, unique=True),
       data=st.data())
def test_a_folder_split_keeps_subjects_apart(tmp_path_factory, names, data):
    seconds = {n: data.draw(st.sampled_from([3.0, 12.0, 31.0, 60.0])) for n in names}
    folder = _folder(tmp_path_factory.mktemp("clips"), seconds)
    entries = folder_split(folder)
    assert [e.name for e in entries] == sorted(names)
    assert all(e.subject == n.split("_")[0] and e.seconds == pytest.approx(seconds[n], abs=0.02)
               for e, n in zip(entries, sorted(names), strict=True))
    _check_split(entries)
    assert folder_split(folder) == entries  # deterministic


def test_the_split_is_a_hash_of_the_subject_ids():
    # Fixed here so that a change of the rule is a visible change: the split is what reports are compared on.
    sides = subject_sides({f"{i:02d}": False for i in range(1, 11)})
    assert sorted(s for s, side in sides.items() if side == "test") == ["05", "07", "09"]


def test_subjects_and_files_without_one():
    assert [clip_subject(n) for n in ("05_12", "105_09", "walk", "_x", "a_b_c")] == ["05", "105", "walk", "_x", "a"]


def test_a_folder_without_subjects_is_split_file_by_file(tmp_path):
    folder = _folder(tmp_path, {f"take{i}": 5.0 for i in range(10)})
    entries = folder_split(folder)
    assert [e.subject for e in entries] == [e.name for e in entries]
    assert sum(e.side == "test" for e in entries) == 3


def test_clip_types_from_words():
    cases = {
        ("walk forward, turn around, walk back", "walk"): "turn",
        ("DrunkWalk", "run"): "walk",
        ("Drunk Wait", "run"): "stand",  # "run" begins no word of "drunk"
        ("mummyDigital8", "construction"): "turn",
        ("basketball signals", "gesture"): "gesture",
        ("salsa dance", "dance"): None,
        ("dragon (human subject)", "construction"): "gesture",  # the category's word
        ("roadrunner (human subject)", "run"): "walk",
    }
    for (description, category), kind in cases.items():
        assert clip_type_from_words(description, category) == kind, description


def _root_motion(yaw_rate: float, speed: float, seconds: float = 4.0) -> Motion:
    human = canonical_human()
    t = np.arange(round(seconds * 30)) / 30
    q = np.tile(human.rest_q(), (t.size, 1))
    q[:, 0], q[:, 2] = speed * t, 0.95
    q[:, 3:7] = quat_from_yaw(yaw_rate * t)
    return Motion(human, 30.0, q, "root")


def test_clip_types_from_the_root_motion():
    assert clip_type_from_motion(_root_motion(0.0, 0.0)) == "stand"
    assert clip_type_from_motion(_root_motion(0.0, 0.2)) == "stand"
    assert clip_type_from_motion(_root_motion(0.0, 1.2)) == "walk"
    assert clip_type_from_motion(_root_motion(0.6, 0.0)) == "turn"  # on the spot
    assert clip_type_from_motion(_root_motion(-0.6, 1.0)) == "turn"
    assert clip_type_from_motion(_root_motion(0.0, 0.4)) == "walk"
    assert clip_type_from_motion(_root_motion(0.3, 0.0)) == "stand"  # a sway, not a turn
    assert clip_type_from_motion(_root_motion(0.0, 1.2, seconds=0.2)) == "walk"  # shorter than a step: one step
    assert clip_type_from_motion(_root_motion(0.0, 1.2, seconds=1 / 30)) == "stand"  # one frame: nothing moves


def test_manifest_types_and_clips_it_does_not_list(tmp_path):
    folder = _folder(tmp_path, {"01_01": 5, "01_02": 40, "02_01": 5, "03_01": 5},
                     {"01_01": ("walk", "walk"), "01_02": ("dance", "salsa dance"), "02_01": ("gesture", "wave")})
    kinds = {e.name: e.clip_type for e in folder_split(folder)}
    assert kinds == {"01_01": "walk", "01_02": "other", "02_01": "gesture", "03_01": None}
    assert {e.name: e.long for e in folder_split(folder)}["01_02"]


def test_bad_input_is_one_clear_error(tmp_path):
    folder = _folder(tmp_path, {"01_01": 5, "01_02": 5})
    with pytest.raises(ConfigError, match="unknown split 'train'"):
        split_clips(folder, "train")
    with pytest.raises(ConfigError, match=r"the test split of .* is empty .*2 clips of 1 subject"):
        split_clips(folder, "test")
    assert [e.name for e in split_clips(folder, "dev")] == ["01_01", "01_02"]
    with pytest.raises(ConfigError, match="test_share"):
        subject_sides({"a": False}, test_share=1.0)


@pytest.mark.skipif(DATA is None or not (DATA / "MANIFEST.csv").is_file(), reason="MORPHKIT_DATA is not set")
def test_the_cmu_split():
    entries = folder_split(DATA)
    _check_split(entries)
    assert folder_split(DATA) == entries
    with (DATA / "MANIFEST.csv").open() as f:
        assert {e.name for e in entries} == {Path(r["file"]).stem for r in csv.DictReader(f)}
    test = [e for e in entries if e.side == "test"]
    assert 0.2 < len({e.subject for e in test}) / len({e.subject for e in entries}) < 0.4
    assert sum(e.long for e in test) >= 3 and all(e.clip_type is not None for e in entries)
    assert {e.clip_type for e in test} == {"walk", "turn", "stand", "gesture", "other"}
    assert all(e.seconds >= LONG_CLIP_SECONDS for e in entries if e.long)
