"""Free drives: the reports run in one compiled loop (``VirtualRobot.run_schedule``, what
``odolab.sim.drives.drive`` uses) against the same reports driven one by one through
``set_wheel_speeds`` and ``advance`` (the loop ``drive`` ran before), in the same run; both give
the same numbers to the bit (checked here too).

Prints the time of each and the ratio (one by one / compiled; higher is better).

Usage: python benchmarks/bench_sim_drive.py [--drives N] [--repeats R]
"""

from __future__ import annotations

import argparse

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab.core.params import PRESETS
from odolab.sim.physics import VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]
TRUTH = TRUTH_PRESETS["jaguar-lab-tracked"]
PERIOD = 0.05  # 20 Hz reports, 10 physics steps of 5 ms each, as sim.drives.drive


def _speeds(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.4, 0.6, n), rng.uniform(-0.4, 0.6, n)


def one_by_one(seed: int, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    robot = VirtualRobot(TRUTH, NOMINAL, "tile", seed=seed, dt=0.005)
    rows = []
    for vl, vr in zip(left.tolist(), right.tolist(), strict=True):
        robot.set_wheel_speeds(vl, vr)
        robot.advance(PERIOD)
        p = robot.true_pose
        rows.append((robot.time, *robot.wheel_ticks(), p.x, p.y, p.heading))
    return np.array(rows)


def compiled(seed: int, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    robot = VirtualRobot(TRUTH, NOMINAL, "tile", seed=seed, dt=0.005)
    return robot.run_schedule(left, right, PERIOD)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drives", type=int, default=200, help="drives of 170 reports (8.5 s) each")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    drives = [_speeds(seed, 170) for seed in range(args.drives)]
    for seed, (left, right) in enumerate(drives[:3]):  # compile, and check the bits
        np.testing.assert_array_equal(compiled(seed, left, right), one_by_one(seed, left, right))
    times = {}
    for name, fn in (("one by one", one_by_one), ("compiled loop", compiled)):
        times[name] = best(lambda fn=fn: [fn(s, lf, rt) for s, (lf, rt) in enumerate(drives)],
                           args.repeats)  # fmt: skip
    reports = args.drives * 170
    for name, t in times.items():
        print(
            f"{name:14s} {t:7.3f} s for {reports:,} reports ({1e6 * t / reports:.1f} us a report)"
        )
    print(f"ratio one by one / compiled loop: {times['one by one'] / times['compiled loop']:.1f}x")


if __name__ == "__main__":
    main()
