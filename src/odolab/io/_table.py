"""Shared numeric-table parsing with error messages that name the file, line and column."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from odolab.errors import LogFormatError

__all__ = ["read_numeric_columns"]


def _locate_bad_cell(path: Path, header: list[str], wanted: Sequence[str], sep: str) -> str:
    """Find the first cell of ``wanted`` columns that is not a number; describe it."""
    with path.open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.reader(fh, delimiter=sep) if sep != r"\s+" else (ln.split() for ln in fh)
        next(iter(reader), None)
        idx = {name: header.index(name) for name in wanted}
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            for name, j in idx.items():
                cell = row[j].strip() if j < len(row) else ""
                try:
                    float(cell)
                except ValueError:
                    shown = repr(cell) if cell else "empty"
                    return f"{path}: line {lineno}, column {name!r} is {shown}, expected a number"
    return f"{path}: could not parse as numbers"


def read_numeric_columns(
    path: str | Path,
    columns: Sequence[str],
    *,
    sep: str = ",",
    names: Sequence[str] | None = None,
    allow_nan: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Read the named columns of a delimited text file as float64 arrays.

    With ``names`` the file has no header and columns are given those names. Every error is a
    :class:`LogFormatError` naming the file, and the line and column where there is one.
    """
    p = Path(path)
    if not p.exists():
        raise LogFormatError(f"{p}: no such file")
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
            f"{p}: missing column {missing[0]!r}; the header has {', '.join(header) or 'nothing'}"
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
        raise LogFormatError(_locate_bad_cell(p, header, columns, sep)) from err
    out: dict[str, NDArray[np.float64]] = {}
    first_line = 1 if names is not None else 2
    for name in columns:
        arr = frame[name].to_numpy(dtype=np.float64)
        if not allow_nan:
            bad = ~np.isfinite(arr)
            if bad.any():
                i = int(np.argmax(bad))
                what = "empty" if np.isnan(arr[i]) else str(arr[i])
                raise LogFormatError(
                    f"{p}: line {i + first_line}, column {name!r} is {what}, expected a number"
                )
        out[name] = arr
    return out
