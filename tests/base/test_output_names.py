"""Issue 64, part 1: one rule for output names. A name from inside an input becomes one plain path component:
never a parent folder, an absolute path, a hidden file or a control character; unicode kept; length bounded."""

from __future__ import annotations

import os
import unicodedata
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from morphkit.output_names import DEFAULT_STEM, MAX_STEM_BYTES, safe_stem, unique_stems


@pytest.mark.parametrize(
    ("name", "stem"),
    [
        ("spot", "spot"),
        ("../../escaped", "escaped"),
        ("/tmp/atk/ABSESC", "tmp_atk_ABSESC"),
        ("..\\..\\win", "win"),
        ("a/../b", "a_b"),
        ("..", DEFAULT_STEM),
        ("", DEFAULT_STEM),
        ("  . / .. / ", DEFAULT_STEM),
        (".hidden", "hidden"),
        ("line\nbreak\ttab", "line_break_tab"),
        ("evil\u202etxt.exe", "evil_txt.exe"),  # a bidi override would show another name than the file's
        ("Käfer 蟹", "Käfer 蟹"),
        ("Ka\u0308fer", "Käfer"),  # one spelling on every disk (NFC)
        ("a:b*c?", "a_b_c_"),
        ("trailing. ", "trailing"),
    ],
)
def test_names_become_one_plain_component(name, stem):
    assert safe_stem(name) == stem


def test_the_default_stem_is_the_callers():
    assert safe_stem("../..", default="clip") == "clip"


def test_a_long_name_is_cut_at_a_character_and_stays_distinct():
    a, b = "蟹" * 200 + "a", "蟹" * 200 + "b"
    sa, sb = safe_stem(a), safe_stem(b)
    assert sa != sb
    for s in (sa, sb):
        assert len(s.encode()) <= MAX_STEM_BYTES and s.startswith("蟹" * 20)
        s.encode("utf-8")  # no half character left


def test_unique_stems_keep_two_names_apart():
    assert unique_stems(["../x", "x", "X", "y"]) == ["x", "x-2", "X-3", "y"]


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=300))
def test_any_name_stays_inside_its_folder(name):
    stem = safe_stem(name)
    assert stem and Path(stem).name == stem and stem not in (".", "..")
    assert "/" not in stem and "\\" not in stem and not stem.startswith(".")
    assert not any(unicodedata.category(c) in ("Cc", "Cf", "Cs") for c in stem)
    assert len(stem.encode("utf-8")) <= MAX_STEM_BYTES
    folder = "/data/out"
    assert os.path.dirname(os.path.normpath(os.path.join(folder, stem + ".npz"))) == folder
