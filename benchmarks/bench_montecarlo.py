"""Benchmark: 10,000 Monte Carlo 20 pi rotations in place at a 20 Hz report rate (jaguar-lab).

Prints the wall time of ``run_protocol`` (physics, instruments, odometry of every trial, Trial
objects) and of the physics kernel alone, and the speed-up against a baseline measured in the
same run: the same rotations driven one at a time through ``VirtualRobot`` (a Python loop per
trial, timed on a subset and scaled).

    PYTHONPATH=src python benchmarks/bench_montecarlo.py [N]
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from odolab.core.params import PRESETS
from odolab.sim.physics import VirtualRobot, kernel_params, simulate_batch
from odolab.sim.presets import TRUTH_PRESETS
from odolab.sim.protocols import parse_protocol, run_protocol, segments_for
from odolab.sim.terrains import get_terrain


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    nominal = PRESETS["jaguar-lite"]
    truth = TRUTH_PRESETS["jaguar-lab"]
    doc = {
        "protocol": {"campaign": "bench", "report_rate": 20.0, "dt": 0.025, "turn_speed": 0.3},
        "trials": [{"motion": "rotation", "angle_pi": 20, "repeats": n}],
    }
    proto = parse_protocol(doc, "bench.toml")
    run_protocol(
        parse_protocol({**doc, "trials": [{"motion": "rotation", "angle_pi": 1}]}), truth, nominal
    )  # warm-up / compile

    t0 = time.perf_counter()
    trials = run_protocol(proto, truth, nominal, seed=1)
    t_full = time.perf_counter() - t0

    (seg,) = segments_for(proto.trials[0].command, nominal)
    p = np.tile(kernel_params(truth, nominal, get_terrain("tile")), (n, 1))
    col = np.ones((n, 1))
    t0 = time.perf_counter()
    simulate_batch(
        p,
        (col * seg[0]).astype(np.int64),
        (col * seg[1]).astype(np.int64),
        col * seg[2],
        col * seg[3],
        np.ones(n, dtype=np.int64),
        align_sigma=truth.align_sigma,
        dt=proto.dt,
        rng=np.random.default_rng(2),
    )
    t_kernel = time.perf_counter() - t0

    # baseline: one VirtualRobot per trial, stepped in a Python loop at the report rate
    m = 20
    duration = abs(seg[1]) * nominal.right_metres_per_tick / 0.3
    robot = VirtualRobot(truth, nominal, seed=3, dt=proto.dt)
    t0 = time.perf_counter()
    for _ in range(m):
        robot.reset()
        robot.set_wheel_speeds(-0.3, 0.3)
        for _ in range(math.ceil(duration * 20)):
            robot.advance(0.05)
            robot.encoder_counts()
        robot.set_wheel_speeds(0.0, 0.0)
    t_base = (time.perf_counter() - t0) / m * n

    samples = sum(len(t.encoder_log) for t in trials if t.encoder_log is not None)
    print(
        f"{n} rotations of 20 pi at 20 Hz ({samples / n:.0f} reports, "
        f"{duration / proto.dt:.0f} physics steps of {proto.dt} s each)"
    )
    print(f"run_protocol (physics + instruments + odometry + trials): {t_full:.2f} s")
    print(f"physics kernel alone:                                    {t_kernel:.2f} s")
    print(f"baseline, VirtualRobot loop per trial (scaled from {m}):  {t_base:.2f} s")
    print(f"speed-up of run_protocol over the baseline: {t_base / t_full:.1f}x")
    sig = np.std(
        [t.measured.rotation for t in trials if t.measured and t.measured.rotation], ddof=1
    )
    print(f"sigma of the measured rotation: {sig:.3f} rad (model 2.94)")


if __name__ == "__main__":
    main()
