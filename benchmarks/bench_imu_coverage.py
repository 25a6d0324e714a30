"""The gyro calibration's goals on the simulated robot (docs/imu.md), over many seeds.

A differential-drive robot (track 7 % wider than jaguar-lite's, r_R/r_L = 1.01) drives one
minute of mixed turning (odolab.sim.gyro); its gyro has bias 0.01 rad/s, scale 1.005, white
noise 0.005 rad/s/sqrt(Hz) at 100 Hz and a clock 40 ms ahead. For each seed, ``odolab calibrate
imu``'s estimator runs twice: with a reference for the total turn (the true turn plus a
tracker's error of 0.01 rad, drawn from the same seed) and without one (scale taken as 1 +- 1 %).

Prints the largest errors and how often each 95 % interval covers the truth.

    python benchmarks/bench_imu_coverage.py [SEEDS]   # default 200
"""

from __future__ import annotations

import sys

import numpy as np

from odolab.calibration.imu import TurnReference, calibrate_imu
from odolab.sim.gyro import simulate_gyro_drive

REF_SD = 0.01


def one(seed: int) -> dict[str, float]:
    d = simulate_gyro_drive(seed=seed)
    rng = np.random.default_rng(10_000 + seed)
    ref = TurnReference(d.turned + REF_SD * float(rng.standard_normal()), REF_SD, "tracker")
    plain = calibrate_imu([d.run], d.nominal)
    withref = calibrate_imu([d.run], d.nominal, references=[ref])
    b, rho, off = (
        d.truth.track_width,
        d.truth.right_wheel_radius / d.truth.left_wheel_radius,
        (d.clock_offset),
    )

    def cover(ci: tuple[float, float], v: float) -> float:
        return float(ci[0] <= v <= ci[1])

    return {
        "track_err_ref_pct": 100 * (withref.track_width / b - 1),
        "track_err_noref_pct": 100 * (plain.track_width / b - 1),
        "ratio_err_pct": 100 * (withref.radius_ratio / rho - 1),
        "offset_err_ms": 1000 * (withref.offsets[0].offset - off),
        "scale_err_pct": 100 * (withref.gyro_scale / d.scale - 1),
        "cover_track_ref": cover(withref.track_width_ci95, b),
        "cover_track_noref": cover(plain.track_width_ci95, b),
        "cover_ratio": cover(withref.radius_ratio_ci95, rho),
        "cover_offset": cover(withref.offsets[0].ci95, off),
        "cover_scale": cover(withref.gyro_scale_ci95, d.scale),
    }


def main(seeds: int) -> None:
    rows = [one(s) for s in range(seeds)]
    keys = list(rows[0])
    a = {k: np.array([r[k] for r in rows]) for k in keys}
    print(f"{seeds} seeds")
    for k in keys:
        v = a[k]
        if k.startswith("cover"):
            print(f"{k}: {100 * v.mean():.1f} %")
        else:
            print(f"{k}: largest |error| {np.abs(v).max():.3f}, RMS {np.sqrt(np.mean(v * v)):.3f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
