"""Systematic error: ordinary least-squares lines with honest uncertainty (odolab.core.regression).

The lab's fits (section VI): actual rotation vs predicted heading (slope = actual/predicted),
actual x vs predicted x, and the y error (predicted - actual) vs predicted x. A fit needs at least
:data:`MIN_FIT_POINTS` trials at two or more different predicted values; fewer raise
:class:`~odolab.core.errors.InsufficientDataError` saying how many are needed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import InsufficientDataError

__all__ = ["MIN_FIT_POINTS", "LinearFit", "fit_line"]

#: A straight line with an intercept needs 3 points to leave one degree of freedom for its
#: uncertainty (2 points fit exactly and say nothing about the scatter).
MIN_FIT_POINTS = 3


@dataclass(frozen=True, eq=False)
class LinearFit:
    """``y = intercept + slope * x`` by OLS, with standard errors and 95% intervals.

    Arrays ``x``, ``y``, ``residuals``, ``fitted`` have shape (n,); ``trial_ids`` has n entries.
    """

    name: str
    n: int
    slope: float
    intercept: float
    slope_se: float
    intercept_se: float
    slope_ci95: tuple[float, float]
    intercept_ci95: tuple[float, float]
    r2: float
    residual_sd: float
    df_resid: int
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    fitted: NDArray[np.float64]
    residuals: NDArray[np.float64]
    trial_ids: tuple[str, ...] = field(default=())

    def predict(self, x: ArrayLike) -> NDArray[np.float64]:
        """The fitted line at ``x`` (any shape)."""
        return self.intercept + self.slope * np.asarray(x, dtype=np.float64)

    def to_dict(self, *, arrays: bool = True) -> dict[str, object]:
        """JSON-able dict (with the data and residuals when ``arrays``)."""
        d: dict[str, object] = {
            "name": self.name,
            "n": self.n,
            "slope": self.slope,
            "intercept": self.intercept,
            "slope_se": self.slope_se,
            "intercept_se": self.intercept_se,
            "slope_ci95": list(self.slope_ci95),
            "intercept_ci95": list(self.intercept_ci95),
            "r2": self.r2,
            "residual_sd": self.residual_sd,
            "df_resid": self.df_resid,
        }
        if arrays:
            d["trial_ids"] = list(self.trial_ids)
            d["x"] = self.x.tolist()
            d["y"] = self.y.tolist()
            d["residuals"] = self.residuals.tolist()
        return d


def fit_line(
    x: ArrayLike,
    y: ArrayLike,
    *,
    name: str = "fit",
    trial_ids: tuple[str, ...] | list[str] = (),
    through_origin: bool = False,
) -> LinearFit:
    """OLS of ``y`` on ``x`` with an intercept. ``x``, ``y``: shape (n,), n >= 3.

    With ``through_origin`` the model is ``y = slope * x`` (no intercept: intercept, its SE and
    interval are 0, and R² is the uncentered one, as for any model without constant).

    Raises :class:`InsufficientDataError` when there are too few points or ``x`` is constant.
    """
    from odolab.core.regression import ols

    xa = np.asarray(x, dtype=np.float64).ravel()
    ya = np.asarray(y, dtype=np.float64).ravel()
    if xa.shape != ya.shape:
        raise InsufficientDataError(f"{name}: x has {xa.size} values but y has {ya.size}")
    if not (np.all(np.isfinite(xa)) and np.all(np.isfinite(ya))):
        raise InsufficientDataError(f"{name}: the data contain NaN or infinite values")
    n = int(xa.size)
    if n < MIN_FIT_POINTS:
        raise InsufficientDataError(
            f"{name}: a line fit needs at least {MIN_FIT_POINTS} measured trials, got {n}"
        )
    if np.ptp(xa) <= 1e-12 * max(1.0, float(np.max(np.abs(xa)))):
        raise InsufficientDataError(
            f"{name}: all {n} trials have the same predicted value; a slope needs trials at "
            "two or more different distances or angles"
        )
    ids = tuple(trial_ids) if trial_ids else tuple(str(i) for i in range(n))
    design = xa[:, None] if through_origin else np.column_stack([np.ones_like(xa), xa])
    res = ols(ya, design)
    r2 = res.rsquared(ya, centered=not through_origin)  # no spread in y: nan
    ci = res.conf_int()
    k = 0 if through_origin else 1  # index of the slope among the coefficients
    return LinearFit(
        name=name,
        n=n,
        slope=float(res.params[k]),
        intercept=0.0 if through_origin else float(res.params[0]),
        slope_se=float(res.bse[k]),
        intercept_se=0.0 if through_origin else float(res.bse[0]),
        slope_ci95=(float(ci[k, 0]), float(ci[k, 1])),
        intercept_ci95=(0.0, 0.0) if through_origin else (float(ci[0, 0]), float(ci[0, 1])),
        r2=r2,
        residual_sd=float(np.sqrt(res.scale)),
        df_resid=round(float(res.df_resid)),
        x=xa,
        y=ya,
        fitted=res.fitted,
        residuals=res.resid,
        trial_ids=ids,
    )
