"""Tabular I/O and `odolab odometry` at the speed of the disk, against baselines in the same run.

1. Libraries: pyarrow vs polars reading a 10 M-row encoder CSV, writing a 5-column CSV of the
   same length, reading and writing Parquet (the measurement behind choosing polars + pyarrow).
2. `odolab odometry` end to end (a fresh process each, as a user runs it):
   - CSV -> CSV, ratio to a process where polars reads the input and writes an output of the
     same shape (acceptance: <= 1.5);
   - Parquet -> Parquet, ratio to a process where pyarrow reads the input and writes an output of
     the same shape (acceptance: <= 1.2);
   - the same with --covariance (six more columns): the cost of the covariance, end to end.
3. Peak memory (VmHWM, the process's peak RSS, minus that of the same command on a 3-row log):
   - whole-file (--chunk-rows 0) on the 10 M-row log, ratio to the output arrays (5 x 8 bytes x
     rows; acceptance: <= 2);
   - chunked: logs of 10x and 100x the chunk: the extra memory stays flat (bounded by the chunk).

Usage: python benchmarks/bench_tabular.py [--rows 10000000] [--chunk 100000] [--dir DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RUN = r"""
import json, sys, time
def hwm():  # this process's peak RSS (ru_maxrss would carry the parent's across exec)
    for line in open('/proc/self/status'):
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) * 1024
t0 = time.perf_counter()
from odolab.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "s": time.perf_counter() - t0,
                  "rss": hwm()}),
      file=sys.stderr)
"""

POLARS = r"""
import json, sys, time
def hwm():  # this process's peak RSS (ru_maxrss would carry the parent's across exec)
    for line in open('/proc/self/status'):
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) * 1024
t0 = time.perf_counter()
import numpy as np, polars as pl
src, dst = sys.argv[1], sys.argv[2]
df = pl.read_csv(src)
t = df["t"].to_numpy()
a = np.cumsum(df["left_ticks"].to_numpy() * 1.37e-3)  # full-precision numbers, like poses
out = pl.DataFrame({"t": t, "x": a, "y": a * 0.7, "theta": a * 0.3, "heading": a * 1.1})
out.write_csv(dst)
print(json.dumps({"s": time.perf_counter() - t0,
                  "rss": hwm()}),
      file=sys.stderr)
"""

PYARROW = r"""
import json, sys, time
def hwm():  # this process's peak RSS (ru_maxrss would carry the parent's across exec)
    for line in open('/proc/self/status'):
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) * 1024
t0 = time.perf_counter()
import pyarrow as pa, pyarrow.parquet as pq
src, dst = sys.argv[1], sys.argv[2]
import numpy as np
tab = pq.read_table(src)
t = tab.column("t").to_numpy()
a = np.cumsum(tab.column("left_ticks").to_numpy() * 1.37e-3)  # full-precision numbers
out = pa.table({"t": t, "x": a, "y": a * 0.7, "theta": a * 0.3, "heading": a * 1.1})
pq.write_table(out, dst)
print(json.dumps({"s": time.perf_counter() - t0,
                  "rss": hwm()}),
      file=sys.stderr)
"""


def run(script: str, *args: str) -> dict[str, float]:
    """Run a Python snippet in a fresh process; wall time (s) from outside, its JSON line."""
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", script, *args], capture_output=True, text=True, check=False
    )
    wall = time.perf_counter() - t0
    last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "{}"
    try:
        doc = json.loads(last)
    except json.JSONDecodeError:
        raise SystemExit(f"failed: {args}\n{proc.stdout}\n{proc.stderr}") from None
    if doc.get("code", 0) != 0:
        raise SystemExit(f"failed: {args}\n{proc.stderr}")
    doc["wall"] = wall
    return doc


def make_log(path: Path, rows: int, seed: int = 0) -> None:
    import polars as pl

    rng = np.random.default_rng(seed)
    t = np.arange(rows) * 0.01
    left = (np.cumsum(rng.integers(-20, 60, rows)) + 5) % 32768
    right = (np.cumsum(rng.integers(-20, 60, rows)) + 9) % 32768
    frame = pl.DataFrame({"t": t, "left_ticks": left, "right_ticks": right})
    if path.suffix == ".parquet":
        frame.write_parquet(path)
    else:
        frame.write_csv(path)


def libraries(folder: Path, rows: int) -> None:
    import polars as pl
    import pyarrow as pa
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    csv, parquet = folder / f"log{rows}.csv", folder / f"log{rows}.parquet"
    rng = np.random.default_rng(1)
    cols = {c: rng.standard_normal(rows) for c in ("t", "x", "y", "theta", "heading")}
    arrow, frame = pa.table(cols), pl.DataFrame(cols)

    def timed(f) -> float:  # type: ignore[no-untyped-def]
        t0 = time.perf_counter()
        f()
        return time.perf_counter() - t0

    rows_out = [
        ("read CSV (3 cols)", timed(lambda: pcsv.read_csv(csv)), timed(lambda: pl.read_csv(csv))),
        ("write CSV (5 float cols)",
         timed(lambda: pcsv.write_csv(arrow, folder / "a.csv")),
         timed(lambda: frame.write_csv(folder / "p.csv"))),
        ("read Parquet", timed(lambda: pq.read_table(parquet)),
         timed(lambda: pl.read_parquet(parquet))),
        ("write Parquet (5 float cols)",
         timed(lambda: pq.write_table(arrow, folder / "a.parquet")),
         timed(lambda: frame.write_parquet(folder / "p.parquet"))),
    ]  # fmt: skip
    print(f"\n1. libraries, {rows:,} rows (s; lower is better)")
    print(f"   {'':30s} {'pyarrow':>8s} {'polars':>8s}")
    for name, a, b in rows_out:
        print(f"   {name:30s} {a:8.2f} {b:8.2f}")
    for f in ("a.csv", "p.csv", "a.parquet", "p.parquet"):
        (folder / f).unlink()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--chunk", type=int, default=100_000)
    ap.add_argument("--dir", type=Path, default=None)
    ap.add_argument("--skip-libraries", action="store_true")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        n = a.rows
        csv, parquet, tiny = d / f"log{n}.csv", d / f"log{n}.parquet", d / "tiny.csv"
        make_log(csv, n)
        make_log(parquet, n)
        make_log(tiny, 3)
        print(f"log: {n:,} rows, CSV {csv.stat().st_size / 1e6:.0f} MB, "
              f"Parquet {parquet.stat().st_size / 1e6:.0f} MB")  # fmt: skip
        if not a.skip_libraries:
            libraries(d, n)

        print("\n2. odolab odometry, end to end (fresh processes; wall s)")
        base_csv = run(POLARS, str(csv), str(d / "polars.csv"))
        whole_csv = run(RUN, "odometry", str(csv), "-o", str(d / "o.csv"), "--chunk-rows", "0")
        chunk_csv = run(RUN, "odometry", str(csv), "-o", str(d / "c.csv"))
        base_pq = run(PYARROW, str(parquet), str(d / "pyarrow.parquet"))
        whole_pq = run(RUN, "odometry", str(parquet), "-o", str(d / "o.parquet"),
                       "--chunk-rows", "0")  # fmt: skip
        chunk_pq = run(RUN, "odometry", str(parquet), "-o", str(d / "c.parquet"),
                       "--chunk-rows", "1000000")  # fmt: skip
        print(
            f"   CSV -> CSV      polars read+write {base_csv['wall']:6.2f}   odolab whole "
            f"{whole_csv['wall']:6.2f} (ratio {whole_csv['wall'] / base_csv['wall']:.2f}, "
            f"acceptance <= 1.5)   odolab default (chunks of 1 M) {chunk_csv['wall']:6.2f} "
            f"(ratio {chunk_csv['wall'] / base_csv['wall']:.2f})"
        )
        print(
            f"   Parquet -> Parq pyarrow read+write {base_pq['wall']:5.2f}   odolab whole "
            f"{whole_pq['wall']:6.2f} (ratio {whole_pq['wall'] / base_pq['wall']:.2f}, "
            f"acceptance <= 1.2)   odolab chunks of 1 M {chunk_pq['wall']:6.2f} "
            f"(ratio {chunk_pq['wall'] / base_pq['wall']:.2f})"
        )
        from odolab.params import PRESETS, NoiseParams, save_params

        noisy = save_params(
            d / "noisy.toml", PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 2e-4))
        )
        cov = ("-p", str(noisy), "--covariance", "--chunk-rows", "0")
        cov_csv = run(RUN, "odometry", str(csv), "-o", str(d / "v.csv"), *cov)
        cov_pq = run(RUN, "odometry", str(parquet), "-o", str(d / "v.parquet"), *cov)
        for name, r, plain in (("CSV", cov_csv, whole_csv), ("Parquet", cov_pq, whole_pq)):
            print(
                f"   --covariance, {name:7s} whole {r['wall']:6.2f} s = {r['wall'] / plain['wall']:.2f}"
                " x without (11 columns instead of 5)"
            )

        print("\n3. peak memory (max RSS minus the same command on a 3-row log)")
        floor = run(RUN, "odometry", str(tiny), "-o", str(d / "t.csv"))["rss"]
        out_bytes = 5 * 8 * n
        for name, r in (("CSV whole", whole_csv), ("Parquet whole", whole_pq)):
            extra = r["rss"] - floor
            print(
                f"   {name:14s} +{extra / 1e6:7.0f} MB = {extra / out_bytes:.2f} x the output "
                f"arrays ({out_bytes / 1e6:.0f} MB; acceptance <= 2)"
            )
        small = d / "log_small.csv"
        make_log(small, 10 * a.chunk, seed=3)
        for name, log, rows in (("10x", small, 10 * a.chunk), ("100x", csv, n)):
            if rows != 100 * a.chunk and name == "100x":
                name = f"{rows // a.chunk}x"
            r = run(RUN, "odometry", str(log), "-o", str(d / "k.csv"),
                    "--chunk-rows", str(a.chunk))  # fmt: skip
            extra = r["rss"] - floor
            print(
                f"   chunked, log {name:>5s} the chunk ({rows:>11,} rows, chunk {a.chunk:,}): "
                f"+{extra / 1e6:5.0f} MB (the whole log's output arrays: "
                f"{5 * 8 * rows / 1e6:5.0f} MB) in {r['wall']:.2f} s"
            )


if __name__ == "__main__":
    main()
