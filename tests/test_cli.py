"""The CLI: summaries of shipped creatures, conversions, and bad input as one line with exit code 2."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from morphkit.cli import main

ROOT = Path(__file__).resolve().parents[1]

GOOD_YAML = """\
name: stick
base: floating
links:
  hip: {shapes: [{type: sphere, radius: 0.1}]}
  shin: {shapes: [{type: capsule, radius: 0.05, length: 0.4, origin: {xyz: [0, 0, -0.2]}}]}
joints:
  knee:
    type: revolute
    parent: hip
    child: shin
    origin: {xyz: [0, 0, -0.1]}
    axis: [0, 1, 0]
    limit: {lower: -1.0, upper: 1.0}
end_effectors:
  foot: {link: shin, offset: [0, 0, -0.45], role: foot}
"""


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "morphkit.cli", *args], capture_output=True, text=True, cwd=ROOT, check=False
    )


@pytest.mark.parametrize(
    ("name", "base", "dof", "roles"),
    [
        ("spot", "floating", 19, {"foot": 4, "hand": 1, "head": 1}),
        ("crab", "floating", 24, {"foot": 6, "hand": 2, "head": 1}),
        ("stretch", "wheeled", None, {"hand": 1, "head": 1}),
        ("human", "floating", None, {"foot": 2, "hand": 2, "head": 1}),
    ],
)
def test_info_json_on_shipped_creatures(name, base, dof, roles, capsys):
    assert main(["info", name, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    for key in (
        "name",
        "base",
        "link_count",
        "joint_counts",
        "dof",
        "coordinate_count",
        "base_dof",
        "end_effectors",
        "characteristic_length",
        "body_length",
        "body_length_rule",
    ):
        assert key in s
    assert s["base"] == base
    if dof is not None:
        assert s["dof"] == dof
    got = {}
    for e in s["end_effectors"]:
        got[e["role"]] = got.get(e["role"], 0) + 1
    assert got == roles
    assert s["link_count"] == sum(s["joint_counts"].values()) + 1
    assert s["characteristic_length"] > 0
    assert s["body_length"] > 0 and s["body_length_rule"] == ("hand_reach" if name == "stretch" else "stance")


def test_info_text_and_convert_round_trip(tmp_path):
    src = tmp_path / "stick.yaml"
    src.write_text(GOOD_YAML)
    out = run_cli("info", str(src))
    assert out.returncode == 0, out.stderr
    assert "DoF                   1" in out.stdout and "stick" in out.stdout
    assert "body length" in out.stdout
    for suffix in (".urdf", ".usda", ".yaml"):
        dst = tmp_path / f"copy{suffix}"
        res = run_cli("convert", str(src), str(dst))
        assert res.returncode == 0, res.stderr
        again = run_cli("info", str(dst), "--json")
        assert json.loads(again.stdout)["dof"] == 1


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        (GOOD_YAML.replace("type: revolute", "type: hinge"), 8, "unknown joint type 'hinge'"),
        (GOOD_YAML.replace("lower: -1.0", "lower: 2.0"), 13, "lower 2.0 > upper 1.0"),
        (GOOD_YAML.replace("child: shin", "child: calf"), 7, "calf"),
        (GOOD_YAML.replace("radius: 0.1}", "radius: .nan}"), 4, "non-finite"),
        (GOOD_YAML + "  oops: [\n", None, ""),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, text, line, fragment):
    src = tmp_path / "bad.yaml"
    src.write_text(text)
    res = run_cli("info", str(src))
    assert res.returncode == 2
    assert "Traceback" not in res.stderr
    err = res.stderr.strip().splitlines()[-1]
    assert err.startswith(f"error: {src}")
    if line is not None:
        assert err.startswith(f"error: {src}:{line}: "), err
    assert fragment in err


def test_missing_file_and_unknown_suffix_exit_2(tmp_path):
    res = run_cli("info", str(tmp_path / "nope.yaml"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    weird = tmp_path / "creature.txt"
    weird.write_text("hello")
    res = run_cli("info", str(weird))
    assert res.returncode == 2 and ".yaml" in res.stderr
    res = run_cli("info")
    assert res.returncode == 2


def test_convert_never_clobbers_output_on_failure(tmp_path):
    src = tmp_path / "bad.yaml"
    src.write_text(GOOD_YAML.replace("type: revolute", "type: hinge"))
    dst = tmp_path / "keep.urdf"
    dst.write_text("precious")
    res = run_cli("convert", str(src), str(dst))
    assert res.returncode == 2
    assert dst.read_text() == "precious"
    assert sorted(os.listdir(tmp_path)) == ["bad.yaml", "keep.urdf"]


def test_convert_motion_between_bvh_npz_and_usd(tmp_path):
    """A BVH motion converts to NPZ, USD and back, frames intact; its skeleton converts to YAML."""
    import numpy as np

    from morphkit.motion import read_motion

    src = ROOT / "tests" / "data" / "tiny.bvh"
    first = read_motion(src)
    for name in ("m.npz", "m.usda", "m.bvh"):
        res = run_cli("convert", str(src), str(tmp_path / name))
        assert res.returncode == 0, res.stderr
        assert "Warp" not in res.stdout
        back = read_motion(tmp_path / name)
        # BVH export gives fixed joints zero rotation channels, so compare frames and link positions.
        assert back.q.shape[0] == first.q.shape[0] and back.fps == first.fps
        assert back.morphology.link_names == first.morphology.link_names
        np.testing.assert_allclose(back.link_positions(), first.link_positions(), atol=1e-5)
    res = run_cli("convert", str(tmp_path / "m.npz"), str(tmp_path / "m60.npz"), "--fps", str(2 * first.fps))
    assert res.returncode == 0, res.stderr
    assert read_motion(tmp_path / "m60.npz").q.shape[0] == 2 * first.q.shape[0] - 1
    res = run_cli("convert", str(src), str(tmp_path / "skeleton.yaml"))
    assert res.returncode == 0 and "links" in res.stdout


def test_convert_unknown_output_format_names_the_output(tmp_path):
    res = run_cli("convert", "spot", str(tmp_path / "spot.zzz"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert res.stderr.strip().startswith(f"error: {tmp_path / 'spot.zzz'}: unknown output format '.zzz'")


@pytest.mark.parametrize("bad", ["0", "-0.5", "nan"])
def test_train_body_length_is_validated_before_training(bad, capsys):
    assert main(["train", "ace", "crab", "--body-length", bad, "--out", "/nonexistent/run"]) == 2
    err = capsys.readouterr().err
    assert err == f"error: --body-length: expected a number above 0 and at most 1000 m, got {bad!r}\n"


def test_warnings_are_one_line_naming_file_and_line(tmp_path, capsys):
    """A missing mesh and a wheeled base without wheels are read with one `warning: FILE:LINE: ...` line each."""
    text = (
        "name: cart\n"
        "base: wheeled\n"
        "links:\n"
        "  body: {shapes: [{type: mesh, file: meshes/body.stl}]}\n"
        "  wheel_l: {}\n"
        "joints:\n"
        "  wheel_l: {type: continuous, parent: body, child: wheel_l, axis: [0, 1, 0]}\n"
    )
    path = tmp_path / "cart.yaml"
    path.write_text(text)
    lines = text.splitlines()
    mesh_line = 1 + next(i for i, ln in enumerate(lines) if "meshes/body.stl" in ln)
    base_line = 1 + lines.index("base: wheeled")
    assert main(["info", str(path)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"warning: {path}:{mesh_line}: mesh file not found: {tmp_path / 'meshes' / 'body.stl'}",
        f"warning: {path}:{base_line}: wheeled base without wheels: the base drives but no joint turns with it; "
        "name them with wheels: {joints: [...], radius: R} (continuous joints: wheel_l)",
    ]
    path.write_text(text + "wheels: {joints: [wheel_l], radius: 0.1}\n")
    assert main(["info", str(path)]) == 0
    assert "wheeled" not in capsys.readouterr().err


def test_cli_prints_no_warp_cuda_chatter():
    """With the CLI's MORPHKIT_QUIET_WARP, loading and running a kernel prints nothing: no Warp banner, no
    module-load line, no note that a CPU-only machine has no CUDA driver."""
    code = "import morphkit.kernels, warp; warp.zeros(3, device='cpu').numpy()"
    env = {**os.environ, "MORPHKIT_QUIET_WARP": "1"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, check=False)
    assert done.returncode == 0 and done.stdout == "" and done.stderr == "", done.stderr
