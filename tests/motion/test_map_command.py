"""``morphkit map``: the text table, ``--json``, overrides, and bad input as one error line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import human_like, random_q, spot_like

from morphkit.cli import main
from morphkit.motion import Motion, body_length, load_motions, write_motion
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
        assert measured[key] == pytest.approx(body_length(clips[0].morphology, clips), abs=1e-6)
    assert main(["map", str(human), str(spot), "--json", "--no-cache", "--body-length", "0.5",
                 "--human-body-length", "1.25"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["body_length"] == {"creature": 0.5, "human": 1.25}
    assert main(["map", str(human), str(spot), "--no-cache", "--creature-length", "0.5"]) == 0  # the old spelling
    assert "body lengths: spot_like 0.500 m" in capsys.readouterr().out
    for bad in ("0", "-1", "nan", "inf"):
        assert main(["map", str(human), str(spot), "--no-cache", "--body-length", bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: --body-length must be a finite length > 0") and "Traceback" not in err
