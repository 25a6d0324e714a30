"""The careful CSV reader's fast case (numpy's loadtxt on a file of numbers alone) gives what its
line-by-line reader gives: the same values, or (by handing the file over) the same message."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odolab.core.errors import LogFormatError
from odolab.io._table import _csv_lines, _plain_numbers, read_numeric_columns

HEADER = ["a", "b", "c"]
#: Cells the fast case reads, then ones it must hand over (a word, a quote around a comma, ...).
PLAIN = ["1", "2.5", " 3 ", '"4"', '" 5.5"', ' "4"', '"4" ', '""4', '"1"2', "1e3", "-0.5",
         "+7", ".5", "1.", "", '""']  # fmt: skip
ODD = ["1_0", "0x10", "1e999", "1 2", '"1,5"', "e5", "--1", "1e", ".", "nan", "\t1"]


def _read(f: object, p: Path, cols: list[str], allow_nan: bool) -> object:
    try:
        got = f(p, HEADER, cols, ",", allow_nan, has_header=True)  # type: ignore[operator]
    except LogFormatError as err:
        return f"error: {err}"
    return None if got is None else {c: v.tolist() for c, v in got.items()}


def test_the_fast_case_reads_what_the_line_by_line_reader_reads(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    p = tmp_path / "log.csv"
    fast_used = 0
    for _ in range(100):
        lines = [",".join(HEADER)]
        for _ in range(int(rng.integers(1, 5))):
            width = 3 if rng.random() > 0.1 else int(rng.integers(1, 5))  # a short or long line
            pool = PLAIN if rng.random() < 0.8 else PLAIN + ODD
            lines.append(",".join(pool[int(rng.integers(0, len(pool)))] for _ in range(width)))
            if rng.random() < 0.15:
                lines.append(["", " ", ",,"][int(rng.integers(0, 3))])
        end = ["\n", "\r\n"][int(rng.integers(0, 2))]
        p.write_bytes(
            (["", "\n", "\r\n\n"][int(rng.integers(0, 3))] + end.join(lines) + end).encode()
        )
        for allow_nan in (False, True):
            for cols in (HEADER, ["b"]):
                fast = _read(_plain_numbers, p, cols, allow_nan)
                if fast is not None:
                    fast_used += 1
                    assert fast == _read(_csv_lines, p, cols, allow_nan), p.read_bytes()
    assert fast_used > 20  # the comparison is not empty (measured: 48 of 400 read fast)


def test_a_quoted_log_is_read_fast_and_a_word_still_named(tmp_path: Path) -> None:
    p = tmp_path / "log.csv"
    p.write_text('\nt,x\n"0", 1.5 \n\n1,2\n')
    assert _plain_numbers(p, ["t", "x"], ["x"], ",", False, has_header=True) is not None
    assert read_numeric_columns(p, ["t", "x"])["x"].tolist() == [1.5, 2.0]
    p.write_text('\nt,x\n"0", 1.5 \n\n1,two\n')
    assert _plain_numbers(p, ["t", "x"], ["x"], ",", False, has_header=True) is None
    try:
        read_numeric_columns(p, ["t", "x"])
    except LogFormatError as err:
        assert str(err) == f"{p}: line 5, column 'x' is 'two', expected a number"
    else:
        raise AssertionError("a word was read as a number")
