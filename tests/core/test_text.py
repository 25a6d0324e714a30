"""odolab.core.text: user text made safe for file names, terminals, HTML and messages."""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.text import (
    MAX_NAME_CHARS,
    UnsafeNameError,
    figure_text,
    quote_input,
    safe_file_name,
    safe_html,
    safe_terminal,
    shorten,
)


def _h(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:8]


@pytest.mark.parametrize(
    "name", ["lab-report-001", "rotation_indoor.3", "Gelände-7", "a..b", "x+y=z@w,1"]
)
def test_safe_names_are_kept_as_they_are(name: str) -> None:
    assert safe_file_name(name) == name
    assert safe_file_name(name, suffix=".csv") == name + ".csv"


@pytest.mark.parametrize(
    ("name", "cleaned"),
    [
        ("../../x", "_._.._x"),
        ("/etc/passwd", "_etc_passwd"),
        ("a/b", "a_b"),
        ("a\\b", "a_b"),
        (".hidden", "_hidden"),
        ("-rf", "_rf"),
        ("name.", "name_"),
        ("red\x1b[31m", "red__31m"),
        ("<script>", "_script_"),
        ("C:x", "C_x"),
        ("con", "con"),  # reserved on Windows: kept but hashed
        ("NUL.txt", "NUL.txt"),
    ],
)
def test_unsafe_names_are_cleaned_and_hashed(name: str, cleaned: str) -> None:
    assert safe_file_name(name) == f"{cleaned}-{_h(name)}"


def test_different_names_never_share_a_file() -> None:
    assert safe_file_name("a/b") != safe_file_name("a_b")
    long_a, long_b = "n" * 10_000, "n" * 9_999 + "m"
    a, b = safe_file_name(long_a), safe_file_name(long_b)
    assert a != b and len(a) == len(b) == MAX_NAME_CHARS
    assert a == "n" * (MAX_NAME_CHARS - 9) + "-" + _h(long_a)


@pytest.mark.parametrize("name", ["", "..", ".", "///", "  ", "\x1b[", "-", "..\\.."])
def test_names_without_a_letter_or_digit_are_refused(name: str) -> None:
    with pytest.raises(UnsafeNameError, match=r"trial id .* cannot be made a safe file name"):
        safe_file_name(name, what="trial id")


@given(st.text(min_size=1, max_size=300))
def test_any_name_stays_in_its_folder(name: str) -> None:
    try:
        out = safe_file_name(name, suffix=".csv")
    except UnsafeNameError:
        assert not any(ch.isalnum() for ch in name)
        return
    assert "/" not in out and "\\" not in out and "\x00" not in out
    assert not out.startswith((".", "-"))
    assert len(out) <= MAX_NAME_CHARS + 4
    assert len(out.encode("utf-8", "surrogatepass")) <= 255
    base = Path("/data/logs")
    assert (base / out).parent == base
    assert safe_terminal(out) == out  # nothing a terminal would obey


def test_terminal_text_shows_escapes_instead_of_obeying_them() -> None:
    assert safe_terminal("plain text, ünïcode") == "plain text, ünïcode"
    assert safe_terminal("\x1b[31mred\x1b[0m") == "\\x1b[31mred\\x1b[0m"
    assert safe_terminal("a\rb\nc\x07\x9b") == "a\\x0db\\x0ac\\x07\\x9b"
    assert safe_terminal("abc\u202edcba") == "abc\\u202edcba"  # bidi override
    assert safe_terminal("x" * 100, limit=10) == "x" * 10 + "... (100 characters)"


def test_html_is_escaped() -> None:
    assert str(safe_html('"><img onerror=alert(1)>')) == ("&#34;&gt;&lt;img onerror=alert(1)&gt;")
    assert str(safe_html("<script>")) == "&lt;script&gt;"


def test_echoed_input_is_capped_and_quoted() -> None:
    assert shorten("abc", 5) == "abc"
    assert shorten("a" * 6, 5) == "aaaaa... (6 characters)"
    q = quote_input("\x00" * 1_000_000)
    assert len(q) < 500 and "\x00" not in q and "1000000 characters" in q
    assert quote_input(1e308) == "1e+308"
    assert quote_input(None) == "None"


@pytest.mark.parametrize(
    ("text", "drawn"),
    [
        ("tile", "tile"),
        (r"$\foo$ floor", r"$\foo$ floor"),  # mathtext's parse error stopped a whole report
        ("$x$", "$x$"),  # not italics: as typed
        (r"a\$b", r"a\$b"),
        ("red\x1b[31m", "red\\x1b[31m"),
        ("n" * 10_000, "n" * 20 + "…" + "n" * 11),
        ("run-2026-11-28-long-campaign-name-a", "run-2026-11-28-long-…aign-name-a"),
        ("Gelände σ", "Gelände σ"),
        ("草地 🌱 tile", "□□ □ tile"),  # no glyph in DejaVu Sans: the box, not a warning
    ],
)
def test_figure_text_is_drawn_as_written_and_fits(text: str, drawn: str) -> None:
    """What matplotlib draws from figure_text(text): the text itself, never mathtext, controls
    as escapes, at most 32 characters with the start and the end of a long name."""
    from matplotlib import cbook
    from matplotlib.figure import Figure

    shown = figure_text(text)
    assert not cbook.is_math_text(shown)
    assert shown.replace(r"\$", "$") == drawn  # what a non-math Text draws
    assert len(drawn) <= 32
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(3, 2))
    fig.add_subplot().set_title(shown)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # matplotlib warned once a missing glyph
        FigureCanvasAgg(fig).draw()  # type: ignore[no-untyped-call]  # no parse error


@given(st.text(max_size=200))
def test_no_text_becomes_mathtext_in_a_figure(text: str) -> None:
    from matplotlib import cbook

    shown = figure_text(text)
    assert not cbook.is_math_text(shown)
    assert len(shown.replace(r"\$", "$")) <= 32
    if len(text) <= 32 and text.isprintable():  # as typed, but for the font's missing glyphs
        drawn = shown.replace(r"\$", "$")
        assert len(drawn) == len(text)
        assert all(d in (c, "□") for d, c in zip(drawn, text, strict=True))
        assert all(d == c for d, c in zip(drawn, text, strict=True) if c.isascii())


def test_figure_text_without_matplotlib_keeps_every_character(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The core without the report extra: no font to ask, nothing replaced, nothing raised."""
    import sys

    from odolab.core import text

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if not installed
    assert text._figure_font_chars() is None
    assert figure_text("草地 🌱") == "草地 🌱"


def test_figure_text_asks_every_font_of_the_fallback_chain() -> None:
    """A family that is not installed is passed over as matplotlib passes over it; the
    setting in force is the one asked (the answer is kept for each setting)."""
    import matplotlib as mpl

    with mpl.rc_context({"font.family": ["No Such Font Anywhere", "DejaVu Sans"]}):
        assert figure_text("Gelände 草") == "Gelände □"
    with mpl.rc_context({"font.family": ["No Such Font Anywhere"]}):  # matplotlib's default
        assert figure_text("Gelände 草") == "Gelände □"


@pytest.mark.parametrize(("limit", "want"), [(1, "…"), (2, "…j"), (3, "a…j"), (4, "ab…j")])
def test_figure_text_keeps_to_any_limit(limit: int, want: str) -> None:
    assert figure_text("abcdefghij", limit) == want
    with pytest.raises(ValueError, match="limit"):
        figure_text("abc", 0)
