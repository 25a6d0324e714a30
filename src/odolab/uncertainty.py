"""Pose covariance of odometry under per-wheel slip noise (Chong & Kleeman; Siegwart et al.).

Each wheel's travelled distance is wrong by a zero-mean random amount whose variance grows
with the distance it rolled: ``var(ds_r) = k_right * |ds_r|``, ``var(ds_l) = k_left * |ds_l|``
(``k`` in metres), independent between wheels and between steps. The covariance of the pose
``(x, y, heading)`` is propagated through the lab's midpoint step (eqs. 3.3-3.6) to first order::

    P' = Fp P Fp^T + Fu Q Fu^T,   Q = diag(k_right |ds_r|, k_left |ds_l|)

Closed forms for a straight run and a rotation in place are given for tests and quick checks.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.errors import OdolabError

__all__ = [
    "pose_covariance",
    "rotation_heading_variance",
    "straight_line_covariance",
]


def _check_k(k_left: float, k_right: float, track_width: float) -> None:
    for name, v in (("k_left", k_left), ("k_right", k_right)):
        if not math.isfinite(v) or v < 0:
            raise OdolabError(f"{name} must be a finite number >= 0 (m), got {v!r}")
    if not math.isfinite(track_width) or track_width <= 0:
        raise OdolabError(f"track_width must be a positive number (m), got {track_width!r}")


def pose_covariance(
    ds_left: ArrayLike,
    ds_right: ArrayLike,
    track_width: float,
    k_left: float,
    k_right: float,
    *,
    heading0: float = 0.0,
    cov0: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Covariance of (x, y, heading) after each step; shape (n + 1, 3, 3).

    ``ds_left``, ``ds_right``: shape (n,), wheel displacements per step (m). The first entry of
    the result is ``cov0`` (default zero) at the start pose with heading ``heading0``.
    """
    dl = np.asarray(ds_left, dtype=np.float64)
    dr = np.asarray(ds_right, dtype=np.float64)
    if dl.shape != dr.shape or dl.ndim != 1:
        raise OdolabError("ds_left and ds_right must be 1-D arrays of the same length")
    if not (np.isfinite(dl).all() and np.isfinite(dr).all()):
        raise OdolabError("wheel displacements must be finite numbers")
    _check_k(k_left, k_right, track_width)
    b = float(track_width)
    n = dl.size
    out = np.empty((n + 1, 3, 3))
    p = np.zeros((3, 3)) if cov0 is None else np.array(cov0, dtype=np.float64).reshape(3, 3)
    out[0] = p
    ds = 0.5 * (dr + dl)
    dth = (dr - dl) / b
    mid = heading0 + np.concatenate(([0.0], np.cumsum(dth)[:-1])) + 0.5 * dth
    c, s = np.cos(mid), np.sin(mid)
    fp = np.zeros((n, 3, 3))
    fp[:, 0, 0] = fp[:, 1, 1] = fp[:, 2, 2] = 1.0
    fp[:, 0, 2] = -ds * s
    fp[:, 1, 2] = ds * c
    fu = np.empty((n, 3, 2))  # columns: right, left
    half_b = ds / (2.0 * b)
    fu[:, 0, 0] = 0.5 * c - half_b * s
    fu[:, 0, 1] = 0.5 * c + half_b * s
    fu[:, 1, 0] = 0.5 * s + half_b * c
    fu[:, 1, 1] = 0.5 * s - half_b * c
    fu[:, 2, 0] = 1.0 / b
    fu[:, 2, 1] = -1.0 / b
    q = np.zeros((n, 2, 2))
    q[:, 0, 0] = k_right * np.abs(dr)
    q[:, 1, 1] = k_left * np.abs(dl)
    noise = fu @ q @ fu.transpose(0, 2, 1)
    for i in range(n):
        p = fp[i] @ p @ fp[i].T + noise[i]
        out[i + 1] = p
    return out


def straight_line_covariance(
    distance: float, track_width: float, k_left: float, k_right: float
) -> NDArray[np.float64]:
    """Covariance of (x, y, heading) after a straight run of ``distance`` m along +x, shape (3, 3).

    The continuous limit of :func:`pose_covariance`: with ``k = k_left + k_right`` and
    ``d = |distance|``: ``var x = k d / 4``, ``var y = k d^3 / (3 b^2)``,
    ``var heading = k d / b^2``, ``cov(y, heading) = k d^2 / (2 b^2)``,
    ``cov(x, heading) = (k_right - k_left) d / (2 b)``,
    ``cov(x, y) = (k_right - k_left) d^2 / (4 b)``
    (signs of the cross terms for a forward run; y and heading flip sign in reverse).
    """
    _check_k(k_left, k_right, track_width)
    d = abs(float(distance))
    sgn = 1.0 if distance >= 0 else -1.0
    b = float(track_width)
    k = k_left + k_right
    dk = k_right - k_left
    cov = np.array(
        [
            [k * d / 4.0, sgn * dk * d**2 / (4.0 * b), dk * d / (2.0 * b)],
            [sgn * dk * d**2 / (4.0 * b), k * d**3 / (3.0 * b**2), sgn * k * d**2 / (2.0 * b**2)],
            [dk * d / (2.0 * b), sgn * k * d**2 / (2.0 * b**2), k * d / b**2],
        ]
    )
    return cov


def rotation_heading_variance(
    angle: float, track_width: float, k_left: float, k_right: float
) -> float:
    """Heading variance (rad^2) after a rotation in place by ``angle`` rad.

    Each wheel rolls ``b |angle| / 2``, so ``var = (k_left + k_right) |angle| / (2 b)``.
    """
    _check_k(k_left, k_right, track_width)
    return (k_left + k_right) * abs(float(angle)) / (2.0 * float(track_width))
