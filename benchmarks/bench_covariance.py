"""Cost of the propagated covariance, against the odometry without it, measured in the same run.

Prints the time of ``integrate`` (poses only) and of ``integrate_with_covariance`` (poses and
the six covariance terms per sample) on the same 10 million samples, and the ratio (the issue's
target: within 2x); the same on one thread; and the two separate calls (``integrate`` +
``covariance_from_ticks``, which computes the headings again). Also the streaming cost per
update with and without covariance.

Usage: python benchmarks/bench_covariance.py [--samples N] [--repeats R]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab import PRESETS, Odometry, integrate
from odolab.core.odometry import integrate_with_covariance
from odolab.core.params import NoiseParams
from odolab.core.uncertainty import covariance_from_ticks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10_000_000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    n = args.samples
    params = PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 2e-4, k_scrub=0.01))
    rng = np.random.default_rng(0)
    left = np.cumsum(rng.integers(-10, 40, n)) % params.encoder_modulus
    right = np.cumsum(rng.integers(-10, 40, n)) % params.encoder_modulus
    t = np.arange(n) * 0.05
    integrate(t[:1000], left[:1000], right[:1000], params)  # compile or load the caches
    for k in (1000, 300_000):
        integrate_with_covariance(t[:k], left[:k], right[:k], params)
    covariance_from_ticks(left[:1000], right[:1000], params)

    plain = best(lambda: integrate(t, left, right, params), args.repeats)
    both = best(lambda: integrate_with_covariance(t, left, right, params), args.repeats)
    plain1 = best(lambda: integrate(t, left, right, params, parallel=1), args.repeats)
    both1 = best(
        lambda: integrate_with_covariance(t, left, right, params, parallel=1), args.repeats
    )

    def separate() -> None:
        integrate(t, left, right, params)
        covariance_from_ticks(left, right, params)

    apart = best(separate, args.repeats)
    print(f"samples                      {n:,}   (numba threads: {numba.get_num_threads()})")
    print(f"integrate (poses)            {plain:.3f} s")
    print(f"integrate_with_covariance    {both:.3f} s")
    print(f"ratio with/without           {both / plain:.2f}x   (target <= 2x)")
    print(f"one thread: {plain1:.3f} s / {both1:.3f} s = {both1 / plain1:.2f}x")
    print(
        f"integrate + covariance_from_ticks (separate calls) {apart:.3f} s = {apart / plain:.2f}x"
    )

    m = 20_000
    for cov in (False, True):
        warm = Odometry(params, covariance=cov)  # compile or load the caches first
        warm.update(0.0, 0, 0)
        warm.update(0.05, 1, 2)
        odo = Odometry(params, covariance=cov)
        t0 = time.perf_counter()
        for i in range(m):
            odo.update(0.05 * i, int(left[i]), int(right[i]))
        per = (time.perf_counter() - t0) / m
        print(f"streaming update, covariance={cov!s:5}  {per * 1e6:.1f} us")


if __name__ == "__main__":
    main()
