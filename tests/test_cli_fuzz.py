"""Issue 64, part 6: fuzzing the CLI over description names and numeric flags. Whatever the input, the command
succeeds or exits 2 with one ``error:`` line, and writes nothing outside its output folder."""

from __future__ import annotations

import importlib
import math
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from morphkit.cli import COMMANDS, main

BLOB = {
    "name": "blob",
    "base": "floating",
    "root": "body",
    "links": {"body": {"shapes": [{"type": "sphere", "radius": 0.2}]},
              "fin": {"shapes": [{"type": "box", "size": [0.1, 0.02, 0.2], "origin": {"xyz": [0, 0, 0.1]}}]}},
    "joints": {"fin": {"type": "revolute", "parent": "body", "child": "fin", "axis": [0, 1, 0],
                       "origin": {"xyz": [0, 0, 0.2]}, "limit": {"lower": -0.5, "upper": 0.5}}},
}
"""A legless creature with one joint: synthesised in a tenth of a second."""

ROOT = "{root}"  # replaced by the example's own temporary folder: an absolute name aimed where a snapshot sees it

_NAME_CHARS = st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")
NAMES = st.one_of(
    st.text(_NAME_CHARS, max_size=30),
    st.lists(st.sampled_from(["..", ".", "", "x", "蟹", "Käfer", "\t", "\n", "\x1b[31m", "\u202e", " ", "a:b", "…"]),
             max_size=6).map("/".join),
    st.lists(st.sampled_from(["..", "x", "\\", "ESC"]), min_size=1, max_size=5).map("\\".join),
    st.sampled_from([ROOT + "/ABS", ROOT + "/../ABS", "/" + "x" * 300, "x" * 400, ".", "..", "../../escaped"]),
)


def _tree(root: Path, skip: Path) -> set[str]:
    """Every path under ``root`` except inside ``skip``."""
    return {str(p.relative_to(root)) for p in root.rglob("*") if skip not in (p, *p.parents)}


def _one_error_line(err: str) -> bool:
    lines = [ln for ln in err.splitlines() if not ln.startswith("warning: ")]
    return len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=NAMES)
def test_a_description_name_never_writes_outside_out(name, capsys):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        work = root / "a" / "b" / "work"
        work.mkdir(parents=True)
        name = name.replace(ROOT, str(root))
        text = yaml.safe_dump({**BLOB, "name": name}, allow_unicode=True)
        assume(yaml.safe_load(text)["name"] == name)
        (work / "c.yaml").write_text(text, encoding="utf-8")
        out = work / "out"
        before = _tree(root, out)
        code = main(["synth", str(work / "c.yaml"), "--frames", "2", "--rollout-seconds", "1", "--out", str(out),
                     "--no-progress"])
        err = capsys.readouterr().err
        assert _tree(root, out) == before, f"written outside --out for name {name!r}"
        assert code == 0 or (code == 2 and _one_error_line(err)), err
        if code == 0:
            written = [p for p in out.iterdir() if p.suffix == ".npz"]
            assert len(written) == 1 and written[0].parent == out


# (command line before the flag, flag, dest, int?, lowest, highest, lowest excluded?): the documented ranges
FLAGS = [
    (["synth", "crab"], "--seed", "seed", True, 0, 2**32 - 1, False),
    (["synth", "crab"], "--frames", "frames", True, 1, None, False),
    (["synth", "crab"], "--fps", "fps", False, 1.0, 1000.0, False),
    (["synth", "crab"], "--rollout-seconds", "rollout_seconds", False, 0.0, 600.0, True),
    (["render", "crab"], "--fps", "fps", False, 1.0, 1000.0, False),
    (["render", "crab"], "--elevation", "elevation", False, -90.0, 90.0, False),
    (["render", "crab"], "--azimuth", "azimuth", False, -360.0, 360.0, False),
    (["convert", "a.bvh", "b.npz"], "--fps", "fps", False, 1.0, 1000.0, False),
    (["convert", "a.bvh", "b.npz"], "--source-fps", "source_fps", False, 1.0, 10000.0, False),
    (["retarget", "--run", "r", "--motion", "m", "--out", "o"], "--fps", "fps", False, 1.0, 10000.0, False),
    (["evaluate", "r"], "--clips", "clips", True, 1, None, False),
    (["evaluate", "r"], "--videos", "videos", True, 0, 1000, False),
    (["evaluate", "r"], "--video-seconds", "video_seconds", False, 0.0, 600.0, True),
    (["generate", "--out", "g.yaml"], "--size", "size", False, 0.01, 100.0, False),
    (["generate", "--out", "g.yaml"], "--seed", "seed", True, 0, 2**32 - 1, False),
    (["map", "h", "c"], "--max-frames", "max_frames", True, 1, 1_000_000, False),
    (["map", "h", "c"], "--body-length", "creature_length", False, 0.0, 1000.0, True),
    (["map", "h", "c"], "--human-body-length", "human_length", False, 0.0, 1000.0, True),
    (["train", "ace", "crab"], "--contact-weight", "contact_weight", False, 0.0, 1000.0, False),
    (["train", "ace", "crab"], "--body-length", "body_length", False, 0.0, 1000.0, True),
    (["bench", "fk"], "--batches", "batches", True, 1, 2**20, False),
    (["bench", "fk"], "--loop-poses", "loop_poses", True, 1, 1_000_000, False),
    (["bench", "fk"], "--threads", "threads", True, 1, 1024, False),
]

VALUES = st.one_of(
    st.integers(-(2**40), 2**40).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["inf", "-inf", "nan", "1e9", "1e309", "-1", "0", "1e-9", "0.5", "1.5", "", " ", "abc", "0x10",
                     "4294967296", "1000.0000001", "600", "-90", "90.0"]),
)


def _allowed(text: str, is_int: bool, lo: float, hi: float | None, lo_open: bool) -> float | None:
    """The value ``text`` stands for when it lies in the range, else None."""
    try:
        value: float = int(text.strip()) if is_int else float(text)
    except ValueError:
        return None
    if not math.isfinite(value) or value < lo or (lo_open and value == lo) or (hi is not None and value > hi):
        return None
    return value


@pytest.fixture
def parsed(monkeypatch: pytest.MonkeyPatch) -> list:
    """Every command's ``run`` replaced by one that keeps its arguments: only parsing is tested."""
    seen: list = []
    for name in COMMANDS:
        monkeypatch.setattr(importlib.import_module(f"morphkit.commands.{name}"), "run",
                            lambda args: seen.append(args) or 0)
    return seen


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(flag=st.sampled_from(FLAGS), text=VALUES)
def test_a_numeric_flag_is_taken_in_range_and_refused_in_one_line_outside(flag, text, parsed, capsys):
    before, option, dest, is_int, lo, hi, lo_open = flag
    parsed.clear()
    code = main([*before, f"{option}={text}"])  # the = form: a value starting with '-' is the flag's too
    err = capsys.readouterr().err
    want = _allowed(text, is_int, lo, hi, lo_open)
    if want is None:
        assert code == 2 and _one_error_line(err), err
        line = err.strip()
        assert line.startswith(f"error: {option}") and str(lo if is_int else f"{lo:g}") in line
        if hi is not None:
            assert str(hi if is_int else f"{hi:g}") in line
        assert not parsed
    else:
        assert code == 0 and err == ""
        value = getattr(parsed[0], dest)
        assert (value == [want]) if option == "--batches" else (value == want)


@pytest.mark.parametrize("command", [
    ["synth", "crab", "--out"], ["train", "ace", "crab", "--out"], ["evaluate", "r", "--out"],
    ["generate", "--out"], ["render", "crab", "--out"], ["retarget", "--run", "r", "--motion", "m", "--out"],
])
@pytest.mark.parametrize("out", ["", "   "])
def test_an_empty_out_is_refused_in_one_line(command, out, parsed, capsys):
    assert main([*command, out]) == 2
    err = capsys.readouterr().err
    assert err == f"error: --out: expected an output path, got {out!r} (use . for the working folder)\n"
    assert not parsed
