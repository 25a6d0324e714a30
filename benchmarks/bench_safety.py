"""Safety measurements of the robot link: frame loss in start-byte garbage, and how long after
the last sensor packet the watchdog's stop reaches a board (real UDP, board in its own process).

    PYTHONPATH=src python benchmarks/bench_safety.py --frames 300000 --repeats 10

[1] Real motor-sensor frames, each inside 80 bytes of garbage made of a quarter each 0x5E, 0x02,
    0x0D and random bytes, decoded as datagrams by the driver's decoder (known TYPE and DES only)
    and by the permissive decoder it replaced (any TYPE, any DES), in the same run.
[2] A virtual board process (``odolab robot sim-server --silent-after S --trace``) goes quiet
    mid-drive; the loop (20 and 50 Hz, watchdog 0.5 s) stops it. From the board's trace: stop
    arrival - start of silence (>= the last report's send time); from the loop: the data age
    (now - arrival of the last packet) at the first stopping cycle. Bound: watchdog + 1 cycle.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.robot.clock import RealClock
from odolab.robot.errors import LinkLostError
from odolab.robot.jaguar.driver import JaguarDriver, UdpTransport
from odolab.robot.jaguar.protocol import DES_PC, Decoder, MotorSensorData, encode_motor_sensor
from odolab.robot.loop import ControlLoop, CycleInfo
from odolab.robot.motions import Straight
from odolab.robot.session import driver_config_for

NOMINAL = PRESETS["jaguar-lite"]


def garbage(rng: np.random.Generator, n: int) -> bytes:
    choice = rng.integers(0, 4, n)
    rnd = rng.integers(0, 256, n)
    g = np.where(choice == 0, 0x5E, np.where(choice == 1, 0x02, np.where(choice == 2, 0x0D, rnd)))
    return g.astype(np.uint8).tobytes()


def frame_loss(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    vals = rng.integers(0, 32768, (n, 2)).tolist()
    frames = [encode_motor_sensor(MotorSensorData((a, b), (1, 2), 3)) for a, b in vals]
    junk = garbage(rng, 80 * n)
    everything = set(range(256))
    for name, dec in (
        ("known TYPE and DES (now)", Decoder({DES_PC})),
        ("any TYPE, any DES (before)", Decoder(everything, everything)),
    ):
        t0 = time.perf_counter()
        found = 0
        for i, f in enumerate(frames):
            g = junk[80 * i : 80 * i + 80]
            found += sum(1 for p in dec.feed_datagram(g[:40] + f + g[40:]) if p.data == f[6:-3])
        lost = n - found
        upper = (3.0 if lost == 0 else lost + 2.0 * math.sqrt(lost)) / n  # ~95 % upper bound
        print(
            f"  {name:28s}: lost {lost} of {n} ({lost / n:.2e}; 95 % upper bound {upper:.1e}), "
            f"{(time.perf_counter() - t0) / n * 1e6:.1f} us per datagram"
        )


def start_board(trace: Path, silent_after: float) -> tuple[subprocess.Popen[str], int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "odolab.cli", "robot", "sim-server", "--port", "0",
         "--truth", "ideal", "--trace", str(trace), "--silent-after", str(silent_after)],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    assert proc.stderr is not None
    m = re.search(r"udp://127\.0\.0\.1:(\d+)", proc.stderr.readline())
    assert m
    return proc, int(m.group(1))


def stop_latency(rate: float, repeats: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    board_delays, ages = [], []
    period = 1.0 / rate
    for _ in range(repeats):
        silent_after = 0.8 + float(rng.random()) * 0.2  # not in phase with the reports
        with tempfile.TemporaryDirectory() as tmp:
            trace = Path(tmp) / "trace"
            proc, port = start_board(trace, silent_after)
            clock = RealClock()
            driver = JaguarDriver(
                UdpTransport("127.0.0.1", port, clock.now), clock, driver_config_for(NOMINAL)
            )
            first_age: list[float] = []

            def on_cycle(info: CycleInfo, first_age: list[float] = first_age) -> None:
                if not info.link_ok and not first_age:
                    first_age.append(info.data_age)

            loop = ControlLoop(driver, Odometry(NOMINAL), clock, rate=rate, on_cycle=on_cycle)
            try:
                loop.run(Straight(20.0, speed=0.5), link_abort=1.0)
            except LinkLostError:
                pass
            finally:
                driver.close()
                time.sleep(0.1)
                proc.terminate()
                proc.wait(timeout=5)
            rows = [ln.split() for ln in trace.read_text().splitlines() if ln[:1] != "#"]
        silent = next(float(r[0]) for r in rows if r[3] == "silent")
        stop = next(
            float(r[0]) for r in rows if float(r[0]) >= silent and r[1] == r[2] == "0.000000"
        )
        board_delays.append(stop - silent)
        ages.append(first_age[0])
    b = np.asarray(board_delays)
    a = np.asarray(ages)
    bound = 0.5 + period
    print(
        f"  {rate:g} Hz ({repeats} runs): board stop - silence p50 {np.median(b) * 1e3:.1f} ms, "
        f"max {b.max() * 1e3:.1f} ms; data age at the stopping cycle p50 "
        f"{np.median(a) * 1e3:.1f} ms, max {a.max() * 1e3:.1f} ms; bound {bound * 1e3:.0f} ms; "
        f"within: {int((b <= bound).sum())}/{repeats} (board), {int((a <= bound).sum())}/"
        f"{repeats} (loop)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=300_000)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    load = os.getloadavg()
    print(f"conditions: {os.cpu_count()} CPUs, load average {load[0]:.2f}")
    print(f"[1] real frames in start-byte garbage ({args.frames} frames)")
    frame_loss(args.frames, args.seed)
    print("[2] watchdog stop at the board, real UDP, board in its own process")
    for rate in (20.0, 50.0):
        stop_latency(rate, args.repeats, args.seed)


if __name__ == "__main__":
    main()
