"""Evaluation of a simulated fleet (2,000 runs by default) on Dask, against today's pool.

Measured in the same run, on the same runs:
- in this process (no Dask): the reference results and the single-core rate;
- the previous many-runs mode: a 2-process ``ProcessPoolExecutor`` (what ``parallel_map`` was);
- a local Dask cluster (``Cluster(workers=2)``, started and stopped by the call, as the CLI does);
- a Dask cluster started with the dask CLI as separate processes on 127.0.0.1 (``dask scheduler``,
  ``dask worker``) with 1 and 2 workers: runs/s, and results equal to the in-process ones;
- the same cluster losing one of its two workers (SIGKILL) a quarter of the way through: every
  run still gets its result, and the loss is reported.

Usage: python benchmarks/bench_fleet.py [--runs 2000] [--seconds 20] [--dir DIR]
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from odolab.core.kinematics import Method
from odolab.core.params import PRESETS
from odolab.fleet import FleetSpec, fleet_rows, simulate_fleet
from odolab.fleet.table import COLUMNS
from odolab.io.registry import LogFormat
from odolab.io.run import ReadOptions
from odolab.metrics.cluster import Cluster, MapReport
from odolab.metrics.runs import RUN_OPTIONS, _evaluate_job, _Job, evaluate_runs

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.scale.dask_cli import dask_cluster

NOMINAL = PRESETS["jaguar-lite"]
READ = ReadOptions(modulus=NOMINAL.encoder_modulus)


def numbers(outcomes: list) -> np.ndarray:  # type: ignore[type-arg]
    rows = fleet_rows(outcomes)
    return np.array([[float(v) for v in rows[c]] for c in COLUMNS[5:]])


def old_pool(paths: list[Path], workers: int = 2) -> list:  # type: ignore[type-arg]
    """Today's mode before this change: ProcessPoolExecutor.map over the jobs, in order.

    Started with "spawn": forking a process that has polars' thread pool running can deadlock.
    """
    import multiprocessing

    jobs = [_Job(p, LogFormat.CSV, READ, NOMINAL, RUN_OPTIONS, Method.MIDPOINT) for p in paths]
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        return list(pool.map(_evaluate_job, jobs))


def timed(label: str, f, n: int, rows: list[tuple[str, float, float]]):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    out = f()
    s = time.perf_counter() - t0
    rows.append((label, s, n / s))
    print(f"   {label:58s} {s:7.2f} s  {n / s:7.1f} runs/s", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--dir", type=Path, default=None)
    a = ap.parse_args()
    robots, days = 10, 10
    per_day = max(1, a.runs // (robots * days))
    spec = FleetSpec(robots=robots, days=days, runs_per_day=per_day, run_seconds=a.seconds,
                     wearing=2, seed=7)  # fmt: skip
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        t0 = time.perf_counter()
        paths = simulate_fleet(d / "fleet", spec)
        n = len(paths)
        print(f"fleet: {n} runs ({robots} robots x {days} days x {per_day}), "
              f"{a.seconds:g} s each at 20 Hz; simulated in {time.perf_counter() - t0:.1f} s")  # fmt: skip
        print(f"machine: {os.cpu_count()} cores\n")
        rows: list[tuple[str, float, float]] = []

        def run_on(cluster: Cluster, report: MapReport | None = None):  # type: ignore[no-untyped-def]
            return evaluate_runs(paths, "csv", params=NOMINAL, read_options=READ,
                                 cluster=cluster, report=report)  # fmt: skip

        ref = timed(
            "in this process (1 core, no Dask)", lambda: run_on(Cluster(workers=1)), n, rows
        )
        failed = [o.error for o in ref if not o.ok]
        if failed:
            print(f"      {len(failed)} runs fail on their own (e.g. {failed[0]})")
        want = numbers(ref)
        pool = timed("previous pool: ProcessPoolExecutor, 2 processes", lambda: old_pool(paths),
                     n, rows)  # fmt: skip
        assert len(pool) == n
        local = timed("local Dask cluster, 2 workers (incl. start and stop)",
                      lambda: run_on(Cluster(workers=2)), n, rows)  # fmt: skip
        print(
            f"      max |difference| to in-process: {np.nanmax(np.abs(numbers(local) - want)):.1e}"
        )
        for workers in (1, 2):
            with dask_cluster(d / f"dask{workers}", workers=workers) as procs:
                got = timed(f"dask CLI cluster on 127.0.0.1, {workers} worker process(es)",
                            lambda procs=procs: run_on(Cluster(scheduler=procs.address)), n, rows)  # fmt: skip
                diff = float(np.nanmax(np.abs(numbers(got) - want)))
                same = np.array_equal(np.isnan(numbers(got)), np.isnan(want))
                print(
                    f"      max |difference| to in-process: {diff:.1e} (<= 1e-12: "
                    f"{diff <= 1e-12 and same})"
                )
        with dask_cluster(d / "kill", workers=2) as procs:
            victim = procs.workers[0]
            killed: list[int] = []

            def kill(done: int, total: int, name: str) -> None:
                if done >= total // 4 and not killed:
                    os.kill(victim.pid, signal.SIGKILL)
                    killed.append(done)

            rep = MapReport("")
            t0 = time.perf_counter()
            got = evaluate_runs(paths, "csv", params=NOMINAL, read_options=READ,
                                cluster=Cluster(scheduler=procs.address), progress=kill,
                                report=rep)  # fmt: skip
            s = time.perf_counter() - t0
            ok = sum(o.ok for o in got)
            diff = float(np.nanmax(np.abs(numbers(got) - want)))
            print(
                f"   one of 2 workers killed after {killed[0]} runs: {ok} of {n} runs have "
                f"results in {s:.2f} s, max |difference| {diff:.1e}; {rep.loss_text()}"
            )
        base = rows[1][1]
        print("\n   runs/s vs workers (this machine; ratio = previous pool's time / this time)")
        for label, s, rate in rows:
            print(f"   | {label:58s} | {rate:7.1f} | {base / s:5.2f} |")


if __name__ == "__main__":
    main()
