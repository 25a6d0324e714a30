"""The ground truth's own noise: estimated from its updates, or given by the user.

Ground truth is a measurement (a lidar's scan matcher, a tracker, GNSS), with a noise of its own.
Over a short horizon a robot's motion is smooth, so each real update's deviation from the straight
line through its two neighbours (the linear interpolation at its instant) is that update's noise
less a share of its neighbours'::

    r_k = p_k - (b_k p_(k-1) + a_k p_(k+1)),   a_k = (t_k - t_(k-1)) / (t_(k+1) - t_(k-1)),  b_k = 1 - a_k
    var(r_k) = sigma^2 (1 + a_k^2 + b_k^2)                      (white noise of sd sigma)

``sigma`` comes from the median of ``r_k^2 / (1 + a_k^2 + b_k^2)`` (over x and y together for the
position; the unwrapped heading alone), divided by the median of a chi-square with one degree of
freedom (0.4549): a scan-matcher glitch does not move a median. Only real updates count: a row
that is exactly the linear interpolation of its neighbours (a truth resampled onto the odometry's
clock) (to the file's rounding, :data:`RESAMPLED`) is not a measurement of its own and is left out, and so is a row that repeats the last
value (a held value; the window reader already keeps only changes). The robot's own acceleration
adds ``acc * dt^2 / 4`` to ``r_k``: at 10 Hz and 1 m/s^2, 2.5 mm; so the estimate is an upper
bound, close for centimetre noise, and a few millimetres on a noise-free truth: such a truth at
a low rate can pass :data:`EXACT_XY` and be allowed for as noisy (give the noise where it is
known: ``--truth-sigma``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from odolab.core.arrays import FloatArray, IntArray
from odolab.core.errors import CalibrationError

__all__ = [
    "CHI2_1_MEDIAN",
    "EXACT_XY",
    "EXACT_YAW",
    "TruthNoise",
    "allowed",
    "estimate_truth_noise",
    "material",
    "parse_truth_sigma",
    "piece_covariance",
    "real_updates",
    "truth_residuals",
    "variance_factors",
]

#: Median of a chi-square with one degree of freedom.
CHI2_1_MEDIAN = 0.454936423119572
#: A row within this share of its size (at least 1 m or 1 rad) of its neighbours' line is a
#: resampled one: text files keep 9 significant digits or fewer (a float32 about 7), a 10 m
#: coordinate so 10 micrometres, below what any pose sensor resolves.
RESAMPLED = 1e-6
#: Fewer real updates than this (interior ones, over all runs) give no estimate.
MIN_UPDATES = 10
#: A ground truth whose noise is below both of these (m, rad) is as good as exact
#: (:func:`material`): motion capture's, or what the estimate reads of a noise-free truth's own
#: bend (0.1 to 0.8 mm on the simulators).
EXACT_XY = 1e-3
EXACT_YAW = 1e-3


@dataclass(frozen=True)
class TruthNoise:
    """White noise of the ground truth's pose: position ``xy`` (m, each axis), heading ``yaw``
    (rad), the median time between its real updates ``spacing`` (s; 0 unknown), how many
    updates the estimate rests on (0: given) and whether it was ``given`` by the user."""

    xy: float
    yaw: float
    spacing: float = 0.0
    updates: int = 0
    given: bool = False

    def describe(self) -> str:
        """One phrase for the output: what the fit took the truth's noise to be, and whence."""
        how = (
            "as given"
            if self.given
            else f"estimated from {self.updates} of its updates' deviations from their neighbours"
        )
        return (
            f"ground truth taken as noisy: {self.xy * 1000:.3g} mm in position, "
            f"{self.yaw:.3g} rad in heading, {how}"
        )


def parse_truth_sigma(text: str) -> TruthNoise:
    """``"XY,YAW"`` (m, rad) as a given :class:`TruthNoise`, or one clear sentence."""
    parts = text.split(",")
    try:
        xy, yaw = (float(p) for p in parts)
    except ValueError:
        raise CalibrationError(
            f"the ground truth's noise is {text!r}; expected two numbers XY,YAW (m, rad), e.g. "
            "0.05,0.1"
        ) from None
    if not (np.isfinite(xy) and np.isfinite(yaw) and xy >= 0 and yaw >= 0):
        raise CalibrationError(
            f"the ground truth's noise is {text!r}; expected two finite numbers XY,YAW of at "
            "least 0 (m, rad)"
        )
    return TruthNoise(xy, yaw, given=True)


def real_updates(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray) -> IntArray:
    """The indices of the truth's real updates among its rows (see the module): a row that
    repeats the last value (a held value) is not one, and neither is a row on the straight line
    through its neighbours to the file's rounding (:data:`RESAMPLED`: a truth resampled onto
    another clock, the odometry's). The first and last rows are kept."""
    t = np.asarray(t, dtype=np.float64)
    p = np.column_stack((x, y, np.unwrap(np.asarray(heading, dtype=np.float64))))
    keep = np.arange(t.size)
    if t.size >= 2:  # held values: the same measurement again
        moved = np.concatenate(([True], np.any(np.diff(p, axis=0) != 0, axis=1) & (np.diff(t) > 0)))
        keep = keep[moved]
    for _ in range(2):  # rows on their neighbours' line are resampled, not measured
        if keep.size < 3:
            break
        tk, pk = t[keep], p[keep]
        a = (tk[1:-1] - tk[:-2]) / (tk[2:] - tk[:-2])
        r = pk[1:-1] - ((1.0 - a)[:, None] * pk[:-2] + a[:, None] * pk[2:])
        size = np.maximum(np.abs(pk[1:-1]), 1.0)
        resampled = np.all(np.abs(r) <= RESAMPLED * size, axis=1)
        if not resampled.any():
            break
        keep = keep[np.concatenate(([True], ~resampled, [True]))]
    return keep


def truth_residuals(
    t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each real interior update's (:func:`real_updates`) deviation from its neighbours' line,
    normalised to unit variance per unit noise variance (see the module): (x and y residuals,
    (2k,); heading residuals, (k,); the spacings between the real updates, s)."""
    keep = real_updates(t, x, y, heading)
    t = np.asarray(t, dtype=np.float64)[keep]
    p = np.column_stack((x, y, np.unwrap(np.asarray(heading, dtype=np.float64))))[keep]
    empty = np.zeros(0)
    if t.size < 3:
        return empty, empty, np.diff(t)
    a = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    r = p[1:-1] - ((1.0 - a)[:, None] * p[:-2] + a[:, None] * p[2:])
    norm = np.sqrt(1.0 + a**2 + (1.0 - a) ** 2)[:, None]
    r = r / norm
    return np.concatenate((r[:, 0], r[:, 1])), r[:, 2], np.diff(t)


def estimate_truth_noise(
    parts: Sequence[tuple[FloatArray, FloatArray, FloatArray]],
) -> TruthNoise | None:
    """The truth's noise from the :func:`truth_residuals` of one or more runs, pooled (None
    with fewer than :data:`MIN_UPDATES` real interior updates)."""
    rxy = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0)
    rh = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0)
    dt = np.concatenate([p[2] for p in parts]) if parts else np.zeros(0)
    if rh.size < MIN_UPDATES:
        return None
    xy = float(np.sqrt(np.median(rxy**2) / CHI2_1_MEDIAN))
    yaw = float(np.sqrt(np.median(rh**2) / CHI2_1_MEDIAN))
    return TruthNoise(xy, yaw, spacing=float(np.median(dt)), updates=int(rh.size))


def allowed(
    given: TruthNoise | None,
    parts: Callable[[], Sequence[tuple[FloatArray, FloatArray, FloatArray]]],
    enabled: bool = True,
) -> TruthNoise | None:
    """The ground truth's noise a fit or a judgement allows for (the one rule): the user's
    ``given``, else estimated from the truth's updates (``parts()``: :func:`truth_residuals` of
    each run; :func:`estimate_truth_noise`); None where ``enabled`` is off and none is given."""
    if given is not None:
        return given
    return estimate_truth_noise(parts()) if enabled else None


def material(noise: TruthNoise | None) -> bool:
    """Whether the truth's noise is worth allowing for: known, and not as good as exact (above
    :data:`EXACT_XY` or :data:`EXACT_YAW`)."""
    return noise is not None and (noise.xy >= EXACT_XY or noise.yaw >= EXACT_YAW)


def variance_factors(t_truth: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
                     t: FloatArray) -> FloatArray:  # fmt: skip
    """The variance of the truth at the instants ``t`` (linear interpolation of its rows, as
    :func:`odolab.metrics.association.interpolate_trajectory` takes it), per unit variance of
    one real update: a real update 1, halfway between two 0.5 (``(1 - a)^2 + a^2``).

    Each row of the truth is a combination of its real updates (:func:`real_updates`): a real
    one itself, a held one the update it repeats, a resampled one the line between its two real
    neighbours; an instant between two rows combines theirs, and its variance is the sum of its
    weights on each real update squared."""
    tr = np.asarray(t_truth, dtype=np.float64)
    tq = np.asarray(t, dtype=np.float64)
    keep = real_updates(tr, x, y, heading)
    if tr.size < 2 or keep.size == 0:
        return np.ones(tq.size)
    tu = tr[keep]
    # each row: two real updates and the weight on the second
    j = np.clip(np.searchsorted(tu, tr, side="right") - 1, 0, tu.size - 1)
    nxt = np.minimum(j + 1, tu.size - 1)
    span = tu[nxt] - tu[j]
    frac = np.where(span > 0, (tr - tu[j]) / np.where(span > 0, span, 1.0), 0.0)
    p = np.column_stack((x, y, heading))
    held = np.all(p == p[keep][j], axis=1)  # repeats its last real update
    frac = np.where(held | np.isin(np.arange(tr.size), keep), 0.0, np.clip(frac, 0.0, 1.0))
    # each instant: between rows r and r + 1, weight w on the second (as
    # odolab.metrics.association.interpolate_trajectory brackets and weighs it)
    r = np.clip(np.searchsorted(tr, tq, side="left"), 1, tr.size - 1) - 1
    gap = tr[r + 1] - tr[r]
    w = np.clip(np.where(gap > 0, (tq - tr[r]) / np.where(gap > 0, gap, 1.0), 0.0), 0.0, 1.0)
    idx = np.column_stack((j[r], nxt[r], j[r + 1], nxt[r + 1]))
    coef = np.column_stack(((1 - w) * (1 - frac[r]), (1 - w) * frac[r],
                            w * (1 - frac[r + 1]), w * frac[r + 1]))  # fmt: skip
    same = idx[:, :, None] == idx[:, None, :]
    return np.asarray(np.einsum("ni,nj,nij->n", coef, coef, same), dtype=np.float64)


def piece_covariance(
    noise: TruthNoise, start: FloatArray, end: FloatArray, d: FloatArray
) -> FloatArray:
    """The truth's noise in the error of pieces that start at the truth's pose and end against
    it (m, 3, 3; x, y, heading; the error's frame is ``d``'s): ``start`` and ``end`` the truth's
    variance factors there (:func:`variance_factors`), ``d`` (m, 2) each piece's displacement.
    The two ends are taken as independent: a piece shorter than two of the truth's update
    spacings interpolates both ends from a shared update, which this overstates (up to twice).

    Both end positions add their noise; the start heading turns the whole piece, by
    ``w = (-d_y, d_x)`` per radian, and enters the heading error too (so the two correlate);
    the end heading adds its own. With start position and heading noise ``n_a``, ``delta`` and
    end noise ``n_b``, ``h_b``: ``e_xy = n_b - n_a - delta w``, ``e_h = h_b - delta``."""
    a = np.asarray(start, dtype=np.float64)
    b = np.asarray(end, dtype=np.float64)
    dd = np.asarray(d, dtype=np.float64).reshape(-1, 2)
    w = np.column_stack((-dd[:, 1], dd[:, 0]))
    sxy, syaw = noise.xy**2, noise.yaw**2
    out = np.zeros((dd.shape[0], 3, 3))
    out[:, :2, :2] = sxy * (a + b)[:, None, None] * np.eye(2) + syaw * a[:, None, None] * (
        w[:, :, None] * w[:, None, :]
    )
    out[:, :2, 2] = syaw * a[:, None] * w
    out[:, 2, :2] = out[:, :2, 2]
    out[:, 2, 2] = syaw * (a + b)
    return out
