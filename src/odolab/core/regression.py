"""Least-squares lines and their uncertainty with numpy alone: ordinary least squares (plain,
cluster-robust and panel Newey-West covariances), a Huber M-estimate, a numerical Hessian.

These are the few pieces of statsmodels that odolab used, written out so that the core installs
without statsmodels and pandas (142 MB; docs/architecture.md, "What the core installs"). Each
follows statsmodels' own definition step for step (the same pseudo-inverse, degrees of freedom,
small-sample corrections, iteration and stopping rule), so the numbers are the same to rounding;
tests/core/test_regression.py compares them with statsmodels itself.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray as F64

__all__ = [
    "OlsFit",
    "approx_hess3",
    "cluster_cov",
    "huber_line",
    "newey_west_panel_cov",
    "ols",
    "panel_lags",
]


#: statsmodels' HuberT tuning constant (95 % efficiency at the normal).
HUBER_T = 1.345
#: The normal's 75 % quantile: a median absolute deviation divided by it estimates sigma.
_MAD_TO_SIGMA = 0.6744897501960817


@dataclass(frozen=True, eq=False)
class OlsFit:
    """``y = X @ params`` by least squares. ``params``, ``bse``: shape (k,); ``resid``,
    ``fitted``: shape (n,); ``normalized_cov``: ``(X'X)^-1``, shape (k, k); ``cov``: the
    parameters' covariance, ``normalized_cov * scale`` with ``scale = ssr / df_resid``."""

    params: F64
    normalized_cov: F64
    fitted: F64
    resid: F64
    ssr: float
    df_resid: int
    rank: int

    @property
    def scale(self) -> float:
        return self.ssr / self.df_resid

    @property
    def cov(self) -> F64:
        return self.normalized_cov * self.scale

    @property
    def bse(self) -> F64:
        return np.sqrt(np.diag(self.cov))

    def conf_int(self, cov: F64 | None = None, level: float = 0.95) -> F64:
        """Intervals of the parameters, shape (k, 2), on Student's t with ``df_resid``
        degrees of freedom (``cov``: another covariance of the parameters, e.g. robust)."""
        from odolab.core.distributions import t_ppf

        se = self.bse if cov is None else np.sqrt(np.diag(cov))
        q = t_ppf(0.5 + level / 2, self.df_resid)
        return np.column_stack([self.params - q * se, self.params + q * se])

    def rsquared(self, y: F64, *, centered: bool) -> float:
        """1 - ssr / tss; ``centered=False`` for a model without a constant (tss about 0)."""
        tss = float(np.sum((y - y.mean()) ** 2)) if centered else float(np.dot(y, y))
        with np.errstate(invalid="ignore", divide="ignore"):
            return float(1.0 - np.float64(self.ssr) / np.float64(tss))


def ols(y: F64, x: F64) -> OlsFit:
    """Ordinary least squares of ``y`` (shape (n,)) on the design ``x`` (shape (n, k)), through
    the singular-value pseudo-inverse, as statsmodels' OLS does."""
    ya = np.asarray(y, dtype=np.float64)
    xa = np.asarray(x, dtype=np.float64)
    pinv = np.linalg.pinv(xa)
    params = pinv @ ya
    fitted = xa @ params
    resid = ya - fitted
    rank = int(np.linalg.matrix_rank(xa))
    return OlsFit(
        params=params,
        normalized_cov=pinv @ pinv.T,
        fitted=fitted,
        resid=resid,
        ssr=float(np.dot(resid, resid)),
        df_resid=int(ya.size - rank),
        rank=rank,
    )


def f_test(full: OlsFit, restricted: OlsFit) -> tuple[float, float, int]:
    """F statistic, its p-value and the numerator's degrees of freedom of ``restricted``
    (a nested model) against ``full``."""
    from odolab.core.distributions import f_sf

    df_diff = restricted.df_resid - full.df_resid
    f = (restricted.ssr - full.ssr) / df_diff / full.ssr * full.df_resid
    return float(f), f_sf(f, df_diff, full.df_resid), df_diff


def _scores(fit: OlsFit, x: F64) -> F64:
    return np.asarray(x, dtype=np.float64) * fit.resid[:, None]


def cluster_cov(fit: OlsFit, x: F64, groups: NDArray[np.int64]) -> F64:
    """The parameters' covariance robust to correlation inside each group (CRV1, with the
    small-sample factor ``G/(G-1) (n-1)/(n-k)``)."""
    xu = _scores(fit, x)
    _, inverse = np.unique(groups, return_inverse=True)
    n_groups = int(inverse.max()) + 1
    sums = np.zeros((n_groups, xu.shape[1]))
    np.add.at(sums, inverse.ravel(), xu)
    bread = fit.normalized_cov
    cov = bread @ (sums.T @ sums) @ bread.T
    n, k = xu.shape
    return np.asarray(cov * (n_groups / (n_groups - 1.0) * ((n - 1.0) / float(n - k))))


def _spans(groups: NDArray[np.int64]) -> list[tuple[int, int]]:
    """(start, end) of each run of equal consecutive ``groups``."""
    g = np.asarray(groups)
    cuts = (np.nonzero(g[:-1] != g[1:])[0] + 1).tolist()
    return list(zip([0, *cuts], [*cuts, len(g)], strict=True))


def panel_lags(groups: NDArray[np.int64], maxlags: int) -> int:
    """The lags :func:`newey_west_panel_cov` uses of ``maxlags``: no more than the longest run
    of equal consecutive ``groups`` has pairs for."""
    longest = max((up - lo for lo, up in _spans(groups)), default=0)
    return max(0, min(maxlags, longest - 1))


def newey_west_panel_cov(fit: OlsFit, x: F64, groups: NDArray[np.int64], maxlags: int) -> F64:
    """The parameters' covariance robust to autocorrelation (Bartlett weights, ``maxlags``)
    inside each run of equal consecutive ``groups`` (the rows of a group are consecutive), with
    the factor ``n/(n-k)``. A lag longer than every group has no pair of rows that far apart
    and adds nothing (statsmodels raises there; :func:`panel_lags` says the lags used)."""
    xu = _scores(fit, x)
    spans = _spans(groups)
    weights = [1.0, 0.0] if maxlags == 0 else 1 - np.arange(maxlags + 1) / (maxlags + 1.0)
    s = weights[0] * (xu.T @ xu)
    for lag in range(1, len(weights)):
        now = [xu[lo + lag : up] for lo, up in spans if lo + lag < up]
        before = [xu[lo : up - lag] for lo, up in spans if lo + lag < up]
        if not now:
            break  # no group this long, nor any longer lag
        cross = np.vstack(now).T @ np.vstack(before)
        s = s + weights[lag] * (cross + cross.T)
    bread = fit.normalized_cov
    n, k = xu.shape
    return np.asarray(bread @ s @ bread.T * (n / float(n - k)))


def _huber_rho(z: F64) -> F64:
    small = np.abs(z) <= HUBER_T
    return np.asarray(small * 0.5 * z**2 + (1 - small) * (np.abs(z) * HUBER_T - 0.5 * HUBER_T**2))


def _huber_weights(z: F64) -> F64:
    small = np.abs(z) <= HUBER_T
    absz = np.abs(z)
    absz[small] = 1.0
    return np.asarray(small + (1 - small) * HUBER_T / absz)


def huber_line(y: F64, x: F64, maxiter: int = 50, tol: float = 1e-8) -> tuple[F64, float]:
    """Huber M-estimate (``t = 1.345``) of ``y`` (n,) on the design ``x`` (n, k) by iteratively
    reweighted least squares from the OLS start, the scale re-estimated at each step as the
    median absolute residual / 0.6745, until the Huber objective changes by at most ``tol``
    (statsmodels' RLM with its defaults). Returns (params, scale)."""
    ya = np.asarray(y, dtype=np.float64)
    xa = np.asarray(x, dtype=np.float64)
    df_resid = ya.size - int(np.linalg.matrix_rank(xa))

    def wls(w: F64) -> tuple[F64, F64, float]:
        half = np.sqrt(w)
        params = np.linalg.pinv(half[:, None] * xa) @ (half * ya)
        resid = ya - xa @ params
        wresid = half * resid
        return params, resid, float(np.dot(wresid, wresid) / df_resid)

    params, resid, wls_scale = wls(np.ones_like(ya))
    scale = float(np.median(np.abs(resid) / _MAD_TO_SIGMA))
    deviance = [math.inf, float(_huber_rho(resid / wls_scale).sum())]
    iteration = 1
    while True:
        if scale == 0.0:  # a perfect fit of the weighted data
            break
        params, resid, wls_scale = wls(_huber_weights(resid / scale))
        scale = float(np.median(np.abs(resid) / _MAD_TO_SIGMA))
        deviance.append(float(_huber_rho(resid / wls_scale).sum()))
        iteration += 1
        if not (abs(deviance[iteration] - deviance[iteration - 1]) > tol and iteration < maxiter):
            break
    return params, scale


def approx_hess3(x: F64, f: Callable[[F64], float]) -> F64:
    """The Hessian of ``f`` at ``x`` (shape (n,)) by central differences with steps
    ``eps^(1/4) max(|x|, 0.1)`` (statsmodels' approx_hess3). Shape (n, n)."""
    xa = np.asarray(x, dtype=np.float64)
    n = xa.size
    h = np.finfo(float).eps ** (1.0 / 4) * np.maximum(np.abs(xa), 0.1)
    ee = np.diag(h)
    hess = np.outer(h, h)
    for i in range(n):
        for j in range(i, n):
            hess[i, j] = (
                f(xa + ee[i, :] + ee[j, :])
                - f(xa + ee[i, :] - ee[j, :])
                - (f(xa - ee[i, :] + ee[j, :]) - f(xa - ee[i, :] - ee[j, :]))
            ) / (4.0 * hess[i, j])
            hess[j, i] = hess[i, j]
    return hess
