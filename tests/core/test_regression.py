"""odolab.core.regression gives statsmodels' numbers (statsmodels stays a dev dependency for this
comparison only): OLS with intervals and R², the F test, cluster and panel Newey-West
covariances, the Huber line and the numerical Hessian, to 1e-9 relative."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from odolab.core.regression import (
    approx_hess3,
    cluster_cov,
    f_test,
    huber_line,
    newey_west_panel_cov,
    ols,
    panel_lags,
)

RTOL = 1e-9


def _ols(y: Any, x: Any) -> Any:
    """statsmodels' OLS, imported when a test runs: statsmodels.api takes 1.2-1.4 s to import,
    which every xdist worker paid at collection for the few tests here."""
    from statsmodels.regression.linear_model import OLS

    return OLS(y, x)


def _line(seed: int, n: int = 40) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.5, 20.0, n)
    y = 0.02 + 0.97 * x + rng.normal(0.0, 0.05 * np.sqrt(x))
    return x, y


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_ols_line_with_intervals_and_r2(seed: int) -> None:
    x, y = _line(seed)
    for design, centered in ((np.column_stack([np.ones_like(x), x]), True), (x[:, None], False)):
        ours = ols(y, design)
        ref = _ols(y, design).fit()
        np.testing.assert_allclose(ours.params, ref.params, rtol=RTOL)
        np.testing.assert_allclose(ours.bse, ref.bse, rtol=RTOL)
        np.testing.assert_allclose(ours.conf_int(), ref.conf_int(alpha=0.05), rtol=RTOL)
        np.testing.assert_allclose(ours.cov, ref.cov_params(), rtol=RTOL)
        assert ours.rsquared(y, centered=centered) == pytest.approx(ref.rsquared, rel=RTOL)
        assert ours.scale == pytest.approx(ref.mse_resid, rel=RTOL)
        assert ours.df_resid == ref.df_resid


def test_f_test_of_nested_models() -> None:
    rng = np.random.default_rng(7)
    x = rng.uniform(1, 10, 30)
    t = np.repeat([0, 1, 2], 10)
    y = 0.1 * t + (1.0 + 0.02 * t) * x + rng.normal(0, 0.1, 30)
    full = np.column_stack([(t == j) for j in range(3)] + [x * (t == j) for j in range(3)])
    reduced = np.column_stack([(t == j) for j in range(3)] + [x])
    ours = f_test(ols(y, full.astype(float)), ols(y, reduced.astype(float)))
    ref = _ols(y, full.astype(float)).fit().compare_f_test(_ols(y, reduced.astype(float)).fit())
    np.testing.assert_allclose(ours, ref, rtol=RTOL)


def test_cluster_and_panel_covariances() -> None:
    rng = np.random.default_rng(11)
    n = 120
    x = np.column_stack([rng.normal(size=n), rng.normal(size=n), np.ones(n)])
    groups = np.repeat(np.arange(24), 5)
    y = x @ np.array([0.3, -1.2, 0.5]) + rng.normal(size=n) + np.repeat(rng.normal(size=24), 5)
    fit = ols(y, x)
    ref = _ols(y, x).fit(cov_type="cluster", cov_kwds={"groups": groups})
    np.testing.assert_allclose(cluster_cov(fit, x, groups), ref.cov_params(), rtol=RTOL)
    segs = np.repeat(np.arange(6), 20)
    for lags in (0, 2, 5):
        ref = _ols(y, x).fit(cov_type="hac-panel", cov_kwds={"groups": segs, "maxlags": lags})
        np.testing.assert_allclose(
            newey_west_panel_cov(fit, x, segs, lags), ref.cov_params(), rtol=RTOL
        )


def test_panel_lags_longer_than_every_group_add_nothing() -> None:
    """A short run (the 2014 board's quarter turn) has segments of 3 rows: lags 3-5 have no
    pairs. statsmodels raises ("all groups are empty taking lags"), which reached the user as a
    traceback after `robot rotate --turns 0.25`; here those lags add nothing, and panel_lags says
    which were used."""
    rng = np.random.default_rng(5)
    n = 12
    x = np.column_stack([rng.normal(size=n), np.ones(n)])
    y = x @ np.array([0.7, 0.1]) + rng.normal(size=n)
    fit = ols(y, x)
    segs = np.repeat(np.arange(4), 3)
    assert panel_lags(segs, 5) == 2 and panel_lags(segs, 1) == 1
    cov = newey_west_panel_cov(fit, x, segs, 5)
    assert np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(cov) > 0)
    # the lags that have pairs, with maxlags 5's Bartlett weights (1 - lag / 6): by hand
    xu = x * fit.resid[:, None]
    s = xu.T @ xu
    for lag, w in ((1, 5 / 6), (2, 4 / 6)):
        a = np.vstack([xu[g * 3 + lag : g * 3 + 3] for g in range(4)])
        b = np.vstack([xu[g * 3 : g * 3 + 3 - lag] for g in range(4)])
        s = s + w * (a.T @ b + b.T @ a)
    want = fit.normalized_cov @ s @ fit.normalized_cov.T * (n / (n - 2))
    np.testing.assert_allclose(cov, want, rtol=RTOL)


@pytest.mark.parametrize("seed", [4, 5])
def test_huber_line_with_outliers(seed: int) -> None:
    from statsmodels.robust.norms import HuberT
    from statsmodels.robust.robust_linear_model import RLM

    x, y = _line(seed, 50)
    y[[3, 17, 30]] += 2 * math.pi  # whole turns miscounted
    w = np.sqrt(x)
    design = np.column_stack([1.0 / w, x / w])
    params, scale = huber_line(y / w, design)
    ref = RLM(y / w, design, M=HuberT()).fit()
    np.testing.assert_allclose(params, ref.params, rtol=RTOL)
    assert scale == pytest.approx(ref.scale, rel=RTOL)


def test_numerical_hessian() -> None:
    from statsmodels.tools.numdiff import approx_hess3 as ref_hess

    def f(u: NDArray[np.float64]) -> float:
        return float(math.exp(u[0]) * u[1] ** 2 + math.sin(u[0] * u[1]) + 3 * u[1] ** 4)

    for u in (np.array([0.3, -1.1]), np.array([-2.0, 0.05]), np.array([1.5])):
        g = f if u.size == 2 else (lambda v: float(math.exp(2 * v[0]) - v[0] ** 3))
        np.testing.assert_allclose(approx_hess3(u, g), ref_hess(u, g), rtol=RTOL)
