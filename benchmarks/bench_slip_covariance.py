"""Cost of the slip model's covariance (odolab.core.slip_uncertainty), against the slip model's
odometry without it and the kinematic covariance, measured in the same run.

The whole-log covariance costs time as the square of the log's cycles (its second-order share
sums over every pair of steps): printed for 3,000, 6,000 and 12,000 cycles (20 Hz: 2.5, 5 and 10
minutes) as a ratio to the poses alone. The streaming stepper's cost per cycle is printed at the
start and after the longest log (it grows with the cycles so far; a 20 Hz loop has 50 ms).

Then the two loops compiled (``slip_covariance.COMPILED``, where numba is installed) against the
numpy loops that run without numba, in the same run: a whole log of 3,000 cycles, and 300
pieces of 20 cycles each (``evaluate --nees`` over 1 s pieces: the DRIVE Husky's 314 windows).

Usage: python benchmarks/bench_slip_covariance.py [--repeats R]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab import PRESETS
from odolab.core.models import SlipModel, slip_covariance
from odolab.core.odometry import integrate_increments
from odolab.core.params import NoiseParams
from odolab.core.slip_uncertainty import SlipCovarianceStepper, propagate_covariance
from odolab.core.uncertainty import covariance_from_ticks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    nominal = PRESETS["jaguar-lite"]
    sigma = np.eye(24) * 1e-4
    slip = nominal.with_(
        model=SlipModel(
            yaw_w=-0.1, fwd_v_absv=-0.05, q_fwd=1e-4, q_yaw=1e-3, k_yaw=0.05, d_yaw=1e-3,
            d_turn=1e-3, posterior=tuple(sigma.ravel()),
        )
    )  # fmt: skip
    kinematic = nominal.with_(noise=NoiseParams(3e-4, 2e-4, 0.17))
    rng = np.random.default_rng(1)
    biggest = 12_000
    t = np.arange(biggest) * 0.05
    dl = rng.integers(-5, 40, biggest).astype(float)
    dr = rng.integers(-5, 50, biggest).astype(float)
    dl[0] = dr[0] = 0.0
    integrate_increments(t[:100], dl[:100], dr[:100], slip)  # compile before timing
    covariance_from_ticks(np.cumsum(dl[:100]), np.cumsum(dr[:100]), kinematic)
    print("cycles  poses (s)  slip covariance (s)  ratio  kinematic covariance (s)")
    for n in (3_000, 6_000, biggest):
        a = best(lambda n=n: integrate_increments(t[:n], dl[:n], dr[:n], slip), args.repeats)
        b = best(lambda n=n: propagate_covariance(t[:n], dl[:n], dr[:n], slip), args.repeats)
        c = best(
            lambda n=n: covariance_from_ticks(np.cumsum(dl[:n]), np.cumsum(dr[:n]), kinematic),
            args.repeats,
        )
        print(f"{n:6d}  {a:9.4f}  {b:19.3f}  {b / a:5.0f}x  {c:24.4f}")
    stepper = SlipCovarianceStepper(slip)
    kl, kr = slip.left_metres_per_tick, slip.right_metres_per_tick
    t0 = time.perf_counter()
    for i in range(1, 201):
        stepper.step(0.0, dl[i] * kl, dr[i] * kr, 0.05)
    first = (time.perf_counter() - t0) / 200
    for i in range(201, biggest):
        stepper.step(0.0, dl[i] * kl, dr[i] * kr, 0.05)
    t0 = time.perf_counter()
    for _ in range(100):
        stepper.step(0.0, 20 * kl, 30 * kr, 0.05)
    last = (time.perf_counter() - t0) / 100
    print(
        f"streaming stepper: {1e3 * first:.3f} ms a cycle at the start, {1e3 * last:.3f} ms after "
        f"{biggest} cycles ({last / first:.1f}x; a 20 Hz loop has 50 ms)"
    )
    if not slip_covariance.HAVE_NUMBA:
        print("numba is not installed: the numpy loops only")
        return

    def whole() -> None:
        propagate_covariance(t[:3000], dl[:3000], dr[:3000], slip)

    def pieces() -> None:
        for p in range(300):
            a = 20 * p
            propagate_covariance(t[a : a + 21], dl[a : a + 21], dr[a : a + 21], slip)

    print("the loops compiled against the numpy loops (seconds, best of the repeats):")
    for label, work in (("a log of 3,000 cycles", whole), ("300 pieces of 20 cycles", pieces)):
        times = {}
        for compiled in (True, False):
            slip_covariance.COMPILED = compiled
            work()  # (compiled: the kernels loaded from numba's cache or compiled, not timed)
            times[compiled] = best(work, args.repeats)
        slip_covariance.COMPILED = True
        print(
            f"  {label}: compiled {times[True]:.3f}, numpy {times[False]:.3f}: "
            f"{times[False] / times[True]:.1f}x faster"
        )


if __name__ == "__main__":
    main()
