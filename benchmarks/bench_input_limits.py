"""What the input limits cost: reading an encoder log CSV with and without the line check.

The check (:func:`odolab.io.limits.check_text_file`: every line at most 1 MB, UTF-8, no NUL
byte) streams the file once in 1 MiB chunks before pandas parses it. Baseline in the same run:
the same reader told the file was already checked. Also: how long the refusal of a sparse
1 GiB file of zero bytes takes (one chunk is read).

Usage: PYTHONPATH=src python benchmarks/bench_input_limits.py [--rows 1000000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from odolab.core.errors import LogFormatError
from odolab.io._table import read_numeric_columns
from odolab.io.limits import check_text_file


def _best(fn, repeat: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    cols = ("t", "left_ticks", "right_ticks")
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "enc.csv"
        rng = np.random.default_rng(0)
        t = np.arange(args.rows) * 0.05
        ticks = np.cumsum(rng.integers(0, 40, size=(args.rows, 2)), axis=0)
        np.savetxt(p, np.column_stack((t, ticks)), fmt=("%.9f", "%d", "%d"), delimiter=",",
                   header=",".join(cols), comments="")  # fmt: skip
        size = p.stat().st_size
        base = _best(lambda: read_numeric_columns(p, cols, checked=True), args.repeat)
        full = _best(lambda: read_numeric_columns(p, cols), args.repeat)
        scan = _best(lambda: check_text_file(p), args.repeat)
        print(f"encoder CSV: {args.rows} rows, {size / 1e6:.1f} MB")
        print(f"  read without the check: {base:.3f} s; with it: {full:.3f} s "
              f"(ratio {full / base:.3f}); the check alone {scan:.3f} s "
              f"= {size / scan / 1e9:.2f} GB/s")  # fmt: skip
        zeros = Path(d) / "zeros.csv"
        with zeros.open("wb") as fh:
            fh.truncate(1 << 30)

        def refuse() -> None:
            try:
                read_numeric_columns(zeros, cols)
            except LogFormatError:
                return
            raise AssertionError("a file of zero bytes was accepted")

        print(f"  refusing a sparse 1 GiB file of zero bytes: {_best(refuse, args.repeat):.4f} s")


if __name__ == "__main__":
    main()
