"""The compiled passes of batch odometry (numba), loaded by :mod:`odolab.core.odometry` on first
use so that importing it (and integrating a short log, see ``NUMPY_MAX_SAMPLES`` there) does not
import numba. See :func:`odolab.core.odometry.integrate` for the three passes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from odolab.core import _jit as numba  # numba's functions, or plain Python without the fast extra
from odolab.core._encoders_jit import unwrap_diff
from odolab.core._fastmath import SINCOS_LIMIT, sincos_poly
from odolab.core._jit import njit, prange
from odolab.core._kinematics_jit import body_motion, chord, wrap

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Coef = tuple[float, float, float, float, float, float]


@njit(cache=True, inline="always")
def _one_step(  # pragma: no cover - compiled
    dl: float, dr: float, kl: float, kr: float, c: Coef, arc: bool, hh: float
) -> tuple[float, float, float, float]:
    """Phase A for one sample: eqs. (3.1)-(3.4) through the model, the chord, the heading.

    Returns (forward chord, sideways chord, mid-cycle heading, new heading): a pure function
    of values; the loops store the results. (Given the arrays to store into, the same step
    ran 9x slower.) ``c`` is the model's coefficients as a tuple, unpacked once per loop."""
    fwd, side, dth = body_motion(c[0], c[1], c[2], c[3], c[4], c[5], dl * kl, dr * kr)
    ch = chord(dth, arc)
    return fwd * ch, side * ch, hh + 0.5 * dth, hh + dth


@njit(cache=True, inline="always")
def _first_step(h0: float, heading: F64, step: F64, lat: F64, mid: F64) -> None:  # pragma: no cover
    heading[0] = h0
    step[0] = 0.0
    mid[0] = h0
    if lat.shape[0] > 0:
        lat[0] = 0.0


@njit(cache=True)
def _steps_from_ticks(  # pragma: no cover - compiled
    t: F64,
    left: I64,
    right: I64,
    modulus: int,
    max_d: int,
    kl: float,
    kr: float,
    c: F64,
    arc: bool,
    h0: float,
    tout: F64,
    heading: F64,
    step: F64,
    lat: F64,
    mid: F64,
) -> tuple[int, int, int, float]:
    """Phase A (sequential, no trigonometry): time check, unwrap, the model, the heading.

    Returns (code, index, value, largest |mid|); code 0 = ok, 1/2 = left/right jump,
    3 = time not finite, 4 = time goes backwards."""
    n = left.shape[0]
    half = modulus // 2
    hh = h0
    big = 0.0
    cc = (c[0], c[1], c[2], c[3], c[4], c[5])
    has_lat = lat.shape[0] > 0
    if n > 0:
        if not math.isfinite(t[0]):
            return 3, 0, 0, big
        tout[0] = t[0]
        _first_step(h0, heading, step, lat, mid)
    for i in range(1, n):
        ti = t[i]
        if not math.isfinite(ti):
            return 3, i, 0, big
        if ti < t[i - 1]:
            return 4, i, 0, big
        tout[i] = ti
        dl = unwrap_diff(left[i] - left[i - 1], modulus, half)
        dr = unwrap_diff(right[i] - right[i - 1], modulus, half)
        if max_d >= 0:
            if abs(dl) > max_d:
                return 1, i, dl, big
            if abs(dr) > max_d:
                return 2, i, dr, big
        fwd, side, m, hh = _one_step(float(dl), float(dr), kl, kr, cc, arc, hh)
        step[i] = fwd  # stored here: passed the arrays, a helper made this loop 7x slower
        if has_lat:
            lat[i] = side
        mid[i] = m
        heading[i] = hh
        big = max(big, abs(m))
    return 0, -1, 0, big


@njit(cache=True, inline="always")
def _rotate_one(
    i: int, step: F64, mid: F64, heading: F64, theta: F64
) -> None:  # pragma: no cover - compiled
    sn, cs = sincos_poly(mid[i])
    c = step[i]
    step[i] = c * cs
    mid[i] = c * sn
    theta[i] = wrap(heading[i])


@njit(cache=True)
def _rotate_steps(
    step: F64, mid: F64, heading: F64, theta: F64
) -> None:  # pragma: no cover - compiled
    """Phase B: step -> (dx, dy) in place, theta from heading. Independent per sample."""
    for i in range(step.shape[0]):
        _rotate_one(i, step, mid, heading, theta)


@njit(cache=True, parallel=True)
def _rotate_steps_parallel(
    step: F64, mid: F64, heading: F64, theta: F64
) -> None:  # pragma: no cover - compiled
    """Phase B on all threads."""
    for i in prange(step.shape[0]):
        _rotate_one(i, step, mid, heading, theta)


@njit(cache=True)
def _rotate_steps_libm(
    step: F64, mid: F64, heading: F64, theta: F64
) -> None:  # pragma: no cover - compiled
    """Phase B with libm's sin/cos, for headings beyond SINCOS_LIMIT."""
    for i in range(step.shape[0]):
        c = step[i]
        m = mid[i]
        step[i] = c * math.cos(m)
        mid[i] = c * math.sin(m)
        theta[i] = wrap(heading[i])


@njit(cache=True)
def _rotate_steps_lateral(
    step: F64, lat: F64, mid: F64, heading: F64, theta: F64, poly: bool
) -> None:  # pragma: no cover - compiled
    """Phase B for models with sideways motion: (forward, lateral) chords -> (dx, dy)."""
    for i in range(step.shape[0]):
        m = mid[i]
        if poly:
            sn, cs = sincos_poly(m)
        else:
            sn = math.sin(m)
            cs = math.cos(m)
        fx = step[i]
        fy = lat[i]
        step[i] = fx * cs - fy * sn
        mid[i] = fx * sn + fy * cs
        theta[i] = wrap(heading[i])


@njit(cache=True)
def _accumulate(dx: F64, dy: F64, x0: float, y0: float) -> None:  # pragma: no cover - compiled
    """Phase C: positions as running sums of the steps, in place (the streaming order)."""
    n = dx.shape[0]
    xx = x0
    yy = y0
    for i in range(n):
        if i > 0:
            xx = xx + dx[i]
            yy = yy + dy[i]
        dx[i] = xx
        dy[i] = yy


@njit(cache=True)
def _steps_from_dticks(  # pragma: no cover - compiled
    dleft: F64,
    dright: F64,
    kl: float,
    kr: float,
    c: F64,
    arc: bool,
    h0: float,
    heading: F64,
    step: F64,
    lat: F64,
    mid: F64,
) -> float:
    """Phase A for per-cycle increments (``dleft[0]``, ``dright[0]`` ignored)."""
    n = dleft.shape[0]
    hh = h0
    big = 0.0
    cc = (c[0], c[1], c[2], c[3], c[4], c[5])
    has_lat = lat.shape[0] > 0
    if n > 0:
        _first_step(h0, heading, step, lat, mid)
    for i in range(1, n):
        fwd, side, m, hh = _one_step(dleft[i], dright[i], kl, kr, cc, arc, hh)
        step[i] = fwd  # stored here: passed the arrays, a helper made this loop 7x slower
        if has_lat:
            lat[i] = side
        mid[i] = m
        heading[i] = hh
        big = max(big, abs(m))
    return big


def _finish(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    lat: NDArray[np.float64],
    heading: NDArray[np.float64],
    theta: NDArray[np.float64],
    x0: float,
    y0: float,
    largest_mid: float,
    parallel: int | None,
    parallel_min_samples: int,
) -> None:
    """Phases B and C: turn chord lengths (in x; sideways ones in lat) at mid headings (in y)
    into positions."""
    threads = numba.get_num_threads() if parallel is None else max(1, int(parallel))
    if lat.size:
        _rotate_steps_lateral(x, lat, y, heading, theta, largest_mid < SINCOS_LIMIT)
    elif largest_mid >= SINCOS_LIMIT:
        _rotate_steps_libm(x, y, heading, theta)
    elif threads > 1 and x.size >= parallel_min_samples:
        _rotate_steps_parallel(x, y, heading, theta)
    else:
        _rotate_steps(x, y, heading, theta)
    _accumulate(x, y, x0, y0)
