"""The few distribution functions odolab's intervals and tests need, from ``scipy.special``.

``scipy.stats`` takes about a second to import (0.95 s here, more than half of an
``odolab analyze`` of the demo's notebook), and odolab used it only for these quantiles and tail
probabilities. Each function here calls the special function that ``scipy.stats``' distribution
calls for it (``chi2._ppf`` is ``2 gammaincinv(k / 2, p)``, ``chi2._sf`` is ``chdtrc``,
``t._ppf`` is ``stdtrit``, ``f._sf`` is ``fdtrc``), so the values are the same to the bit
(tests/core/test_distributions.py compares them with ``scipy.stats`` itself). The
Shapiro-Wilk test is Royston's algorithm AS R94 (1995), the one ``scipy.stats.shapiro`` runs, in
double precision (scipy's runs in single: the two agree to about 1e-6).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Z95",
    "chi2_mean_bounds",
    "chi2_ppf",
    "chi2_sf",
    "f_sf",
    "norm_fit",
    "norm_pdf",
    "shapiro_wilk",
    "t_ppf",
]

#: The standard normal's 0.975 quantile: a 95 % two-sided interval is the estimate +- Z95 standard
#: errors (``scipy.special.ndtri(0.975)``, as ``scipy.stats.norm.ppf(0.975)``).
Z95 = 1.959963984540054


def chi2_ppf(p: float, dof: float) -> float:
    """The chi-square distribution's ``p`` quantile with ``dof`` degrees of freedom."""
    from scipy import special

    return float(2.0 * special.gammaincinv(dof / 2.0, p))


def chi2_mean_bounds(dof: float, values: int) -> tuple[float, float]:
    """Two-sided 95 % bounds of the mean of ``values`` numbers whose sum is chi-square with
    ``dof`` degrees of freedom (a NEES mean: ``dof`` = 3 a piece, less any the fit took)."""
    return chi2_ppf(0.025, dof) / values, chi2_ppf(0.975, dof) / values


def chi2_sf(x: float, dof: float) -> float:
    """P(X > ``x``) for a chi-square ``X`` with ``dof`` degrees of freedom (1 for ``x`` <= 0;
    NaN for ``dof`` <= 0, as scipy.stats)."""
    from scipy import special

    if not dof > 0:
        return math.nan
    return 1.0 if x <= 0.0 else float(special.chdtrc(dof, x))


def t_ppf(q: float, dof: float) -> float:
    """Student's t distribution's ``q`` quantile with ``dof`` degrees of freedom."""
    from scipy import special

    return float(special.stdtrit(dof, q))


def f_sf(x: float, dfn: float, dfd: float) -> float:
    """P(F > ``x``) for an F distribution with (``dfn``, ``dfd``) degrees of freedom (NaN for
    degrees of freedom <= 0, as scipy.stats)."""
    from scipy import special

    if not (dfn > 0 and dfd > 0):
        return math.nan
    return 1.0 if x <= 0.0 else float(special.fdtrc(dfn, dfd, x))


def norm_pdf(x: ArrayLike, mean: float, sd: float) -> NDArray[np.float64]:
    """The normal density with ``mean`` and standard deviation ``sd`` at ``x``."""
    z = (np.asarray(x, dtype=np.float64) - mean) / sd
    return np.asarray(np.exp(-(z**2) / 2.0) / math.sqrt(2.0 * math.pi) / sd, dtype=np.float64)


def norm_fit(data: ArrayLike) -> tuple[float, float]:
    """Maximum-likelihood (mean, standard deviation) of a normal fitted to ``data`` (the
    deviation divides by n, as ``scipy.stats.norm.fit``)."""
    d = np.asarray(data, dtype=np.float64)
    loc = d.mean()
    return float(loc), float(np.sqrt(((d - loc) ** 2).mean()))


# Royston (1992, 1995), AS R94: the weights' corrections (in 1/sqrt(n)) and the p-value's
# normalising transformation (small n: in n; n >= 12: in log n); constant term first
_C1 = (0.0, 0.221157, -0.147981, -2.071190, 4.434685, -2.706056)
_C2 = (0.0, 0.042981, -0.293762, -1.752461, 5.682633, -3.582633)
_C3 = (0.5440, -0.39978, 0.025054, -6.714e-4)
_C4 = (1.3822, -0.77857, 0.062767, -0.0020322)
_C5 = (-1.5861, -0.31082, -0.083751, 0.0038915)
_C6 = (-0.4803, -0.082676, 0.0030302)
_G = (-2.273, 0.459)


def _poly(c: tuple[float, ...], x: float) -> float:
    return sum(ci * x**i for i, ci in enumerate(c))


def shapiro_wilk(sample: ArrayLike) -> tuple[float, float]:
    """Shapiro-Wilk's W and its p-value for 3 to 5,000 values (not all equal): Royston's
    approximation (AS R94), as ``scipy.stats.shapiro``."""
    from scipy import special

    x = np.sort(np.asarray(sample, dtype=np.float64).ravel())
    n = x.size
    if n < 3:
        raise ValueError(f"Shapiro-Wilk needs at least 3 values, got {n}")
    half = n // 2
    if n == 3:
        a = np.array([math.sqrt(0.5)])
    else:
        m = special.ndtri((np.arange(1, half + 1) - 0.375) / (n + 0.25))  # the lower half, < 0
        summ2 = 2.0 * float(np.sum(m * m))
        ssumm2 = math.sqrt(summ2)
        rsn = 1.0 / math.sqrt(n)
        a = -m  # the upper half's weights before the corrections
        a1 = _poly(_C1, rsn) - m[0] / ssumm2
        if n > 5:
            a2 = _poly(_C2, rsn) - m[1] / ssumm2
            fac = math.sqrt((summ2 - 2 * m[0] ** 2 - 2 * m[1] ** 2) / (1 - 2 * a1**2 - 2 * a2**2))
            a = a / fac
            a[:2] = a1, a2
        else:
            fac = math.sqrt((summ2 - 2 * m[0] ** 2) / (1 - 2 * a1**2))
            a = a / fac
            a[0] = a1
    spread = x[::-1][:half] - x[:half]  # x(n+1-i) - x(i)
    ss = float(np.sum((x - x.mean()) ** 2))
    w = min(float(np.dot(a, spread)) ** 2 / ss, 1.0)
    if n == 3:
        return w, max(6.0 / math.pi * (math.asin(math.sqrt(w)) - math.asin(math.sqrt(0.75))), 0.0)
    y = math.log1p(-w) if w < 1.0 else -math.inf
    if n <= 11:
        gamma = _poly(_G, n)
        if y >= gamma:
            return w, 1e-99  # (AS R94's "small")
        y = -math.log(gamma - y)
        mean, sd = _poly(_C3, n), math.exp(_poly(_C4, n))
    else:
        mean, sd = _poly(_C5, math.log(n)), math.exp(_poly(_C6, math.log(n)))
    return w, float(special.ndtr(-(y - mean) / sd))
