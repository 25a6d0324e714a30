"""Table I of the lab report, regenerated from the data with computed uncertainties.

One row per motion and terrain. ``ratio`` is actual/predicted for rotation and x: the slope of
the proportional fit ``actual = ratio * predicted`` (the line with an intercept is in the fits
table, where its intercept tests that assumption); for the y rows it is the y error (predicted - actual) per metre travelled, so a reverse
run's slope against (negative) predicted x is negated. ``sigma`` is the sample standard deviation
of the error over the trials repeated at ``sigma_at`` (m or rad; the farthest repeated distance
or angle); ``sigmas`` lists every repeated distance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from odolab.analysis.core import LabAnalysis
from odolab.core.motion import Motion

__all__ = ["growth_text", "pooled_y_sigmas", "table1"]


def pooled_y_sigmas(rows: Sequence[dict[str, Any]], terrain: str = "tile") -> dict[float, float]:
    """sigma of the y error at each repeated distance, pooled over forward and reverse runs.

    From Table I rows (:func:`table1`): the pooled variance is the degrees-of-freedom weighted
    mean of the two directions' group variances (how the lab quotes one sigma for both).
    ``terrain``: the lab report's own floor unless told otherwise (the report sets these beside
    the lab's tile sigmas), not the simulator's default terrain.
    """
    acc: dict[float, list[float]] = {}
    for r in rows:
        if r["terrain"] != terrain or not Motion.parse(r["motion"], "a Table I row").is_y:
            continue
        for g in r["sigmas"]:
            d = round(abs(float(g["commanded"])), 6)
            ss_df = acc.setdefault(d, [0.0, 0.0])
            ss_df[0] += (g["n"] - 1) * g["sigma"] ** 2
            ss_df[1] += g["n"] - 1
    return {d: math.sqrt(ss / df) for d, (ss, df) in sorted(acc.items()) if df > 0}


def growth_text(row: Mapping[str, Any]) -> str:
    """A Table I row's growth exponent as every text face writes it: ``p [lo, hi]``, an open
    end ``unbounded``, a value at the search's edge ``<= p (search's edge)``; ``-`` without one
    (:func:`odolab.core.numfmt.with_open_ci`)."""
    from odolab.core import numfmt

    if "growth_p" not in row:
        return "-"
    lo, hi = row["growth_p_ci95"]
    return numfmt.with_open_ci(row["growth_p"], lo, hi, at_bound=bool(row.get("growth_p_at_bound")))


def table1(analysis: LabAnalysis) -> list[dict[str, object]]:
    """Table I rows (JSON-able dicts), in report order."""
    rows: list[dict[str, object]] = []
    for m in analysis.motions:
        lo, hi = m.ratio_ci95
        row: dict[str, object] = {
            "motion": m.motion.value,
            "terrain": m.terrain,
            "n": m.fit.n,
            "ratio": m.ratio,
            "ratio_ci95": [lo, hi],
            "ratio_se": m.ratio_se,
            "ratio_unit": m.motion.ratio_unit,
            "intercept": m.fit.intercept,
            "intercept_ci95": list(m.fit.intercept_ci95),
            "r2": m.fit.r2,
            "residual_sd": m.random.sd,
            "residual_sd_ci95": list(m.random.sd_ci95),
            "unit": m.motion.unit,
        }
        if m.motion.ideal_line:
            row["error_per_predicted"] = 1.0 - m.ratio
            row["error_per_predicted_ci95"] = [1.0 - hi, 1.0 - lo]
        else:
            row["error_per_predicted"] = m.ratio
            row["error_per_predicted_ci95"] = [lo, hi]
        sig = sorted(m.groups, key=lambda g: g.at)
        row["sigmas"] = [
            {
                "at": g.at,
                "commanded": g.commanded,
                "n": g.n,
                "sigma": g.sd,
                "sigma_ci95": list(g.sd_ci95),
            }
            for g in sig
        ]
        if sig:
            g = sig[-1]
            row["sigma"] = g.sd
            row["sigma_ci95"] = list(g.sd_ci95)
            row["sigma_at"] = g.at
            row["sigma_n"] = g.n
        if m.growth is not None:
            row["growth_p"] = m.growth.p
            row["growth_p_ci95"] = m.growth.p_ci95_json()  # an open end: None, never Infinity
            row["growth_p_at_bound"] = m.growth.at_bound
            if m.growth.note() is not None:
                row["growth_p_note"] = m.growth.note()
        if m.outliers:
            row["outliers"] = [o.trial_id for o in m.outliers]
        rows.append(row)
    return rows
