"""Do terrains differ in systematic error? An F-test on the slopes, with an effect size.

For one motion (e.g. x translation) measured on several terrains, two OLS models (odolab.core.regression):

* full: a separate line per terrain (``actual = a_t + b_t * predicted``);
* reduced: one common slope, separate intercepts (``actual = a_t + b * predicted``).

The F-test of reduced against full asks whether the slopes (the actual/predicted ratios) differ.
The effect size is the partial eta squared of the slope-by-terrain interaction,
``(RSS_reduced - RSS_full) / RSS_reduced``, and the largest pairwise slope difference with its
95% interval (from the full model's covariance).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import InsufficientDataError

__all__ = ["TerrainComparison", "compare_terrains"]


@dataclass(frozen=True)
class TerrainComparison:
    """Result of comparing one motion's slope across terrains."""

    motion: str
    terrains: tuple[str, ...]
    slopes: dict[str, float]
    f_statistic: float
    df_num: int
    df_den: int
    pvalue: float
    partial_eta2: float
    #: the pair of terrains whose slopes differ most, the difference (first - second) and its CI
    largest_pair: tuple[str, str]
    largest_difference: float
    largest_difference_ci95: tuple[float, float]

    @property
    def differ(self) -> bool:
        """True when equal slopes are rejected at the 5% level."""
        return self.pvalue < 0.05

    def verdict(self) -> str:
        a, b = self.largest_pair
        word = "differ" if self.differ else "do not differ detectably"
        return (
            f"{self.motion}: slopes on {', '.join(self.terrains)} {word} "
            f"(F({self.df_num}, {self.df_den}) = {self.f_statistic:.2f}, p = {self.pvalue:.3g}, "
            f"partial eta^2 = {self.partial_eta2:.2f}); largest difference {a} - {b} = "
            f"{self.largest_difference:+.4f} (95% CI {self.largest_difference_ci95[0]:+.4f} to "
            f"{self.largest_difference_ci95[1]:+.4f})"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "motion": self.motion,
            "terrains": list(self.terrains),
            "slopes": dict(self.slopes),
            "f_statistic": self.f_statistic,
            "df_num": self.df_num,
            "df_den": self.df_den,
            "pvalue": self.pvalue,
            "partial_eta2": self.partial_eta2,
            "differ_at_5pct": self.differ,
            "largest_pair": list(self.largest_pair),
            "largest_difference": self.largest_difference,
            "largest_difference_ci95": list(self.largest_difference_ci95),
            "verdict": self.verdict(),
        }


def compare_terrains(
    motion: str, data: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
) -> TerrainComparison:
    """Compare slopes of ``actual`` on ``predicted`` across terrains.

    ``data`` maps terrain -> (predicted, actual), each shape (n_t,); at least two terrains with
    3 or more trials each.
    """
    from odolab.core.distributions import t_ppf
    from odolab.core.regression import f_test, ols

    names = tuple(sorted(t for t, (x, _) in data.items() if np.asarray(x).size >= 3))
    if len(names) < 2:
        raise InsufficientDataError(
            f"{motion}: comparing terrains needs at least 2 terrains with 3 or more trials each"
        )
    xs = [np.asarray(data[t][0], dtype=np.float64) for t in names]
    ys = [np.asarray(data[t][1], dtype=np.float64) for t in names]
    n = sum(x.size for x in xs)
    k = len(names)
    y = np.concatenate(ys)
    full = np.zeros((n, 2 * k))
    reduced = np.zeros((n, k + 1))
    row = 0
    for j, x in enumerate(xs):
        sl = slice(row, row + x.size)
        full[sl, j] = 1.0
        full[sl, k + j] = x
        reduced[sl, j] = 1.0
        reduced[sl, k] = x
        row += x.size
    res_full = ols(y, full)
    res_red = ols(y, reduced)
    f, p, df_diff = f_test(res_full, res_red)
    rss_full, rss_red = float(res_full.ssr), float(res_red.ssr)
    eta2 = (rss_red - rss_full) / rss_red if rss_red > 0 else 0.0
    slopes = {t: float(res_full.params[k + j]) for j, t in enumerate(names)}
    cov = res_full.cov
    best = (0, 1, 0.0)
    for i in range(k):
        for j in range(i + 1, k):
            diff = slopes[names[i]] - slopes[names[j]]
            if abs(diff) >= abs(best[2]):
                best = (i, j, diff)
    i, j, diff = best
    var = cov[k + i, k + i] + cov[k + j, k + j] - 2 * cov[k + i, k + j]
    tq = t_ppf(0.975, res_full.df_resid)
    half = tq * float(np.sqrt(max(var, 0.0)))
    return TerrainComparison(
        motion=motion,
        terrains=names,
        slopes=slopes,
        f_statistic=float(f),
        df_num=round(float(df_diff)),
        df_den=round(float(res_full.df_resid)),
        pvalue=float(p),
        partial_eta2=float(eta2),
        largest_pair=(names[i], names[j]),
        largest_difference=float(diff),
        largest_difference_ci95=(float(diff - half), float(diff + half)),
    )
