"""The one YAML reader of morphkit's files: descriptions, configs, tables and run metadata.

Every document is read with :class:`LineLoader` (YAML 1.1 as PyYAML reads it, safe, with ``1e-3`` read as a
float, no dates, duplicate keys refused) into :class:`YamlMapping` / :class:`YamlList`, which remember the
1-based line of each key and item, so a caller can name the line of a bad value. Every failure — an unreadable
file, text that is not UTF-8, malformed YAML — raises the caller's error class with the file and line.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from morphkit.errors import ConfigError, MorphkitError, SourceLocation

__all__ = [
    "MALFORMED",
    "MAX_DEPTH",
    "LineLoader",
    "YamlList",
    "YamlMapping",
    "load_yaml",
    "load_yaml_file",
    "plain_data",
]

MALFORMED = "malformed YAML"
"""The words an error about text that is no YAML starts with (a caller may choose others)."""


class YamlMapping(dict):
    """A YAML mapping with the 1-based line of the mapping and of each key."""

    line: int = 0
    key_lines: dict[Any, int]


class YamlList(list):
    """A YAML sequence with the 1-based line of the sequence and of each item."""

    line: int = 0
    item_lines: list[int]


# libyaml's parser is ~8x faster than PyYAML's pure-Python one; both give the same nodes and marks.
_SafeLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
MAX_DEPTH = 100
"""Deepest nesting of mappings and lists accepted (libyaml's recursive composer crashes on very deep input)."""


class LineLoader(_SafeLoader):  # type: ignore[misc, valid-type]
    """SafeLoader that records source lines, refuses duplicate keys, and reads ``1e-3`` as a float.

    PyYAML implements YAML 1.1, where ``1e-3`` (no dot) is a string and ``2001-01-01`` a date;
    morphkit's files want YAML 1.2 numbers and no dates.
    """


LineLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag != "tag:yaml.org,2002:timestamp"]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
LineLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def _construct_map(loader: LineLoader, node: yaml.MappingNode) -> Iterable[YamlMapping]:
    data = YamlMapping()
    data.line = node.start_mark.line + 1
    data.key_lines = {}
    yield data
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise yaml.constructor.ConstructorError(
                None, None, f"unhashable mapping key {key!r}", key_node.start_mark
            ) from None
        line = key_node.start_mark.line + 1
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r} (first written on line {seen[key]})", key_node.start_mark
            )
        seen[key] = line
    loader.flatten_mapping(node)
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        data[key] = loader.construct_object(value_node, deep=True)
        data.key_lines[key] = key_node.start_mark.line + 1


def _construct_seq(loader: LineLoader, node: yaml.SequenceNode) -> Iterable[YamlList]:
    data = YamlList()
    data.line = node.start_mark.line + 1
    data.item_lines = [n.start_mark.line + 1 for n in node.value]
    yield data
    data.extend(loader.construct_object(n, deep=True) for n in node.value)


LineLoader.add_constructor("tag:yaml.org,2002:map", _construct_map)
LineLoader.add_constructor("tag:yaml.org,2002:seq", _construct_seq)


def _check_depth(text: str, source: str | None, error: type[MorphkitError], malformed: str) -> None:
    """Refuse absurdly deep nesting before composing (the event stream is parsed iteratively)."""
    depth = 0
    for event in yaml.parse(text, Loader=LineLoader):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                line = event.start_mark.line + 1 if event.start_mark is not None else None
                raise error(f"{malformed}: nested more than {MAX_DEPTH} levels deep",
                            location=SourceLocation(source, line))
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1


def load_yaml(text: str, source: str | None, *, error: type[MorphkitError] = ConfigError,
              malformed: str = MALFORMED) -> Any:
    """Parse YAML ``text`` (from file ``source``) into :class:`YamlMapping` / :class:`YamlList` / scalars.

    Raises:
        MorphkitError: ``error`` (default :class:`ConfigError`) for every parser failure, ``"<malformed>: <what>"``
            at ``source`` and the line where the parser stopped, when it can tell.
    """
    where = SourceLocation(source)
    try:
        _check_depth(text, source, error, malformed)
        return yaml.load(text, Loader=LineLoader)  # LineLoader is a SafeLoader
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = exc.problem or exc.context or "malformed YAML"
        raise error(f"{malformed}: {problem}", location=where.at_line(line)) from exc
    except yaml.reader.ReaderError as exc:
        position = getattr(exc, "position", None)
        line = text.count("\n", 0, position) + 1 if isinstance(position, int) else None
        character = getattr(exc, "character", None)
        raise error(f"{malformed}: unacceptable character {character!r}", location=where.at_line(line)) from exc
    except yaml.YAMLError as exc:
        raise error(f"{malformed}: {exc}", location=where) from exc
    except RecursionError as exc:
        raise error(f"{malformed}: nested too deeply", location=where) from exc
    except (ValueError, TypeError, OverflowError) as exc:  # scalar constructors (e.g. !!binary, !!float)
        raise error(f"{malformed}: {exc}", location=where) from exc


def load_yaml_file(path: str | os.PathLike[str], *, what: str, error: type[MorphkitError] = ConfigError,
                   malformed: str | None = None) -> Any:
    """Read a UTF-8 YAML file with :func:`load_yaml`.

    Args:
        path: The file.
        what: What it is, for messages (``"config"``: ``cannot read config: No such file or directory``).
        error: The error class raised.
        malformed: The words an error about malformed YAML starts with (default ``cannot read <what>: malformed
            YAML``).

    Raises:
        MorphkitError: ``error``, naming the file (and the line where one is known) when it cannot be read, is
            not UTF-8 text, or is not valid YAML.
    """
    source = os.fspath(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise error(f"cannot read {what}: {exc.strerror or exc}", location=SourceLocation(source)) from exc
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise error(f"{what} is not UTF-8 text (byte {exc.start})", location=SourceLocation(source, line)) from exc
    return load_yaml(text, source, error=error, malformed=f"cannot read {what}: {MALFORMED}" if malformed is None
                     else malformed)


def plain_data(value: Any) -> Any:
    """``value`` with every :class:`YamlMapping` and :class:`YamlList` turned into a plain dict and list (what
    ``yaml.safe_dump`` writes back)."""
    if isinstance(value, dict):
        return {k: plain_data(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain_data(v) for v in value]
    return value
