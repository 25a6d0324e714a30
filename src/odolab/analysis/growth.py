"""How random error grows with distance or angle: ``sigma(d) = a * d**p``, by maximum likelihood.

Each residual ``r_i`` (of a systematic fit) is taken as ``N(0, (a * d_i**p)**2)``. For a fixed
``p`` the best ``a`` has a closed form, ``a**2 = mean(r**2 / d**(2p))``, so the profile
log-likelihood is a function of ``p`` alone; ``p`` is its maximum and the 95% interval is the
set of ``p`` whose likelihood-ratio statistic is below ``chi2_{1, 0.95} = 3.84`` (a profile
likelihood interval). Each of the lab's candidate laws is tested the same way: ``p = 0.5``
(independent errors per unit distance, a random walk of position), ``p = 1`` (the lab's guess:
sigma linear in distance) and ``p = 1.5`` (a random walk of heading integrated into y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import InsufficientDataError

__all__ = ["CANDIDATE_EXPONENTS", "GrowthFit", "fit_growth", "profile_loglik"]

CANDIDATE_EXPONENTS = (0.5, 1.0, 1.5)
_P_RANGE = (-3.0, 5.0)
MIN_GROWTH_POINTS = 4


def profile_loglik(p: float, d: NDArray[np.float64], r: NDArray[np.float64]) -> float:
    """Profile log-likelihood of exponent ``p`` (``a`` maximised out); d, r shape (n,)."""
    scaled = r**2 / d ** (2.0 * p)
    a2 = float(np.mean(scaled))
    if a2 <= 0.0:
        return math.inf
    n = r.size
    return float(-0.5 * n * math.log(2.0 * math.pi * a2) - p * np.sum(np.log(d)) - 0.5 * n)


@dataclass(frozen=True)
class GrowthFit:
    """``sigma = a * d**p`` with a 95% profile-likelihood interval for ``p`` and LR tests."""

    n: int
    a: float
    p: float
    p_ci95: tuple[float, float]
    #: exponent -> p-value of the likelihood-ratio test of that exponent
    tests: dict[float, float]
    d_min: float
    d_max: float

    def compatible(self, exponent: float) -> bool:
        """True when ``exponent`` is not rejected at the 5% level."""
        return self.tests[exponent] >= 0.05

    def sigma_at(self, d: ArrayLike) -> NDArray[np.float64]:
        return self.a * np.abs(np.asarray(d, dtype=np.float64)) ** self.p

    @property
    def at_bound(self) -> bool:
        """True when ``p`` is where the search's range ends (the likelihood still rises beyond
        it): then ``p`` is no estimate, only a side."""
        return min(abs(self.p - edge) for edge in _P_RANGE) < 1e-3

    def p_ci95_json(self) -> list[float | None]:
        """The interval for JSON: an end the data do not bound is None (never Infinity)."""
        return [v if math.isfinite(v) else None for v in self.p_ci95]

    def note(self) -> str | None:
        """Why ``p`` or its interval is not a plain number, in one sentence; None when it is."""
        parts = []
        if self.at_bound:
            edge = min(_P_RANGE, key=lambda e: abs(self.p - e))
            parts.append(
                f"p stopped at the search's edge ({edge:g}; the likelihood still rises beyond "
                "it), so it is no estimate"
            )
        reach = {
            "below": f"down to p = {_P_RANGE[0] - 5:g}",
            "above": f"up to p = {_P_RANGE[1] + 5:g}",
        }
        open_ends = [w for w, v in zip(("below", "above"), self.p_ci95, strict=True)
                     if not math.isfinite(v)]  # fmt: skip
        if open_ends:
            parts.append(
                f"the data do not bound p {' or '.join(open_ends)}: its 95% interval is "
                f"unbounded (the likelihood stays within the 95% level "
                f"{' and '.join(reach[w] for w in open_ends)})"
            )
        if not parts:
            return None
        return (
            "; ".join(parts)
            + f" ({self.n} trials at {self.d_min:.3g} to {self.d_max:.3g}: more, farther apart, "
            "would tell how sigma grows)"
        )

    def text(self) -> str:
        """``p [lo, hi]`` as every face writes it (:func:`odolab.core.numfmt.with_open_ci`)."""
        from odolab.core import numfmt

        return numfmt.with_open_ci(self.p, *self.p_ci95, at_bound=self.at_bound)

    def verdict(self) -> str:
        """One sentence: which of the candidate laws the data allow."""
        ok = [e for e in self.tests if self.compatible(e)]
        span = f"p {'' if self.at_bound else '= '}{self.text()} (95% CI)"
        note = self.note()
        tail = "" if note is None else f"; {note}"
        if not ok:
            return f"{span}: none of p = 0.5, 1, 1.5 fits{tail}"
        names = ", ".join(f"{e:g}" for e in ok)
        return f"{span}: compatible with p = {names}{tail}"

    def to_dict(self) -> dict[str, object]:
        return {
            "n": self.n,
            "a": self.a,
            "p": self.p,
            "p_ci95": self.p_ci95_json(),
            "p_at_bound": self.at_bound,
            "p_note": self.note(),
            "lr_test_pvalues": {f"{k:g}": v for k, v in self.tests.items()},
            "compatible": {f"{k:g}": self.compatible(k) for k in self.tests},
            "d_range": [self.d_min, self.d_max],
            "verdict": self.verdict(),
        }


def fit_growth(d: ArrayLike, residuals: ArrayLike, *, name: str = "growth") -> GrowthFit:
    """Fit ``sigma = a * |d|**p`` to residuals ``r`` at distances/angles ``d`` (shape (n,)).

    Needs at least 4 residuals at two or more clearly different |d| (ratio >= 1.2).
    """
    from scipy import optimize

    from odolab.core.distributions import chi2_ppf, chi2_sf

    da = np.abs(np.asarray(d, dtype=np.float64)).ravel()
    r = np.asarray(residuals, dtype=np.float64).ravel()
    keep = (da > 0) & np.isfinite(da) & np.isfinite(r)
    da, r = da[keep], r[keep]
    if r.size < MIN_GROWTH_POINTS:
        raise InsufficientDataError(
            f"{name}: the growth of sigma needs at least {MIN_GROWTH_POINTS} trials, got {r.size}"
        )
    if da.max() / da.min() < 1.2:
        raise InsufficientDataError(
            f"{name}: the growth of sigma needs trials at distances or angles at least 20% apart, "
            f"got only {da.min():.3g} to {da.max():.3g}"
        )
    if np.all(r == 0):
        raise InsufficientDataError(f"{name}: all residuals are zero; no random error to model")

    def nll(p: float) -> float:
        return -profile_loglik(p, da, r)

    grid = np.linspace(*_P_RANGE, 161)
    vals = np.array([nll(float(g)) for g in grid])
    i = int(np.argmin(vals))
    lo_b, hi_b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    opt = optimize.minimize_scalar(nll, bounds=(lo_b, hi_b), method="bounded")
    p_hat = float(opt.x)
    ll_max = -float(opt.fun)
    crit = chi2_ppf(0.95, 1)

    def excess(p: float) -> float:
        return 2.0 * (ll_max + nll(p)) - crit

    def bound(direction: float) -> float:
        step, edge = 0.25, p_hat
        while True:
            nxt = edge + direction * step
            if not (_P_RANGE[0] - 5 <= nxt <= _P_RANGE[1] + 5):
                return math.inf * direction
            if excess(nxt) > 0:
                return float(optimize.brentq(excess, min(edge, nxt), max(edge, nxt)))
            edge = nxt

    ci = (bound(-1.0), bound(1.0))
    tests = {}
    for e in CANDIDATE_EXPONENTS:
        lr = max(0.0, 2.0 * (ll_max + nll(e)))
        tests[e] = chi2_sf(lr, 1)
    a_hat = math.sqrt(float(np.mean(r**2 / da ** (2.0 * p_hat))))
    return GrowthFit(
        n=int(r.size),
        a=a_hat,
        p=p_hat,
        p_ci95=ci,
        tests=tests,
        d_min=float(da.min()),
        d_max=float(da.max()),
    )
