"""Cost of the slip model's covariance (odolab.core.slip_uncertainty), against the slip model's
odometry without it and the kinematic covariance, measured in the same run.

The whole-log covariance costs time as the square of the log's cycles (its second-order share
sums over every pair of steps): printed for 3,000, 6,000 and 12,000 cycles (20 Hz: 2.5, 5 and 10
minutes) as a ratio to the poses alone. The streaming stepper's cost per cycle is printed at the
start and after the longest log (it grows with the cycles so far; a 20 Hz loop has 50 ms).

Then the two loops compiled (``slip_covariance.COMPILED``, where numba is installed) against the
numpy loops that run without numba, in the same run: a whole log of 3,000 cycles, and 300
pieces of 20 cycles each (``evaluate --nees`` over 1 s pieces: the DRIVE Husky's 314 windows).

With ``--before OLD/src``, last: the slip fit's end-of-piece share (``end_second_order``, which
the noise-term fit calls some hundred times on the same pieces) of this tree against OLD's
(its ``odolab/core/models/slip_covariance.py`` loaded beside this one), on the same pieces at
the shapes of 1 s and 3 s pieces at 20 Hz, the calls alternated; the fastest of 40 calls each
(a single call is short: the fastest is the one least disturbed by the machine's load).

Usage: python benchmarks/bench_slip_covariance.py [--repeats R] [--before OLD/src]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _timing import best  # benchmarks/_timing.py (run as python benchmarks/...)

from odolab import PRESETS
from odolab.core.models import SlipModel, slip_covariance
from odolab.core.odometry import integrate_increments
from odolab.core.params import NoiseParams
from odolab.core.slip_uncertainty import (
    TERMS,
    EndPairs,
    SlipCovarianceStepper,
    end_second_order,
    propagate_covariance,
)
from odolab.core.uncertainty import covariance_from_ticks


def _end_pairs(before: Path) -> None:
    """``end_second_order`` of this tree against ``before``'s, on the same pieces."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location(
        "before_slip_covariance", before / "odolab" / "core" / "models" / "slip_covariance.py"
    )
    if spec is None or spec.loader is None:
        raise SystemExit(f"{before}: no odolab/core/models/slip_covariance.py there")
    old = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = old  # (its dataclasses look their module up)
    spec.loader.exec_module(old)
    rng = np.random.default_rng(0)
    theta = rng.uniform(0.1, 2.0, len(TERMS))
    print("end_second_order (ms a call, fastest of 40): this tree | before | before / this")
    for m, k in ((18, 61), (58, 21)):
        base = rng.uniform(0.0, 1e-4, (m, k, k, 4))
        c0 = rng.uniform(0.0, 1e-5, (m, k, k))
        arrays = (
            rng.normal(0.0, 0.05, (m, k, 2)), 0.5 * (base + base.transpose(0, 2, 1, 3)),
            0.5 * (c0 + c0.transpose(0, 2, 1)), rng.uniform(0.0, 1e-4, (m, k, 4)),
            rng.uniform(0.0, 1e-5, (m, k)),
        )  # fmt: skip
        now, then = EndPairs(*arrays), old.EndPairs(*arrays)
        got, want = end_second_order(theta, now), old.end_second_order(theta, then)
        same = all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
        times: dict[str, list[float]] = {"now": [], "before": []}
        for _ in range(40):
            for name, fn, pairs in (
                ("now", end_second_order, now),
                ("before", old.end_second_order, then),
            ):
                t0 = time.perf_counter()
                fn(theta, pairs)
                times[name].append(time.perf_counter() - t0)
        a, b = min(times["now"]), min(times["before"])
        print(
            f"  {m} pieces of {k} steps: {1e3 * a:.2f} | {1e3 * b:.2f} | {b / a:.2f}x "
            f"({'the same bits' if same else 'RESULTS DIFFER'})"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--before", type=Path, default=None, help="another odolab tree's src/")
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
    if args.before is not None:
        _end_pairs(args.before)
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
