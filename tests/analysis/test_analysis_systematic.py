"""Line fits against scipy, and the 95% interval's coverage over many seeds."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.analysis import MIN_FIT_POINTS, fit_line
from odolab.core.errors import InsufficientDataError


def test_fit_matches_scipy_linregress() -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    rng = np.random.default_rng(3)
    x = np.linspace(1, 20, 15)
    y = 0.875 * x + 0.3 + rng.normal(0, 0.5, x.size)
    fit = fit_line(x, y, name="rotation")
    ref = stats.linregress(x, y)
    assert fit.slope == pytest.approx(ref.slope, rel=1e-12)
    assert fit.intercept == pytest.approx(ref.intercept, rel=1e-12)
    assert fit.slope_se == pytest.approx(ref.stderr, rel=1e-10)
    assert fit.intercept_se == pytest.approx(ref.intercept_stderr, rel=1e-10)
    assert fit.r2 == pytest.approx(ref.rvalue**2, rel=1e-12)
    t = stats.t.ppf(0.975, x.size - 2)
    assert fit.slope_ci95 == pytest.approx((ref.slope - t * ref.stderr, ref.slope + t * ref.stderr))
    resid = y - (ref.intercept + ref.slope * x)
    np.testing.assert_allclose(fit.residuals, resid, atol=1e-12)
    assert fit.residual_sd == pytest.approx(np.sqrt(np.sum(resid**2) / (x.size - 2)))


def test_slope_interval_covers_truth_95_percent_of_seeds() -> None:
    truth, n_seeds, hits = 0.905, 400, 0
    x = np.array([1.1] * 5 + [2.5] * 5 + [-1.1] * 5 + [-2.5] * 5)
    for seed in range(n_seeds):
        rng = np.random.default_rng(seed)
        y = truth * x + rng.normal(0, 0.02, x.size)
        lo, hi = fit_line(x, y).slope_ci95
        hits += lo <= truth <= hi
    # binomial(400, 0.95): sd 4.4 trials; 0.92..0.98 is about +-2.7 sd
    # measured 0.948 (379 of 400 seeds; the same with seeds shifted by 1-3); bounds 0.92 and 0.98
    # are 11 and 13 seeds away, the binomial sd is 4.5 seeds
    assert 0.92 <= hits / n_seeds <= 0.98


def test_too_few_trials_say_how_many_are_needed() -> None:
    with pytest.raises(InsufficientDataError, match=f"at least {MIN_FIT_POINTS} measured trials"):
        fit_line([1.0, 2.0], [0.9, 1.8], name="x (tile)")


def test_constant_predicted_value_is_refused() -> None:
    with pytest.raises(InsufficientDataError, match="two or more different"):
        fit_line([2.5, 2.5, 2.5], [2.2, 2.3, 2.25])


def test_nan_is_refused() -> None:
    with pytest.raises(InsufficientDataError, match="NaN"):
        fit_line([1.0, 2.0, np.nan], [1.0, 2.0, 3.0])


def test_through_origin_fit_matches_hand_formula() -> None:
    """Table I's ratio: y = slope * x, slope = x.y / x.x, se = s / |x|, s^2 = RSS / (n - 1)."""
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    from odolab.analysis.systematic import fit_line

    rng = np.random.default_rng(5)
    x = np.linspace(1.0, 10.0, 12)
    y = 0.9 * x + rng.normal(0, 0.05, x.size)
    f = fit_line(x, y, through_origin=True)
    slope = x @ y / (x @ x)
    s2 = np.sum((y - slope * x) ** 2) / (x.size - 1)
    se = np.sqrt(s2 / (x @ x))
    t = stats.t.ppf(0.975, x.size - 1)
    assert f.slope == pytest.approx(slope, rel=1e-12)
    assert f.slope_se == pytest.approx(se, rel=1e-10)
    assert f.slope_ci95 == pytest.approx((slope - t * se, slope + t * se), rel=1e-10)
    assert f.intercept == 0.0 and f.df_resid == x.size - 1
