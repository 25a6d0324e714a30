"""The slip regression's shrinkage toward the kinematic centre chosen by grouped
cross-validation (``slipfit._shrinkage``; off by default, measured in
benchmarks/bench_truth_noise.py --shrink): held-out pieces of chained windows pick no slip
where the data have none and the weak prior where they have a large one."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.calibration import slipfit


def _heading_design(n: int) -> slipfit.SlipDesign:
    z = np.zeros(0)
    return slipfit.SlipDesign(
        a_xy=np.zeros((0, 1)),
        y_xy=z,
        a_yaw=np.zeros((n, 1)),
        y_yaw=np.zeros(n),
        durations=np.full(n, 0.5),
        travel=np.zeros(n),
        turn=np.zeros(n),
        v_rms=1.0,
        w_rms=1.0,
        phi_rms=np.ones(1),
        previous=np.arange(n) - 1,
        turn_from_previous=np.zeros(n),
    )


@pytest.mark.parametrize(("slip", "expected"), [(0.0, "none"), (0.2, "weak prior")])
def test_cross_validation_picks_the_kinematic_centre_or_the_weak_prior(
    slip: float, expected: str
) -> None:
    rng = np.random.default_rng(5)
    n = 300
    d = _heading_design(n)
    x = rng.normal(size=(n, 4))
    beta = np.array([slip, -slip, 0.5 * slip, 0.0])
    y = x @ beta + 0.05 * rng.normal(size=n)
    fold = np.minimum(np.arange(n) * slipfit.SHRINK_FOLDS // n, slipfit.SHRINK_FOLDS - 1)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(slipfit, "SHRINK_GRID", slipfit.SHRINK_GRID_MEASURED)
        mult = slipfit._shrinkage(x, y, np.ones(4), np.ones((n, 1)), np.zeros(4), None, d, fold)
    # the grid's steps: 0, 0.03, 0.1, 0.3, 1
    if expected == "none":
        assert mult <= 0.03  # measured (seed 5): 0.0 without slip
    else:
        assert mult > 0.1  # measured (seed 5): 0.3 with a slip of 0.2 on a noise of 0.05


def test_no_grid_keeps_the_weak_prior() -> None:
    d = _heading_design(10)
    fold = np.arange(10) % 2
    mult = slipfit._shrinkage(
        np.ones((10, 1)), np.ones(10), np.ones(1), np.ones((10, 1)), np.zeros(1), None, d, fold
    )
    assert mult == 1.0
