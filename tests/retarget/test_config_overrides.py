"""``--set`` values are parsed without expanding YAML aliases: an alias bomb is refused before it is built."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from morphkit.cli import main
from morphkit.errors import ConfigError
from morphkit.retarget.config import parse_overrides


def _bomb(levels: int) -> str:
    """A "billion laughs" list: ``levels`` lines of nine aliases each, 9**levels strings once expanded."""
    names = "abcdefghijk"
    parts = ['&a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for k in range(1, levels):
        parts.append(f"&{names[k]} [" + ", ".join([f"*{names[k - 1]}"] * 9) + "]")
    return "[" + ", ".join(parts) + "]"


def test_an_alias_bomb_in_a_set_value_is_refused_at_once():
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"override retarget\.w_fea: YAML anchors and aliases"):
        parse_overrides([f"retarget.w_fea={_bomb(9)}"])
    assert time.perf_counter() - start < 2.0


@pytest.mark.parametrize("value", ["&x 3", "[*x]", "{a: &y 1, b: *y}"])
def test_any_anchor_or_alias_is_refused(value: str):
    with pytest.raises(ConfigError, match="anchors and aliases"):
        parse_overrides([f"seed={value}"])


def test_ampersands_and_stars_inside_plain_values_still_parse():
    assert parse_overrides(["name=a&b*c", 'tag="*x"', "hidden=[8, 8]", "lr=3e-4", "x="]) == {
        "name": "a&b*c", "tag": "*x", "hidden": [8, 8], "lr": "3e-4", "x": ""}


def test_the_cli_refuses_the_bomb_with_one_line_and_writes_nothing(tmp_path: Path, capsys):
    run = tmp_path / "run"
    code = main(["train", "ace", "spot", "--preset", "smoke", "--out", str(run), "--no-progress",
                 "--set", f"retarget.w_fea={_bomb(5)}"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: override retarget.w_fea: YAML anchors and aliases") and err.count("\n") == 1
    assert not run.exists()
