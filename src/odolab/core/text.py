"""User text made safe where it goes: a file name, a terminal, an HTML page, an error message.

Trial ids, campaign names, terrains, parameter-set names, exclusion reasons and notes are typed
by people (or come from files other people wrote). Wherever odolab puts such text somewhere it
could do harm, it goes through one of these functions:

- :func:`safe_file_name`: one path component. No path separator, no ``..``, no leading dot or
  dash, no control or invisible character, at most :data:`MAX_NAME_CHARS` characters. A name that
  is already safe is kept as it is; any other gets its unsafe characters replaced by ``_`` and a
  short hash of the original appended, so that two different names never share a file. A name
  with no letter or digit at all (``""``, ``".."``, ``"///"``) is refused with one sentence.
- :func:`safe_terminal`: control characters (ANSI escape sequences, carriage returns, C1
  controls) and invisible formatting characters (bidirectional overrides) shown as visible
  ``\\x1b``-style escapes instead of being obeyed by the terminal.
- :func:`safe_html`: text escaped for HTML (``<``, ``>``, ``&``, quotes), as a ``Markup``.
- :func:`shorten` and :func:`quote_input`: any input echoed in a message is capped in length.
- :func:`figure_text`: text drawn in a figure (a title, a legend, a tick label): never read as
  matplotlib's mathtext (a terrain named ``$\\foo$`` stopped a whole report with a parse error),
  controls shown as escapes, and cut in the middle to what a figure's width holds.
- :func:`inert_csv_cell` and :func:`read_csv_cell`: a text cell of a CSV written for people
  (a trials export, a fleet table) that a spreadsheet would run as a formula (it starts with
  ``=``, ``+``, ``-``, ``@``, a tab or a carriage return: the OWASP rule) gets a leading ``'``,
  which spreadsheets show as "this is text" and odolab's readers take off again.
"""

from __future__ import annotations

import functools
import unicodedata
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, cast

from odolab.core.errors import OdolabError

if TYPE_CHECKING:
    from markupsafe import Markup

__all__ = [
    "CSV_FORMULA_STARTS",
    "MAX_ECHO_CHARS",
    "MAX_FIGURE_CHARS",
    "MAX_NAME_CHARS",
    "UnsafeNameError",
    "display_value",
    "figure_text",
    "inert_csv_cell",
    "quote_input",
    "read_csv_cell",
    "safe_display",
    "safe_file_name",
    "safe_html",
    "safe_terminal",
    "shorten",
]

#: Longest file name :func:`safe_file_name` returns (characters, before any suffix); at most
#: 4 bytes a character in UTF-8 keeps it under the 255-byte limit of common file systems.
MAX_NAME_CHARS = 60
#: Longest piece of user input echoed in a message (characters).
MAX_ECHO_CHARS = 80
#: Most characters of a user's name a figure shows: the report's 4.5 in figures hold about 50
#: characters a line at 10-11 pt, and a title or legend line has words of its own around the name.
MAX_FIGURE_CHARS = 32

#: Characters other than letters and digits that a file name may keep.
_NAME_PUNCTUATION = frozenset("-_.+=@,")
#: Names Windows reserves for devices (with any extension).
_RESERVED = frozenset(
    ["CON", "PRN", "AUX", "NUL"] + [f"{d}{i}" for d in ("COM", "LPT") for i in range(1, 10)]
)
#: Unicode categories a terminal must not receive raw: controls, format (bidi overrides,
#: zero-width), line and paragraph separators, surrogates, private use, unassigned.
_UNSAFE_CATEGORIES = frozenset({"Cc", "Cf", "Zl", "Zp", "Cs", "Co", "Cn"})


#: First characters that make a spreadsheet read a CSV cell as a formula (OWASP, "CSV
#: injection"); a text cell starting with one is written after a ``'``.
CSV_FORMULA_STARTS = frozenset("=+-@\t\r")


class UnsafeNameError(OdolabError):
    """A name cannot be made into a safe file name (it has no letter or digit)."""


def shorten(text: str, limit: int = MAX_ECHO_CHARS) -> str:
    """``text`` cut to ``limit`` characters, saying how long it was when it was cut."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} characters)"


def figure_text(text: object, limit: int = MAX_FIGURE_CHARS) -> str:
    """``text`` (a terrain, a parameter set's, a robot's or a run's name) as a figure draws it.

    Every ``$`` is escaped, so matplotlib draws the text as it is and never parses it as
    mathtext (``$\\foo$`` is a parse error at drawing time, ``$x$`` would come out in italics);
    controls and invisible characters are shown as :func:`safe_terminal` shows them; and a text
    longer than ``limit`` characters keeps its start and its end around a ``…`` (names often
    differ at the end: ``run-2026-11-28-a``, ``...-b``). A longer name ran off both sides of the
    figure and squeezed its plot (and drew all its glyphs: a 10,000-character terrain took 7 s
    of a report); the page's headings and tables show it whole. A character the figures' font
    has no glyph for (``草``, ``🌱`` in matplotlib's DejaVu Sans) is drawn as the box matplotlib
    would draw, ``□``, without matplotlib's warning (one a character, printed with its own
    source line, at every report)."""
    if limit < 1:
        raise ValueError(f"figure_text's limit is {limit!r}; expected 1 character or more")
    shown = safe_terminal(text)
    if not shown.isascii():  # the default font (DejaVu Sans) draws every ASCII character
        drawable = _figure_font_chars()
        if drawable is not None:
            shown = "".join(c if ord(c) in drawable else "□" for c in shown)
    if len(shown) > limit:
        head = (limit - 1) * 2 // 3
        tail = max(0, limit - 1 - head)
        shown = shown[:head] + "…" + (shown[-tail:] if tail else "")
    return shown.replace("$", r"\$")


def _figure_font_chars() -> frozenset[int] | None:
    """The code points the figures' fonts draw: the union of the fonts matplotlib finds for
    each family of ``font.family`` (its fallback chain; DejaVu Sans alone by default), kept for
    each setting. None where that cannot be told (no matplotlib: the core without the
    ``report`` extra; a font file that cannot be read): every character passes, and matplotlib
    says what it cannot draw as before. matplotlib is imported here, for a name that is not
    ASCII only."""
    try:
        import matplotlib as mpl
    except ImportError:
        return None
    settings = cast("Mapping[str, Sequence[str]]", mpl.rcParams)  # keys made from the families
    families = tuple(settings["font.family"])
    generic = {f: tuple(settings.get(f"font.{f}", ())) for f in families}
    return _font_chars(families, tuple(sorted(generic.items())))


@functools.cache
def _font_chars(
    families: tuple[str, ...], generic: tuple[tuple[str, tuple[str, ...]], ...]
) -> frozenset[int] | None:
    """:func:`_figure_font_chars` for one setting (``generic``: the lists the generic family
    names stand for, part of the key only)."""
    try:
        from matplotlib import font_manager, ft2font

        paths = []
        for family in families:
            try:
                prop = font_manager.FontProperties(family=[family])
                paths.append(font_manager.findfont(prop, fallback_to_default=False))
            except ValueError:  # not installed: matplotlib passes over it too
                continue
        if not paths:
            paths.append(font_manager.findfont(font_manager.FontProperties()))
        chars: set[int] = set()
        for path in dict.fromkeys(paths):
            chars.update(ft2font.FT2Font(path).get_charmap())
        return frozenset(chars)
    except Exception:  # an unreadable font: let matplotlib draw and say it
        return None


def safe_terminal(text: object, *, limit: int | None = None, unicode_escapes: bool = False) -> str:
    """``text`` with every control or invisible character shown as an escape (``\\x1b``).

    A terminal then prints the text and obeys nothing in it: no colour change, no cursor move,
    no overwritten line, no reversed text. With ``limit`` the text is also :func:`shorten`-ed.
    ``unicode_escapes``: ``\\u001b`` (and ``\\U...``) only, the escapes a TOML or JSON string
    reads back as the character (for text that must stay valid TOML)."""
    s = str(text)
    if limit is not None:
        s = shorten(s, limit)
    if s.isprintable():  # the common case: nothing to do (space is printable, \t and \n not)
        return s
    out = []
    for ch in s:
        if ch == " " or unicodedata.category(ch) not in _UNSAFE_CATEGORIES:
            out.append(ch)
        elif ord(ch) < 0x100 and not unicode_escapes:
            out.append(f"\\x{ord(ch):02x}")
        elif ord(ch) < 0x10000:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(f"\\U{ord(ch):08x}")
    return "".join(out)


def safe_display(text: object) -> str:
    """``text`` for a page: every control or invisible character shown as an escape, as
    :func:`safe_terminal` does (a right-to-left override in a name reversed the page's own
    sentences after it), but line breaks and tabs kept (on a page they are white space)."""
    s = str(text)
    if s.isprintable():
        return s
    return "\n".join(safe_terminal(part).replace("\\x09", "\t") for part in s.split("\n"))


def display_value(value: object) -> object:
    """A page template's ``finalize``: every text it prints through :func:`safe_display`
    (markup odolab made is left as it is)."""
    from markupsafe import Markup

    if isinstance(value, str) and not isinstance(value, Markup):
        return safe_display(value)
    return value


def quote_input(value: object, limit: int = MAX_ECHO_CHARS) -> str:
    """``value`` quoted for an error message: capped at ``limit`` characters, terminal-safe."""
    if isinstance(value, str):
        return repr(shorten(value, limit))  # repr escapes control and invisible characters
    return safe_terminal(shorten(repr(value), limit))


def safe_html(text: object) -> Markup:
    """``text`` escaped for HTML (element content and quoted attribute values)."""
    from markupsafe import escape

    return escape(str(text))


def safe_file_name(text: str, *, what: str = "name", suffix: str = "") -> str:
    """A file name made from ``text`` (plus ``suffix``, e.g. ``".csv"``) that stays in its folder.

    Letters, digits and ``- _ . + = @ ,`` are kept; a leading ``.`` or ``-``, a trailing ``.``,
    and every other character (``/``, ``\\``, ``:``, spaces, controls ...) become ``_``. When
    anything had to change, or the name is longer than :data:`MAX_NAME_CHARS` or is a name
    Windows reserves (``CON``, ``NUL`` ...), the result is cut and ends in ``-`` and 8 hex digits
    of the original's SHA-256, so different names give different files. Raises
    :class:`UnsafeNameError` for a name with no letter or digit; ``what`` names it there.
    """
    if not isinstance(text, str):
        raise UnsafeNameError(f"{what} {quote_input(text)} is not text; expected a name")
    if not any(ch.isalnum() for ch in text):
        raise UnsafeNameError(
            f"{what} {quote_input(text)} cannot be made a safe file name; expected a name "
            "with at least one letter or digit"
        )
    chars = [ch if ch.isalnum() or ch in _NAME_PUNCTUATION else "_" for ch in text]
    if chars[0] in ".-":
        chars[0] = "_"
    if chars[-1] == ".":
        chars[-1] = "_"
    name = "".join(chars)
    reserved = name.split(".")[0].upper() in _RESERVED
    if name != text or len(name) > MAX_NAME_CHARS or reserved:
        import hashlib  # here: 5 ms of every command's start-up otherwise

        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
        name = f"{name[: MAX_NAME_CHARS - 9]}-{digest}"
    return name + suffix


def inert_csv_cell(text: str) -> str:
    """``text`` as a CSV text cell a spreadsheet shows and never runs.

    A cell starting with one of :data:`CSV_FORMULA_STARTS` gets a leading ``'`` (the OWASP
    rule). So does a cell that already starts with ``'``, so that :func:`read_csv_cell` gives
    every text back exactly: ``'=1`` is written ``''=1`` and read back ``'=1``. Only text cells
    go through this: a number (``-0.5``) in a numeric column stays a number.
    """
    if text and (text[0] in CSV_FORMULA_STARTS or text[0] == "'"):
        return "'" + text
    return text


def read_csv_cell(cell: str) -> str:
    """A text cell as :func:`inert_csv_cell` wrote it, back to the text (one leading ``'``
    taken off)."""
    return cell[1:] if cell.startswith("'") else cell
