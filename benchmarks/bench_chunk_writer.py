"""The chunked odometry's writer, in one process (no start-up, so the machine's noise is smaller
than in bench_tabular.py's whole-process runs): ``odolab.io.chunked.integrate_file`` with its
writer thread against the same with every chunk written in the caller's thread, and the Parquet
writer's settings (no dictionary, statistics) against pyarrow's defaults; the library's own read
and write of the same file (polars for CSV, pyarrow for Parquet) is the baseline, measured in the
same rounds.

Each round runs every variant once (interleaved, so the machine's load hits them alike); the
best of the rounds, the spread, and the ratio of the bests to the baseline are printed.

Usage: python benchmarks/bench_chunk_writer.py [--rows 10000000] [--chunk 1000000] [--rounds 5]
       [--dir DIR]
"""

from __future__ import annotations

import argparse
import functools
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import odolab.io.chunked as chunked
import odolab.io.tabular as tabular
from odolab.core.params import PRESETS


def make_log(path: Path, rows: int) -> None:
    import polars as pl

    rng = np.random.default_rng(0)
    t = np.arange(rows) * 0.01
    left = (np.cumsum(rng.integers(-20, 60, rows)) + 5) % 32768
    right = (np.cumsum(rng.integers(-20, 60, rows)) + 9) % 32768
    frame = pl.DataFrame({"t": t, "left_ticks": left, "right_ticks": right})
    frame.write_parquet(path) if path.suffix == ".parquet" else frame.write_csv(path)


def library(src: Path, dst: Path) -> None:
    """The baseline: the library reads the log and writes five float columns of its length."""
    if src.suffix == ".csv":
        import polars as pl

        df = pl.read_csv(src)
        a = np.cumsum(df["left_ticks"].to_numpy() * 1.37e-3)
        t = df["t"].to_numpy()
        pl.DataFrame({"t": t, "x": a, "y": a * 0.7, "theta": a * 0.3, "heading": a}).write_csv(dst)
        return
    import pyarrow as pa
    import pyarrow.parquet as pq

    tab = pq.read_table(src)
    t = tab.column("t").to_numpy()
    a = np.cumsum(tab.column("left_ticks").to_numpy() * 1.37e-3)
    pq.write_table(pa.table({"t": t, "x": a, "y": a * 0.7, "theta": a * 0.3, "heading": a}), dst)


def odolab(src: Path, dst: Path, chunk: int, *, background: bool, defaults: bool) -> None:
    """``integrate_file``; ``background=False``: chunks written in this thread; ``defaults``:
    pyarrow's ParquetWriter defaults (a dictionary tried on every column)."""
    writer = functools.partial(tabular.ChunkWriter, background=background)
    options = dict(tabular.PARQUET_WRITER_OPTIONS)
    if defaults:
        tabular.PARQUET_WRITER_OPTIONS.clear()
    chunked.ChunkWriter = writer  # type: ignore[misc]
    try:
        chunked.integrate_file(src, dst, PRESETS["jaguar-lite"], chunk_rows=chunk)
    finally:
        chunked.ChunkWriter = tabular.ChunkWriter  # type: ignore[misc]
        tabular.PARQUET_WRITER_OPTIONS.update(options)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--chunk", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--dir", type=Path, default=None)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        csv, pq = d / "log.csv", d / "log.parquet"
        make_log(csv, a.rows)
        make_log(pq, a.rows)
        c = a.chunk
        variants: dict[str, Callable[[], None]] = {
            "CSV: polars read+write": lambda: library(csv, d / "b.csv"),
            "CSV: odolab, writer thread": lambda: odolab(
                csv, d / "o.csv", c, background=True, defaults=False
            ),
            "CSV: odolab, written in turn": lambda: odolab(
                csv, d / "o.csv", c, background=False, defaults=False
            ),
            "Parquet: pyarrow read+write": lambda: library(pq, d / "b.parquet"),
            "Parquet: odolab, writer thread": lambda: odolab(
                pq, d / "o.parquet", c, background=True, defaults=False
            ),
            "Parquet: odolab, written in turn": lambda: odolab(
                pq, d / "o.parquet", c, background=False, defaults=False
            ),
            "Parquet: odolab, thread, pyarrow's defaults": lambda: odolab(
                pq, d / "o.parquet", c, background=True, defaults=True
            ),
        }
        for run in variants.values():  # warm: the kernels, the disk cache
            run()
        times: dict[str, list[float]] = {k: [] for k in variants}
        for _ in range(a.rounds):
            for name, run in variants.items():
                t0 = time.perf_counter()
                run()
                times[name].append(time.perf_counter() - t0)
    print(f"{a.rows:,} rows, chunks of {c:,}; {a.rounds} interleaved rounds, in one process")
    for name, ts in times.items():
        base = times["CSV: polars read+write" if name.startswith("CSV") else
                     "Parquet: pyarrow read+write"]  # fmt: skip
        print(f"  {name:44s} best {min(ts):6.3f} s ({min(ts):.3f}-{max(ts):.3f})  "
              f"{min(ts) / min(base):.2f} x the library")  # fmt: skip


if __name__ == "__main__":
    main()
