"""Trainer configs: YAML round trip, type checking with file and line, presets and overrides."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest

from morphkit.errors import ConfigError
from morphkit.retarget.config import (
    PRESET_NAMES,
    config_diff,
    parse_overrides,
    preset_config,
    read_config,
    replace_config,
    write_config,
)


@dataclass(frozen=True)
class PriorConfig:
    """A nested config."""

    experts: int = 8
    hidden: tuple[int, ...] = (512, 512)
    lr: float = 1e-4


@dataclass(frozen=True)
class TrainConfig:
    """A trainer config using every supported kind of field."""

    seed: int = 0
    window: int = 32
    name: str = "x"
    activation: Literal["elu", "leaky_relu"] = "elu"
    dropout: float | None = None
    data: Path | None = None
    shuffle: bool = True
    weights: dict[str, float] = field(default_factory=dict)
    pair: tuple[int, float] = (1, 2.0)
    prior: PriorConfig = PriorConfig()

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("name must be given")


PRESETS = {
    "smoke": TrainConfig(prior=PriorConfig(experts=2, hidden=(16,))),
    "quick": TrainConfig(prior=PriorConfig(experts=4, hidden=(64, 64))),
    "default": TrainConfig(),
    "paper": TrainConfig(name="paper"),
}


def test_write_read_round_trip(tmp_path: Path):
    """A config written as YAML reads back equal, tuples and paths included."""
    cfg = TrainConfig(dropout=0.3, data=Path("/d"), weights={"adv": 1.0}, prior=PriorConfig(hidden=(3, 4)))
    path = write_config(tmp_path / "config.yaml", cfg)
    assert read_config(TrainConfig, path) == cfg
    assert path.read_text().startswith("# TrainConfig\nseed: 0\n")


def test_read_accepts_ints_and_exponent_strings_for_floats(tmp_path: Path):
    """`lr: 1e-3` (a string to YAML 1.1) and `dropout: 0` read as floats."""
    path = tmp_path / "c.yaml"
    path.write_text("dropout: 0\nprior:\n  lr: 1e-3\n")
    cfg = read_config(TrainConfig, path)
    assert cfg.dropout == 0.0 and isinstance(cfg.dropout, float) and cfg.prior.lr == 1e-3


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("seed: 1\nshuffle: 3\n", 2, "'shuffle': expected bool"),
        ("seed: 1\nprior:\n  experts: many\n", 3, "'prior.experts': expected int"),
        ("seed: 1\nactivation: tanh\n", 2, "not one of: 'elu', 'leaky_relu'"),
        ("seed: 1\nsed: 2\n", 2, "unknown config field 'sed'"),
        ("pair: [1, 2, 3]\n", 1, "'pair'"),
        ("seed: -1\n", 1, "'seed': expected a finite number >= 0"),
        ("name: ''\n", 1, "name must be given"),
    ],
)
def test_read_names_file_line_and_field(tmp_path: Path, text: str, line: int | None, words: str):
    """A bad value, an unknown key or a failed check is a ConfigError naming the file, line and field."""
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=words) as info:
        read_config(TrainConfig, path)
    assert str(path) in str(info.value)
    if "must be" not in words:
        assert info.value.location is not None and info.value.location.line == line


def test_read_rejects_bad_yaml_and_missing_file(tmp_path: Path):
    """Broken YAML and a missing file are ConfigErrors naming the file."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("seed: [1\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        read_config(TrainConfig, bad)
    with pytest.raises(ConfigError, match="cannot read config"):
        read_config(TrainConfig, tmp_path / "none.yaml")


def test_presets_and_overrides():
    """A preset is picked by name, overrides (mapping or name=value strings, dotted) are type-checked."""
    assert set(PRESET_NAMES) <= set(PRESETS)
    cfg = preset_config(PRESETS, "smoke", ["prior.lr=3e-4", "seed=5", "prior.hidden=[8, 8]"])
    assert cfg.prior == PriorConfig(experts=2, hidden=(8, 8), lr=3e-4) and cfg.seed == 5
    assert preset_config(PRESETS, "paper") is PRESETS["paper"]
    assert replace_config(PRESETS["default"], {"name": "y"}).name == "y"
    with pytest.raises(ConfigError, match="unknown preset 'fast'; expected one of: smoke, quick, default, paper"):
        preset_config(PRESETS, "fast")
    with pytest.raises(ConfigError, match=r"unknown config field 'prior\.expert'"):
        preset_config(PRESETS, "smoke", {"prior.expert": 3})
    with pytest.raises(ConfigError, match="expected int"):
        preset_config(PRESETS, "smoke", ["seed=abc"])
    with pytest.raises(ConfigError, match="name=value"):
        parse_overrides(["seed"])


def test_config_diff_lists_dotted_fields():
    """config_diff names each differing field, nested ones dotted."""
    assert config_diff(PRESETS["default"], PRESETS["smoke"]) == {
        "prior.experts": (8, 2),
        "prior.hidden": ([512, 512], [16]),
    }


def test_a_deleted_option_reads_where_it_is_off_and_is_refused_where_it_was_on(tmp_path: Path):
    """A run written before an option was deleted (``retired``) reads where the option was off, naming it nowhere
    after; where it was on the run cannot be used, and the error names the field, its line and how to go on."""
    from morphkit.retarget.ace.config import AceConfig, PriorConfig, RetargetConfig
    from morphkit.retarget.training_data import DataConfig

    path = tmp_path / "config.yaml"
    old = write_config(path, AceConfig()).read_text()
    old = old.replace("  latent: 32\n", "  latent: 32\n  residual: false\n  contact_flags: false\n"
                                        "  contact_weight: 2.0\n")
    old = old.replace("  window: 32\n", "  window: 32\n  lr_final_fraction: 1.0\n  discriminator_feet: false\n")
    old = old.replace("  human_frames: 6000\n", "  human_frames: 6000\n  forward_speed: null\n")
    path.write_text(old)
    assert read_config(AceConfig, path) == AceConfig()
    for text, field_name in ((old.replace("residual: false", "residual: true"), "prior.residual"),
                             (old.replace("lr_final_fraction: 1.0", "lr_final_fraction: 0.1"),
                              "retarget.lr_final_fraction"),
                             (old.replace("forward_speed: null", "forward_speed: [-0.5, 5.0]"), "data.forward_speed")):
        path.write_text(text)
        with pytest.raises(ConfigError, match=f"'{field_name}' is .*deleted.*bringing-back") as info:
            read_config(AceConfig, path)
        line = next(i for i, s in enumerate(text.splitlines(), 1) if s.strip().startswith(field_name.split(".")[1]))
        assert info.value.location is not None and info.value.location.line == line
    # a deleted option cannot be set again, and the tables name only options that are gone
    with pytest.raises(ConfigError, match=r"unknown config field 'prior\.residual'"):
        replace_config(AceConfig(), ["prior.residual=false"])
    for cls in (PriorConfig, RetargetConfig, DataConfig):
        assert not set(cls.retired) & set(cls.__dataclass_fields__)


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("prior:\n  lr: .nan\n", 2, "finite"),
        ("prior:\n  lr: .inf\n", 2, "finite"),
        ("prior:\n  lr: -1e-4\n", 2, ">= 0"),
        ("seed: 3\nwindow: -5\n", 2, ">= 0"),
        ("prior:\n  experts: 0\n", 2, "1 to"),
        ("prior:\n  experts: 100000\n", 2, "1 to"),
        ("prior:\n  hidden: [512, 100000000]\n", 2, "network size"),
        ("prior:\n  hidden: [" + ", ".join(["8"] * 65) + "]\n", 2, "layers"),
    ],
)
def test_numbers_are_finite_and_in_range_on_load(tmp_path: Path, text: str, line: int, words: str):
    path = tmp_path / "config.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=words) as info:
        read_config(TrainConfig, path)
    assert info.value.location.path == str(path) and info.value.location.line == line
    with pytest.raises(ConfigError, match=words):  # an override from a command line too
        replace_config(TrainConfig(), [t.strip().replace(": ", "=", 1) for t in _leaf(text)])


def _leaf(text: str) -> list[str]:
    """``"prior:\\n  lr: .nan\\n"`` -> ``["prior.lr: .nan"]``: the YAML's leaf as a dotted override."""
    rows = text.splitlines()
    if rows[0].endswith(":"):
        return [f"{rows[0][:-1]}.{rows[1].strip()}"]
    return [rows[-1]]
