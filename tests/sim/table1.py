"""Table I statistics of a simulated lab campaign, fitted with plain numpy (as the lab did).

- rotation ratio: least-squares slope through the origin of measured vs predicted rotation;
- rotation sigma: sample sigma (ddof=1) of the measured rotation over the 18 repeats at 20 pi;
- x ratio: slope through the origin of measured x vs predicted x (forward and reverse together);
- y drift: slope of the lab's straight-line fit (with intercept) of the y error (predicted -
  measured) against the predicted distance |x|, forward and reverse separately;
- sigma_y at a distance: residual sigma of the y error around each direction's fit, pooled over
  forward and reverse (5 + 5 runs, 2 fitted means: 8 degrees of freedom).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from odolab.core.trials import Trial


def _through_origin(pred: np.ndarray, meas: np.ndarray) -> float:
    return float(pred @ meas / (pred @ pred))


def table1(trials: Sequence[Trial]) -> dict[str, float]:
    rot = [t for t in trials if t.campaign == "rotation-indoor"]
    ind = [t for t in trials if t.campaign == "translation-indoor"]
    out = [t for t in trials if t.campaign == "translation-outdoor"]
    res: dict[str, float] = {}
    p = np.array([t.predicted.heading for t in rot])
    m = np.array([t.measured.rotation for t in rot])  # type: ignore[union-attr]
    res["rotation_ratio"] = _through_origin(p, m)
    reps = m[-18:]
    assert all(abs(t.command.angle - 20 * math.pi) < 1e-9 for t in rot[-18:])  # type: ignore[operator]
    res["rotation_sigma"] = float(np.std(reps, ddof=1))
    px = np.array([t.predicted.x for t in ind])
    py = np.array([t.predicted.y for t in ind])
    mx = np.array([t.measured.x for t in ind])  # type: ignore[union-attr]
    my = np.array([t.measured.y for t in ind])  # type: ignore[union-attr]
    res["x_ratio_tile"] = _through_origin(px, mx)
    yerr = py - my
    dist = np.abs(px)
    cmd = np.array([abs(t.command.distance) for t in ind])  # type: ignore[arg-type]
    resid = np.empty_like(yerr)
    for name, sel in (("forward", px > 0), ("reverse", px < 0)):
        slope, icpt = np.polyfit(dist[sel], yerr[sel], 1)
        res[f"y_drift_{name}"] = float(slope)
        resid[sel] = yerr[sel] - (slope * dist[sel] + icpt)
    for d, key in ((1.0, "sigma_y_1m"), (2.5, "sigma_y_2.5m")):
        sel = np.isclose(cmd, d)
        res[key] = float(np.sqrt(np.sum(resid[sel] ** 2) / (sel.sum() - 2)))
    for terrain in ("concrete", "grass"):
        sel = [t for t in out if t.terrain == terrain]
        res[f"x_ratio_{terrain}"] = _through_origin(
            np.array([t.predicted.x for t in sel]),
            np.array([t.measured.x for t in sel]),  # type: ignore[union-attr]
        )
    return res


#: Table I of the lab report: (value, stated uncertainty)
TABLE_I = {
    "rotation_ratio": (0.875, 0.005),
    "rotation_sigma": (2.94, 0.05),
    "x_ratio_tile": (0.905, 0.005),
    "y_drift_forward": (0.03, 0.01),
    "y_drift_reverse": (0.09, 0.01),
    "sigma_y_1m": (0.03, 0.01),
    "sigma_y_2.5m": (0.07, 0.01),
    "x_ratio_concrete": (0.920, 0.005),
    "x_ratio_grass": (0.904, 0.005),
}


def misses(stats: dict[str, float]) -> list[str]:
    """Names of the statistics outside Table I's stated uncertainty."""
    return [k for k, (v, u) in TABLE_I.items() if abs(stats[k] - v) > u + 1e-12]
