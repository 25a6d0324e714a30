"""Random error: chi-square intervals, group spreads, normality test, coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.analysis import group_spreads, random_error, sd_confidence_interval
from odolab.core.errors import InsufficientDataError


def test_sd_interval_matches_chi_square_by_hand() -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    lo, hi = sd_confidence_interval(2.94, 17)
    assert lo == pytest.approx(2.94 * math.sqrt(17 / stats.chi2.ppf(0.975, 17)))
    assert hi == pytest.approx(2.94 * math.sqrt(17 / stats.chi2.ppf(0.025, 17)))
    # measured 2.94 over seed shifts 0-3; bound 4.41; the same at every seed
    assert lo < 2.94 < hi


def test_sd_interval_covers_truth_95_percent_of_seeds() -> None:
    sigma, n, n_seeds, hits = 0.07, 5, 600, 0
    for seed in range(n_seeds):
        s = float(np.std(np.random.default_rng(seed).normal(0.1, sigma, n), ddof=1))
        lo, hi = sd_confidence_interval(s, n - 1)
        hits += lo <= sigma <= hi
    # measured 0.955 (573 of 600 seeds; seeds 1-603 give the same to 3 digits); bounds 0.925 and
    # 0.975 are 18 and 12 seeds away, the binomial sd is 5 seeds
    assert 0.925 <= hits / n_seeds <= 0.975


def test_random_error_uses_residual_dof_and_shapiro() -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    r = np.random.default_rng(5).normal(0, 0.03, 20)
    r -= r.mean()
    res = random_error(r, df=18)
    assert res.sd == pytest.approx(math.sqrt(np.sum(r**2) / 18))
    sh = stats.shapiro(r)
    assert res.normality is not None
    assert res.normality.pvalue == pytest.approx(sh.pvalue)
    mu, s = stats.norm.fit(r)
    # measured equal to 1e-12 (the interval's arithmetic) at every seed shift 0-3; tolerance 1e-6
    assert res.interval95 == pytest.approx((mu - 1.959964 * s, mu + 1.959964 * s), rel=1e-6)
    with pytest.raises(InsufficientDataError):
        random_error([0.1], df=0)


def test_group_spreads_split_by_signed_distance() -> None:
    cmd = np.array([1.1] * 5 + [-1.1] * 5 + [2.5] * 2)
    rng = np.random.default_rng(2)
    err = np.concatenate([0.1 + rng.normal(0, 0.01, 5), -0.1 + rng.normal(0, 0.02, 5), [0, 1]])
    groups = group_spreads(cmd, cmd, err)
    assert [g.commanded for g in groups] == [-1.1, 1.1]  # 2.5 has only 2 trials: left out
    assert groups[1].sd == pytest.approx(np.std(err[:5], ddof=1))
    assert groups[0].sd == pytest.approx(np.std(err[5:10], ddof=1))
    assert groups[1].at == pytest.approx(1.1)
