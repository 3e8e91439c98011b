"""The one YAML reader: every config and metadata file's malformed YAML is refused at its file and line."""

from __future__ import annotations

from pathlib import Path

import pytest

from morphkit.errors import ConfigError, RunError, SourceLocation
from morphkit.retarget.ace.config import AceConfig
from morphkit.retarget.config import read_config, write_config


def test_a_malformed_config_is_refused_at_its_file_and_line(tmp_path: Path):
    path = tmp_path / "config.yaml"
    path.write_text("seed: 1\nprior:\n  lr: 0.001\n  epochs: [3\nretarget: {}\n")
    with pytest.raises(ConfigError, match="not valid YAML") as err:
        read_config(AceConfig, path)
    assert err.value.location == SourceLocation(str(path), 5)


def test_a_config_key_written_twice_is_refused_at_the_second(tmp_path: Path):
    path = tmp_path / "config.yaml"
    write_config(path, AceConfig())
    path.write_text(path.read_text() + "seed: 7\n")
    lines = path.read_text().splitlines()
    with pytest.raises(ConfigError, match=r"duplicate key 'seed' \(first written on line 2\)") as err:
        read_config(AceConfig, path)
    assert err.value.location == SourceLocation(str(path), len(lines))


def test_run_metadata_names_the_line_of_its_malformed_yaml(tmp_path: Path):
    from morphkit.retarget.training_run import stage_trainer

    (tmp_path / "run.yaml").write_text("trainer: ace\ncreature: [dog\n")
    with pytest.raises(RunError, match="cannot read the run identity: malformed YAML") as err:
        stage_trainer(tmp_path)
    assert err.value.location == SourceLocation(str(tmp_path / "run.yaml"), 3)


def test_lines_are_kept_and_plain_data_drops_them(tmp_path: Path):
    from morphkit.yaml_loader import YamlMapping, load_yaml_file, plain_data

    path = tmp_path / "table.yaml"
    path.write_text("# a table\nlinks:\n  hip: [a, b, 0.5]\nscale: 1e-2\n")
    data = load_yaml_file(path, what="table")
    assert isinstance(data, YamlMapping) and data.key_lines == {"links": 2, "scale": 4}
    assert data["links"].key_lines == {"hip": 3} and data["scale"] == 0.01  # YAML 1.2's float
    plain = plain_data(data)
    assert type(plain) is dict and type(plain["links"]["hip"]) is list and plain == data
    with pytest.raises(ConfigError, match="cannot read table: ") as err:
        load_yaml_file(tmp_path / "missing.yaml", what="table")
    assert err.value.location == SourceLocation(str(tmp_path / "missing.yaml"))
