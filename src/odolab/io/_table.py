"""Shared numeric-table parsing with error messages that name the file, line and column."""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError
from odolab.core.text import quote_input, safe_terminal, shorten
from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells

__all__ = ["data_line_numbers", "read_numeric_columns"]

#: One column read: float64, or int64 where asked and every value is written as an integer.
Column = NDArray[np.float64] | NDArray[np.int64]
Columns = dict[str, Column]  # column name -> array


def as_float64(columns: Columns) -> dict[str, NDArray[np.float64]]:
    """Columns read without ``integer`` as what they are: float64 arrays (none is copied)."""
    return {k: np.asarray(v, dtype=np.float64) for k, v in columns.items()}


class _CsvRefused(Exception):
    """The streaming CSV reader refused a block; the careful reader names the line."""


_BLANK_LINE = re.compile(rb"(?:^|\n)(?=\r?\n)")  # where a blank line starts (overlapping)


def check_columns_present(p: Path, header: Sequence[str], columns: Sequence[str]) -> None:
    """Refuse a table whose header lacks one of ``columns``, naming the first one missing."""
    missing = [c for c in columns if c not in header]
    if missing:
        raise LogFormatError(
            f"{p}: missing column {missing[0]!r}; the header has "
            f"{safe_terminal(shorten(', '.join(header), 200)) or 'nothing'}"
            f" but {', '.join(columns)} are expected"
        )


def _data_lines(fh: Iterable[str], has_header: bool) -> Iterator[tuple[int, str]]:
    """``(line number from 1, line)`` of each non-blank line after the header, the first
    non-blank line (as :func:`odolab.io.limits.first_line_cells` reads it); the numbers are
    the file's own, blank lines counted."""
    header_to_skip = has_header
    for lineno, line in enumerate(fh, start=1):
        if not line.strip():
            continue  # a blank line is no row (a line of empty cells is one)
        if header_to_skip:
            header_to_skip = False
            continue
        yield lineno, line


def _parse_block(
    text: bytes,
    header: list[str],
    columns: Sequence[str],
    integer: Sequence[str],
    *,
    sep: str = ",",
) -> Columns:
    """One block of CSV lines as numpy arrays (int64 for ``integer`` columns where every value
    there is written as an integer, else float64); blank lines are skipped. Raises
    :class:`_CsvRefused` for anything else unusual (a missing cell, a word). ``sep``: the one
    byte between cells."""
    import polars as pl

    idx = [header.index(c) for c in columns]
    frame = None
    refusal = ""
    for ints in (True, False) if integer else (False,):
        types = {c: pl.Int64 if ints and c in integer else pl.Float64 for c in columns}
        try:
            frame = pl.read_csv(
                text, has_header=False, new_columns=list(header), columns=idx,
                schema_overrides=types, infer_schema=False, encoding="utf8", separator=sep,
            )  # fmt: skip
            break
        except pl.exceptions.PolarsError as err:
            refusal = str(err).splitlines()[0] if str(err) else type(err).__name__
    if frame is None:
        raise _CsvRefused(refusal)
    if frame.width != len(columns):
        raise _CsvRefused("a line of another width")
    if any(s.null_count() for s in frame.get_columns()):
        empty = pl.all_horizontal(pl.all().is_null())  # a blank line, or a line of commas
        if int(frame.select(empty.sum()).item()) != len(_BLANK_LINE.findall(text)):
            raise _CsvRefused("an empty cell")
        frame = frame.filter(~empty)
        if any(s.null_count() for s in frame.get_columns()):
            raise _CsvRefused("an empty cell")
    out: Columns = {}
    for c, series in zip(columns, frame.get_columns(), strict=True):
        arr = series.to_numpy()
        out[c] = arr if arr.flags.writeable else arr.copy()  # numpy's own: polars' is freed
    return out


def _not_a_number(path: Path, lineno: int, name: str, cell: str) -> str:
    """The sentence for a cell that is not the number expected: file, line, column, the cell."""
    shown = quote_input(cell) if cell else "empty"
    return f"{path}: line {lineno}, column {name!r} is {shown}, expected a number"


def _locate_bad_cell(
    path: Path,
    header: list[str],
    wanted: Sequence[str],
    sep: str,
    *,
    has_header: bool = True,
    finite: bool = False,
) -> str:
    """Find the first cell of ``wanted`` columns that is not a (finite) number; describe it.

    Line numbers count every physical line of the file, blank and comment lines included.
    """
    with path.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        whitespace = sep == r"\s+"
        idx = {name: header.index(name) for name in wanted}
        for lineno, line in _data_lines(fh, has_header):
            try:
                row = line.split() if whitespace else next(csv.reader([line], delimiter=sep), [])
            except csv.Error:  # a cell over csv's 128 KiB field limit (lines may have 1 MB)
                row = line.rstrip("\r\n").split(sep)
            if whitespace and row[0].startswith("#"):
                continue
            for name, j in idx.items():
                cell = row[j].strip() if j < len(row) else ""
                try:
                    ok = math.isfinite(float(cell)) or not finite
                except ValueError:
                    ok = False
                if not ok:
                    return _not_a_number(path, lineno, name, cell)
    return f"{path}: could not parse as numbers"


def data_line_numbers(
    path: str | Path, *, sep: str = ",", has_header: bool = True
) -> NDArray[np.int64]:
    """Physical line number (from 1) of each data row, skipping what the reader skips.

    Blank lines (and, for whitespace-separated files, ``#`` comment lines) are not rows, so a
    row's index alone does not give its line; error messages use this to name the right line.
    """
    lines: list[int] = []
    with Path(path).open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        for lineno, line in _data_lines(fh, has_header):
            if not (sep == r"\s+" and line.lstrip().startswith("#")):
                lines.append(lineno)
    return np.asarray(lines, dtype=np.int64)


def read_numeric_columns(
    path: str | Path,
    columns: Sequence[str],
    *,
    sep: str = ",",
    names: Sequence[str] | None = None,
    allow_nan: bool = False,
    checked: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Read the named columns of a delimited text file as float64 arrays.

    With ``names`` the file has no header and columns are given those names; ``sep`` is ``","``
    or ``r"\\s+"`` (runs of spaces or tabs; ``#`` starts a comment). Every error is a
    :class:`LogFormatError` naming the file, and the line and column where there is one. The
    file's lines are checked first (:func:`odolab.io.limits.check_text_file`; ``checked``: the
    caller already did) and a header that names a column twice is refused.

    One fast path (polars' parser, on every core) reads the usual file; only a file it refuses
    is read again by a careful reader that names the line: Python's csv reader for a
    comma-separated file, a line-by-line scan for a whitespace-separated one.
    """
    p = Path(path)
    if not p.exists():
        raise LogFormatError(f"{p}: no such file")
    if not p.is_file():
        raise LogFormatError(f"{p}: is not a file (a folder?); expected a delimited text file")
    if not checked:
        check_text_file(p, expected="a delimited text file")
        if names is None:
            check_columns_unique(p, first_line_cells(p, sep))
    if names is None:
        header = first_line_cells(p, sep)
        if not header:
            raise LogFormatError(f"{p}: empty or unreadable file; expected a header line")
    else:
        header = list(names)
    check_columns_present(p, header, columns)
    if names is not None:
        fast = _fast_headerless(p, header, columns, sep)
        if fast is not None and (
            allow_nan or all(bool(np.isfinite(a).all()) for a in fast.values())
        ):
            return fast
    if sep == r"\s+":
        return _careful_whitespace(p, header, columns, allow_nan, has_header=names is None)
    return _careful_csv(p, header, columns, sep, allow_nan, has_header=names is None)


_COMMENT = re.compile(rb"#[^\r\n]*")
_SPACES = bytes.maketrans(b"\t\f\v", b"   ")


def _fast_headerless(
    p: Path, header: list[str], columns: Sequence[str], sep: str
) -> dict[str, NDArray[np.float64]] | None:
    """A header-less file read at once by polars (:func:`odolab.io.tabular._parse_block`),
    whitespace-separated text split at single spaces (and, where that is refused, again after
    :func:`_single_spaced`). None: the careful reader must look (a quote, a comma inside
    whitespace-separated text, a short line, a word)."""
    data = p.read_bytes()  # (checked: UTF-8 lines of at most 1 MB; read whole, as before)
    data = data.removeprefix(b"\xef\xbb\xbf")
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n")
        if b"\r" in data:
            return None  # lines ended by a bare carriage return: the careful reader
    if sep not in (",", r"\s+"):
        return None
    if sep == r"\s+":
        if b"," in data or b'"' in data:
            return None  # would be read as other columns: the careful reader names the cell
        if b"#" in data:
            data = _COMMENT.sub(b"", data)
    data = data.lstrip(b"\n")
    if not data or data.isspace():
        return {c: np.empty(0, np.float64) for c in columns}
    one = " " if sep == r"\s+" else ","
    try:
        parsed = _parse_block(data, header, columns, (), sep=one)
    except _CsvRefused:
        if sep == ",":
            return None
        # not one space between cells: tabs, runs of spaces, spaces at a line's ends
        try:
            parsed = _parse_block(_single_spaced(data), header, columns, (), sep=one)
        except _CsvRefused:
            return None
    return {c: np.asarray(parsed[c], dtype=np.float64) for c in columns}


def _single_spaced(data: bytes) -> bytes:
    """Whitespace-separated lines with one space between cells and none at either end (at
    bytes' own speed: a regular expression took 0.85 s on 9 MB)."""
    if b"\t" in data or b"\f" in data or b"\v" in data:
        data = data.translate(_SPACES)
    while b"  " in data:  # each pass halves every run of spaces
        data = data.replace(b"  ", b" ")
    data = data.replace(b"\n ", b"\n").replace(b" \n", b"\n")
    return data.removeprefix(b" ").removesuffix(b" ")


def _careful_whitespace(
    p: Path, header: list[str], columns: Sequence[str], allow_nan: bool, *, has_header: bool
) -> dict[str, NDArray[np.float64]]:
    """Whitespace-separated text line by line (``#`` comments, blank lines skipped; cells past
    the header's ignored): the values, or the first bad cell's line and column."""
    idx = [header.index(c) for c in columns]
    out: list[list[float]] = [[] for _ in columns]
    with p.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        for lineno, line in _data_lines(fh, has_header):
            cells = line.split("#", 1)[0].split()
            if not cells:
                continue
            for k, (name, j) in enumerate(zip(columns, idx, strict=True)):
                cell = cells[j] if j < len(cells) else ""
                try:
                    value = float(cell)
                except ValueError:
                    value = math.nan
                    ok = False
                else:
                    ok = math.isfinite(value) or (allow_nan and math.isnan(value))
                if not ok:
                    raise LogFormatError(_not_a_number(p, lineno, name, cell))
                out[k].append(value)
    return {c: np.asarray(v, dtype=np.float64) for c, v in zip(columns, out, strict=True)}


#: The cells pandas' CSV parser took for a missing value (read as nan; refused unless allowed).
_MISSING = frozenset(
    {"", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN",
     "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null"}
)  # fmt: skip


def _careful_csv(
    p: Path,
    header: list[str],
    columns: Sequence[str],
    sep: str,
    allow_nan: bool,
    *,
    has_header: bool,
) -> dict[str, NDArray[np.float64]]:
    """What the fast path refused (quotes, spaces around numbers, a short line): numbers alone
    read at numpy's speed (:func:`_plain_numbers`), anything else by Python's csv reader line by
    line (:func:`_csv_lines`), which names the first bad cell's line and column."""
    fast = _plain_numbers(p, header, columns, sep, allow_nan, has_header=has_header)
    if fast is not None:
        return fast
    return _csv_lines(p, header, columns, sep, allow_nan, has_header=has_header)


#: The bytes of a file :func:`_plain_numbers` reads (with the separator): digits, signs,
#: points, exponents, quotes, spaces and line ends; a word, a tab or ``nan`` go line by line.
_PLAIN_BYTES = b'0123456789.+-eE" \r\n'


def _plain_numbers(
    p: Path,
    header: list[str],
    columns: Sequence[str],
    sep: str,
    allow_nan: bool,
    *,
    has_header: bool,
) -> dict[str, NDArray[np.float64]] | None:
    """The careful reader's usual case at C speed: numpy's loadtxt (quotes understood) on a
    file of numbers only, every line as wide as the header; the values :func:`_csv_lines`
    gives. None where that reader must look (a word, a missing or extra cell, a line of
    spaces, a number that is not finite where one is expected), or the file has no rows."""
    if len(sep) != 1 or not sep.isascii():
        return None
    data = p.read_bytes().removeprefix(b"\xef\xbb\xbf")
    start = 0
    while has_header:  # past the header, the first non-blank line
        end = data.find(b"\n", start)
        line, start = (data[start:], len(data)) if end < 0 else (data[start:end], end + 1)
        if line.strip() or end < 0:
            break
    rest = data[start:]
    if rest.translate(None, _PLAIN_BYTES + sep.encode()) or rest.isspace() or not rest:
        return None
    if b"\r" in rest and rest.count(b"\r") != rest.count(b"\r\n"):
        return None  # a bare carriage return: a line end to Python, not to polars
    out = _trimmed_polars(rest, header, columns, sep)
    if out is None:
        out = _loadtxt(rest, header, columns, sep)
    if out is None:
        return None
    if not allow_nan and not all(bool(np.isfinite(a).all()) for a in out.values()):
        return None
    return out


def _trimmed_polars(
    data: bytes, header: list[str], columns: Sequence[str], sep: str
) -> dict[str, NDArray[np.float64]] | None:
    """Numbers with spaces beside the separators (none beside a quote, none inside a number)
    read by polars once those spaces are gone; None where it refuses them."""
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n")
    first = data.find(b" ")
    if first >= 0:  # only the lines from the first space to the last are looked at, copied
        lo = data.rfind(b"\n", 0, first) + 1
        hi = data.find(b"\n", data.rfind(b" ")) + 1 or len(data)
        spaced = data[lo:hi]
        if b' "' in spaced or b'" ' in spaced:
            return None  # a quote after a space is no quote to Python's csv reader
        spaced = _trimmed(spaced, sep.encode())
        if b" " in spaced:
            return None  # a space inside a number: the line-by-line reader names it
        data = data[:lo] + spaced + data[hi:]
    data = data.lstrip(b"\n")
    if not data:
        return None
    try:
        parsed = _parse_block(data, header, header, (), sep=sep)  # all: a wider line refused
    except _CsvRefused:
        return None
    return {c: np.asarray(parsed[c], dtype=np.float64) for c in columns}


def _trimmed(data: bytes, sep: bytes) -> bytes:
    """Whole lines without the spaces beside a separator or at either end of a line."""
    for spaced, bare in ((b" " + sep, sep), (sep + b" ", sep), (b" \n", b"\n"), (b"\n ", b"\n")):
        while len(trimmed := data.replace(spaced, bare)) < len(data):  # a space a pass
            data = trimmed
    return data.strip(b" ")  # (the first line's start, the last one's end)


def _loadtxt(
    data: bytes, header: list[str], columns: Sequence[str], sep: str
) -> dict[str, NDArray[np.float64]] | None:
    """Numbers read by numpy's loadtxt (quotes understood, each line as wide as the header);
    None where it refuses them."""
    try:
        table = np.loadtxt(
            io.StringIO(data.decode("ascii")), dtype=np.float64, delimiter=sep, comments=None,
            quotechar='"', ndmin=2,
        )  # fmt: skip
    except ValueError:
        return None
    if table.shape[1] != len(header):
        return None
    return {c: np.ascontiguousarray(table[:, header.index(c)]) for c in columns}


def _csv_lines(
    p: Path,
    header: list[str],
    columns: Sequence[str],
    sep: str,
    allow_nan: bool,
    *,
    has_header: bool,
) -> dict[str, NDArray[np.float64]]:
    """Python's csv reader, line by line, and on any failure the first bad cell's line and
    column. A short line's missing cells are empty; a line with more cells than the header is
    refused."""
    idx = [header.index(c) for c in columns]
    out: list[list[float]] = [[] for _ in columns]
    with p.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        for lineno, line in _data_lines(fh, has_header):  # a quote never spans lines here
            try:
                row = next(csv.reader([line], delimiter=sep), [])
            except csv.Error:  # a cell over csv's 128 KiB field limit (lines may have 1 MB)
                row = line.rstrip("\r\n").split(sep)
            if len(row) > len(header):
                raise LogFormatError(
                    f"{p}: line {lineno} has {len(row)} cells, expected at most "
                    f"{len(header)} (the header's)"
                )
            for k, (name, j) in enumerate(zip(columns, idx, strict=True)):
                cell = row[j].strip() if j < len(row) else ""
                value = _cell_value(cell)
                if value is None or (not allow_nan and not math.isfinite(value)):
                    raise LogFormatError(_not_a_number(p, lineno, name, cell))
                out[k].append(value)
    return {c: np.asarray(v, dtype=np.float64) for c, v in zip(columns, out, strict=True)}


def _cell_value(cell: str) -> float | None:
    """A cell as a number (nan for a missing value); None for anything else (a word, and the
    digit separators Python's float alone accepts)."""
    if cell in _MISSING:
        return math.nan
    if "_" in cell:
        return None
    try:
        return float(cell)
    except ValueError:
        return None
