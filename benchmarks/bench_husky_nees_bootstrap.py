"""How much the slip model's NEES on the DRIVE Husky moves with its own estimation (issue 37):
the slip model refitted on command steps resampled with replacement (the even steps; a cluster
bootstrap, DRIVE's unit), each refit's mean NEES over 1 s pieces of the held-out (odd) windows.
The chi-square bounds take the covariance as known; widened by the refits' spread (their
2.5-97.5 % ratio to the fit's own mean NEES, applied to the bounds), they allow for it.

    PYTHONPATH=src ODOLAB_TEST_DATA=../shared/data python benchmarks/bench_husky_nees_bootstrap.py [B]
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
from _husky import HUSKY

from odolab.calibration.lsq import LsqOptions, calibrate_lsq, prepare_run
from odolab.io.registry import find_runs, read_run
from odolab.io.run import ReadOptions
from odolab.metrics.consistency import nees_of_runs, nees_summary


def main() -> None:
    boots = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    data = Path(os.environ.get("ODOLAB_TEST_DATA", "../shared/data"))
    table = data / "drive-husky" / "husky_windows.csv"
    ro = ReadOptions(params=HUSKY)
    train = [read_run(p, "drive", ro) for p in find_runs([f"{table}#even"], "drive")]
    held = [read_run(p, "drive", ro) for p in find_runs([f"{table}#odd"], "drive")]
    prep = [prepare_run(r, 2.0) for r in train]
    steps: dict[int, list[int]] = {}
    for k, r in enumerate(train):
        steps.setdefault(int(r.meta["calib_step"]), []).append(k)

    def mean_nees(runs: list[int]) -> tuple[float, tuple[float, float]]:
        fit = calibrate_lsq([prep[k] for k in runs], HUSKY, LsqOptions(model="slip"))
        results, _, _ = nees_of_runs(held, lambda _r: fit.params, segment_s=1.0)
        s = nees_summary(results)
        return s.mean, s.mean_bounds95

    own, (lo, hi) = mean_nees(list(range(len(train))))
    print(f"fit on all even steps: mean NEES {own:.3f}, chi-square bounds [{lo:.3f}, {hi:.3f}]")
    rng = np.random.default_rng(0)
    keys = sorted(steps)
    ratios = []
    for b in range(boots):
        drawn = rng.choice(keys, size=len(keys), replace=True)
        runs = [k for s in drawn for k in steps[int(s)]]
        m, _ = mean_nees(runs)
        ratios.append(m / own)
        print(f"refit {b + 1}: mean NEES {m:.3f} ({m / own:.3f}x)", flush=True)
    q_lo, q_hi = np.percentile(ratios, [2.5, 97.5])
    wlo, whi = lo * min(q_lo, 1.0), hi * max(q_hi, 1.0)
    inside = "inside" if wlo <= own <= whi else "outside"
    print(
        f"refits' mean NEES over the fit's: {q_lo:.3f}-{q_hi:.3f} ({boots} refits); bounds "
        f"widened for the estimation: [{wlo:.3f}, {whi:.3f}]: the fit's {own:.3f} is {inside}"
    )


if __name__ == "__main__":
    main()
