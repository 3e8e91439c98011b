"""Property-based fuzz of the BVH reader: mutated valid text fails only with a located MorphkitError.

Hypothesis mutates ``tests/data/tiny.bvh`` (character edits, token swaps and inserts from the
format's own vocabulary, line drops, duplications and truncations). Whatever it produces,
:func:`~morphkit.io.bvh.parse_bvh` and :func:`~morphkit.io.bvh.skeleton_from_bvh` either
succeed or raise a :class:`~morphkit.errors.MorphkitError` whose line lies inside the text.
The runs are derandomised so CI is reproducible.
"""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from morphkit.errors import MorphkitError
from morphkit.io.bvh import parse_bvh, skeleton_from_bvh

TINY_TEXT = (Path(__file__).resolve().parents[1] / "data" / "tiny.bvh").read_text()
LINES = TINY_TEXT.split("\n")

VOCAB = [
    "HIERARCHY",
    "ROOT",
    "JOINT",
    "End",
    "Site",
    "OFFSET",
    "CHANNELS",
    "MOTION",
    "Frames:",
    "Frame",
    "Time:",
    "{",
    "}",
    "0",
    "1",
    "-1",
    "3",
    "6",
    "7",
    "1e308",
    "-1e308",
    "1e-320",
    "nan",
    "inf",
    "-inf",
    "0.04",
    "x",
    "",
    "Xposition",
    "Yposition",
    "Zposition",
    "Xrotation",
    "Yrotation",
    "Zrotation",
    "Wrotation",
    "Hips",
    "Head",
    "LeftHand",
    "LeftFoot",
    "\n",
    "\t",
    "\r",
    " ",
    "\ufeff",
    "\x00",
    "\u00a0",
    "é",
    "１",
    "²",
]
"""Tokens the mutations insert: the format's keywords, edge-case numbers and odd characters."""


def _check(text: str) -> None:
    n_lines = text.replace("\r\n", "\n").replace("\r", "\n").count("\n") + 1
    try:
        bvh = parse_bvh(text, source="fuzz.bvh")
        skeleton_from_bvh(bvh)
    except MorphkitError as exc:
        loc = exc.location
        assert loc is not None and loc.path == "fuzz.bvh", repr(exc)
        assert loc.line is None or 1 <= loc.line <= n_lines, f"line {loc.line} outside 1..{n_lines}: {exc}"


@st.composite
def _char_mutations(draw: st.DrawFn) -> str:
    text = TINY_TEXT
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "insert", "replace", "truncate"]))
        i = draw(st.integers(0, len(text)))
        if kind == "delete":
            j = draw(st.integers(i, min(len(text), i + 40)))
            text = text[:i] + text[j:]
        elif kind == "insert":
            piece = draw(st.one_of(st.sampled_from(VOCAB), st.text(max_size=8)))
            text = text[:i] + piece + text[i:]
        elif kind == "replace":
            text = text[:i] + draw(st.text(min_size=1, max_size=3)) + text[i + 1 :]
        else:
            text = text[:i]
    return text


@st.composite
def _token_mutations(draw: st.DrawFn) -> str:
    lines = [line.split() for line in LINES]
    for _ in range(draw(st.integers(1, 5))):
        kind = draw(st.sampled_from(["swap_token", "add_token", "drop_line", "dup_line", "swap_lines", "number"]))
        r = draw(st.integers(0, len(lines) - 1))
        if kind == "swap_token" and lines[r]:
            lines[r][draw(st.integers(0, len(lines[r]) - 1))] = draw(st.sampled_from(VOCAB))
        elif kind == "add_token":
            lines[r].insert(draw(st.integers(0, len(lines[r]))), draw(st.sampled_from(VOCAB)))
        elif kind == "drop_line":
            del lines[r]
        elif kind == "dup_line":
            lines.insert(r, list(lines[r]))
        elif kind == "swap_lines":
            s = draw(st.integers(0, len(lines) - 1))
            lines[r], lines[s] = lines[s], lines[r]
        elif kind == "number" and lines[r]:
            value = draw(st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(10**400), 10**400))
            lines[r][draw(st.integers(0, len(lines[r]) - 1))] = str(value)
        if not lines:
            break
    return "\n".join(" ".join(tokens) for tokens in lines)


_SETTINGS = settings(
    max_examples=1000,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


@_SETTINGS
@given(_char_mutations())
def test_character_mutations_raise_only_morphkit_errors(text: str) -> None:
    _check(text)


@_SETTINGS
@given(_token_mutations())
def test_token_mutations_raise_only_morphkit_errors(text: str) -> None:
    _check(text)


def test_unmutated_fixture_parses() -> None:
    """The fuzz starts from a valid file (otherwise it would only test the first error)."""
    skeleton_from_bvh(parse_bvh(TINY_TEXT))
