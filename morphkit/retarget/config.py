"""Trainer configurations: frozen dataclasses, written as YAML, read back with type checking, presets.

A trainer's configuration is one frozen dataclass whose fields are documented (attribute
docstrings citing the paper section). :func:`write_config` dumps it as YAML (``config.yaml`` in
a run folder); :func:`read_config` reads such a file back into the dataclass, checking every
value against the field's annotation and naming the file and line of a bad one. Presets are data:
a mapping ``name -> config`` holding at least :data:`PRESET_NAMES`; :func:`preset_config` picks one
and applies overrides (``{"lr": 1e-4}`` or ``"prior.lr=1e-4"`` strings from a command line).

Every number must be finite and ≥ 0, and network sizes (layer widths, layer and expert counts) within
:data:`MAX_WIDTH` and :data:`MAX_COUNT`: a bad one is refused on load, naming the file and line.

Supported field types: ``bool``, ``int``, ``float`` (ints and strings such as ``1e-4`` accepted),
``str``, ``Path``, ``Literal[...]``, ``X | None``, ``tuple[X, ...]``, ``tuple[X, Y]``,
``list[X]``, ``dict[str, X]`` and nested frozen dataclasses.
"""

from __future__ import annotations

import dataclasses
import math
import os
import types
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

from morphkit._atomic import atomic_write_text
from morphkit.errors import ConfigError, SourceLocation
from morphkit.yaml_loader import YamlMapping, load_yaml_file

__all__ = [
    "MAX_COUNT",
    "MAX_WIDTH",
    "PRESET_NAMES",
    "config_diff",
    "config_from_dict",
    "config_to_dict",
    "parse_overrides",
    "preset_config",
    "read_config",
    "replace_config",
    "write_config",
]

C = TypeVar("C")

MAX_WIDTH = 8192
"""Largest layer width (``*hidden``, ``*channels``, ``latent``, ``hidden``) a config may ask for: 16× the paper's
512, and one 8192² layer is 256 MiB of float32 weights; ``hidden: 1e8`` would ask for tens of gigabytes."""
MAX_COUNT = 64
"""Largest count of layers or experts a config may ask for."""
_WIDTH_FIELDS = ("hidden", "channels", "latent")
_COUNT_FIELDS = ("layers", "experts")

PRESET_NAMES = ("smoke", "quick", "default", "paper")
"""Preset names every trainer provides: ``smoke`` (tests, ≤ 60 s on 2 CPU cores), ``quick`` (the main
job, ≤ 5 min), ``default`` (quality runs), ``paper`` (the paper's sizes)."""


def config_to_dict(config: Any) -> dict[str, Any]:
    """A config dataclass as plain YAML-ready data (tuples become lists, paths strings)."""
    if not (dataclasses.is_dataclass(config) and not isinstance(config, type)):
        raise TypeError(f"expected a dataclass instance, got {type(config).__name__}")
    return {f.name: _plain(getattr(config, f.name)) for f in dataclasses.fields(config)}


def _plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return config_to_dict(value)
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


def config_from_dict(cls: type[C], data: Any, *, source: str | None = None) -> C:
    """Build config dataclass ``cls`` from plain data, checking each value against its annotation.

    Missing fields take their defaults; unknown keys, missing required fields and values of the
    wrong type raise :class:`~morphkit.errors.ConfigError` naming the field (and the file and line
    when ``source`` names the YAML file the data came from).
    """
    return _build(cls, data, "", _LineMap(None), source)


def write_config(path: str | os.PathLike[str], config: Any) -> Path:
    """Write ``config`` as YAML at ``path`` (atomically); returns the path."""
    text = f"# {type(config).__name__}\n" + yaml.safe_dump(config_to_dict(config), sort_keys=False)
    atomic_write_text(path, text)
    return Path(path)


def read_config(cls: type[C], path: str | os.PathLike[str]) -> C:
    """Read a YAML file written by :func:`write_config` (or by hand) into config dataclass ``cls``.

    Raises:
        ConfigError: an unreadable file, malformed YAML (a duplicate key included) or a bad value, at its line.
    """
    source = os.fspath(path)
    data = load_yaml_file(path, what="config", malformed="not valid YAML")
    return _build(cls, {} if data is None else data, "", _LineMap(data), source)


def replace_config(config: C, overrides: Mapping[str, Any] | Iterable[str]) -> C:
    """``config`` with fields replaced, type-checked; dotted keys reach nested configs (``"prior.lr"``).

    ``overrides`` is a mapping of field name to value, or ``"name=value"`` strings whose values
    are parsed as YAML (so ``"lr=1e-4"``, ``"hidden=[256, 256]"``, ``"seed=3"`` work).
    """
    items = parse_overrides(overrides) if not isinstance(overrides, Mapping) else dict(overrides)
    data = config_to_dict(config)
    for key, value in items.items():
        node = data
        *parents, leaf = key.split(".")
        for part in parents:
            if not isinstance(node.get(part), dict):
                raise ConfigError(f"unknown config field {key!r} ({part!r} is not a nested config)")
            node = node[part]
        if leaf not in node:
            raise ConfigError(f"unknown config field {key!r}; expected one of: {', '.join(node)}")
        node[leaf] = _plain(value)
    return config_from_dict(type(config), data)


def parse_overrides(items: Iterable[str]) -> dict[str, Any]:
    """``["lr=1e-4", "prior.experts=4"]`` → ``{"lr": 1e-4, "prior.experts": 4}`` (values parsed as YAML)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"override {item!r} is not of the form name=value")
        try:
            _refuse_aliases(text, key.strip())
            out[key.strip()] = yaml.safe_load(text) if text.strip() else ""
        except yaml.YAMLError as exc:
            raise ConfigError(f"override {item!r}: value is not valid YAML") from exc
    return out


def _refuse_aliases(text: str, key: str) -> None:
    """Refuse anchors and aliases in a command-line value before it is built: nine lines of ``*a`` aliases
    (a "billion laughs") expand to 10⁹ items when the value is copied; no config field needs them."""
    for event in yaml.parse(text, Loader=yaml.SafeLoader):  # events only: nothing is expanded
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            raise ConfigError(f"override {key}: YAML anchors and aliases (&name, *name) are not allowed in a "
                              "--set value; write the value out")


def preset_config(presets: Mapping[str, C], name: str, overrides: Mapping[str, Any] | Iterable[str] | None = None) -> C:
    """The preset called ``name`` from ``presets``, with ``overrides`` applied (see :func:`replace_config`)."""
    if name not in presets:
        raise ConfigError(f"unknown preset {name!r}; expected one of: {', '.join(presets)}")
    config = presets[name]
    return replace_config(config, overrides) if overrides else config


def config_diff(a: Any, b: Any) -> dict[str, tuple[Any, Any]]:
    """Fields (dotted for nested configs) whose values differ between two configs: ``{name: (a, b)}``."""
    da, db = _flatten(config_to_dict(a)), _flatten(config_to_dict(b))
    return {k: (da.get(k), db.get(k)) for k in sorted(da.keys() | db.keys()) if da.get(k) != db.get(k)}


def _flatten(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


class _LineMap:
    """1-based line numbers of the keys in a loaded YAML mapping (:class:`~morphkit.yaml_loader.YamlMapping`),
    by dotted path."""

    def __init__(self, data: Any) -> None:
        self.lines: dict[str, int] = {}
        self._walk(data, "")

    def _walk(self, data: Any, prefix: str) -> None:
        if isinstance(data, YamlMapping):
            for key, value in data.items():
                path = f"{prefix}{key}"
                self.lines[path] = data.key_lines[key]
                self._walk(value, path + ".")

    def at(self, source: str | None, path: str) -> SourceLocation | None:
        if source is None:
            return None
        key = path.rstrip(".")
        # An item of a list (``hidden[1]``) is on its field's line, or below it.
        return SourceLocation(source, self.lines.get(key, self.lines.get(key.split("[", 1)[0])))


def _build(cls: type[C], data: Any, prefix: str, lines: _LineMap, source: str | None) -> C:
    where = prefix.rstrip(".") or cls.__name__
    if not isinstance(data, Mapping):
        raise ConfigError(
            f"{where}: expected a mapping of fields, got {type(data).__name__}", location=lines.at(source, prefix)
        )
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
    hints = typing.get_type_hints(cls)
    data = _without_retired(cls, data, prefix, lines, source)
    unknown = [k for k in data if k not in fields]
    if unknown:
        raise ConfigError(
            f"unknown config field {prefix}{unknown[0]!r} in {cls.__name__}; expected one of: {', '.join(fields)}",
            location=lines.at(source, f"{prefix}{unknown[0]}"),
        )
    kwargs: dict[str, Any] = {}
    for name, field in fields.items():
        if name in data:
            kwargs[name] = _coerce(data[name], hints[name], f"{prefix}{name}", lines, source)
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise ConfigError(
                f"config field {prefix}{name!r} of {cls.__name__} is required", location=lines.at(source, prefix)
            )
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:  # a __post_init__ check
        raise ConfigError(f"{where}: {exc}", location=lines.at(source, prefix)) from exc


def _without_retired(cls: type, data: Mapping[str, Any], prefix: str, lines: _LineMap,
                     source: str | None) -> Mapping[str, Any]:
    """``data`` without the keys of deleted options that ``cls.retired`` names (``{name: off value}``, ``...``: any
    value), so a run written before they were deleted still reads; one that trained with an option on cannot."""
    retired: Mapping[str, Any] = getattr(cls, "retired", {})
    for name in data:
        off = retired.get(name, ...)
        if name in retired and off is not ... and data[name] != off:
            raise ConfigError(
                f"config field {prefix + name!r} is {data[name]!r}: that option was deleted (off: {off!r}) and this "
                "version cannot use a run trained with it; docs/experiments/bringing-back.md says how to bring it back",
                location=lines.at(source, f"{prefix}{name}"),
            )
    return {k: v for k, v in data.items() if k not in retired}


def _coerce(value: Any, hint: Any, path: str, lines: _LineMap, source: str | None) -> Any:
    def bad() -> ConfigError:
        return ConfigError(
            f"config field {path!r}: expected {_type_name(hint)}, got {value!r}", location=lines.at(source, path)
        )

    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is Any:
        return value
    if origin is typing.Union or origin is types.UnionType:
        if value is None and type(None) in args:
            return None
        for arg in (a for a in args if a is not type(None)):
            try:
                return _coerce(value, arg, path, lines, source)
            except ConfigError:
                continue
        raise bad()
    if origin is typing.Literal:
        if value in args:
            return value
        raise ConfigError(
            f"config field {path!r}: {value!r} is not one of: {', '.join(map(repr, args))}",
            location=lines.at(source, path),
        )
    if origin in (tuple, list):
        if not isinstance(value, (list, tuple)):
            raise bad()
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(args) != len(value):
                raise bad()
            pairs = enumerate(zip(value, args, strict=True))
            return tuple(_coerce(v, a, f"{path}[{i}]", lines, source) for i, (v, a) in pairs)
        if path.rsplit(".", 1)[-1].endswith(_WIDTH_FIELDS) and len(value) > MAX_COUNT:
            raise ConfigError(f"config field {path!r}: {len(value)} layers, the most is {MAX_COUNT} (a network size)",
                              location=lines.at(source, path))
        item = args[0] if args else Any
        items = [_coerce(v, item, f"{path}[{i}]", lines, source) for i, v in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if origin is dict:
        if not isinstance(value, Mapping):
            raise bad()
        item = args[1] if args else Any
        return {str(k): _coerce(v, item, f"{path}.{k}", lines, source) for k, v in value.items()}
    if dataclasses.is_dataclass(hint):
        if isinstance(value, hint):
            return value
        return _build(hint, value, path + ".", lines, source)
    if hint is bool:
        if isinstance(value, bool):
            return value
        raise bad()
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            _check_size(value, path, lines, source)
            return _check_number(value, path, lines, source)
        raise bad()
    if hint is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return _check_number(float(value), path, lines, source)
        if isinstance(value, str):  # YAML 1.1 reads 1e-4 (no dot) as a string
            try:
                number = float(value)
            except ValueError:
                pass
            else:
                return _check_number(number, path, lines, source)
        raise bad()
    if hint is str:
        if isinstance(value, str):
            return value
        raise bad()
    if hint is Path:
        if isinstance(value, (str, os.PathLike)):
            return Path(value)
        raise bad()
    if isinstance(hint, type) and isinstance(value, hint):
        return value
    raise bad()


def _check_number(value: float, path: str, lines: _LineMap, source: str | None) -> Any:
    """Every number of a trainer config is a finite count, rate, weight, size or seed: never NaN, ±inf or < 0."""
    if not math.isfinite(value) or value < 0:
        raise ConfigError(f"config field {path!r}: expected a finite number >= 0, got {value!r}",
                          location=lines.at(source, path))
    return value


def _check_size(value: int, path: str, lines: _LineMap, source: str | None) -> None:
    """Network sizes within bounds, checked on load: a size that does not fit fails here, not in an allocation."""
    name = path.rsplit(".", 1)[-1].split("[", 1)[0]
    for suffixes, most in ((_WIDTH_FIELDS, MAX_WIDTH), (_COUNT_FIELDS, MAX_COUNT)):
        if name.endswith(suffixes) and not 1 <= value <= most:
            raise ConfigError(f"config field {path!r}: {value} is outside 1 to {most} (a network size)",
                              location=lines.at(source, path))


def _type_name(hint: Any) -> str:
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")
