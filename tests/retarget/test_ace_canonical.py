"""Any human clip into an ACE run: the run records the canonical human, clips of other conventions (CMU-22
names, unknown names, and with ``MORPHKIT_DATA`` real CMU-22, Daz and Bandai Namco clips) are mapped onto it,
a non-human is refused before anything is retargeted, a run from before the record keeps working, and the
human training data is canonical whatever the folder's conventions."""

from __future__ import annotations

import os
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from _ace_fixtures import write_human_clips, write_quadruped
from _bvh_creature import creature_bvh
from _human_bvh import CMU22, canonical_clip, renamed_bvh

from morphkit.errors import MotionFormatError
from morphkit.io import read_morphology
from morphkit.motion import canonical_human, canonical_record, human_state_layout, read_motion
from morphkit.retarget.ace.config import preset
from morphkit.retarget.ace.retarget import AceRetargeter
from morphkit.retarget.ace.train import train_ace
from morphkit.retarget.config import replace_config
from morphkit.retarget.training_data import (
    CONVENTION_FILE,
    EMBEDDED_EVALUATION_CLIPS,
    DataConfig,
    evaluation_clips,
    human_motions,
)

TINY = ["prior.epochs=1", "prior.steps_per_epoch=2", "retarget.epochs=1", "retarget.steps_per_epoch=2"]
DATA = Path(os.environ["MORPHKIT_DATA"]) if os.environ.get("MORPHKIT_DATA") else None


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("canonical_run")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MORPHKIT_CACHE_DIR", str(root.parent / "ace_cache"))
        human = write_human_clips(root / "human", clips=2, frames=60)
        cfg = replace_config(preset("smoke"), TINY)
        train_ace(root / "run", read_morphology(write_quadruped(root)), cfg, human_data=human, progress=False,
                  log=lambda s: None)
    return root / "run"


@pytest.fixture(autouse=True)
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(tmp_path.parent / "ace_cache"))


def _bvh(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


def test_a_run_records_the_canonical_human_and_takes_clips_of_other_conventions(run, tmp_path):
    meta = yaml.safe_load((run / "ace.yaml").read_text())
    assert meta["canonical_human"] == canonical_record() and meta["human_skeleton"] == "human"
    model = AceRetargeter(run)
    assert model.canonical == canonical_record()
    clip = canonical_clip(frames=30)
    cmu = read_motion(_bvh(tmp_path, "cmu.bvh", renamed_bvh(clip, CMU22, bone_scale={"LeftLeg": 0.9, "RightLeg": 0.9})))
    odd = read_motion(_bvh(tmp_path, "odd.bvh", renamed_bvh(clip, {n: f"b{i}" for i, n in
                                                                    enumerate(canonical_human().link_names)})),
                      facing="+z")
    with pytest.warns(UserWarning, match="guessed from the skeleton's shape"):
        out = model.retarget([cmu, odd, clip])
    assert [r.motion.frame_count for r in out] == [30, 30, 30]
    assert all(r.source.morphology is canonical_human() for r in out[:2])
    np.testing.assert_allclose(out[1].motion.q, out[2].motion.q, atol=1e-4)  # same motion, other names


def test_a_dog_is_refused_before_anything_is_retargeted(run, tmp_path, capsys):
    dog = _bvh(tmp_path, "dog.bvh", creature_bvh())
    model = AceRetargeter(run)
    with pytest.raises(MotionFormatError, match="no two arms"):
        model.retarget([canonical_clip(frames=10), read_motion(dog)])
    from morphkit.cli import main

    assert main(["retarget", "--run", str(run), "--motion", str(dog), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {dog}: ") and "cannot be mapped onto the canonical human" in err
    assert not (tmp_path / "o").exists()


def test_a_run_from_before_the_record_keeps_working(run, tmp_path):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(run, old)
    meta = yaml.safe_load((old / "ace.yaml").read_text())
    del meta["canonical_human"]
    (old / "ace.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    clip = canonical_clip(frames=20)
    model = AceRetargeter(old)
    assert model.artifact.canonical_human is None and model.canonical == canonical_record()  # trained on `human`
    np.testing.assert_array_equal(model.retarget([clip])[0].motion.q, AceRetargeter(run).retarget([clip])[0].motion.q)
    model.artifact.save_meta(old)
    assert "canonical_human" not in yaml.safe_load((old / "ace.yaml").read_text())
    # trained on another skeleton: clips are taken as they are, as before
    meta["human_skeleton"] = "01_01"
    (old / "ace.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
    assert AceRetargeter(old).canonical is None


@pytest.mark.skipif(DATA is None or not (DATA / "human" / "cmu_daz").is_dir(), reason="MORPHKIT_DATA is not set")
def test_the_run_retargets_real_cmu_daz_and_bandai_clips(run):
    assert DATA is not None
    root = DATA / "human"
    clips = [read_motion(root / "cmu" / "05_01.bvh").slice(0, 45),
             read_motion(root / "cmu_daz" / "cmu_05_01.bvh", fps=30.0).slice(1, 46),
             read_motion(sorted((root / "second_skeleton").glob("*walk*.bvh"))[0]).slice(0, 45)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every one of them by its convention table, no guessing
        out = AceRetargeter(run).retarget(clips)
    assert [r.motion.frame_count for r in out] == [45, 45, 45]
    assert all(np.isfinite(r.motion.q).all() for r in out)


def test_human_training_data_is_canonical_whatever_the_folder_holds(tmp_path):
    folder = tmp_path / "mixed"
    folder.mkdir()
    clip = canonical_clip(frames=40)
    _bvh(folder, "a_cmu.bvh", renamed_bvh(clip, CMU22, bone_scale={"Spine1": 1.2}))
    _bvh(folder, "b_mixamo.bvh", renamed_bvh(clip, {n: f"mixamorig:{n}" for n in canonical_human().link_names}))
    mine = {n: f"my_{n.lower()}" for n in canonical_human().link_names}
    _bvh(folder, "c_mine.bvh", renamed_bvh(clip, mine))
    (folder / CONVENTION_FILE).write_text("name: mine\nfacing: +z\nlinks:\n" +
                                          "".join(f"  {k}: {v}\n" for k, v in mine.items()))
    data = DataConfig(fps=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the folder's own table, no guessing
        motions = human_motions(folder, data, cache_dir=None)
    assert [m.name for m in motions] == ["a_cmu", "b_mixamo", "c_mine"]
    assert all(m.morphology is canonical_human() for m in motions)
    assert {human_state_layout(m.morphology).dim for m in motions} == {104}
    np.testing.assert_allclose(motions[2].link_positions(), clip.link_positions(), atol=1e-6)
    # data.human_mirror: each clip's mirror image follows the clips; its pelvis walks the reflected path
    mirrored = human_motions(folder, replace(data, human_mirror=True), cache_dir=None)
    assert [m.name for m in mirrored] == ["a_cmu", "b_mixamo", "c_mine", "a_cmu_mirrored", "b_mixamo_mirrored",
                                          "c_mine_mirrored"]
    np.testing.assert_allclose(mirrored[5].link_positions()[:, 0], motions[2].link_positions()[:, 0] * [1, -1, 1],
                               atol=1e-9)
    raw = evaluation_clips(folder, data, cache_dir=None, canonical=False)
    assert raw[0].morphology.link_names[0] == "root"
    assert evaluation_clips(folder, data, cache_dir=None, limit=1)[0].morphology is canonical_human()


def test_embedded_default_evaluation_gives_the_clips_asked_for() -> None:
    """The main job's `--clips 6` gets six embedded held-out clips (a quarter of the training frames held three),
    none of them a training clip; a limit takes the first of them."""
    data = DataConfig(human_frames=600)
    clips = evaluation_clips(None, data)
    assert len(clips) == EMBEDDED_EVALUATION_CLIPS and all(c.frame_count == 300 for c in clips)
    assert [c.name for c in evaluation_clips(None, data, limit=2)] == [c.name for c in clips[:2]]
    trained = human_motions(None, data)
    assert not any(np.array_equal(c.q[:10], t.q[:10]) for c in clips for t in trained)
    assert len(human_motions(None, replace(data, human_mirror=True))) == 2 * len(trained)
