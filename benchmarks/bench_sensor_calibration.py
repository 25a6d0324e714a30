"""Monte Carlo study of ``odolab calibrate sensor`` (Censi et al. 2013) on synthetic laser runs.

The virtual robot (true radii 0.0850 / 0.0820 m, true track 0.60 m; nominal jaguar-lite) drives
the calibration drive twice (96 s, integer encoder counts at 20 Hz); a sensor mounted at
(0.20 m, -0.05 m, 0.3 rad) sees its relative motion over 0.5 s intervals with independent noise
(5 mm, 5 mm, 0.5 deg). For every seed: the estimate, its standard errors. Printed: per parameter
the fraction of seeds within 2 standard errors, the mean standard error over the Monte Carlo
spread, and the Cramér-Rao bound (true parameters, true noise) over the spread.

    .venv/bin/python benchmarks/bench_sensor_calibration.py [SEEDS] [--outliers FRACTION]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from odolab.calibration.sensor import (
    PARAM_NAMES,
    SensorMotions,
    calibrate_sensor,
    cramer_rao_bound,
    motions_from_trajectory,
)
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.sim.drives import calibration_drive, record_drive
from odolab.sim.physics import TrueParams

TRUE_ROBOT = (0.0850, 0.0820, 0.60)
MOUNT = (0.20, -0.05, 0.3)
SIGMA = (0.005, 0.005, math.radians(0.5))


def clean_motions() -> tuple[SensorMotions, np.ndarray]:
    """The noiseless intervals of the synthetic run, and the true parameter vector."""
    nominal = PRESETS["jaguar-lite"]
    rl, rr, b = TRUE_ROBOT
    drive = record_drive(TrueParams(rl, rl, rr, rr, b), nominal, calibration_drive(repeats=2))
    tr = drive.truth
    c, s = np.cos(tr.heading), np.sin(tr.heading)
    lx, ly, lth = MOUNT
    sensor = Trajectory.from_xyh(
        tr.t, tr.x + c * lx - s * ly, tr.y + s * lx + c * ly, tr.heading + lth
    )
    k = 2.0 * math.pi / nominal.ticks_per_rev
    m = motions_from_trajectory(
        drive.t, drive.counts_left * k, drive.counts_right * k, sensor, interval_s=0.5
    )
    return m, np.array([*TRUE_ROBOT, *MOUNT])


def noisy(m: SensorMotions, seed: int, outliers: float = 0.0) -> SensorMotions:
    """``m`` with independent Gaussian noise (and a fraction of gross errors) on the motions."""
    rng = np.random.default_rng(seed)
    motion = m.motion + rng.standard_normal(m.motion.shape) * np.array(SIGMA)
    if outliers > 0:
        bad = rng.random(len(m)) < outliers
        motion[bad] += rng.normal(0.0, [0.2, 0.2, 0.3], (int(bad.sum()), 3))
    return SensorMotions(m.t0, m.t1, motion, m.dphi_left, m.dphi_right, m.interval)


def study(seeds: int, outliers: float = 0.0) -> dict[str, dict[str, float]]:
    m, true = clean_motions()
    nominal = PRESETS["jaguar-lite"]
    est, se = [], []
    for seed in range(seeds):
        r = calibrate_sensor(noisy(m, seed, outliers), nominal)
        est.append([r.values[k] for k in PARAM_NAMES])
        se.append([r.stderr[k] for k in PARAM_NAMES])
    e, s = np.array(est), np.array(se)
    crb = np.sqrt(np.diag(cramer_rao_bound(true, m, SIGMA)))
    spread = e.std(axis=0, ddof=1)
    out = {}
    for i, k in enumerate(PARAM_NAMES):
        out[k] = {
            "within_2se": float(np.mean(np.abs(e[:, i] - true[i]) <= 2 * s[:, i])),
            "se_over_spread": float(s[:, i].mean() / spread[i]),
            "crb_over_spread": float(crb[i] / spread[i]),
            "bias_over_spread": float((e[:, i].mean() - true[i]) / spread[i]),
            "spread": float(spread[i]),
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("seeds", nargs="?", type=int, default=200)
    ap.add_argument("--outliers", type=float, default=0.0)
    a = ap.parse_args()
    t0 = time.perf_counter()
    res = study(a.seeds, a.outliers)
    took = time.perf_counter() - t0
    print(f"{a.seeds} seeds, outlier fraction {a.outliers:g}, {took:.1f} s")
    print(
        f"{'parameter':20s} {'in 2 SE':>8s} {'SE/MC':>7s} {'CRB/MC':>7s} {'bias/MC':>8s} {'MC sd':>10s}"
    )
    for k, v in res.items():
        print(
            f"{k:20s} {v['within_2se']:8.3f} {v['se_over_spread']:7.3f} "
            f"{v['crb_over_spread']:7.3f} {v['bias_over_spread']:8.3f} {v['spread']:10.3g}"
        )


if __name__ == "__main__":
    main()
