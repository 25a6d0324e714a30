"""Outliers that would bend a fit: flagged with a reason, left out of the fit, listed in the report.

A miscounted turn: the compass gives the heading modulo a whole turn and a person counts the
turns; one miscount shifts the actual rotation by about 2*pi. Such a trial's residual (from a
robust Huber line, odolab.core.regression.huber_line) lies near a non-zero multiple of 2*pi *and* far outside the
scatter of the other trials (more than ``k`` robust standard deviations, scaled with the angle:
random error grows with the rotation). A 2*pi residual that the scatter explains is kept.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

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

    def to_dict(self) -> dict[str, object]:
        """Every field, by its own name."""
        return asdict(self)


def _robust_residuals(
    predicted: NDArray[np.float64], actual: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Robust line through the trials, with random error growing like sqrt|predicted|.

    Huber M-estimation (:func:`odolab.core.regression.huber_line`) of ``actual / w = c / w + s * predicted / w`` with
    ``w = sqrt|predicted|`` (a homoscedastic form). Returns the residuals ``r`` of actual, their
    scale-free form ``z = r / w`` and the robust scale of ``z``.
    """
    from odolab.core.regression import huber_line

    w = np.sqrt(np.maximum(np.abs(predicted), 1e-9))
    design = np.column_stack([1.0 / w, predicted / w])
    params, scale = huber_line(actual / w, design)
    c, slope = (float(v) for v in params)
    r = actual - (c + slope * predicted)
    return r, r / w, max(scale, 1e-12)


def miscounted_turns(
    predicted: ArrayLike,
    actual: ArrayLike,
    *,
    k: float = 4.5,
    tolerance: float = 1.0,
) -> NDArray[np.bool_]:
    """Mask (shape (n,)) of rotation trials whose actual rotation is off by a whole turn.

    ``predicted``, ``actual``: rotations in rad, shape (n,). A trial is flagged when its
    residual from a robust line (Huber) is near ``m * 2*pi`` (m != 0: within ``tolerance`` rad or
    two local robust standard deviations, whichever is larger), its scale-free size
    ``|r| / sqrt(|predicted|)`` exceeds ``k`` robust standard deviations (Huber scale) of that
    quantity over all trials, and the local scatter is small enough to tell a whole turn from
    noise (2*pi > 5 local standard deviations). Needs 5 or more trials; fewer: none flagged.
    """
    p = np.asarray(predicted, dtype=np.float64).ravel()
    a = np.asarray(actual, dtype=np.float64).ravel()
    if p.size < 5 or np.ptp(p) == 0:
        return np.zeros(p.size, dtype=bool)
    r, z, mad = _robust_residuals(p, a)
    local = mad * np.sqrt(np.abs(p))
    m = np.round(r / _TWO_PI)
    near = (m != 0) & (np.abs(r - m * _TWO_PI) < np.maximum(tolerance, 2.0 * local))
    big = np.abs(z) > k * mad
    resolvable = 5.0 * local < _TWO_PI
    flagged: NDArray[np.bool_] = np.asarray(near & big & resolvable, dtype=bool)
    return flagged
