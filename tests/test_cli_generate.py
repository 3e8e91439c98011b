"""``morphkit generate``: its written-out choices agree with the generators, building the CLI starts no Warp (its
banner would land on every command's stdout), and ``--wheels`` writes a robot whose drive the reader finds."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from morphkit.cli import main
from morphkit.commands.generate import FAMILY_NAMES, WHEEL_DRIVES


def test_written_out_choices_are_the_generators():
    from morphkit.synth.creatures import FAMILIES
    from morphkit.synth.wheeled_bodies import WHEELED_DRIVES

    assert FAMILY_NAMES == tuple(sorted(FAMILIES))
    assert WHEEL_DRIVES == WHEELED_DRIVES


def test_building_the_parser_starts_no_warp():
    code = "import sys, morphkit.cli as c; c.build_parser(); print('warp' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize("drive", WHEEL_DRIVES)
def test_generated_wheeled_robot_reads_with_its_drive(tmp_path, drive, capsys):
    out = tmp_path / f"{drive}.urdf"
    assert main(["generate", "--wheels", drive, "--arm", "--unlabelled", "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)  # stdout is the JSON alone
    assert info["base"] == "wheeled" and info["wheels"]["drive"] == drive
    assert not any(e["link"].startswith("wheel") for e in info["end_effectors"])


def test_wheels_with_a_creature_flag_is_refused(tmp_path, capsys):
    assert main(["generate", "--wheels", "differential", "--legs", "4", "--out", str(tmp_path / "w.urdf")]) == 2
    assert "--legs is a creature's" in capsys.readouterr().err
    assert not (tmp_path / "w.urdf").exists()
