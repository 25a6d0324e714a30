"""What the slip fit's Kalman filter costs (issue 37): `calibrate lsq --model slip`'s fit on a
60 s exploration of the independent icr-speed simulator with 5 cm / 0.1 rad of truth noise
(where the filter gives the coefficients), against the same fit with the regression forced
(``slipfit.filtered`` off), each with numba and as plain Python (``NUMBA_DISABLE_JIT=1``, as a
core install without the ``fast`` extra runs it). Every variant runs in its own process, after
one untimed fit (numba's cache filled, imports done), best of ``--rounds``; ratios, not times.

    PYTHONPATH=src:tests python benchmarks/bench_slip_filter.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import sys, time
sys.path.insert(0, {root!r}); sys.path.insert(0, {root!r} + "/benchmarks")
from bench_noisy_truth import noisy
from tests.models.independent_sims import IcrSpeedSim, exploration
from odolab.calibration import slipfit
from odolab.calibration.lsq import LsqOptions, calibrate_lsq, prepare_run
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.io.run import OdometryRun
r = noisy(exploration(IcrSpeedSim(), 1), 0.05, 0.1, 7919)
gt = Trajectory.from_xyh(r.t, r.x, r.y, r.heading)
run = prepare_run(OdometryRun("e", "e", r.t, r.dticks_left, r.dticks_right, ground_truth=gt))
if {regression}:
    slipfit.filtered = lambda *a, **k: False
fit = lambda: calibrate_lsq([run], PRESETS["jaguar-lite"], LsqOptions(model="slip"))
fit()
best = float("inf")
for _ in range({rounds}):
    t0 = time.perf_counter(); f = fit(); best = min(best, time.perf_counter() - t0)
print(best, f.notes[-1][:40])
"""


def _time(regression: bool, jit: bool, rounds: int) -> float:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT / "tests"), str(ROOT)])
    if not jit:
        env["NUMBA_DISABLE_JIT"] = "1"
    code = CHILD.format(root=str(ROOT), regression=regression, rounds=rounds)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return float(out.stdout.split()[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    t = {(reg, jit): _time(reg, jit, a.rounds) for reg in (False, True) for jit in (True, False)}
    base = t[(True, True)]
    for (reg, jit), v in t.items():
        what = "regression (forced)" if reg else "Kalman filter (the default here)"
        print(f"{what:32s} {'numba' if jit else 'plain Python':12s} {v:7.2f} s  {v / base:5.2f}x")
    print(f"the filter over the regression, with numba: {t[(False, True)] / base:.2f}x")
    print(f"without numba over with it, the filter: {t[(False, False)] / t[(False, True)]:.2f}x")


if __name__ == "__main__":
    main()
