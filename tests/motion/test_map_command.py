"""``morphkit map``: the text table, ``--json``, overrides, and bad input as one error line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import human_like, random_q, spot_like

from morphkit.cli import main
from morphkit.motion import Motion, load_motions, measured_body_length, write_motion
from morphkit.motion._fk import compiled_model


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("map")
    for name, make in (("human", human_like), ("spot", spot_like)):
        m = make()
        folder = root / name
        for seed in range(2):
            q = random_q(compiled_model(m), 20, seed=seed)
            q[:, 2] = np.abs(q[:, 2]) + 0.5
            write_motion(Motion(m, 30.0, q, f"{name}{seed}"), folder / f"{name}{seed}.npz")
    return root / "human", root / "spot"


def test_map_prints_table_and_json(data: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    human, spot = data
    assert main(["map", str(human), str(spot), "--no-cache"]) == 0
    out = capsys.readouterr().out
    assert "gripper" in out and "-> " in out and "KL" in out
    assert main(["map", str(human), str(spot), "--json", "--no-cache", "--set", "gripper=lhand_ee"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["mapping"]["gripper"] == "lhand_ee"
    assert set(doc["mapping"]) == {e.name for e in spot_like().end_effectors}
    assert set(doc["kl"]["fl_foot"]) == {e.name for e in human_like().end_effectors}
    assert all(v >= 0 for row in doc["kl"].values() for v in row.values())


def test_map_bad_input_is_one_error_line(data: tuple[Path, Path], tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    human, spot = data
    override = tmp_path / "o.yaml"
    override.write_text("gripper: nose\n")
    assert main(["map", str(human), str(spot), "--override", str(override), "--no-cache"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {override}") and "valid: " in err and "Traceback" not in err
    assert main(["map", str(human), str(tmp_path / "missing"), "--no-cache"]) == 2
    assert "no such file or folder" in capsys.readouterr().err
    assert main(["map", str(human), str(spot), "--set", "gripper", "--no-cache"]) == 2
    assert "--set" in capsys.readouterr().err


def test_map_body_lengths_are_measured_reported_and_overridable(data: tuple[Path, Path],
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    human, spot = data
    assert main(["map", str(human), str(spot), "--json", "--no-cache"]) == 0
    measured = json.loads(capsys.readouterr().out)["body_length"]
    for key, folder in (("human", human), ("creature", spot)):
        clips = load_motions([folder], cache_dir=None)
        assert measured[key] == pytest.approx(measured_body_length(clips[0].morphology, clips), abs=1e-6)
    assert main(["map", str(human), str(spot), "--json", "--no-cache", "--body-length", "0.5",
                 "--human-body-length", "1.25"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["body_length"] == {"creature": 0.5, "human": 1.25}
    assert main(["map", str(human), str(spot), "--no-cache", "--creature-length", "0.5"]) == 0  # the old spelling
    assert "body lengths: spot_like 0.500 m" in capsys.readouterr().out
    for bad in ("0", "-1", "nan", "inf"):
        assert main(["map", str(human), str(spot), "--no-cache", "--body-length", bad]) == 2
        err = capsys.readouterr().err
        assert err == ("error: --body-length/--creature-length: expected a number above 0 and at most 1000 m, "
                       f"got {bad!r}\n")


KANGAROO_YAML = """\
name: kangaroo
base: floating
root: pelvis
links:
  pelvis: {shapes: [{type: capsule, radius: 0.12, length: 0.3, origin: {rpy: [0, 1.5708, 0]}}]}
  chest: {shapes: [{type: capsule, radius: 0.1, length: 0.3, origin: {xyz: [0.1, 0, 0.12], rpy: [0, 0.8, 0]}}]}
  head: {shapes: [{type: sphere, radius: 0.08}]}
  l_arm: {shapes: [{type: capsule, radius: 0.02, length: 0.15, origin: {xyz: [0, 0, -0.075]}}]}
  r_arm: {shapes: [{type: capsule, radius: 0.02, length: 0.15, origin: {xyz: [0, 0, -0.075]}}]}
  l_thigh: {shapes: [{type: capsule, radius: 0.05, length: 0.3, origin: {xyz: [0, 0, -0.15]}}]}
  r_thigh: {shapes: [{type: capsule, radius: 0.05, length: 0.3, origin: {xyz: [0, 0, -0.15]}}]}
  l_shin: {shapes: [{type: capsule, radius: 0.035, length: 0.35, origin: {xyz: [0, 0, -0.175]}}]}
  r_shin: {shapes: [{type: capsule, radius: 0.035, length: 0.35, origin: {xyz: [0, 0, -0.175]}}]}
  tail_a: {shapes: [{type: capsule, radius: 0.05, length: 0.35, origin: {xyz: [-0.175, 0, 0], rpy: [0, 1.5708, 0]}}]}
  tail_b: {shapes: [{type: capsule, radius: 0.03, length: 0.35, origin: {xyz: [-0.175, 0, 0], rpy: [0, 1.5708, 0]}}]}
joints:
  spine: {type: revolute, parent: pelvis, child: chest, origin: {xyz: [0.1, 0, 0.05]}, axis: [0, 1, 0],
          limit: {lower: -0.5, upper: 0.5}}
  neck: {type: revolute, parent: chest, child: head, origin: {xyz: [0.25, 0, 0.3]}, axis: [0, 1, 0],
         limit: {lower: -0.6, upper: 0.6}}
  l_shoulder: {type: revolute, parent: chest, child: l_arm, origin: {xyz: [0.25, 0.08, 0.1]}, axis: [0, 1, 0],
               limit: {lower: -1.5, upper: 1.0}}
  r_shoulder: {type: revolute, parent: chest, child: r_arm, origin: {xyz: [0.25, -0.08, 0.1]}, axis: [0, 1, 0],
               limit: {lower: -1.5, upper: 1.0}}
  l_hip: {type: revolute, parent: pelvis, child: l_thigh, origin: {xyz: [0, 0.1, -0.05]}, axis: [0, 1, 0],
          limit: {lower: -1.2, upper: 0.6}}
  r_hip: {type: revolute, parent: pelvis, child: r_thigh, origin: {xyz: [0, -0.1, -0.05]}, axis: [0, 1, 0],
          limit: {lower: -1.2, upper: 0.6}}
  l_knee: {type: revolute, parent: l_thigh, child: l_shin, origin: {xyz: [0, 0, -0.3]}, axis: [0, 1, 0],
           limit: {lower: 0.0, upper: 2.0}}
  r_knee: {type: revolute, parent: r_thigh, child: r_shin, origin: {xyz: [0, 0, -0.3]}, axis: [0, 1, 0],
           limit: {lower: 0.0, upper: 2.0}}
  tail_root: {type: revolute, parent: pelvis, child: tail_a, origin: {xyz: [-0.15, 0, 0]}, axis: [0, 1, 0],
              limit: {lower: -0.6, upper: 0.4}}
  tail_mid: {type: revolute, parent: tail_a, child: tail_b, origin: {xyz: [-0.35, 0, 0]}, axis: [0, 1, 0],
             limit: {lower: -0.5, upper: 0.5}}
end_effectors:
  l_foot: {link: l_shin, offset: [0.1, 0, -0.35], role: foot}
  r_foot: {link: r_shin, offset: [0.1, 0, -0.35], role: foot}
  l_paw: {link: l_arm, offset: [0, 0, -0.15], role: hand}
  r_paw: {link: r_arm, offset: [0, 0, -0.15], role: hand}
  snout: {link: head, offset: [0.1, 0, 0], role: head}
  tail_tip: {link: tail_b, offset: [-0.35, 0, 0]}
"""
"""A kangaroo-like creature: pitch-only legs, short arms, a long tail whose tip has no role (a tool)."""


@pytest.mark.parametrize("name", ["spot", "crab", "kangaroo"])
def test_map_sends_the_head_to_the_human_head(name: str, data: tuple[Path, Path], tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """Roles constrain the KL choice by default and --kl-only keeps the paper's argmin; both are reported,
    and each data set is labelled by its folder when its skeleton is only named after a clip."""
    from morphkit.graph import EndEffectorRole
    from morphkit.io import read_morphology

    if name == "kangaroo":
        (tmp_path / "kangaroo.yaml").write_text(KANGAROO_YAML)
        m = read_morphology(tmp_path / "kangaroo.yaml")
    else:
        m = read_morphology(name)  # the shipped creature, by name
    folder = tmp_path / "clips"
    for seed in range(2):
        q = random_q(compiled_model(m), 20, seed=seed)
        q[:, 2] = np.abs(q[:, 2]) + 0.5
        write_motion(Motion(m, 30.0, q, f"{name}{seed}"), folder / f"{name}{seed}.npz")
    human_data, _ = data
    human = human_like()
    human_heads = {e.name for e in human.end_effectors if e.role == EndEffectorRole.HEAD}
    heads = [e.name for e in m.end_effectors if e.role == EndEffectorRole.HEAD]
    assert heads and human_heads
    for kl_only in (False, True):
        assert main(["map", str(human_data), str(folder), "--json", "--no-cache", *(["--kl-only"] * kl_only)]) == 0
        doc = json.loads(capsys.readouterr().out)
        paper = {c: min(row, key=row.get) for c, row in doc["kl"].items()}  # Eq. 11, from the reported table
        assert doc["kl_only"] == paper
        assert all(doc["by_role"][h] in human_heads for h in heads)
        assert doc["mapping"] == (paper if kl_only else doc["by_role"])
        assert doc["rule"] == ("kl" if kl_only else "roles")
        assert doc["data"]["creature"] == {"label": m.name, "clips": 2}
    if name == "kangaroo":
        assert doc["roles"]["tail_tip"] == "tool"  # an omitted role reads as a tool
        human_hands = {e.name for e in human.end_effectors if e.role == EndEffectorRole.HAND}
        assert doc["by_role"]["tail_tip"] in human_hands
    assert main(["map", str(human_data), str(folder), "--no-cache"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{m.name} (2 clips) -> human_like (2 clips)")
    assert "KL only" in out and "mapping: KL within roles" in out


def test_map_labels_a_bvh_data_set_by_its_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """BVH skeletons are named after their file: the report names the folder the clips came from."""
    from morphkit.motion import write_bvh_motion

    human = tmp_path / "mocap"
    for seed in range(2):
        m = human_like()
        q = random_q(compiled_model(m), 20, seed=seed)
        q[:, 2] = np.abs(q[:, 2]) + 0.5
        write_bvh_motion(Motion(m, 30.0, q, f"take{seed}"), human / f"take{seed}.bvh")
    spot = spot_like()
    q = random_q(compiled_model(spot), 20, seed=3)
    q[:, 2] = np.abs(q[:, 2]) + 0.5
    write_motion(Motion(spot, 30.0, q, "walk"), tmp_path / "walk.npz")
    assert main(["map", str(human), str(tmp_path / "walk.npz"), "--no-cache"]) == 0
    assert capsys.readouterr().out.startswith("spot_like (1 clip) -> mocap (2 clips)")
