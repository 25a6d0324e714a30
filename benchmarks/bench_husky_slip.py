"""The slip fit's alternatives on the DRIVE Husky (issue 37): fitted on even command steps,
held out on odd ones; the held-out mean end-point error of each alternative over the ICR model's
(the best kinematic model on end points). Ratios, not times.

    PYTHONPATH=src ODOLAB_TEST_DATA=../shared/data python benchmarks/bench_husky_slip.py

Alternatives: the regression window (0.25, 0.5 = the default, 1, 1.9 s) and the rows' noise
Gaussian or Student-t (``slipfit.ROBUST_NU`` 10, 4, 2: a row far off its variance weighs less,
against scan-matcher glitches).
"""

from __future__ import annotations

import functools

from _husky import HUSKY, held_out_error, husky_split

from odolab.calibration import slipfit
from odolab.calibration.lsq import LsqOptions, calibrate_lsq


def main() -> None:
    _train, held, prep = husky_split()

    def end(params: object) -> float:
        return held_out_error(held, params)

    icr = end(calibrate_lsq(prep, HUSKY, LsqOptions(model="icr")).params)
    print(f"icr (best kinematic on end points): {icr:.4f} m")
    original = slipfit.fit_slip_model
    for window in (0.25, 0.5, 1.0, 1.9):
        slipfit.fit_slip_model = functools.partial(original, window_s=window)  # type: ignore[assignment]
        e = end(calibrate_lsq(prep, HUSKY, LsqOptions(model="slip")).params)
        print(f"slip, window {window:g} s, Gaussian rows: {e:.4f} m, {e / icr:.3f}x icr")
    slipfit.fit_slip_model = original  # type: ignore[assignment]
    for nu in (10.0, 4.0, 2.0):
        slipfit.ROBUST_NU = nu
        e = end(calibrate_lsq(prep, HUSKY, LsqOptions(model="slip")).params)
        print(f"slip, window 0.5 s, Student-t rows (nu {nu:g}): {e:.4f} m, {e / icr:.3f}x icr")
    slipfit.ROBUST_NU = None


if __name__ == "__main__":
    main()
