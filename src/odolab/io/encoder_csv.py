"""Encoder log CSV: header ``t,left_ticks,right_ticks`` (s; raw counters, may wrap).

Per-cycle increments are read too, with header ``t,dticks_left,dticks_right``: they are summed
into counters that never wrap. The same columns in a Parquet (``.parquet``) or Arrow IPC
(``.arrow``, ``.feather``) file are read and written by extension (:mod:`odolab.io.tabular`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import overload

import numpy as np
from numpy.typing import NDArray

from odolab.core.encoders import as_tick_array
from odolab.core.errors import LogFormatError
from odolab.core.trajectory import check_times
from odolab.core.trials import EncoderLog
from odolab.core.writing import path_first
from odolab.io._table import Column, data_line_numbers
from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells
from odolab.io.tabular import read_columns, read_header, table_format, write_columns

__all__ = ["check_encoder_header", "read_encoder_csv", "write_encoder_csv"]

RAW = ("t", "left_ticks", "right_ticks")
INCREMENTS = ("t", "dticks_left", "dticks_right")


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def check_encoder_header(p: Path, cells: list[str]) -> None:
    """Refuse a CSV whose first line is data, not a header (one sentence: what is expected).

    Raises:
        LogFormatError: the first line is data, or lacks the encoder log's columns.
    """
    if not cells or not all(_is_number(c) for c in cells):
        return
    from odolab.core.text import safe_terminal, shorten

    raise LogFormatError(
        f"{p}: line 1 ({safe_terminal(shorten(','.join(cells), 80))}) is data, not a header; "
        "expected the header line t,left_ticks,right_ticks (raw counters) or "
        "t,dticks_left,dticks_right (per-cycle increments) first"
        + (
            " (an OptiOdom run: give {{format}} optiodom)"
            if len(cells) == 6 and "_run-" in p.name
            else ""
        )
    )


#: Largest count a float64 holds exactly (2**53).
_EXACT = float(2**53)


def _ticks(
    p: Path,
    values: Column,
    name: str,
    line_of: Callable[[int], int],
    where: str = "line",
) -> NDArray[np.int64]:
    """The column as integer counts; a fractional value, or one past 2**53 (where a float
    holds no exact count), is refused naming its line."""
    if values.dtype.kind == "i":  # read as integers: nothing to check
        return values.astype(np.int64, copy=False)
    if values.dtype.kind != "f":
        return as_tick_array(values, name)  # (refuses it)
    rounded = np.rint(values)
    off = ~((np.abs(values - rounded) <= 1e-6) & (np.abs(rounded) <= _EXACT))  # (NaN, inf too)
    if off.any():
        i = int(np.argmax(off))
        raise LogFormatError(
            f"{p}: {where} {line_of(i)}, column {name!r} is {values[i]}, expected an integer count"
        )
    ints: NDArray[np.int64] = rounded.astype(np.int64)
    return ints


def read_encoder_csv(path: str | Path, *, modulus: int | None = None) -> EncoderLog:
    """Read an encoder log; raw counters keep ``modulus`` (the robot's), increments get None.

    Raises:
        LogFormatError: the path is a folder, the log has no samples, or a time or count is wrong
            (the line is named).
    """
    p = Path(path)
    if p.exists() and not p.is_file():
        raise LogFormatError(f"{p}: is not a file (a folder?); expected an encoder log CSV")
    text = table_format(p) == "csv"
    if text:
        check_text_file(p, expected="an encoder log CSV")
        cells = first_line_cells(p)
        check_encoder_header(p, cells)
        check_columns_unique(p, cells)
    header = read_header(p)  # the header without pandas (its import is a second of a run)
    increments = "dticks_left" in header and "left_ticks" not in header
    cols = INCREMENTS if increments else RAW
    data = read_columns(p, cols, integer=cols[1:], checked=True)
    t = np.asarray(data["t"], dtype=np.float64)  # (float64 already: not in ``integer``)
    if t.size == 0:
        raise LogFormatError(f"{p}: no samples after the header")

    where = "line" if text else "row"

    def line_of(i: int) -> int:
        return int(data_line_numbers(p)[i]) if text else i + 1

    check_times(t, str(p), line_of=line_of, what=where)
    left = _ticks(p, data[cols[1]], cols[1], line_of, where)
    right = _ticks(p, data[cols[2]], cols[2], line_of, where)
    if increments:
        left = np.cumsum(left)
        right = np.cumsum(right)
        left -= left[0]
        right -= right[0]
        return EncoderLog(t, left, right, None)
    if modulus is not None:
        check_counter_range(p, cols, left, right, modulus, line_of, where)
    return EncoderLog(t, left, right, modulus)


def check_counter_range(
    p: Path,
    cols: tuple[str, ...],
    left: NDArray[np.int64],
    right: NDArray[np.int64],
    modulus: int,
    line_of: Callable[[int], int],
    where: str,
) -> None:
    """Raw counters must lie in 0..modulus-1: one sentence naming the line (or row) otherwise.

    Raises:
        LogFormatError: a raw counter value lies outside 0..modulus-1 (the line is named).
    """
    for name, arr in ((cols[1], left), (cols[2], right)):
        if arr.size == 0 or (arr.min() >= 0 and arr.max() < modulus):
            continue  # (two reductions: a third of the time of the element-wise test)
        out = (arr < 0) | (arr >= modulus)
        if out.any():
            i = int(np.argmax(out))
            raise LogFormatError(
                f"{p}: {where} {line_of(i)}, column {name!r} is {arr[i]}, expected a counter "
                f"value in 0..{modulus - 1} (encoder_modulus {modulus})"
            )


@overload
def write_encoder_csv(path: str | Path, log: EncoderLog) -> Path: ...
@overload
def write_encoder_csv(path: EncoderLog, log: str | Path) -> Path: ...  # the old order
def write_encoder_csv(path: str | Path | EncoderLog, log: EncoderLog | str | Path) -> Path:
    """Write ``t,left_ticks,right_ticks`` (raw counters) to ``path``; CSV (shortest round-trip
    text), Parquet or Arrow IPC by extension."""
    p, entry = path_first(path, log, EncoderLog, "write_encoder_csv")
    columns = dict(zip(RAW, (entry.t, entry.left_ticks, entry.right_ticks), strict=True))
    return write_columns(p, columns, "encoder log")
