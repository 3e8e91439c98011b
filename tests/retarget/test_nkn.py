"""NKN on tiny presets: the FK layer batched over bone offsets against the reference FK, gradients from the
loss reach every GRU parameter (finite differences), twist and baseline against closed forms, smoke losses
fall, a SIGTERMed run resumes bit-identically, the cross-morphology mode trains on a YAML-only creature,
the example runs, bad input gets one clear error.

The FK layer's own bone-offset gradients (``ForwardKinematics(differentiable_offsets=True)``) are checked
against finite differences in ``tests/torch/test_layers.py``; here the NKN layer on top of it.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from _nkn_fixtures import human, walk_motion, write_skeleton_clips

from morphkit.errors import MotionFormatError, RunError
from morphkit.motion import NormStats
from morphkit.retarget.config import replace_config
from morphkit.retarget.logs import read_metrics
from morphkit.retarget.nkn import NknRetargeter, SkeletonFK, copy_rotations, preset, train_nkn
from morphkit.retarget.nkn.features import global_motion, integrate_global_motion
from morphkit.retarget.nkn.losses import twist_angles, twist_loss
from morphkit.retarget.nkn.model import NknGenerator, Side
from morphkit.retarget.nkn.skeleton import bone_offsets, scale_limbs

ROOT = Path(__file__).resolve().parents[2]
QUIET = {"progress": False, "log": lambda s: None}


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_skeleton_clips(tmp_path_factory.mktemp("skeletons"))


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory, data_dir: Path) -> Path:
    """One smoke run shared by the tests that only read it."""
    run = tmp_path_factory.mktemp("nkn") / "run"
    train_nkn(run, replace_config(preset("smoke"), ["epochs=4", "steps_per_epoch=8"]), human_data=data_dir, **QUIET)
    return run


def _rows(run: Path, name: str) -> np.ndarray:
    _, rows = read_metrics(run / "metrics.csv")
    return np.array([r[name] for r in rows if r.get(name) is not None], dtype=float)


def test_skeleton_fk_is_the_reference_fk_on_per_sample_offsets():
    """Warp FK + the linear offset correction equals the pure-torch FK, values and gradients (q and offsets)."""
    h = human()
    fast, ref = SkeletonFK(h), SkeletonFK(h, backend="reference")
    gen = torch.Generator().manual_seed(0)
    q = torch.randn(3, 2, h.coordinate_count, generator=gen, dtype=torch.float64, requires_grad=True)
    variant = scale_limbs(h, {"legs": 0.7, "arms": 1.3})
    off = torch.tensor(np.stack([bone_offsets(h), bone_offsets(variant), 1.2 * bone_offsets(variant)]))[:, None]
    off = off.expand(3, 2, -1, -1).clone().requires_grad_()
    a, b = fast(q, off), ref(q, off)
    torch.testing.assert_close(a, b, atol=1e-12, rtol=0)
    w = torch.randn(a.shape, generator=gen, dtype=torch.float64)
    for ga, gb in zip(torch.autograd.grad((a * w).sum(), (q, off)), torch.autograd.grad((b * w).sum(), (q, off)),
                      strict=True):
        torch.testing.assert_close(ga, gb, atol=1e-10, rtol=1e-9)
    # Against finite differences too, on one skeleton's offsets.
    q0 = q.detach()[:1, :1]
    assert torch.autograd.gradcheck(lambda o: fast(q0, o), (off.detach()[:1, :1].clone().requires_grad_(),))


def _tiny_generator() -> tuple[NknGenerator, torch.Tensor, torch.Tensor]:
    h = human()
    L, J = h.link_count, h.joint_count
    feats = NormStats(np.zeros(3 * L + 4), np.ones(3 * L + 4))
    offs = NormStats(bone_offsets(h).reshape(-1), np.full(3 * J, 0.05))
    cfg = replace_config(preset("smoke"), ["hidden=6", "keep_prob=1.0", "head_init_std=0.3"])
    side = Side(h, feats, offs)
    net = NknGenerator(side.feature_dim, side, cfg).double()
    gen = torch.Generator().manual_seed(1)
    x = torch.randn(2, 3, side.feature_dim, generator=gen, dtype=torch.float64)
    off = torch.tensor(np.stack([bone_offsets(h), bone_offsets(scale_limbs(h, {"legs": 0.8}))]))
    return net, x, off


def test_fk_layer_gradients_reach_every_gru_parameter():
    """Every parameter gets a finite, non-zero gradient through the FK layer; samples match central differences."""
    net, x, off = _tiny_generator()

    def loss() -> torch.Tensor:
        return net(x, off).p.square().sum()  # positions only: everything flows back through the FK layer

    net.zero_grad()
    loss().backward()
    for name, p in net.named_parameters():
        assert p.grad is not None and torch.isfinite(p.grad).all(), name
        assert p.grad.abs().sum() > 0, f"{name} gets no gradient through the FK layer"
    rng = np.random.default_rng(0)
    for name, p in [(n, p) for n, p in net.named_parameters() if "decoder" in n or "encoder" in n][::2]:
        i = int(rng.integers(p.numel()))
        analytic = p.grad.flatten()[i].item()
        with torch.no_grad():
            flat = p.view(-1)
            flat[i] += 1e-6
            up = loss().item()
            flat[i] -= 2e-6
            down = loss().item()
            flat[i] += 1e-6
        numeric = (up - down) / 2e-6
        assert numeric == pytest.approx(analytic, rel=1e-4, abs=1e-7), name


def test_twist_loss_is_zero_inside_alpha_and_grows_outside():
    axis = torch.tensor([[0.0, 1.0, 0.0]], dtype=torch.float64)
    angles = torch.tensor([-2.5, -1.0, 0.0, 1.5, 1.74, 2.0, 3.0], dtype=torch.float64)
    quats = torch.stack([torch.zeros_like(angles), torch.sin(angles / 2), torch.zeros_like(angles),
                         torch.cos(angles / 2)], -1)[:, None]  # [N, 1, 4] twists about y
    torch.testing.assert_close(twist_angles(quats, axis)[:, 0], angles)
    # A swing (about x) adds no twist about y.
    swing = torch.tensor([[[math.sin(0.6), 0.0, 0.0, math.cos(0.6)]]], dtype=torch.float64)
    assert twist_angles(swing, axis).abs().item() < 1e-12
    alpha = math.radians(100.0)
    per = [twist_loss(q[None], axis, alpha).item() for q in quats]
    inside = [p for p, a in zip(per, angles.tolist(), strict=True) if abs(a) <= alpha]
    assert inside and all(p == 0.0 for p in inside)
    outside = sorted((abs(a), p) for p, a in zip(per, angles.tolist(), strict=True) if abs(a) > alpha)
    assert [p for _, p in outside] == sorted(p for _, p in outside) and outside[0][1] > 0
    assert outside[-1][1] == pytest.approx((3.0 - alpha) ** 2)


def test_copy_baseline_on_a_skeleton_twice_as_large_doubles_the_motion(tmp_path):
    """Analytic case: every offset ×2 → leg ratio 2, and every link of the baseline moves on twice the path."""
    h = human()
    big = scale_limbs(h, dict.fromkeys(("trunk", "legs", "arms", "head"), 2.0), name="big")
    assert big.leg_length == pytest.approx(2 * h.leg_length)
    clip = walk_motion(h, 40, seed=3)
    out = copy_rotations(clip, big)
    fk = SkeletonFK(h)
    with torch.no_grad():
        P_src = fk(torch.tensor(clip.q), torch.tensor(bone_offsets(h))).numpy()
        P_out = fk(torch.tensor(out.q), torch.tensor(bone_offsets(big))).numpy()
    start = np.array([*clip.q[0, :2], 0.0])
    np.testing.assert_allclose(P_out - start, 2 * (P_src - start), atol=1e-9)
    with pytest.raises(MotionFormatError, match="another topology"):
        from _ace_fixtures import write_quadruped

        from morphkit.io import read_morphology

        copy_rotations(clip, read_morphology(write_quadruped(tmp_path)))


def test_global_motion_integrates_back_to_the_root_path():
    clip = walk_motion(human(), 50, seed=5)
    root = clip.root_pose()
    from morphkit.rotations import yaw_from_quat

    yaw = yaw_from_quat(root[:, 3:])
    xy, yaw_back = integrate_global_motion(global_motion(root, clip.fps), clip.fps, start_xy=tuple(root[0, :2]),
                                           start_yaw=float(yaw[0]))
    np.testing.assert_allclose(xy, root[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.unwrap(yaw_back), np.unwrap(yaw), atol=1e-9)


def test_smoke_losses_decrease_and_the_run_retargets(trained, data_dir):
    cycle = _rows(trained, "cycle")
    assert cycle[-6:].mean() < 0.7 * cycle[:6].mean()
    assert len(_rows(trained, "loss_d")) > 0, "the discriminator never stepped"
    model = NknRetargeter(trained)
    clip = walk_motion(human(), 30, seed=9)
    for target in (None, *list(model.skeletons)[:2], scale_limbs(model.template, {"legs": 0.7})):
        out = [r.motion for r in model.retarget([clip, clip.slice(0, 20)], target)]
        assert [m.frame_count for m in out] == [30, 20]
        assert all(np.isfinite(m.q).all() for m in out)
        # Online (causal): a prefix, padded in the batch, is retargeted alike (up to float32 rounding).
        np.testing.assert_allclose(out[1].q, out[0].q[:20], atol=2e-3)


_SIGTERM_SETS = ["epochs=3", "steps_per_epoch=5"]


def test_sigterm_then_resume_equals_an_uninterrupted_run(tmp_path, data_dir, monkeypatch):
    cfg = replace_config(preset("smoke"), _SIGTERM_SETS)
    train_nkn(tmp_path / "full", cfg, human_data=data_dir, **QUIET)

    from morphkit.retarget.training_run import Run

    log = Run.log

    def log_then_term(self, **values):
        log(self, **values)
        if self.global_step == 7:  # inside the 8th step, mid-epoch 2
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(Run, "log", log_then_term)
    with pytest.raises(SystemExit) as stop:
        train_nkn(tmp_path / "cut", cfg, human_data=data_dir, **QUIET)
    assert stop.value.code == 128 + signal.SIGTERM
    position = torch.load(tmp_path / "cut" / "checkpoint.pt", weights_only=True)["position"]
    assert (position["epoch"], position["step"]) == (1, 3)
    monkeypatch.setattr(Run, "log", log)
    train_nkn(tmp_path / "cut", cfg, human_data=data_dir, **QUIET)
    a = torch.load(tmp_path / "full" / "checkpoint.pt", weights_only=True)
    b = torch.load(tmp_path / "cut" / "checkpoint.pt", weights_only=True)
    for part in ("generator", "discriminator", "optimizer_g"):
        flat_a, flat_b = _tensors(a["states"][part]), _tensors(b["states"][part])
        assert len(flat_a) == len(flat_b)
        for x, y in zip(flat_a, flat_b, strict=True):
            assert torch.equal(x, y), f"{part} differs after resume"
    assert a["extra"] == b["extra"]
    assert (tmp_path / "full" / "metrics.csv").read_text() == (tmp_path / "cut" / "metrics.csv").read_text()


def _tensors(state) -> list[torch.Tensor]:
    if isinstance(state, torch.Tensor):
        return [state]
    if isinstance(state, dict):
        return [t for k in sorted(state, key=str) for t in _tensors(state[k])]
    if isinstance(state, (list, tuple)):
        return [t for v in state for t in _tensors(v)]
    return []


def test_cross_morphology_mode_on_a_yaml_creature(tmp_path, data_dir, monkeypatch):
    from _ace_fixtures import write_quadruped

    from morphkit.io import read_morphology

    monkeypatch.setenv("MORPHKIT_CACHE_DIR", str(tmp_path / "cache"))
    dog = read_morphology(write_quadruped(tmp_path))
    cfg = replace_config(preset("smoke"), ["epochs=2", "steps_per_epoch=4", "data.character_frames=300"])
    run = train_nkn(tmp_path / "cross", cfg, human_data=data_dir, creature=dog, **QUIET)
    assert np.isfinite(_rows(run, "loss_g")).all() and len(_rows(run, "loss_d")) > 0
    model = NknRetargeter(run)
    clips = [walk_motion(human(), 25, seed=1), walk_motion(human(), 18, seed=2)]
    out = [r.motion for r in model.retarget(clips)]
    assert [m.morphology.name for m in out] == ["testdog", "testdog"]
    assert [m.frame_count for m in out] == [25, 18] and all(np.isfinite(m.q).all() for m in out)
    lo, hi = dog.coordinate_limits
    assert ((out[0].q[:, 7:] >= lo[7:] - 1e-6) & (out[0].q[:, 7:] <= hi[7:] + 1e-6)).all()  # tanh keeps limits
    with pytest.raises(RunError, match="skeletons"):
        train_nkn(tmp_path / "cross", cfg, human_data=data_dir, **QUIET)
    # morphkit retarget with the cross run: the creature's motion, readable back, in every format asked for
    from morphkit.cli import main
    from morphkit.motion import read_motion, write_motion

    write_motion(clips[0], tmp_path / "walk.npz")
    assert main(["retarget", "--run", str(run), "--motion", str(tmp_path / "walk.npz"), "--out",
                 str(tmp_path / "out"), "--formats", "npz,bvh", "--contacts", "none"]) == 0
    back = read_motion(next((tmp_path / "out").glob("*.npz")))
    assert back.morphology.name == "testdog" and back.frame_count == 25
    assert read_motion(next((tmp_path / "out").glob("*.bvh"))).frame_count == 25
    # a clip whose root races off at 300 m/s: NKN's global motion is bounded, the output finite
    fast = clips[0].q.copy()
    fast[:, 0] += np.arange(len(fast)) * 10.0
    wild = model.retarget([clips[0].replace(q=fast, name="wild")])[0].motion
    assert np.isfinite(wild.q).all()
    step = np.linalg.norm(np.diff(wild.root_pose()[:, :2], axis=0), axis=1) * 30.0
    side = model.generator.side
    bound = (side.x_mean[-4:-2].abs() + 6.0 * side.x_std[-4:-2]).norm().item()
    assert step.max() <= bound + 1e-6


def test_morphkit_retarget_onto_an_unseen_skeleton_with_an_nkn_run(trained, data_dir, tmp_path, capsys):
    """NKN over human skeletons from the CLI: the first unseen bone-length variant unless --target says."""
    from morphkit.cli import main
    from morphkit.motion import read_motion

    clip = sorted(data_dir.glob("*.npz"))[0]
    assert main(["retarget", "--run", str(trained), "--motion", str(clip), "--out", str(tmp_path / "a.bvh"),
                 "--contacts", "none"]) == 0
    assert read_motion(tmp_path / "a.bvh").frame_count == read_motion(clip).frame_count
    assert main(["retarget", "--run", str(trained), "--motion", str(clip), "--out", str(tmp_path / "b.npz"),
                 "--contacts", "none", "--target", "tall"]) == 0
    assert read_motion(tmp_path / "b.npz").morphology.name == "tall"
    capsys.readouterr()
    assert main(["retarget", "--run", str(trained), "--motion", str(clip), "--out", str(tmp_path / "c.npz"),
                 "--target", "giraffe"]) == 2
    assert "unknown target 'giraffe'" in capsys.readouterr().err


def test_bad_input_is_one_clear_error(tmp_path, trained, data_dir):
    from _ace_fixtures import write_quadruped

    from morphkit.io import read_morphology
    from morphkit.motion import Motion, write_motion

    dog = read_morphology(write_quadruped(tmp_path))
    model = NknRetargeter(trained)
    with pytest.raises(MotionFormatError, match=r"'testdog' is of another topology than"):
        model.retarget([walk_motion(human(), 10, seed=0)], dog)
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for f in sorted(data_dir.glob("*.npz"))[:2]:
        (mixed / f.name).write_bytes(f.read_bytes())
    write_motion(Motion(dog, 30.0, np.tile(dog.rest_q(), (70, 1)), "dog"), mixed / "zz_dog.npz")
    with pytest.raises(MotionFormatError, match="another topology"):
        train_nkn(tmp_path / "run", preset("smoke"), human_data=mixed, **QUIET)
    with pytest.raises(RunError, match="not an NKN run folder"):
        NknRetargeter(tmp_path)


def test_example_smoke_runs(tmp_path, data_dir):
    env = {**os.environ, "MORPHKIT_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "nkn_train.py"), "--smoke", "--no-video",
                           "--human-data", str(data_dir), "--out", str(tmp_path / "out")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "done in" in proc.stdout and "| NKN |" in proc.stdout and "copy rotations" in proc.stdout
    assert len(list((tmp_path / "out" / "plots").glob("*.png"))) == 2
    assert list((tmp_path / "out" / "clips").glob("*.bvh"))


@pytest.mark.skipif(not os.environ.get("MORPHKIT_DATA"), reason="MORPHKIT_DATA not set")
def test_second_skeleton_maps_onto_the_cmu_topology_exactly():
    """Bandai Namco clips re-expressed on CMU's 22 joints: every mapped link where the source's is, a T-pose rest."""
    from morphkit.model import compile_model
    from morphkit.motion import read_motion
    from morphkit.retarget.nkn.mapping import find_link_map, map_motion
    from morphkit.retarget.nkn.skeleton import topology_difference

    root = Path(os.environ["MORPHKIT_DATA"]) / "human"
    cmu = read_motion(root / "cmu" / "01_01.bvh").morphology
    src = read_motion(sorted((root / "second_skeleton").glob("*walk*.bvh"))[0]).slice(0, 60)
    link_map = find_link_map(src.morphology, cmu)
    assert link_map is not None and find_link_map(cmu, cmu) is None
    mapped = map_motion(src, cmu, link_map, skeleton_name="bandai")
    assert topology_difference(cmu, mapped.morphology) is None
    import morphkit.torch as mt

    with torch.no_grad():
        got = mt.link_positions(compile_model(mapped.morphology), torch.tensor(mapped.q)).numpy()
        poses = mt.fk(compile_model(src.morphology), torch.tensor(src.q)).numpy()
    for name, spec in link_map.links.items():
        if isinstance(spec, str):
            np.testing.assert_allclose(got[:, cmu.link_index(name)], poses[:, src.morphology.link_index(spec), :3],
                                       atol=1e-9)
    rest = mapped.morphology.rest_link_poses()[:, :3]
    assert rest[cmu.link_index("lankle"), 2] < -0.7 and rest[cmu.link_index("lwrist"), 1] > 0.4  # T-pose
    assert mapped.morphology.rest_stance_height == pytest.approx(0.87, abs=0.03)


def test_cli_train_nkn_rejects_ace_options(capsys):
    from morphkit.cli import main

    assert main(["train", "nkn", "--no-adversarial"]) == 2
    assert "unrecognized arguments: --no-adversarial" in capsys.readouterr().err
    assert main(["train", "ace", "--preset", "smoke"]) == 2
    assert "needs a CREATURE" in capsys.readouterr().err


def test_a_run_is_listed_and_opened_through_the_protocol_and_one_cut_short_says_so(trained, data_dir, tmp_path):
    """trained_retargeters finds the run finished without loading it; with_target retargets onto another skeleton and
    leaves the retargeter it came from as it was; a run short of its configured epochs is listed unfinished and
    load opens it with a warning naming how far it got."""
    import shutil

    import yaml

    from morphkit.motion import read_motion
    from morphkit.retarget import load
    from morphkit.retarget.run_loader import trained_retargeters

    (found,) = trained_retargeters(trained)
    assert (found.label, found.run, found.stage, found.creature) == ("NKN", trained, trained, None)
    assert found.progress == (4, 4, 0) and found.progress.finished
    model = load(trained)
    tall = model.with_target("tall")
    assert tall.target.name == "tall" and model.target is None
    clip = read_motion(sorted(data_dir.glob("*.npz"))[0])
    assert tall.retarget([clip])[0].motion.morphology.name == "tall"

    short = tmp_path / "short"
    shutil.copytree(trained, short, ignore=shutil.ignore_patterns(".lock"))
    config = yaml.safe_load((short / "config.yaml").read_text())
    (short / "config.yaml").write_text(yaml.safe_dump({**config, "epochs": 6}, sort_keys=False))
    assert not trained_retargeters(short)[0].progress.finished
    with pytest.warns(UserWarning, match="NKN has trained 4 of 6 epochs"):
        load(short)


def test_nkn_data_config_is_the_shared_one_and_its_old_config_files_read(tmp_path):
    """NknDataConfig extends the one DataConfig (NKN's creature data default stays 12k frames); a config.yaml of the
    layout written before (NKN's fields first, no human_mirror) reads back to the same config; mirrored clips are
    refused for NKN."""
    import yaml

    from morphkit.errors import ConfigError
    from morphkit.retarget.config import config_to_dict, read_config
    from morphkit.retarget.nkn import NknConfig, NknDataConfig
    from morphkit.retarget.training_data import DataConfig

    assert issubclass(NknDataConfig, DataConfig) and NknDataConfig().character_frames == 12_000
    cfg = preset("quick")
    written = config_to_dict(cfg)
    old_order = ("fps", "human_frames", "synth_seed", "synth_variants", "synth_variant_frames", "train_variants",
                 "variant_range", "variant_seed", "character_frames", "stand_probability", "arm_hang_share",
                 "full_arm_travel", "test_frames", "held_out")
    written["data"] = {k: written["data"][k] for k in old_order}
    (tmp_path / "config.yaml").write_text("# NknConfig\n" + yaml.safe_dump(written, sort_keys=False))
    assert read_config(NknConfig, tmp_path / "config.yaml") == cfg
    with pytest.raises(ConfigError, match="human_mirror"):
        replace_config(cfg, ["data.human_mirror=true"])
