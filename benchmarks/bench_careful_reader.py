"""The careful CSV reader (odolab.io._table, what polars refuses) against polars and pandas, in
the same run.

For each size (1e5 and 1e6 rows of t,x,y,theta) two files are written: a clean one, and the same
numbers with spaces around the first data line's cells (two quoted) and a blank line before the header (polars'
fast path refuses it; the careful reader reads it). Timed, best of ``--repeat``:

- polars: ``pl.read_csv`` of the clean file (the fast path's speed: the baseline, ratio 1);
- pandas: ``pd.read_csv`` of the refused file (the reader the careful one replaced);
- careful: ``read_numeric_columns`` of the refused file (numpy's loadtxt on numbers alone);
- careful, line by line: its Python csv loop (what a file with a word or a short line gets, and
  all the careful reader did before).

Usage: python benchmarks/bench_careful_reader.py [--rows 100000 1000000] [--repeat 3] [--dir DIR]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

COLUMNS = ("t", "x", "y", "theta")


def write_files(d: Path, rows: int) -> tuple[Path, Path]:
    rng = np.random.default_rng(7)
    data = np.column_stack(
        [np.arange(rows) * 0.01, *(np.cumsum(rng.normal(0, 0.01, (3, rows)), axis=1))]
    )
    clean = d / f"clean{rows}.csv"
    np.savetxt(clean, data, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.9g")
    text = clean.read_text().split("\n", 2)
    cells = text[1].split(",")
    first = ",".join(f'"{c}"' if i % 2 else f" {c} " for i, c in enumerate(cells))
    refused = d / f"refused{rows}.csv"
    refused.write_text("\n" + text[0] + "\n" + first + "\n" + text[2])
    return clean, refused


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", type=Path, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        for rows in args.rows:
            clean, refused = write_files(Path(tmp), rows)
            times = measure(clean, refused, args.repeat)
            base = times["polars (clean file)"]
            pandas = times["pandas (refused file)"]
            print(f"{rows:>9} rows ({refused.stat().st_size / 1e6:.1f} MB):")
            for name, t in times.items():
                print(
                    f"  {name:<24} {t:8.3f} s  {t / base:6.1f}x polars  {t / pandas:6.1f}x pandas"
                )


def measure(clean: Path, refused: Path, repeat: int) -> dict[str, float]:
    """Best-of-``repeat`` seconds of each reader (the values checked equal first)."""
    import pandas as pd
    import polars as pl

    from odolab.io._table import _csv_lines, read_numeric_columns
    from odolab.io.tabular import _fast_csv, read_header

    header = read_header(refused)
    assert _fast_csv(refused, header, COLUMNS, ()) is None  # polars refuses it
    expected = pl.read_csv(clean, columns=list(COLUMNS)).to_numpy()
    got = read_numeric_columns(refused, COLUMNS)
    assert np.array_equal(np.column_stack([got[c] for c in COLUMNS]), expected)
    floats = dict.fromkeys(COLUMNS, pl.Float64)
    timings = {
        "polars (clean file)": lambda: pl.read_csv(
            clean, columns=list(COLUMNS), schema_overrides=floats
        ),
        "pandas (refused file)": lambda: pd.read_csv(
            refused, usecols=list(COLUMNS), dtype=float, skip_blank_lines=True
        ),
        "careful (refused file)": lambda: read_numeric_columns(refused, COLUMNS),
        "careful, line by line": lambda: _csv_lines(
            refused, header, COLUMNS, ",", False, has_header=True
        ),
    }
    return {name: best(fn, repeat) for name, fn in timings.items()}


if __name__ == "__main__":
    main()
