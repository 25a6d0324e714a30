"""Control-loop timing over real UDP on loopback against a virtual Jaguar in another process.

1. The loop at 20 Hz for --duration s (default 60): period error p50/p99/max, wake-up lateness,
   overruns, and the cycle count against duration * rate. Baseline in the same run: a naive
   loop that sleeps one period after its work (relative sleeping) for the same time; the ratio
   shows what absolute deadlines buy.
2. The highest rate the loop sustains: rates up to 5 kHz, --sweep s each; a rate is sustained
   when at most 1 % of cycles overrun and the p99 period error is below half a period.

Usage: PYTHONPATH=src python benchmarks/bench_loop.py [--duration 60] [--sweep 3] [--spin 0]

How long it takes: [1] runs the loop and then the baseline, --duration s each, and [2] runs
every rate for --sweep s: 2 x 60 + 7 x 3 = 141 s with the defaults. --realtime repeats both in
SCHED_FIFO (6 rates up to 2 kHz): about 280 s in all. The script prints its estimate first.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.robot.clock import RealClock, set_realtime
from odolab.robot.jaguar.driver import JaguarDriver, UdpTransport, driver_config_for
from odolab.robot.loop import ControlLoop, LoopStats, timing_stats

NOMINAL = PRESETS["jaguar-lite"]


def start_server() -> tuple[subprocess.Popen[str], int]:
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen(
        [sys.executable, "-m", "odolab.cli", "robot", "sim-server", "--host", "127.0.0.1",
         "--port", "0", "--truth", "ideal"],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env,
    )  # fmt: skip
    assert proc.stderr is not None
    line = proc.stderr.readline()
    match = re.search(r"udp://127\.0\.0\.1:(\d+)", line)
    if not match:
        proc.kill()
        raise SystemExit(f"server did not start: {line!r}")
    return proc, int(match.group(1))


def run_loop(port: int, rate: float, duration: float, spin: float) -> LoopStats:
    clock = RealClock(spin)
    driver = JaguarDriver(UdpTransport("127.0.0.1", port), clock, driver_config_for(NOMINAL))
    try:
        loop = ControlLoop(driver, Odometry(NOMINAL), clock, rate=rate, watchdog_timeout=0.5)
        return loop.run(None, max_cycles=round(duration * rate) + 1).stats
    finally:
        driver.close()


def naive_loop(port: int, rate: float, duration: float) -> tuple[int, float, float]:
    """Baseline: work, then time.sleep(period). Returns (cycles, p99 period error, elapsed)."""
    clock = RealClock()
    driver = JaguarDriver(UdpTransport("127.0.0.1", port), clock, driver_config_for(NOMINAL))
    odo = Odometry(NOMINAL)
    try:
        driver.connect()
        period = 1.0 / rate
        wakes = []
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < duration:
            now = time.perf_counter()
            wakes.append(now)
            driver.poll()
            r = driver.latest
            assert r is not None
            odo.update(now - t0, r.left_ticks, r.right_ticks)
            driver.stop()
            time.sleep(period)
        _, p99, _ = timing_stats(np.asarray(wakes), rate)
        return len(wakes), p99, wakes[-1] - wakes[0]
    finally:
        driver.close()


def conditions() -> str:
    load = os.getloadavg()
    return (
        f"{platform.node()} {platform.machine()}, {os.cpu_count()} CPUs, Python "
        f"{platform.python_version()}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}"
    )


def expected_seconds(args: argparse.Namespace) -> float:
    """Wall time of a run: the loop and its baseline, then the sweep; twice with --realtime."""
    rates = [float(r) for r in args.rates.split(",")]
    total = 2 * args.duration + len(rates) * args.sweep
    if args.realtime:
        total += 2 * args.duration + sum(r <= 2000 for r in rates) * args.sweep
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--sweep", type=float, default=3.0)
    ap.add_argument("--spin", type=float, default=0.0, help="RealClock spin (s)")
    ap.add_argument("--rates", default="50,100,200,500,1000,2000,5000")
    ap.add_argument(
        "--realtime", action="store_true", help="also run [1] and [2] in SCHED_FIFO (up to 2 kHz)"
    )
    args = ap.parse_args()
    print(f"this takes about {expected_seconds(args):.0f} s")
    print("conditions:", conditions())
    proc, port = start_server()
    try:
        measure(port, args, "normal scheduling")
        if args.realtime:
            if set_realtime(True):
                args.rates = ",".join(r for r in args.rates.split(",") if float(r) <= 2000)
                measure(port, args, "SCHED_FIFO real-time scheduling")
                set_realtime(False)
            else:
                print("\nSCHED_FIFO refused by the OS; no real-time figures")
    finally:
        proc.terminate()
        proc.wait(timeout=5)


def measure(port: int, args: argparse.Namespace, label: str) -> None:
    print(f"\n===== {label} =====")
    rate = 20.0
    print(f"\n[1] loop at {rate:g} Hz for {args.duration:g} s (spin {args.spin * 1e3:g} ms)")
    s = run_loop(port, rate, args.duration, args.spin)
    expected = s.duration * rate + 1
    print(
        f"  period error: p50 {s.period_error_p50 * 1e3:.3f} ms, "
        f"p99 {s.period_error_p99 * 1e3:.3f} ms, max {s.period_error_max * 1e3:.3f} ms"
    )
    print(
        f"  lateness: p50 {s.lateness_p50 * 1e3:.3f} ms, p99 {s.lateness_p99 * 1e3:.3f} ms, "
        f"max {s.lateness_max * 1e3:.3f} ms; overruns {s.overruns}"
    )
    print(f"  cycles {s.cycles} over {s.duration:.3f} s (expected {expected:.1f})")
    print(f"  sensor packets {s.sensor_packets}, link losses {s.link_lost_events}")
    nb_cycles, nb_p99, nb_elapsed = naive_loop(port, rate, args.duration)
    nb_expected = nb_elapsed * rate + 1
    print(
        f"  baseline (sleep one period after the work): {nb_cycles} cycles in "
        f"{nb_elapsed:.3f} s (expected {nb_expected:.1f}, drift "
        f"{nb_expected - nb_cycles:.1f} cycles), p99 period error {nb_p99 * 1e3:.3f} ms"
    )
    ratio = s.period_error_p99 / nb_p99 if nb_p99 > 0 else float("nan")
    print(f"  p99 period error, absolute deadlines / baseline: {ratio:.3f}")
    print(f"  conditions after: {conditions()}")

    print(f"\n[2] rate sweep, {args.sweep:g} s per rate")
    best = 0.0
    for r in (float(x) for x in args.rates.split(",")):
        st = run_loop(port, r, args.sweep, args.spin)
        period = 1.0 / r
        ok = st.overruns <= 0.01 * st.cycles and st.period_error_p99 < 0.5 * period
        best = r if ok else best
        print(
            f"  {r:7.0f} Hz: {st.cycles:6d} cycles, overruns {st.overruns:5d} "
            f"({100 * st.overruns / st.cycles:5.1f} %), period error p50 "
            f"{st.period_error_p50 * 1e6:7.1f} us p99 {st.period_error_p99 * 1e6:8.1f} us "
            f"max {st.period_error_max * 1e6:8.1f} us  {'sustained' if ok else 'NOT sustained'}"
        )
    print(f"\nhighest sustained rate ({label}): {best:g} Hz")
    print(f"conditions: {conditions()}")


if __name__ == "__main__":
    main()
