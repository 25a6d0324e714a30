"""Shared numeric-table parsing with error messages that name the file, line and column."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from odolab.errors import LogFormatError
from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells
from odolab.text import quote_input, safe_terminal, shorten

__all__ = ["data_line_numbers", "read_numeric_columns"]


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
        for lineno, line in enumerate(fh, start=1):
            if has_header and lineno == 1:
                continue
            if not line.strip():
                continue  # a blank line is no row (a line of empty cells is one)
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
                    shown = quote_input(cell) if cell else "empty"
                    return f"{path}: line {lineno}, column {name!r} is {shown}, expected a number"
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
        for lineno, line in enumerate(fh, start=1):
            if has_header and lineno == 1:
                continue
            text = line.strip()
            if not text or (sep == r"\s+" and text.startswith("#")):
                continue
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

    With ``names`` the file has no header and columns are given those names. Every error is a
    :class:`LogFormatError` naming the file, and the line and column where there is one. The
    file's lines are checked first (:func:`odolab.io.limits.check_text_file`; ``checked``: the
    caller already did) and a header that names a column twice is refused.
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
    try:
        if names is None:
            head = pd.read_csv(p, sep=sep, nrows=0, encoding="utf-8-sig")
            header = [str(c).strip() for c in head.columns]
        else:
            header = list(names)
    except (pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise LogFormatError(f"{p}: empty or unreadable file; expected a header line") from err
    missing = [c for c in columns if c not in header]
    if missing:
        raise LogFormatError(
            f"{p}: missing column {missing[0]!r}; the header has "
            f"{safe_terminal(shorten(', '.join(header), 200)) or 'nothing'}"
            f" but {', '.join(columns)} are expected"
        )
    try:
        frame = pd.read_csv(
            p,
            sep=sep,
            header=None if names is not None else 0,
            names=header,
            usecols=list(columns),
            dtype=dict.fromkeys(columns, np.float64),
            skip_blank_lines=True,
            encoding="utf-8-sig",
            engine="c" if sep != r"\s+" else "python",
            comment="#" if sep == r"\s+" else None,
        )
    except (ValueError, pd.errors.ParserError) as err:
        raise LogFormatError(
            _locate_bad_cell(p, header, columns, sep, has_header=names is None)
        ) from err
    out: dict[str, NDArray[np.float64]] = {}
    for name in columns:
        arr = frame[name].to_numpy(dtype=np.float64)
        if not allow_nan:
            bad = ~np.isfinite(arr)
            if bad.any():
                raise LogFormatError(
                    _locate_bad_cell(p, header, [name], sep, has_header=names is None, finite=True)
                )
        out[name] = arr
    return out
