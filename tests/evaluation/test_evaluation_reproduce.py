"""Reproducing Table 1: a finished stage is never run again (spied stage functions), the prior is trained
once for every seed and method, `examples/reproduce_table1.py --smoke` runs end to end on a YAML-only
quadruped (videos: test_evaluation_report.py), `morphkit evaluate` scores its runs to the same table, and
bad input gets one clear error."""

from __future__ import annotations

import json
import os
import runpy
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml
from morphkit_testing import spot_like
from retarget._ace_fixtures import write_quadruped

import morphkit.evaluation.reproduce as reproduce
from morphkit.cli import main as cli
from morphkit.errors import ConfigError, RunError
from morphkit.evaluation import ReproduceConfig, reproduce_table1
from morphkit.evaluation.reproduce import DONE_FILE, Stage, run_stages

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "reproduce_table1.py"
METHODS = ("ACE", "ACE+replan", "ACE+lock", "NKN", "NKN+replan", "NKN+lock", "ACEwoFea", "ACEwoAdv", "ACE+contact")


def test_a_finished_stage_is_not_run_again_and_a_failed_one_is(tmp_path):
    calls: list[str] = []

    def fail() -> None:
        calls.append("b")
        raise RuntimeError("killed")

    stages = [Stage("a", tmp_path / "a", lambda: calls.append("a")), Stage("b", tmp_path / "b", fail)]
    with pytest.raises(RuntimeError):
        run_stages(stages, log=lambda s: None)
    assert calls == ["a", "b"] and (tmp_path / "a" / DONE_FILE).is_file() and not (tmp_path / "b" / DONE_FILE).exists()
    stages[1] = Stage("b", tmp_path / "b", lambda: calls.append("b again"))
    assert run_stages(stages, log=lambda s: None) == ["b"]
    assert run_stages(stages, log=lambda s: None) == []
    assert calls == ["a", "b", "b again"]
    # A marker written for other inputs (its key) does not count; a downstream stage follows any that ran.
    changed = Stage("a", tmp_path / "a", lambda: calls.append("a2"), {"clips": 3})
    report = Stage("report", tmp_path / "r", lambda: calls.append("report"), downstream=True)
    assert run_stages([changed, report], log=lambda s: None) == ["a", "report"]
    assert run_stages([changed, report], log=lambda s: None) == []
    assert run_stages([Stage("b", tmp_path / "b", lambda: None, {"preset": "quick"}), report],
                      log=lambda s: None) == ["b", "report"]


def _meet(me: Path, other: Path) -> None:
    """Say ``me`` started (our pid in the file), then wait for ``other`` to start: only lanes that run at once meet."""
    me.write_text(str(os.getpid()))
    deadline = time.monotonic() + 60
    while not other.exists():
        if time.monotonic() > deadline:
            raise RuntimeError(f"{other.name} never started beside {me.name}")
        time.sleep(0.05)


def test_lanes_run_at_once_in_their_own_processes_and_a_failing_lane_is_reported(tmp_path):
    def write(name: str) -> Callable[[], None]:
        return lambda: (tmp_path / name).write_text(str(os.getpid()))

    stages = [Stage("data", tmp_path / "s/data", write("data")),
              Stage("a1", tmp_path / "s/a1", lambda: _meet(tmp_path / "a1", tmp_path / "b1"), lane="A"),
              Stage("a2", tmp_path / "s/a2", write("a2"), lane="A"),
              Stage("b1", tmp_path / "s/b1", lambda: _meet(tmp_path / "b1", tmp_path / "a1"), lane="B"),
              Stage("report", tmp_path / "s/report", write("report"), downstream=True)]
    ran = run_stages(stages, jobs=2, log=lambda s: None)
    assert sorted(ran) == ["a1", "a2", "b1", "data", "report"] and ran[0] == "data" and ran[-1] == "report"
    pid = {name: int((tmp_path / name).read_text()) for name in ("data", "a1", "a2", "b1", "report")}
    assert pid["data"] == pid["report"] == os.getpid()  # the stages around the lanes run here
    assert pid["a1"] == pid["a2"] != pid["b1"] and os.getpid() not in (pid["a1"], pid["b1"])
    assert all((tmp_path / "s" / n / DONE_FILE).is_file() for n in pid)  # markers written by the lane processes
    assert run_stages(stages, jobs=2, log=lambda s: None) == []

    # One lane's bad input ends the other at once (SIGTERM) and comes back here as one clear error; nothing of
    # either is marked done, so a re-run redoes both.
    def slow() -> None:
        (tmp_path / "slow").write_text("started")
        time.sleep(120)

    def bad() -> None:
        while not (tmp_path / "slow").exists():
            time.sleep(0.05)
        raise ConfigError("no such field: retarget.w_nothing")

    started = time.monotonic()
    with pytest.raises(RunError, match=r"no such field: retarget\.w_nothing"):
        run_stages([Stage("slow", tmp_path / "t/slow", slow, lane="A"), Stage("bad", tmp_path / "t/bad", bad,
                                                                                lane="B")], jobs=2, log=lambda s: None)
    assert time.monotonic() - started < 60  # the slow lane was stopped, not waited for
    assert not list((tmp_path / "t").rglob(DONE_FILE))
    # One job: the same stages in turn, here.
    assert run_stages(stages[:3], jobs=1, log=lambda s: None) == []
    (tmp_path / "s/a2" / DONE_FILE).unlink()
    assert run_stages(stages[:3], jobs=1, log=lambda s: None) == ["a2"]
    assert int((tmp_path / "a2").read_text()) == os.getpid()


_LANES_SCRIPT = """
import sys, time
from dataclasses import dataclass
from pathlib import Path
from morphkit.evaluation.reproduce import Stage, run_stages
from morphkit.retarget import Run

@dataclass(frozen=True)
class Slow:
    steps: int = 12

def train(folder):
    with Run(folder, trainer="slow", config=Slow(), progress=False, tensorboard=False) as run:
        for _ in run.epochs(1):
            for _ in run.steps(Slow.steps):
                (Path(folder) / "started").touch()
                # b's steps are long: a stops and reports first, and b must still be let finish its step
                time.sleep(0.2 if Path(folder).name == "a" else 1.0)
                run.log(x=1.0)

root = Path(sys.argv[1])
stages = [Stage(n, root / n, lambda n=n: train(root / n), lane=n) for n in ("a", "b")]
try:
    print("ran", run_stages(stages, jobs=2))
except KeyboardInterrupt:
    sys.exit(130)
"""


def test_ctrl_c_stops_both_lanes_with_a_checkpoint_and_a_rerun_finishes_them(tmp_path):
    script = tmp_path / "lanes.py"
    script.write_text(_LANES_SCRIPT)
    cmd = [sys.executable, str(script), str(tmp_path / "runs")]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    with subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        deadline = time.monotonic() + 120
        while not all((tmp_path / "runs" / n / "started").exists() for n in "ab"):
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()[1][-3000:]
            time.sleep(0.1)
        proc.send_signal(signal.SIGINT)  # what Ctrl-C sends the foreground process (the lanes have their own group)
        err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 130, err[-3000:]
    for n in "ab":  # each lane checkpointed where it stopped, before the end
        position = torch.load(tmp_path / "runs" / n / "checkpoint.pt", weights_only=True)["position"]
        assert 0 < position["global_step"] < 12, (n, position)
        assert not (tmp_path / "runs" / n / DONE_FILE).exists()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "ran ['a', 'b']" in done.stdout or "ran ['b', 'a']" in done.stdout
    for n in "ab":  # resumed, not restarted: one metrics row per step over both launches
        assert len((tmp_path / "runs" / n / "metrics.csv").read_text().splitlines()) == 1 + 12


def test_pipeline_trains_the_prior_once_and_a_rerun_trains_nothing(tmp_path, monkeypatch):
    calls: list[tuple] = []

    def rel(p: os.PathLike | None) -> str | None:
        return None if p is None else Path(p).relative_to(tmp_path / "out").as_posix()

    def evaluate(runs, out, **kw):
        calls.append(("evaluate", [rel(r) for r in runs]))
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "table.md").write_text("| method |\n")

    monkeypatch.setattr(reproduce, "character_motions", lambda *a, **k: calls.append(("data",)) or [])
    monkeypatch.setattr(reproduce, "prepare", lambda run, *a, **k: calls.append(("prepare", rel(run))))
    monkeypatch.setattr(reproduce, "train_prior", lambda prior, *a, **k: calls.append(("prior", rel(prior))))
    monkeypatch.setattr(reproduce, "train_ace", lambda run, creature, cfg, *, variant, prior_dir, **k: calls.append(
        ("ace", rel(run), variant, cfg.seed, cfg.retarget.w_contact, rel(prior_dir))))
    monkeypatch.setattr(reproduce, "train_nkn", lambda run, cfg, **k: calls.append(
        ("nkn", rel(run), cfg.seed, cfg.data.character_frames, cfg.data.human_frames)))
    monkeypatch.setattr(reproduce, "evaluate_runs", evaluate)
    cfg = ReproduceConfig(preset="smoke", seeds=2, contact_weight=0.5, progress=False, jobs=1)
    quiet = {"log": lambda s: None}

    reproduce_table1(spot_like(), tmp_path / "out", cfg, **quiet)
    ace_frames, human_frames = 1_200, 600  # the ACE smoke preset's data, which NKN is given too
    expected = [("data",), ("prepare", "runs/ace_seed0"), ("prior", "runs/ace_seed0/prior")]
    for seed in (0, 1):
        prior = None if seed == 0 else "runs/ace_seed0/prior"
        expected += [("ace", f"runs/ace_seed{seed}", v, seed, 0.5 if v == "ace-contact" else 0.0, prior)
                     for v in ("ace", "ace-wofea", "ace-woadv", "ace-contact")]
        expected.append(("nkn", f"runs/nkn_seed{seed}", seed, ace_frames, human_frames))
    expected.append(("evaluate", ["runs/ace_seed0", "runs/nkn_seed0", "runs/ace_seed1", "runs/nkn_seed1"]))
    assert calls == expected
    markers = sorted((tmp_path / "out").rglob(DONE_FILE))
    assert len(markers) == 2 + 2 * 5 + 1
    stamps = [m.stat().st_mtime_ns for m in markers]

    calls.clear()
    reproduce_table1(spot_like(), tmp_path / "out", cfg, **quiet)
    assert calls == []
    assert [m.stat().st_mtime_ns for m in markers] == stamps

    # Another preset into the same folder is not taken for done (its runs then refuse the other config).
    other = ReproduceConfig(preset="quick", seeds=2, progress=False, jobs=1)
    reproduce_table1(spot_like(), tmp_path / "out", other, **quiet)
    assert len(calls) == len(expected) and calls[0] == ("data",)
    for marker in markers:  # back to the smoke configuration
        marker.unlink()
    reproduce_table1(spot_like(), tmp_path / "out", cfg, **quiet)
    calls.clear()

    # One more seed: its stages and the evaluation run, nothing else.
    reproduce_table1(spot_like(), tmp_path / "out", ReproduceConfig(preset="smoke", seeds=3, contact_weight=0.5,
                                                                    progress=False, jobs=1), **quiet)
    assert [c[:2] for c in calls] == [("ace", "runs/ace_seed2")] * 4 + [("nkn", "runs/nkn_seed2"), ("evaluate", [
        "runs/ace_seed0", "runs/nkn_seed0", "runs/ace_seed1", "runs/nkn_seed1", "runs/ace_seed2", "runs/nkn_seed2"])]
    assert all(c[5] == "runs/ace_seed0/prior" for c in calls[:4])

    # A change of the retargeters' config retrains them, not the prior, the data or NKN.
    calls.clear()
    reproduce_table1(spot_like(), tmp_path / "out", ReproduceConfig(
        preset="smoke", seeds=3, contact_weight=0.5, ace_overrides=("retarget.w_adv=2",), progress=False, jobs=1),
        **quiet)
    assert [c[0] for c in calls] == ["ace"] * 12 + ["evaluate"]


def test_table_nkn_trains_the_budgeted_steps_unless_overridden(tmp_path):
    """At ``default`` Table 1's NKN trains NKN_BUDGET's epochs (not the NKN preset's); --nkn-set wins."""
    from morphkit.evaluation.reproduce import NKN_BUDGET, plan_stages
    from morphkit.retarget.nkn import preset as nkn_preset

    def nkn_epochs(cfg: ReproduceConfig) -> int:
        stage = next(s for s in plan_stages(spot_like(), tmp_path, cfg, log=lambda s: None) if s.name.startswith("NKN"))
        return stage.key["config"]["epochs"]

    assert NKN_BUDGET["default"]["epochs"] < nkn_preset("default").epochs
    assert nkn_epochs(ReproduceConfig()) == NKN_BUDGET["default"]["epochs"]
    assert nkn_epochs(ReproduceConfig(nkn_overrides=("epochs=20",))) == 20
    assert nkn_epochs(ReproduceConfig(preset="quick")) == nkn_preset("quick").epochs


# ---- end to end on a YAML-only quadruped ------------------------------------------------------------


@pytest.fixture(scope="module")
def smoke(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str], str]:
    """``examples/reproduce_table1.py --smoke`` run once: (its --out folder, its environment, its stdout)."""
    root = tmp_path_factory.mktemp("table1")
    dog = write_quadruped(root)
    # The ACE tests' cache: the same synthesised toy data and embedded human motion.
    env = {**os.environ, "MORPHKIT_CACHE_DIR": str(tmp_path_factory.getbasetemp() / "ace_cache"),
           "PYOPENGL_PLATFORM": os.environ.get("PYOPENGL_PLATFORM", "egl"), "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, str(EXAMPLE), "--character", str(dog), "--smoke", "--videos", "0", "--out",
           str(root / "out")]
    proc = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return root / "out", env, proc.stdout


def _table(path: Path) -> dict[str, list[str]]:
    """Table 1 of a ``table.md`` (the first table; the figures beyond the paper's follow a blank line)."""
    lines = path.read_text().split("\n\n")[0].splitlines()[2:]
    return {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]] for line in lines}


def test_smoke_trains_every_method_and_writes_the_report(smoke):
    out, _, stdout = smoke
    folder = out / "testdog"
    assert "done in" in stdout and "testdog:" in stdout
    # --jobs 2 (the default): NKN trained in its own process beside the ACE lane; both lanes' lines reach stdout.
    assert "training 2 lanes at once (ACE, NKN)" in stdout
    assert "NKN seed 0: done in" in stdout and "ACE+contact seed 0: done in" in stdout
    assert "| claim | met | measured |" in stdout  # the paper's claims, checked, after the table
    table = _table(folder / "report" / "table.md")
    assert list(table) == ["Dataset", *METHODS]
    assert all(cells[-1] == table["ACE"][-1] for name, cells in table.items() if name != "Dataset")
    for f in ("index.html", "table.csv", "runs.csv", "evaluation.json", "charts/div.png", "charts/ufr.png"):
        assert (folder / "report" / f).is_file(), f
    assert "No videos in this report" in (folder / "report" / "index.html").read_text()  # --videos 0
    runs = folder / "runs"
    for stage in ("data", "ace_seed0/prior", "ace_seed0/retarget", "ace_seed0/retarget_wofea",
                  "ace_seed0/retarget_woadv", "ace_seed0/retarget_contact", "nkn_seed0"):
        assert json.loads((runs / stage / DONE_FILE).read_text())["seconds"] >= 0, stage


def test_a_rerun_skips_every_stage_and_prints_the_same_table(smoke, monkeypatch, capsys):
    out, env, _ = smoke
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", env["MORPHKIT_CACHE_DIR"])
    files = [p for p in (out / "testdog").rglob("*") if p.is_file()]
    stamps = {p: p.stat().st_mtime_ns for p in files}
    main = runpy.run_path(str(EXAMPLE), run_name="reproduce_table1")["main"]
    assert main(["--character", str(out.parent / "testdog.yaml"), "--smoke", "--videos", "0", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("done, skipped") == 8 and "running" not in printed
    assert {p: p.stat().st_mtime_ns for p in files} == stamps
    assert (out / "testdog" / "report" / "table.md").read_text().strip() in printed


def test_morphkit_evaluate_scores_the_runs_to_the_same_table(smoke, tmp_path, monkeypatch, capsys):
    out, env, _ = smoke
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", env["MORPHKIT_CACHE_DIR"])
    runs = out / "testdog" / "runs"
    assert cli(["evaluate", "--runs", str(runs / "ace_seed0"), str(runs / "nkn_seed0"), "--clips", "2",
                "--videos", "0", "--out", str(tmp_path / "eval")]) == 0
    assert (tmp_path / "eval" / "table.md").read_text() == (out / "testdog" / "report" / "table.md").read_text()
    # One ACE stage given directly: that method alone.
    assert cli(["evaluate", "--runs", str(runs / "ace_seed0" / "retarget_wofea"), "--videos", "0", "--clips", "1",
                "--out", str(tmp_path / "one")]) == 0
    assert list(_table(tmp_path / "one" / "table.md")) == ["Dataset", "ACEwoFea"]
    # NKN alone: the end-effector pairing computed as ACE's prepare does gives the same pairing and the same row.
    assert cli(["evaluate", "--runs", str(runs / "nkn_seed0"), "--clips", "2", "--videos", "0",
                "--out", str(tmp_path / "nkn")]) == 0
    full, alone = (json.loads((p / "evaluation.json").read_text()) for p in (out / "testdog" / "report",
                                                                                tmp_path / "nkn"))
    assert alone["reference"] != full["reference"] and alone["mapping"] == full["mapping"]
    assert _table(tmp_path / "nkn" / "table.md")["NKN"] == _table(out / "testdog" / "report" / "table.md")["NKN"]
    capsys.readouterr()


def test_evaluate_refuses_bad_input_with_one_clear_error(smoke, tmp_path, monkeypatch, capsys):
    out, env, _ = smoke
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", env["MORPHKIT_CACHE_DIR"])
    runs = out / "testdog" / "runs"
    empty = tmp_path / "empty"
    empty.mkdir()
    other = tmp_path / "crab_run"
    shutil.copytree(runs / "ace_seed0", other)
    meta = yaml.safe_load((other / "ace.yaml").read_text())
    (other / "ace.yaml").write_text(yaml.safe_dump({**meta, "creature": "crab"}))
    from morphkit.motion import Motion, write_motion
    from morphkit.retarget.ace.retarget import AceRetargeter

    dog = AceRetargeter(runs / "ace_seed0").creature
    clips = tmp_path / "dog_clips"
    clips.mkdir()
    write_motion(Motion(dog, 30.0, np.tile(dog.rest_q(), (40, 1)), "dog"), clips / "dog.npz")
    cases = [
        (["--runs", str(tmp_path / "missing")], "no such run folder"),
        (["--runs", str(empty)], "not an ACE or NKN run folder"),
        (["--runs", str(runs / "ace_seed0"), str(other)], "run of creature 'crab'"),
        (["--runs", str(runs / "ace_seed0"), "--human-data", str(clips), "--videos", "0"], "no two arms"),
        (["--runs", str(runs / "ace_seed0"), "--clips", "0"], "--clips: expected an integer >= 1"),
    ]
    for args, message in cases:
        assert cli(["evaluate", *args, "--out", str(tmp_path / "report")]) == 2, args
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and "Traceback" not in err, (args, err)
    example = runpy.run_path(str(ROOT / "examples" / "ace_eval.py"), run_name="ace_eval")["main"]
    assert example(["--runs", str(tmp_path / "missing")]) == 2
    assert "no such run folder" in capsys.readouterr().err


def test_an_evaluation_survives_one_failing_method(smoke, tmp_path, monkeypatch):
    """A method whose retargeting fails is listed as failed; the other rows and the report are written, and
    the call still ends in an error (exit code 2 from the CLI)."""
    import morphkit.evaluation.evaluate as evaluate

    out, env, _ = smoke
    monkeypatch.setenv("MORPHKIT_CACHE_DIR", env["MORPHKIT_CACHE_DIR"])
    runs = out / "testdog" / "runs"
    real = evaluate.retarget_clips

    def failing(method, clips, **kw):
        if method.name == "NKN":
            raise RunError(f"clip {clips[0].name!r}: non-finite output at frame 3 of 10 (root_x)")
        return real(method, clips, **kw)

    monkeypatch.setattr(evaluate, "retarget_clips", failing)
    with pytest.raises(RunError, match="1 method\\(s\\) failed: NKN \\(seed 0\\)"):
        reproduce.evaluate_runs([runs / "ace_seed0", runs / "nkn_seed0"], tmp_path / "eval", clips=1, videos=0,
                                log=lambda s: None)
    assert "NKN" not in _table(tmp_path / "eval" / "table.md") and "ACE" in _table(tmp_path / "eval" / "table.md")
    assert "FAILED NKN (seed 0)" in (tmp_path / "eval" / "table.md").read_text()
    assert "non-finite output at frame 3" in json.loads((tmp_path / "eval" / "evaluation.json").read_text())[
        "failed"]["NKN (seed 0)"]


def test_table_nkn_sees_the_creature_data_ace_sees(tmp_path):
    """Every option that shapes the creature's synthesised data reaches NKN's config from ACE's, and NKN builds the
    same data config from it; a new DataConfig field must be declared a synthesis option or not."""
    import dataclasses

    from morphkit.evaluation.reproduce import plan_stages
    from morphkit.retarget.config import config_from_dict
    from morphkit.retarget.nkn import NknConfig
    from morphkit.retarget.nkn.config import NknDataConfig
    from morphkit.retarget.training_data import SYNTHESIS_OPTIONS, DataConfig, synthesis_options

    not_synthesis = {"character_frames", "fps", "synth_seed", "human_frames", "human_mirror", "human_split"}
    fields = {f.name for f in dataclasses.fields(DataConfig)}
    assert fields == not_synthesis | set(SYNTHESIS_OPTIONS)
    assert set(SYNTHESIS_OPTIONS) <= {f.name for f in dataclasses.fields(NknDataConfig)}

    chosen = {"stand_probability": 0.2, "yaw_rate": 1.5, "arm_hang_share": 0.4, "full_arm_travel": False}
    assert set(chosen) == set(SYNTHESIS_OPTIONS)
    for name, value in chosen.items():  # none is its default, so a field left uncopied would show
        assert getattr(DataConfig(), name) != value
    overrides = tuple(f"data.{k}={list(v) if isinstance(v, tuple) else v}" for k, v in chosen.items())
    cfg = ReproduceConfig(preset="smoke", ace_overrides=overrides)
    stage = next(s for s in plan_stages(spot_like(), tmp_path, cfg, log=lambda s: None) if s.name.startswith("NKN"))
    nkn = config_from_dict(NknConfig, stage.key["config"])
    assert synthesis_options(nkn.data) == chosen
