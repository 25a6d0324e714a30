"""Outliers that would bend a fit: flagged with a reason, left out of the fit, listed in the report.

A miscounted turn: the compass gives the heading modulo a whole turn and a person counts the
turns; one miscount shifts the actual rotation by about 2*pi. Such a trial's residual (from a
robust Theil-Sen line, scipy) lies near a non-zero multiple of 2*pi *and* far outside the
scatter of the other trials (more than ``k`` robust standard deviations, scaled with the angle:
random error grows with the rotation). A 2*pi residual that the scatter explains is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Outlier", "miscounted_turns"]

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Outlier:
    """One trial left out of a fit, and why."""

    trial_id: str
    motion: str
    terrain: str
    predicted: float
    actual: float
    residual: float
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "trial_id": self.trial_id,
            "motion": self.motion,
            "terrain": self.terrain,
            "predicted": self.predicted,
            "actual": self.actual,
            "residual": self.residual,
            "reason": self.reason,
        }


def miscounted_turns(
    predicted: ArrayLike,
    actual: ArrayLike,
    *,
    k: float = 5.0,
    tolerance: float = 1.0,
) -> NDArray[np.bool_]:
    """Mask (shape (n,)) of rotation trials whose actual rotation is off by a whole turn.

    ``predicted``, ``actual``: rotations in rad, shape (n,). A trial is flagged when its
    residual from a Theil-Sen line is within ``tolerance`` rad of ``m * 2*pi`` (m != 0) and its
    scale-free size ``|r| / sqrt(|predicted|)`` exceeds ``k`` robust standard deviations
    (1.4826 * MAD) of that quantity over all trials. Needs 5 or more trials; fewer: none flagged.
    """
    from scipy import stats

    p = np.asarray(predicted, dtype=np.float64).ravel()
    a = np.asarray(actual, dtype=np.float64).ravel()
    flags = np.zeros(p.size, dtype=bool)
    if p.size < 5 or np.ptp(p) == 0:
        return flags
    slope, intercept, _, _ = stats.theilslopes(a, p)
    r = a - (intercept + slope * p)
    scale = np.sqrt(np.maximum(np.abs(p), 1e-9))
    z = r / scale
    mad = float(stats.median_abs_deviation(z, scale="normal"))
    m = np.round(r / _TWO_PI)
    near = (m != 0) & (np.abs(r - m * _TWO_PI) < tolerance)
    big = np.abs(z - np.median(z)) > k * max(mad, 1e-12)
    flagged: NDArray[np.bool_] = np.asarray(near & big, dtype=bool)
    return flagged
