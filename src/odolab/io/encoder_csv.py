"""Encoder log CSV: header ``t,left_ticks,right_ticks`` (s; raw counters, may wrap).

Per-cycle increments are read too, with header ``t,dticks_left,dticks_right``: they are summed
into counters that never wrap.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import overload

import numpy as np
from numpy.typing import NDArray

from odolab.encoders import as_tick_array
from odolab.errors import LogFormatError
from odolab.io._table import data_line_numbers, read_numeric_columns
from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells
from odolab.trajectory import check_times
from odolab.trials import EncoderLog
from odolab.writing import path_first

__all__ = ["read_encoder_csv", "write_encoder_csv"]

RAW = ("t", "left_ticks", "right_ticks")
INCREMENTS = ("t", "dticks_left", "dticks_right")


def _ticks(
    p: Path, values: NDArray[np.float64], name: str, line_of: Callable[[int], int]
) -> NDArray[np.int64]:
    """The column as integer counts; a fractional value is refused naming its line."""
    off = np.abs(values - np.rint(values)) > 1e-6
    if off.any():
        i = int(np.argmax(off))
        raise LogFormatError(
            f"{p}: line {line_of(i)}, column {name!r} is {values[i]}, expected an integer count"
        )
    return as_tick_array(values, name)


def read_encoder_csv(path: str | Path, *, modulus: int | None = None) -> EncoderLog:
    """Read an encoder log; raw counters keep ``modulus`` (the robot's), increments get None."""
    p = Path(path)
    import pandas as pd

    if p.exists() and not p.is_file():
        raise LogFormatError(f"{p}: is not a file (a folder?); expected an encoder log CSV")
    check_text_file(p, expected="an encoder log CSV")
    check_columns_unique(p, first_line_cells(p))
    try:
        header = [str(c).strip() for c in pd.read_csv(p, nrows=0, encoding="utf-8-sig").columns]
    except FileNotFoundError as err:
        raise LogFormatError(f"{p}: no such file") from err
    except (pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise LogFormatError(f"{p}: empty or unreadable file; expected a header line") from err
    increments = "dticks_left" in header and "left_ticks" not in header
    cols = INCREMENTS if increments else RAW
    data = read_numeric_columns(p, cols, checked=True)
    t = data["t"]
    if t.size == 0:
        raise LogFormatError(f"{p}: no samples after the header")

    def line_of(i: int) -> int:
        return int(data_line_numbers(p)[i])

    check_times(t, str(p), line_of=line_of)
    left = _ticks(p, data[cols[1]], cols[1], line_of)
    right = _ticks(p, data[cols[2]], cols[2], line_of)
    if increments:
        left = np.cumsum(left)
        right = np.cumsum(right)
        left -= left[0]
        right -= right[0]
        return EncoderLog(t, left, right, None)
    if modulus is not None:
        for name, arr in (("left_ticks", left), ("right_ticks", right)):
            out = (arr < 0) | (arr >= modulus)
            if out.any():
                i = int(np.argmax(out))
                raise LogFormatError(
                    f"{p}: line {line_of(i)}, column {name!r} is {arr[i]}, expected a counter value in "
                    f"0..{modulus - 1} (encoder_modulus {modulus})"
                )
    return EncoderLog(t, left, right, modulus)


@overload
def write_encoder_csv(path: str | Path, log: EncoderLog) -> Path: ...
@overload
def write_encoder_csv(path: EncoderLog, log: str | Path) -> Path: ...  # the old order
def write_encoder_csv(path: str | Path | EncoderLog, log: EncoderLog | str | Path) -> Path:
    """Write ``t,left_ticks,right_ticks`` (raw counters) to ``path``."""
    p, entry = path_first(path, log, EncoderLog, "write_encoder_csv")
    return _write_encoder_csv(entry, p)


def _write_encoder_csv(log: EncoderLog, path: str | Path) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    table = np.column_stack((log.t, log.left_ticks, log.right_ticks))
    np.savetxt(p, table, fmt=("%.9f", "%d", "%d"), delimiter=",", header=",".join(RAW), comments="")
    return p
