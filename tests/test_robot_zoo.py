"""Smoke test of ``benchmarks/robot_zoo.py``: its per-robot measurement on a tiny quadruped written here (URDF +
SRDF ``group_state``, no download), the height ratio against a hand computation, and the pass/fail rules."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import TINY_LEGS, TINY_SHIN, TINY_THIGH, tiny_quadruped_urdf

pytest.importorskip("warp")

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "robot_zoo.py"

THIGH, SHIN, LEGS = TINY_THIGH, TINY_SHIN, TINY_LEGS
HIP, KNEE = 0.5, -1.0  # the SRDF's standing pose


def _zoo():
    if not SCRIPT.is_file():
        pytest.skip("benchmarks/robot_zoo.py is not in this checkout")
    spec = importlib.util.spec_from_file_location("robot_zoo", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("robot_zoo", mod)  # its dataclass looks its module up
    spec.loader.exec_module(sys.modules["robot_zoo"])
    return sys.modules["robot_zoo"]


def _write_robot(folder: Path) -> None:
    (folder / "tiny" / "urdf").mkdir(parents=True)
    (folder / "tiny" / "srdf").mkdir(parents=True)
    (folder / "tiny" / "urdf" / "tiny.urdf").write_text(tiny_quadruped_urdf())
    joints = "".join(f'<joint name="{n}_hip" value="{HIP}"/><joint name="{n}_knee" value="{KNEE}"/>' for n in LEGS)
    (folder / "tiny" / "srdf" / "tiny.srdf").write_text(
        '<?xml version="1.0"?>\n<robot name="tiny">\n'
        '  <group_state name="home" group="all"><joint name="FL_hip" value="0.3"/></group_state>\n'
        f'  <group_state name="standing" group="all"><joint name="root_joint" value="0 0 0.3 0 0 0 1"/>{joints}'
        '</group_state>\n</robot>\n')


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _foot_depth(hip: float, knee: float, offset: np.ndarray) -> float:
    """By hand: the foot point's depth below the hip (= below the root) of a two-hinge leg about y."""
    foot = _ry(hip) @ (np.array([0.0, 0.0, -THIGH]) + _ry(knee) @ (np.array([0.0, 0.0, -SHIN]) + offset))
    return float(-foot[2])


def test_tiny_quadruped_height_ratio_and_verdict(tmp_path: Path) -> None:
    zoo = _zoo()
    _write_robot(tmp_path)
    assert zoo.srdf_state(tmp_path / "tiny/srdf/tiny.srdf")[0] == "standing"  # preferred over "home"
    robot = zoo.Robot("tiny", "quadruped", "tiny/urdf/tiny.urdf", "tiny/srdf/tiny.srdf", 4, 0)
    row = zoo.measure_robot(robot, tmp_path, frames=0)
    assert row["read"] == "ok" and row["base"] == "floating"
    if row["feet"] != 4:
        pytest.skip(f"the reader found {row['feet']} feet on the tiny quadruped; the ratio needs four")
    assert row["srdf_state"] == "standing" and row["srdf_joints"] == "8/8"  # the root's 7 numbers skipped

    from morphkit.io import read_morphology

    m = read_morphology(tmp_path / "tiny/urdf/tiny.urdf")
    rest = dict(m.rest_pose)
    ee = {e.link: np.array(e.offset) for e in m.end_effectors}
    rest_h = max(_foot_depth(rest.get(f"{n}_hip", 0.0), rest.get(f"{n}_knee", 0.0), ee[f"{n}_foot"]) for n in LEGS)
    srdf_h = max(_foot_depth(HIP, KNEE, ee[f"{n}_foot"]) for n in LEGS)
    assert row["height"] == pytest.approx(rest_h, abs=1e-3)
    assert row["srdf_height"] == pytest.approx(srdf_h, abs=1e-3)
    assert row["height_ratio"] == pytest.approx(rest_h / srdf_h, abs=2e-3)

    from morphkit.io.urdf import read_urdf

    alone = read_urdf(tmp_path / "tiny/urdf/tiny.urdf", srdf=False)  # the stance the anatomy searches
    found = dict(alone.rest_pose)
    ee_alone = {e.link: np.array(e.offset) for e in alone.end_effectors}
    searched_h = max(_foot_depth(found.get(f"{n}_hip", 0.0), found.get(f"{n}_knee", 0.0), ee_alone[f"{n}_foot"])
                     for n in LEGS)
    srdf_alone_h = max(_foot_depth(HIP, KNEE, ee_alone[f"{n}_foot"]) for n in LEGS)
    assert row["searched_ratio"] == pytest.approx(searched_h / srdf_alone_h, abs=2e-3)

    ok, why = zoo.judge(row)  # no synthesis (frames=0): heights and joints only
    expect_ok = (abs(rest_h / srdf_h - 1.0) <= zoo.HEIGHT_TOLERANCE and row["max_rest_joint"] <= math.pi
                 and abs(searched_h / srdf_alone_h - 1.0) <= zoo.HEIGHT_TOLERANCE)
    assert ok is expect_ok, why


def test_judge_rules() -> None:
    zoo = _zoo()
    legged = {"name": "q", "kind": "quadruped", "read": "ok", "base": "floating", "feet": 4, "hands": 0,
              "legs_expected": 4, "arms_expected": 0, "srdf_state": "standing", "height_ratio": 1.05,
              "max_rest_joint": 1.5, "sliding_cm_s": 0.2, "under_mm": 1.0}
    assert zoo.judge(legged) == (True, [])
    assert zoo.judge({**legged, "height_ratio": 1.15})[1] == ["height +15 %"]
    assert zoo.judge({**legged, "height_ratio": 1.15, "srdf_state": "default"})[0] is True  # not a stance
    assert zoo.judge({**legged, "max_rest_joint": 7.05})[1] == ["joint 7.0 rad"]
    assert zoo.judge({**legged, "feet": 3})[1] == ["feet 3/4"]
    assert zoo.judge({**legged, "sliding_cm_s": 1.0})[1] == ["sliding 1.0 cm/s"]
    assert zoo.judge({**legged, "under_mm": 19.0})[1] == ["19 mm under"]
    arm = {"name": "a", "kind": "arm", "read": "ok", "base": "fixed", "feet": 0, "hands": 1, "legs_expected": 0,
           "arms_expected": 1, "max_rest_joint": 0.0}
    assert zoo.judge(arm) == (True, [])
    assert zoo.judge({**arm, "base": "floating", "hands": 0})[1] == ["floating base", "hands 0/1"]
    assert zoo.judge({"name": "w", "kind": "wheeled", "read": "ok"})[0] is None
    assert zoo.judge({"name": "x", "kind": "arm", "read": "not found: x.urdf"}) == (False, ["not read"])
    table = zoo.format_table([legged, arm, {"name": "w", "kind": "wheeled", "read": "ok", "legs_expected": 0,
                                            "arms_expected": 1}])
    assert table.rstrip().endswith("2 of 2 pass (1 wheeled not judged here)")


def test_missing_file_is_a_row(tmp_path: Path) -> None:
    zoo = _zoo()
    row = zoo.measure_robot(zoo.Robot("nobody", "arm", "no/such.urdf", None, 0, 1), tmp_path, frames=0)
    assert row["read"] == "not found: no/such.urdf"
    assert zoo.judge(row) == (False, ["not read"])
