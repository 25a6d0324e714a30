"""Batch odometry speed: 10 million samples, compared with baselines measured in the same run.

Prints samples per second and two ratios (lower is better):
- floor: ``integrate`` time / the time numpy takes to copy arrays of the same input and output
  size (3 input arrays read, 5 output arrays written): the memory-bandwidth floor;
- loop:  ``integrate`` time / a plain per-sample Python loop of the lab's pseudocode (Figs. 6-8),
  timed on a slice and scaled (a full 10-million-sample Python loop takes minutes).

Then where ``integrate``'s time goes against the floor: each compiled pass timed alone on arrays
already in memory (best of the repeats), and the first touch of the five fresh output arrays
(page faults, which the floor pays too).

Usage: python benchmarks/bench_odometry.py [--samples N] [--repeats R]
"""

from __future__ import annotations

import argparse
import math
import statistics

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab import PRESETS, integrate
from odolab.core.params import RobotParams


def lab_pseudocode_loop(t, left, right, params):  # type: ignore[no-untyped-def]
    """The lab's control loop, one Python iteration per sample (Figs. 6-8), with rollover."""
    m = params.encoder_modulus
    kl, kr, b = params.left_metres_per_tick, params.right_metres_per_tick, params.track_width
    x = y = th = 0.0
    xs, ys, ths = [0.0], [0.0], [0.0]
    for i in range(1, len(t)):
        dl = int(left[i]) - int(left[i - 1])
        dr = int(right[i]) - int(right[i - 1])
        if dl > m // 2:
            dl -= m
        elif dl < -m // 2:
            dl += m
        if dr > m // 2:
            dr -= m
        elif dr < -m // 2:
            dr += m
        dsl, dsr = dl * kl, dr * kr
        dth = (dsr - dsl) / b
        ds = (dsr + dsl) / 2
        x += ds * math.cos(th + dth / 2)
        y += ds * math.sin(th + dth / 2)
        th += dth
        if th > math.pi or th <= -math.pi:
            th = (th + math.pi) % (2 * math.pi) - math.pi
        xs.append(x)
        ys.append(y)
        ths.append(th)
    return xs, ys, ths


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    n = args.samples
    params = PRESETS["jaguar-lite"]
    rng = np.random.default_rng(0)
    # a robot wandering at up to ~1 m/s, counters wrapping at 15 bits
    left = np.cumsum(rng.integers(-10, 40, n)) % params.encoder_modulus
    right = np.cumsum(rng.integers(-10, 40, n)) % params.encoder_modulus
    t = np.arange(n) * 0.05

    integrate(t[:1000], left[:1000], right[:1000], params)  # compile (or load the cache)
    integrate(t, left, right, params)  # warm the thread pool and the allocator

    def floor() -> None:
        # the same bytes in and out as integrate: 3 arrays read, 5 float64 arrays written
        outs = [np.empty(n) for _ in range(5)]
        np.copyto(outs[0], t)
        np.copyto(outs[1], left)
        np.copyto(outs[2], right)
        np.copyto(outs[3], t)
        np.copyto(outs[4], t)

    t_int, t_floor = [], []
    for _ in range(args.repeats):  # interleave, so that noise hits both alike
        t_int.append(best(lambda: integrate(t, left, right, params), 1))
        t_floor.append(best(floor, 1))
    k = min(n, 200_000)
    t_loop = best(lambda: lab_pseudocode_loop(t[:k], left[:k], right[:k], params), 1) * (n / k)
    ti, tf = min(t_int), min(t_floor)
    print(f"samples: {n:,}")
    print(
        f"integrate: {ti:.3f} s (median {statistics.median(t_int):.3f}) -> {n / ti / 1e6:.1f} M samples/s"
    )
    print(f"memory floor (numpy copies, same in/out bytes): {tf:.3f} s")
    print(f"python loop of the lab's pseudocode (scaled from {k:,}): {t_loop:.1f} s")
    print(f"ratio to floor: {ti / tf:.2f}x   (issue 42's goal <= 1.2x)")
    print(
        f"python loop / floor: {t_loop / tf:.0f}x   integrate speed-up over the loop: {t_loop / ti:.0f}x"
    )
    breakdown(t, left, right, params, args.repeats, ti, tf)


def breakdown(t, left, right, params: RobotParams, repeats: int, total: float, floor: float):  # type: ignore[no-untyped-def]
    """The passes of ``integrate`` one at a time (best of ``repeats``), as it calls them."""
    import odolab.core._odometry_kernels as k
    import odolab.core.odometry as od
    from odolab.core.odometry import _model_arrays

    n = len(t)
    coef, lat = _model_arrays(params, n)
    tt, x, y, theta, heading = (np.ones(n) for _ in range(5))  # touched: no page faults
    max_d = params.encoder_modulus // 4

    def phase_a() -> None:
        k._steps_from_ticks(t, left, right, params.encoder_modulus, max_d,
                            params.left_metres_per_tick, params.right_metres_per_tick, coef,
                            False, 0.0, 0, n, tt, heading, x, lat, y)  # fmt: skip

    def model_steps() -> None:
        counts = (params.encoder_modulus, max_d, params.left_metres_per_tick,
                  params.right_metres_per_tick)  # fmt: skip
        k._model_steps(t, left, right, counts, coef, tt, x, y)

    def first_touch() -> None:
        for a in (np.empty(n) for _ in range(5)):
            a[::512] = 0.0  # one write a page

    def copies() -> None:  # the floor's work without its page faults
        np.copyto(tt, t)
        np.copyto(x, left)
        np.copyto(y, right)
        np.copyto(theta, t)
        np.copyto(heading, t)

    parts = {
        "A: time check, unwrap, model, heading (sequential)": best(phase_a, repeats),
        "  A's per-sample part (vectorized)": best(model_steps, repeats),
        "  A's running heading (sequential)": best(lambda: k._headings(0.0, heading, y), repeats),
        "B: sin/cos of the mid heading, theta (parallel)": best(
            lambda: k._rotate_steps_parallel(x, y, heading, theta), repeats
        ),
        "B on one thread": best(lambda: k._rotate_steps(x, y, heading, theta), repeats),
        "  B's turn alone": best(lambda: k._turn_steps(x, y, True), repeats),
        "  B's theta alone": best(lambda: k._wrap_headings(heading, theta), repeats),
        "C: running sums of the steps (sequential)": best(
            lambda: k._accumulate(x, y, 0.0, 0.0), repeats
        ),
        "first touch of 5 fresh output arrays (page faults)": best(first_touch, repeats),
        "the floor's copies into arrays already touched": best(copies, repeats),
    }
    print(
        "\nintegrate runs A on one thread, B and C on another, block by block"
        f" ({od.PIPELINE_BLOCK:,} samples; logs of {od.PIPELINE_MIN_SAMPLES:,} or more)"
    )
    print(f"where the time goes (best of {repeats}; integrate {total:.3f} s, floor {floor:.3f} s)")
    for name, sec in parts.items():
        print(f"  {name:52s} {sec:.3f} s = {sec / floor:.2f} x the floor")


if __name__ == "__main__":
    main()
