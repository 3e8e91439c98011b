"""Property-based fuzz of the YAML and URDF readers: mutated valid text either reads, or raises a
MorphkitError — never another exception. Whatever reads must also write and read back.

``MORPHKIT_FUZZ_EXAMPLES`` raises the number of cases per test (default 1500) for a longer hunt.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

from _compare import assert_morphology_equal
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from morphkit.errors import MorphkitError
from morphkit.io.urdf import dump_urdf, parse_urdf
from morphkit.io.yaml_format import dump_yaml, parse_yaml

DATA = Path(__file__).resolve().parents[1] / "data"
YAML_SEEDS = [(DATA / "tiny_creature.yaml").read_text()]
URDF_SEEDS = [(DATA / "tiny_robot.urdf").read_text()]

EXAMPLES = int(os.environ.get("MORPHKIT_FUZZ_EXAMPLES", "1500"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])

NUMBER = re.compile(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")
NUMBER_REPLACEMENTS = [
    "nan", ".nan", "NaN", "inf", "-inf", ".inf", "-.Inf", "1e999", "-1e999", "abc", "", "0", "-1", "1e-3",
    "yes", "null", "~", "[]", "{}", "[1, 2]", "'1'", '"x"', "0x1F", "1_000", "1:30", "2001-01-01", "&#0;",
    "&amp;", "1 2", "1e", "--1", "+.5", "\x00", "\u00e9", "9" * 400,
]
CHARS = st.sampled_from([*"<>/&\"'=:{}[],-#!*&|>%@`\t\n \\?x0.", "\x00", "\x07", "\u00e9", "\ufeff", "\u2028"])


@st.composite
def mutated(draw: st.DrawFn, seeds: list[str], snippets: list[str]) -> str:
    """A seed text after 1-4 random edits: char flips, deletions, line duplications/deletions/swaps,
    numbers replaced by non-numbers, non-finite or out-of-range values, and inserted snippets."""
    text = draw(st.sampled_from(seeds))
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(KINDS))
        if not text:
            text = draw(CHARS)
            continue
        if kind == "flip":
            i = draw(st.integers(0, len(text) - 1))
            text = text[:i] + draw(CHARS) + text[i + 1 :]
        elif kind == "delete":
            i = draw(st.integers(0, len(text) - 1))
            n = draw(st.integers(1, 40))
            text = text[:i] + text[i + n :]
        elif kind == "insert":
            i = draw(st.integers(0, len(text)))
            text = text[:i] + draw(st.text(CHARS, min_size=1, max_size=5)) + text[i:]
        elif kind in ("dup_line", "del_line", "swap_lines"):
            lines = text.splitlines(keepends=True)
            i = draw(st.integers(0, len(lines) - 1))
            j = draw(st.integers(0, len(lines) - 1))
            if kind == "dup_line":
                lines.insert(j, lines[i])
            elif kind == "del_line":
                del lines[i]
            else:
                lines[i], lines[j] = lines[j], lines[i]
            text = "".join(lines)
        elif kind == "number":
            spans = [m.span() for m in NUMBER.finditer(text)]
            if spans:
                a, b = draw(st.sampled_from(spans))
                text = text[:a] + draw(st.sampled_from(NUMBER_REPLACEMENTS)) + text[b:]
        elif kind == "word":  # swap one identifier for another: names, types, roles, keys
            spans = [m.span() for m in WORD.finditer(text)]
            if spans:
                a, b = draw(st.sampled_from(spans))
                words = [m.group() for m in WORD.finditer(text)]
                text = text[:a] + draw(st.sampled_from(words) | st.sampled_from(WORDS)) + text[b:]
        elif kind == "snippet":
            i = draw(st.integers(0, len(text)))
            text = text[:i] + draw(st.sampled_from(snippets)) + text[i:]
    return text


# Character-level edits mostly break the syntax; semantic edits (numbers, words, lines) reach the
# readers' value and structure checks, so they are drawn more often.
KINDS = ("flip", "delete", "insert", "dup_line", "dup_line", "del_line", "del_line", "swap_lines",
         "number", "number", "number", "number", "word", "word", "word", "snippet", "snippet")
WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
WORDS = ["hinge", "world", "spherical", "planar", "floating", "wheeled", "fixed", "claw", "capsule", "mesh",
         "quat", "rpy", "xyz", "name", "link", "joint", "parent", "child", "mimic", "wheels", "true", "null"]
YAML_SNIPPETS = [
    "\n  extra: {type: fixed, parent: body, child: arm}\n", "\n  x: &a {b: *a}\n",
    "\nwheels: {joints: [], radius: 1}\n", "!!python/object:os.system ", "<<: {a: 1}\n", "\n---\n",
    "? [1, 2]\n: 3\n", "!!binary ", "&x ", "*x ", "\n  quat: [0, 0, 0, 0]\n", "mimic: {joint: shoulder}",
    "{", "[", "'", '"', "|\n", ">-\n", "%YAML 1.1\n",
]
URDF_SNIPPETS = [
    '<joint name="x" type="fixed"><parent link="body"/><child link="body"/></joint>',
    '<link name="world"/>', '<base type="planar"/>', '<wheels joints="spin" radius="0.1"/>',
    '<!DOCTYPE robot [<!ENTITY a "b">]>', "&a;", "<![CDATA[x]]>", "<?pi x?>", "<!-- c -->", "&#x0;",
    '<geometry><capsule radius="1" length="-1"/></geometry>', '<mimic joint="hip"/>', '<origin rpy="0 0"/>',
    '<limit lower="1" upper="0"/>', '<collision><geometry/></collision>', "</robot>", "<robot>",
    '<end_effector name="e" link="nowhere"/>', '<joint name="f" type="floating"><parent link="world"/></joint>',
]


def _reads_or_refuses(parse, dump, text: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing meshes warn; that is not what this test is about
        try:
            m = parse(text)
        except MorphkitError:
            return
        # What reads must write and read back the same (the writer copes with anything the reader accepts).
        try:
            dumped = dump(m)
        except MorphkitError:
            return
        assert_morphology_equal(m, parse(dumped), 1e-9)


@FUZZ
@given(mutated(YAML_SEEDS, YAML_SNIPPETS))
def test_yaml_reader_raises_only_morphkit_errors(text):
    _reads_or_refuses(parse_yaml, dump_yaml, text)


@FUZZ
@given(mutated(URDF_SEEDS, URDF_SNIPPETS))
def test_urdf_reader_raises_only_morphkit_errors(text):
    _reads_or_refuses(parse_urdf, dump_urdf, text)


@settings(max_examples=max(200, EXAMPLES // 5), deadline=None)
@given(st.text(max_size=200))
def test_arbitrary_text(text):
    _reads_or_refuses(parse_yaml, dump_yaml, text)
    _reads_or_refuses(parse_urdf, dump_urdf, text)
