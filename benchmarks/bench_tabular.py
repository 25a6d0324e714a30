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

4. `odolab evaluate GT EST` on two trajectories of ``--eval-rows`` poses (Parquet; the estimate
   at shifted stamps, with noise): whole (--chunk-rows 0) against chunks of 1 M and of
   ``--chunk`` rows, time and peak memory (over the same command on 3-row files); the chunked
   peak stays flat from 10x to 100x the chunk.

Usage: python benchmarks/bench_tabular.py [--rows 10000000] [--chunk 100000] [--dir DIR]
       [--eval-rows 10000000] [--repeat 3] [--skip-libraries] [--skip-odometry]
       [--skip-evaluate]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

PRELUDE = r"""
import json, sys, time
def hwm():  # this process's peak RSS (ru_maxrss would carry the parent's across exec)
    for line in open('/proc/self/status'):
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) * 1024
"""

RUN = (
    PRELUDE
    + r"""
t0 = time.perf_counter()
from odolab.cli import main
code = main()  # as the odolab program calls it (its arguments: sys.argv[1:])
print(json.dumps({"code": code, "s": time.perf_counter() - t0,
                  "rss": hwm()}),
      file=sys.stderr)
"""
)

POLARS = (
    PRELUDE
    + r"""
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
)

PYARROW = (
    PRELUDE
    + r"""
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
)


def run(script: str, *args: str, src: Path | None = None) -> dict[str, float]:
    """Run a Python snippet in a fresh process; wall time (s) from outside, its JSON line.
    ``src``: another odolab source tree first on the path (``--before``)."""
    env = None
    if src is not None:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(src), *filter(None, [os.environ.get("PYTHONPATH")])])}  # fmt: skip
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", script, *args], capture_output=True, text=True, check=False,
        env=env,
    )  # fmt: skip
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


def make_trajectories(folder: Path, rows: int, seed: int = 2) -> tuple[Path, Path]:
    """GT (100 Hz) and EST (the same path, stamps 3 ms later, positions with 1 cm noise)."""
    import polars as pl

    rng = np.random.default_rng(seed)
    t = np.arange(rows) * 0.01
    h = np.cumsum(rng.normal(0.0, 0.01, rows))
    x = np.cumsum(np.cos(h) * 0.005)
    y = np.cumsum(np.sin(h) * 0.005)
    wrap = np.angle(np.exp(1j * h))
    gt, est = folder / f"gt{rows}.parquet", folder / f"est{rows}.parquet"
    pl.DataFrame({"t": t, "x": x, "y": y, "theta": wrap, "heading": h}).write_parquet(gt)
    noise = rng.normal(0.0, 0.01, (2, rows))
    pl.DataFrame(
        {"t": t + 0.003, "x": x + noise[0], "y": y + noise[1], "theta": wrap, "heading": h}
    ).write_parquet(est)
    return gt, est


def evaluation(folder: Path, rows: int, chunk: int) -> None:
    print(f"\n4. odolab evaluate GT EST, {rows:,} poses each (Parquet; fresh processes)")
    tiny = make_trajectories(folder, 3)
    floor = run(RUN, "evaluate", *map(str, tiny), "--chunk-rows", "0")["rss"]
    gt, est = make_trajectories(folder, rows)
    whole = run(RUN, "evaluate", str(gt), str(est), "--chunk-rows", "0", "--json",
                str(folder / "w.json"))  # fmt: skip
    out = [("whole (--chunk-rows 0)", whole)]
    for size in (1_000_000, chunk):
        r = run(RUN, "evaluate", str(gt), str(est), "--chunk-rows", str(size), "--json",
                str(folder / f"c{size}.json"))  # fmt: skip
        out.append((f"chunks of {size:,}", r))
    w = json.loads((folder / "w.json").read_text())
    for name, r in out:
        print(
            f"   {name:24s} {r['wall']:6.2f} s ({r['wall'] / whole['wall']:.2f} x whole), "
            f"peak +{(r['rss'] - floor) / 1e6:6.0f} MB"
        )
    for size in (1_000_000, chunk):
        c = json.loads((folder / f"c{size}.json").read_text())
        diff = max(abs(c["ape"][k] - w["ape"][k]) for k in w["ape"])
        print(f"   chunks of {size:,}: APE statistics differ from whole by {diff:.1e} m at most")
    small = make_trajectories(folder, 10 * chunk, seed=4)
    r = run(RUN, "evaluate", *map(str, small), "--chunk-rows", str(chunk))
    print(
        f"   chunked, files 10x the chunk ({10 * chunk:,} poses): peak "
        f"+{(r['rss'] - floor) / 1e6:.0f} MB; {rows // chunk}x the chunk: "
        f"+{(out[2][1]['rss'] - floor) / 1e6:.0f} MB (the whole run's: "
        f"+{(whole['rss'] - floor) / 1e6:.0f} MB)"
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--chunk", type=int, default=100_000)
    ap.add_argument("--dir", type=Path, default=None)
    ap.add_argument("--eval-rows", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=3, help="rounds of section 2")
    ap.add_argument("--skip-libraries", action="store_true")
    ap.add_argument("--skip-odometry", action="store_true")
    ap.add_argument("--skip-evaluate", action="store_true")
    ap.add_argument(
        "--skip-extras",
        action="store_true",
        help="section 2 without --covariance, and no section 3 (peak memory)",
    )
    ap.add_argument("--before", type=Path, default=None,
                    help="another odolab source tree (its src/): its odometry runs in the same "
                    "rounds, for a before/after")  # fmt: skip
    a = ap.parse_args()
    if a.dir is not None:
        a.dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        n = a.rows
        csv, parquet, tiny = d / f"log{n}.csv", d / f"log{n}.parquet", d / "tiny.csv"
        make_log(csv, n)
        make_log(parquet, n)
        make_log(tiny, 3)
        prepare(d, tiny, a.before)
        print(f"log: {n:,} rows, CSV {csv.stat().st_size / 1e6:.0f} MB, "
              f"Parquet {parquet.stat().st_size / 1e6:.0f} MB")  # fmt: skip
        if not a.skip_libraries:
            libraries(d, n)
        if not a.skip_odometry:
            odometry(d, a, csv, parquet, tiny)
        if not a.skip_evaluate:
            evaluation(d, a.eval_rows, a.chunk)


def prepare(d: Path, tiny: Path, before: Path | None = None) -> None:
    """What an installed odolab has before its first timed command: its modules compiled to
    bytecode (pip compiles them at install; an editable install under PYTHONDONTWRITEBYTECODE
    would compile them in every command, 0.07 s) and numba's cache of the kernels."""
    import compileall

    import odolab

    compileall.compile_dir(Path(odolab.__file__).parent, quiet=1)
    if before is not None:
        compileall.compile_dir(before / "odolab", quiet=1)
    warm = d / "warm.csv"
    make_log(warm, 3000)  # long enough for the compiled kernels
    for src in (None, before) if before is not None else (None,):
        for chunk in ("0", "1000"):  # the batch and the chunked kernels
            run(RUN, "odometry", str(warm), "-o", str(d / "w.csv"), "--chunk-rows", chunk, src=src)


def odometry(d: Path, a: argparse.Namespace, csv: Path, parquet: Path, tiny: Path) -> None:
    """Sections 2 and 3: `odolab odometry` end to end, and its peak memory."""
    n = a.rows

    print(
        f"\n2. odolab odometry, end to end (fresh processes; wall s; {a.repeat} rounds, each "
        "runs every command once; medians, ratios within a round)"
    )
    jobs: dict[str, tuple[Any, ...]] = {
        "base_csv": (POLARS, str(csv), str(d / "polars.csv")),
        "whole_csv": (RUN, "odometry", str(csv), "-o", str(d / "o.csv"), "--chunk-rows", "0"),
        "chunk_csv": (RUN, "odometry", str(csv), "-o", str(d / "c.csv")),
        "base_pq": (PYARROW, str(parquet), str(d / "pyarrow.parquet")),
        "whole_pq": (RUN, "odometry", str(parquet), "-o", str(d / "o.parquet"),
                     "--chunk-rows", "0"),
        "chunk_pq": (RUN, "odometry", str(parquet), "-o", str(d / "c.parquet")),
    }  # fmt: skip
    if a.before is not None:  # the same commands with the older tree
        for name in ("whole_csv", "chunk_csv", "whole_pq", "chunk_pq"):
            script, *args = jobs[name]
            k = args.index("-o") + 1
            out = Path(args[k])
            args[k] = str(out.with_name(f"{out.stem}.before{out.suffix}"))
            jobs[f"{name}_before"] = (script, *args, {"src": a.before})
    rounds = []
    for _ in range(a.repeat):
        rounds.append({name: run(*(job[:-1] if isinstance(job[-1], dict) else job),
                                 **(job[-1] if isinstance(job[-1], dict) else {}))
                       for name, job in jobs.items()})  # fmt: skip

    def med(name: str, key: str = "wall") -> float:
        return float(np.median([r[name][key] for r in rounds]))

    def ratio(name: str, base: str) -> str:
        each = [r[name]["wall"] / r[base]["wall"] for r in rounds]
        return f"{np.median(each):.2f} ({', '.join(f'{x:.2f}' for x in each)})"

    def spread(name: str) -> str:
        w = [r[name]["wall"] for r in rounds]
        return f"best {min(w):5.2f} s ({min(w):.2f}-{max(w):.2f})"

    def best_ratio(name: str, base: str) -> float:
        return min(r[name]["wall"] for r in rounds) / min(r[base]["wall"] for r in rounds)

    print("   best of the rounds (spread), ratio of the bests; then the median of the rounds'"
          " ratios (each round's)")  # fmt: skip
    for base, label in (("base_csv", "polars read+write CSV"),
                        ("base_pq", "pyarrow read+write Parquet")):  # fmt: skip
        print(f"   {label:34s} {spread(base)}")
        kind = "csv" if base == "base_csv" else "pq"
        for mode, what in (("chunk", "odolab default (chunks of 1 M)"),
                           ("whole", "odolab whole (--chunk-rows 0)")):  # fmt: skip
            for suffix in ("", "_before") if a.before is not None else ("",):
                name = f"{mode}_{kind}{suffix}"
                print(f"   {what + (' BEFORE' if suffix else ''):34s} {spread(name)}  "
                      f"ratio {best_ratio(name, base):.2f} (goal <= 1.2); rounds "
                      f"{ratio(name, base)}")  # fmt: skip
    if a.skip_extras:
        return
    whole_csv = {"wall": med("whole_csv"), "rss": med("whole_csv", "rss")}
    whole_pq = {"wall": med("whole_pq"), "rss": med("whole_pq", "rss")}
    from odolab.core.params import PRESETS, NoiseParams, save_params

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
        extra = r["rss"] - floor  # (the median of the rounds)
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
