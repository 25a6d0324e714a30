"""Random error: the scatter around the systematic fit, with confidence intervals.

* the residual standard deviation of a fit with its 95% interval (chi-square, ``df`` degrees of
  freedom): ``[s*sqrt(df/chi2_{0.975,df}), s*sqrt(df/chi2_{0.025,df})]``;
* a Gaussian fitted to the residuals, a normality test (Shapiro-Wilk, scipy) and the 95% interval
  of the error (``mean +- 1.96 sigma``);
* the spread at each repeated distance or angle (e.g. 1.1 m and 2.5 m, or 20 pi): sample
  standard deviation (ddof=1) of the trials in the group, with its chi-square interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.distributions import Z95
from odolab.core.errors import InsufficientDataError

__all__ = [
    "GroupSpread",
    "NormalityTest",
    "RandomError",
    "group_spreads",
    "random_error",
    "sd_confidence_interval",
]


def sd_confidence_interval(sd: float, df: int, level: float = 0.95) -> tuple[float, float]:
    """Chi-square interval for a normal standard deviation ``sd`` estimated with ``df`` dof."""
    from odolab.core.distributions import chi2_ppf

    if df < 1:
        raise InsufficientDataError(
            f"a standard deviation interval needs at least 1 degree of freedom, got {df}"
        )
    a = 1.0 - level
    lo = sd * math.sqrt(df / chi2_ppf(1.0 - a / 2.0, df))
    hi = sd * math.sqrt(df / chi2_ppf(a / 2.0, df))
    return lo, hi


@dataclass(frozen=True)
class NormalityTest:
    """A normality test of a sample: the test's name, statistic and p-value."""

    test: str
    statistic: float
    pvalue: float

    @property
    def normal(self) -> bool:
        """True when normality is not rejected at the 5% level."""
        return self.pvalue >= 0.05

    def to_dict(self) -> dict[str, object]:
        return {
            "test": self.test,
            "statistic": self.statistic,
            "pvalue": self.pvalue,
            "normal_at_5pct": self.normal,
        }


def _normality(sample: NDArray[np.float64]) -> NormalityTest | None:
    from odolab.core.distributions import shapiro_wilk

    if sample.size < 3 or float(np.ptp(sample)) == 0.0:
        return None
    return NormalityTest("shapiro-wilk", *shapiro_wilk(sample))


@dataclass(frozen=True)
class RandomError:
    """Scatter of residuals around a fit: ``sd`` (with ``df`` dof), its CI, Gaussian, normality."""

    n: int
    df: int
    sd: float
    sd_ci95: tuple[float, float]
    gauss_mean: float
    gauss_sd: float
    interval95: tuple[float, float]
    normality: NormalityTest | None

    def to_dict(self) -> dict[str, object]:
        return {
            "n": self.n,
            "df": self.df,
            "sd": self.sd,
            "sd_ci95": list(self.sd_ci95),
            "gauss_mean": self.gauss_mean,
            "gauss_sd": self.gauss_sd,
            "interval95": list(self.interval95),
            "normality": None if self.normality is None else self.normality.to_dict(),
        }


def random_error(residuals: ArrayLike, df: int) -> RandomError:
    """Random error from fit residuals (shape (n,)) with ``df`` residual degrees of freedom."""
    from odolab.core.distributions import norm_fit

    r = np.asarray(residuals, dtype=np.float64).ravel()
    if r.size < 2 or df < 1:
        raise InsufficientDataError(
            f"random error needs at least 1 residual degree of freedom, got {df} from {r.size}"
        )
    sd = float(np.sqrt(np.sum(r**2) / df))
    mu, s = norm_fit(r)
    return RandomError(
        n=int(r.size),
        df=int(df),
        sd=sd,
        sd_ci95=sd_confidence_interval(sd, df),
        gauss_mean=float(mu),
        gauss_sd=float(s),
        interval95=(float(mu - Z95 * s), float(mu + Z95 * s)),
        normality=_normality(r),
    )


@dataclass(frozen=True, eq=False)
class GroupSpread:
    """The trials repeated at one distance or angle: their errors and spread.

    ``at`` is the mean |predicted| value of the group (m or rad); ``errors`` (shape (n,)) are
    ``predicted - actual``; ``sd`` is their sample standard deviation (ddof=1).
    """

    at: float
    commanded: float
    n: int
    mean_error: float
    sd: float
    sd_ci95: tuple[float, float]
    interval95: tuple[float, float]
    normality: NormalityTest | None
    errors: NDArray[np.float64]

    def to_dict(self) -> dict[str, object]:
        return {
            "at": self.at,
            "commanded": self.commanded,
            "n": self.n,
            "mean_error": self.mean_error,
            "sd": self.sd,
            "sd_ci95": list(self.sd_ci95),
            "interval95": list(self.interval95),
            "normality": None if self.normality is None else self.normality.to_dict(),
            "errors": self.errors.tolist(),
        }


def group_spreads(
    commanded: ArrayLike,
    at: ArrayLike,
    errors: ArrayLike,
    *,
    min_n: int = 3,
    decimals: int = 3,
) -> list[GroupSpread]:
    """Spread of ``errors`` for each repeated commanded value (all arrays shape (n,)).

    Trials are grouped by signed ``commanded`` rounded to ``decimals``; groups with fewer than
    ``min_n`` trials are left out. ``at`` (e.g. |predicted|) gives each group's location.
    """
    c = np.round(np.asarray(commanded, dtype=np.float64), decimals)
    a = np.abs(np.asarray(at, dtype=np.float64))
    e = np.asarray(errors, dtype=np.float64)
    out: list[GroupSpread] = []
    for value in np.unique(c):
        m = c == value
        if int(m.sum()) < max(min_n, 2):
            continue
        g = e[m]
        mean = float(np.mean(g))
        sd = float(np.std(g, ddof=1))
        out.append(
            GroupSpread(
                at=float(np.mean(a[m])),
                commanded=float(value),
                n=int(g.size),
                mean_error=mean,
                sd=sd,
                sd_ci95=sd_confidence_interval(sd, int(g.size) - 1),
                interval95=(mean - Z95 * sd, mean + Z95 * sd),
                normality=_normality(g),
                errors=g,
            )
        )
    return out
