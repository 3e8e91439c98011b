"""``morphkit bench fk`` runs end to end, and every implementation it times computes the same FK.

No timing is asserted: the benchmark runs at a tiny batch in ``--quick --json`` mode and the
records' schema is checked; the peers (pytorch-kinematics, Pinocchio, MuJoCo; ``pip install -e
".[bench]"``) are checked against morphkit's torch reference FK where installed, skipped otherwise.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import every_joint

pytest.importorskip("torch")

import morphkit.bench as bench
from morphkit.bench.peers import urdf_text_for_peers
from morphkit.cli import main
from morphkit.errors import ConfigError
from morphkit.io.mjcf import dump_mjcf

PEER_MODULES = {"pytorch_kinematics": "pytorch_kinematics", "pinocchio": "pinocchio", "mujoco": "mujoco"}
RECORD_KEYS = {"creature", "impl", "mode", "batch", "poses_per_s"}
TARGETS = Path(__file__).resolve().parents[1] / "benchmarks" / "fk_targets.yaml"


def _installed(impl: str) -> bool:
    module = PEER_MODULES.get(impl)
    return module is None or importlib.util.find_spec(module) is not None


def _require(impl: str) -> None:
    if not _installed(impl):
        pytest.skip(f"{impl} is not installed (pip install -e '.[bench]')")


def _creature(name: str):
    if name == "every_joint_floating":
        return every_joint("floating")
    if name == "every_joint_fixed":
        return every_joint("fixed")
    return bench.load_creature(name).morphology


def test_bench_fk_quick_json_records(capsys):
    """A tiny --quick --json run prints one well-formed record per (creature, impl, mode, batch)."""
    rc = main(["bench", "fk", "--quick", "--json", "--batches", "2", "--threads", "1"])
    assert rc == 0
    out = capsys.readouterr()
    records = json.loads(out.out)
    assert isinstance(records, list) and records
    for r in records:
        assert set(r) == RECORD_KEYS
        assert r["creature"] in ("spot", "human")
        assert r["impl"] in bench.IMPLS
        assert r["mode"] in ("fwd", "fwd_bwd")
        assert r["batch"] == 2
        assert isinstance(r["poses_per_s"], float) and math.isfinite(r["poses_per_s"]) and r["poses_per_s"] > 0
    seen = {(r["creature"], r["impl"], r["mode"]) for r in records}
    expected = {(c, i, m) for c in ("spot", "human") for i in bench.IMPLS if _installed(i) for m in ("fwd", "fwd_bwd")}
    assert seen == expected
    assert len(records) == len(seen)
    # The human-readable report goes to stderr in --json mode.
    assert "### spot, forward" in out.err and "Agreement with the torch reference" in out.err


def test_bench_fk_rejects_bad_batches(capsys):
    """A non-positive batch size is bad input: one error line and exit code 2."""
    assert main(["bench", "fk", "--batches", "0"]) == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize("impl", [i for i in bench.IMPLS if i != "torch"])
@pytest.mark.parametrize("name", ["spot", "human", "every_joint_floating", "every_joint_fixed"])
def test_impl_link_positions_match_reference(impl, name):
    """Every implementation's link positions equal the torch reference FK (float64) at random poses."""
    _require(impl)
    m = _creature(name)
    q = bench.random_q(m, 6, np.random.default_rng(7))
    ref = bench.make_impl("torch", m).link_positions(q)
    got = bench.make_impl(impl, m).link_positions(q)
    assert got.shape == (6, m.link_count, 3)
    # float32 implementations (morphkit, pytorch-kinematics) carry ~1e-7 relative error.
    np.testing.assert_allclose(got, ref, atol=2e-5, rtol=0)


@pytest.mark.parametrize("impl", ["morphkit", "morphkit_torch"])
@pytest.mark.parametrize("name", ["spot", "human"])
def test_fwd_bwd_is_gradient_of_summed_positions(impl, name):
    """What ``fwd_bwd`` times is ∂(Σ link positions)/∂q, equal to the torch reference's autograd gradient."""
    import torch

    from morphkit.model import compile_model
    from morphkit.torch.reference import fk_reference

    m = _creature(name)
    q = bench.random_q(m, 5, np.random.default_rng(3))
    grad = bench.make_impl(impl, m).workload(q).fwd_bwd()
    got = grad.numpy() if hasattr(grad, "numpy") else np.asarray(grad)
    qt = torch.as_tensor(q, dtype=torch.float64).requires_grad_(True)
    fk_reference(compile_model(m), qt)[..., :3].sum().backward()
    np.testing.assert_allclose(got, qt.grad.numpy(), atol=2e-3, rtol=1e-3)


def test_peer_descriptions_expand_spherical_joints():
    """The peers' URDF has three revolutes per ball joint; the MJCF one body per link."""
    m = every_joint("floating")
    urdf = urdf_text_for_peers(m)
    assert urdf.count("<joint ") == m.joint_count + 2 * 2  # two spherical joints → 3 revolutes each
    assert 'name="a_sph__rz"' in urdf and 'name="a_sph__rx"' in urdf
    mjcf = dump_mjcf(m)
    assert mjcf.count("<body ") == m.link_count and "<freejoint" in mjcf and 'type="ball"' in mjcf


def test_peers_reject_planar_base():
    """Peers cannot express a planar base: a ConfigError, which the benchmark lists as skipped."""
    _require("pinocchio")
    from morphkit.bench.peers import PinocchioFK

    with pytest.raises(ConfigError, match="planar"):
        PinocchioFK(every_joint("planar"))


def test_report_checks_targets():
    """The markdown report prints PASS/MISS with the margin for the project's targets (benchmarks/fk_targets.yaml)."""
    targets = bench.load_targets(TARGETS)
    records = [
        {"creature": "spot", "impl": "morphkit", "mode": "fwd", "batch": 16384, "poses_per_s": 5e6},
        {"creature": "spot", "impl": "pinocchio", "mode": "fwd", "batch": 16384, "poses_per_s": 2e6},
        {"creature": "human", "impl": "morphkit", "mode": "fwd", "batch": 16384, "poses_per_s": 1e6},
    ]
    result = bench.BenchResult(records=records, config=bench.BenchConfig(batches=(16384,), modes=("fwd",)))
    result.creatures = {"spot": "test", "human": "test"}
    result.bridge = {"spot": {"raw": 30.0, "torch": 50.0, "overhead": 20.0}}
    checks = {c.name: c for c in bench.check_targets(result, targets)}
    assert checks["spot fwd, morphkit"].passed and checks["spot fwd, morphkit"].margin == pytest.approx(1.25)
    assert not checks["spot fwd, morphkit / pinocchio"].passed  # 2.5× < 3×
    assert not checks["human fwd, morphkit"].passed
    report = bench.markdown_report(result, targets)
    assert "- PASS spot fwd, morphkit: 5 M poses/s" in report
    assert "- MISS human fwd, morphkit" in report
    assert "| 16384 | 5 M | 2 M (×2.5) |" in report
    assert "- PASS spot torch bridge overhead at B=1: 20 µs (target ≤ 40 µs; margin 2.00×)" in report
    assert "| spot | 30.0 µs | 50.0 µs | 20.0 µs |" in report


def test_targets_file_errors_name_the_entry(tmp_path):
    """A malformed targets file is a ConfigError naming the file, the entry and what is wrong."""
    cases = {
        "targets: []": "positive integer 'batch'",
        "batch: 8\ntargets:\n  - {kind: speed, at_least: 1}": r"targets\[0\]: unknown kind 'speed'",
        "batch: 8\ntargets:\n  - {kind: rate, creature: spot, mode: fwd, at_least: 1}": "missing impl",
        "batch: 8\ntargets:\n  - {kind: rate, creature: spot, mode: fwd, impl: morphkit, at_least: fast}":
            "'fast' is text",
        "batch: 8\ntargets:\n  - {kind: cold_compile, at_least: 1, at_most: 2}": "exactly one number",
        "batch: 8\ntargets:\n  - {kind: speedup, creature: spot, mode: fwd, impl: morphkit, over: numpy, at_least: 2}":
            "unknown over 'numpy'",
    }
    for i, (text, message) in enumerate(cases.items()):
        path = tmp_path / f"t{i}.yaml"
        path.write_text(text)
        with pytest.raises(ConfigError, match=message) as info:
            bench.load_targets(path)
        assert str(path) in str(info.value)
    # The one YAML reader reads YAML 1.2 numbers: 4.0e6 is a number, not text, without a signed exponent.
    path = tmp_path / "exponent.yaml"
    path.write_text("batch: 8\ntargets:\n  - {kind: rate, creature: spot, mode: fwd, impl: morphkit, at_least: 4.0e6}")
    target = bench.load_targets(path).targets[0]
    assert target.at_least and target.bound == 4.0e6
