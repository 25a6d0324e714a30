"""Terrain comparison: F-test against an independent computation, false-positive rate."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.analysis import compare_terrains
from odolab.core.errors import InsufficientDataError

X = np.arange(0.5, 5.01, 0.5)


def _data(seed: int, slopes: dict[str, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    return {t: (X.copy(), s * X + rng.normal(0, 0.02, X.size)) for t, s in slopes.items()}


def test_f_test_matches_separate_fits_by_hand() -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    data = _data(0, {"tile": 0.905, "concrete": 0.920, "grass": 0.904})
    res = compare_terrains("x", data)
    rss_full = 0.0
    for x, y in data.values():
        ref = stats.linregress(x, y)
        rss_full += np.sum((y - ref.intercept - ref.slope * x) ** 2)
        assert res.slopes[next(t for t in data if data[t][1] is y)] == pytest.approx(ref.slope)
    # reduced: common slope, one intercept per terrain, by numpy least squares
    n, k = 3 * X.size, 3
    design = np.zeros((n, k + 1))
    y_all = np.concatenate([data[t][1] for t in sorted(data)])
    for j in range(k):
        design[j * X.size : (j + 1) * X.size, j] = 1
        design[j * X.size : (j + 1) * X.size, k] = X
    beta, *_ = np.linalg.lstsq(design, y_all, rcond=None)
    rss_red = np.sum((y_all - design @ beta) ** 2)
    f = ((rss_red - rss_full) / (k - 1)) / (rss_full / (n - 2 * k))
    assert res.f_statistic == pytest.approx(f, rel=1e-9)
    assert res.pvalue == pytest.approx(stats.f.sf(f, k - 1, n - 2 * k), rel=1e-9)
    assert res.partial_eta2 == pytest.approx((rss_red - rss_full) / rss_red, rel=1e-9)
    assert res.df_num == 2 and res.df_den == n - 6


def test_equal_slopes_rejected_about_5_percent_of_seeds() -> None:
    n_seeds = 300
    rejected = sum(
        compare_terrains("x", _data(s, {"a": 0.9, "b": 0.9, "c": 0.9})).differ
        for s in range(n_seeds)
    )
    # measured 0.0433-0.0467 over seed shifts 0-3; bound 0.085; at seed shift 0 it is 12.5x the
    # spread over seeds away
    assert 0.02 <= rejected / n_seeds <= 0.085


def test_clear_difference_is_found() -> None:
    res = compare_terrains("x", _data(1, {"tile": 0.90, "grass": 0.95}))
    assert res.differ
    assert res.largest_pair == ("grass", "tile")
    lo, hi = res.largest_difference_ci95
    # measured 0.05 over seed shifts 0-3; bound 4 bounds; the same at every seed
    assert lo <= 0.05 <= hi
    # measured |value - expected| 0.00153-0.0054 over seed shifts 0-3; tolerance 0.01; at seed shift
    # 0 it is 2.12x the spread over seeds away
    assert res.largest_difference == pytest.approx(0.05, abs=0.01)


def test_needs_two_terrains() -> None:
    with pytest.raises(InsufficientDataError, match="at least 2 terrains"):
        compare_terrains("x", {"tile": (X, X), "grass": (X[:2], X[:2])})
