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
from odolab.core.arrays import FloatArray as F64
from odolab.core.arrays import IntArray as I64

Coef = tuple[float, float, float, float, float, float]
Counts = tuple[int, int, float, float]  # modulus, largest step, metres per count left, right
_INT_MAX = 2**62  # beyond any counter difference; a bound that a comparison never passes
_INT32_MAX = 2**31 - 1
#: The share of each block's sin/cos turn that :func:`pipelined_ticks`' first thread does itself
#: after phase A, so that the two threads are even (the second has the rest of the turn, theta
#: and the running sums): 10 M samples took 0.082-0.093 s at 0.2 against 0.098-0.119 s with the
#: whole turn on the second thread, same machine and runs (0.1: 0.086-0.100 s, 0.3: 0.086 s).
PIPELINE_SHARE = 0.2
#: The turn's (phase B's) compile options: its sin/cos polynomials may fuse ``a * b + c`` into one
#: rounding (FMA). 10 M turns took 0.042 s instead of 0.052 s; 4 % of the turned steps move by one
#: ulp, and the sine and cosine stay within 2 ulp of numpy's (tests/core/test_fastmath.py). Every
#: kernel that turns steps has them, so that the passes, the pipeline and the parallel turn agree
#: to the bit.
TURN = {"contract"}


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


@njit(cache=True, nogil=True)
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
    lo: int,
    hi: int,
    tout: F64,
    heading: F64,
    step: F64,
    lat: F64,
    mid: F64,
) -> tuple[int, int, int, float, float]:
    """Phase A (sequential, no trigonometry) on samples ``lo`` to ``hi``: time check, unwrap, the
    model, the heading, from the heading ``h0`` after sample ``lo - 1`` (the start heading when
    ``lo`` is 0).

    Returns (code, index, value, largest |mid|, heading after sample ``hi - 1``); code 0 = ok,
    1/2 = left/right jump, 3 = time not finite, 4 = time goes backwards."""
    half = modulus // 2
    big = 0.0
    cc = (c[0], c[1], c[2], c[3], c[4], c[5])
    has_lat = lat.shape[0] > 0
    if lo == 0 and hi > 0:
        if not math.isfinite(t[0]):
            return 3, 0, 0, big, h0
        tout[0] = t[0]
        _first_step(h0, heading, step, lat, mid)
    # the block as views from sample lo - 1, so that the loop reads as the whole log's
    base = max(lo - 1, 0)
    tb, lb, rb = t[base:hi], left[base:hi], right[base:hi]
    ob, hb, sb, mb = tout[base:hi], heading[base:hi], step[base:hi], mid[base:hi]
    ab = lat[base:hi] if has_lat else lat
    fast = not arc and not has_lat  # the midpoint rule (chord 1) and no sideways motion
    if fast and _model_steps(tb, lb, rb, (modulus, max_d, kl, kr), c, ob, sb, mb):
        big, hh = _headings(h0, hb, mb)
        return 0, -1, 0, big, hh
    hh = h0
    for i in range(1, tb.shape[0]):
        ti = tb[i]
        if not math.isfinite(ti):
            return 3, base + i, 0, big, hh
        if ti < tb[i - 1]:
            return 4, base + i, 0, big, hh
        ob[i] = ti
        dl = unwrap_diff(lb[i] - lb[i - 1], modulus, half)
        dr = unwrap_diff(rb[i] - rb[i - 1], modulus, half)
        if max_d >= 0:
            if abs(dl) > max_d:
                return 1, base + i, dl, big, hh
            if abs(dr) > max_d:
                return 2, base + i, dr, big, hh
        fwd, side, m, hh = _one_step(float(dl), float(dr), kl, kr, cc, arc, hh)
        sb[i] = fwd  # stored here: passed the arrays, a helper made this loop 7x slower
        if has_lat:
            ab[i] = side
        mb[i] = m
        hb[i] = hh
        big = max(big, abs(m))
    return 0, -1, 0, big, hh


@njit(cache=True, nogil=True)
def _model_steps(  # pragma: no cover - compiled
    t: F64, left: I64, right: I64, counts: Counts, c: F64, tout: F64, step: F64, dth: F64
) -> bool:
    """Phase A's work that is independent per sample, on views that start one sample early:
    times copied, counters unwrapped (``counts``: the counters' modulus, the largest step
    allowed, the metres per count left and right), the midpoint model's forward step into
    ``step`` and turn into ``dth`` from index 1 on. No branch leaves the loop, so that it vectorizes; returns
    False where any sample needs :func:`_steps_from_ticks`'s careful loop (a time not
    finite or going backwards, a jump, a counter outside its range), which then finds the first
    problem and says it."""
    modulus, max_d, kl, kr = counts
    half = modulus // 2
    w_l, w_r, e_l, e_r, den = c[0], c[1], c[2], c[3], c[4]
    # unwrap_diff's first correction, without its rare modulo fallback; no branch in the loop
    top, low = (modulus - half, -half) if modulus > 0 else (_INT_MAX, -_INT_MAX)
    wrap_by = modulus if modulus > 0 else 0
    # and |d| below 2**31, so that it converts to a float through int32 (a vector instruction;
    # int64 has none before AVX-512), exactly
    limit = min(max_d if max_d >= 0 else _INT_MAX, _INT32_MAX)
    bad = False  # or-ed with | (not "or"/"and", which branch and stop the vectorizing)
    for i in range(1, t.shape[0]):
        ti = t[i]
        bad |= (not math.isfinite(ti)) | (ti < t[i - 1])
        tout[i] = ti
        dl = left[i] - left[i - 1]
        dr = right[i] - right[i - 1]
        dl = dl - wrap_by * (dl >= top) + wrap_by * (dl < low)
        dr = dr - wrap_by * (dr >= top) + wrap_by * (dr < low)
        bad |= (dl >= top) | (dl < low) | (dr >= top) | (dr < low)
        bad |= (abs(dl) > limit) | (abs(dr) > limit)
        dsl = float(np.int32(dl)) * kl
        dsr = float(np.int32(dr)) * kr
        dth[i] = (e_r * dsr - e_l * dsl) / den  # body_motion's operations, in its order
        step[i] = w_l * dsl + w_r * dsr
    return not bad


@njit(cache=True, nogil=True)
def _headings(
    h0: float, heading: F64, mid: F64
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Phase A's sequential part from index 1 of views that start one sample early: the turn in
    ``mid`` becomes the mid-cycle heading, and ``heading`` the running sum from ``h0`` (the
    operations of :func:`_one_step`). Returns (largest |mid|, last heading)."""
    hh = h0
    big = 0.0
    for i in range(1, mid.shape[0]):
        d = mid[i]
        m = hh + 0.5 * d
        hh = hh + d
        mid[i] = m
        heading[i] = hh
        big = max(big, abs(m))
    return big, hh


@njit(cache=True, inline="always")
def _turn_one(i: int, step: F64, mid: F64) -> None:  # pragma: no cover - compiled
    """Chord ``step[i]`` at the mid heading ``mid[i]`` -> (dx, dy) in place."""
    sn, cs = sincos_poly(mid[i])
    c = step[i]
    step[i] = c * cs
    mid[i] = c * sn


@njit(cache=True, inline="always")
def _turn_one_libm(i: int, step: F64, mid: F64) -> None:  # pragma: no cover - compiled
    c = step[i]
    m = mid[i]
    step[i] = c * math.cos(m)
    mid[i] = c * math.sin(m)


@njit(cache=True, nogil=True, fastmath=TURN)
def _turn_steps(step: F64, mid: F64, poly: bool) -> None:  # pragma: no cover - compiled
    """Phase B's turn alone (no theta), polynomial or libm sin/cos."""
    if poly:
        for i in range(step.shape[0]):
            _turn_one(i, step, mid)
    else:
        for i in range(step.shape[0]):
            _turn_one_libm(i, step, mid)


@njit(cache=True, nogil=True)
def _wrap_headings(heading: F64, theta: F64) -> None:  # pragma: no cover - compiled
    """Phase B's theta alone: each heading wrapped."""
    for i in range(heading.shape[0]):
        theta[i] = wrap(heading[i])


@njit(cache=True, parallel=True, fastmath=TURN)
def _turn_steps_parallel(step: F64, mid: F64) -> None:  # pragma: no cover - compiled
    """Phase B's polynomial turn on all threads."""
    for i in prange(step.shape[0]):
        _turn_one(i, step, mid)


@njit(cache=True, parallel=True)
def _wrap_headings_parallel(heading: F64, theta: F64) -> None:  # pragma: no cover - compiled
    """Phase B's theta on all threads."""
    for i in prange(heading.shape[0]):
        theta[i] = wrap(heading[i])


def _rotate_steps(step: F64, mid: F64, heading: F64, theta: F64) -> None:
    """Phase B: step -> (dx, dy) in place, theta from heading. Independent per sample. The turn
    and the wrap are separate kernels: only the turn's compile options fuse (``TURN``), so that
    theta is :func:`wrap`'s to the bit wherever it is computed."""
    _turn_steps(step, mid, True)
    _wrap_headings(heading, theta)


def _rotate_steps_parallel(step: F64, mid: F64, heading: F64, theta: F64) -> None:
    """Phase B on all threads."""
    _turn_steps_parallel(step, mid)
    _wrap_headings_parallel(heading, theta)


@njit(cache=True, nogil=True)
def _rotate_steps_libm(
    step: F64, mid: F64, heading: F64, theta: F64
) -> None:  # pragma: no cover - compiled
    """Phase B with libm's sin/cos, for headings beyond SINCOS_LIMIT."""
    _turn_steps(step, mid, False)
    _wrap_headings(heading, theta)


def _rotate_steps_lateral(
    step: F64, lat: F64, mid: F64, heading: F64, theta: F64, poly: bool
) -> None:
    """Phase B for models with sideways motion: (forward, lateral) chords -> (dx, dy)."""
    _turn_lateral(step, lat, mid, poly)
    _wrap_headings(heading, theta)


@njit(cache=True, fastmath=TURN)
def _turn_lateral(step: F64, lat: F64, mid: F64, poly: bool) -> None:  # pragma: no cover - compiled
    """Phase B's turn of (forward, lateral) chords at the mid headings."""
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


@njit(cache=True, nogil=True)
def _accumulate_range(
    dx: F64, dy: F64, lo: int, hi: int, x0: float, y0: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Phase C on samples ``lo`` to ``hi``, from the position (x0, y0) at sample ``lo - 1`` (the
    start position when ``lo`` is 0); returns the position at sample ``hi - 1``."""
    xx = x0
    yy = y0
    for i in range(lo, hi):
        if i > 0:
            xx = xx + dx[i]
            yy = yy + dy[i]
        dx[i] = xx
        dy[i] = yy
    return xx, yy


@njit(cache=True, nogil=True)
def _accumulate(dx: F64, dy: F64, x0: float, y0: float) -> None:  # pragma: no cover - compiled
    """Phase C: positions as running sums of the steps, in place (the streaming order)."""
    _accumulate_range(dx, dy, 0, dx.shape[0], x0, y0)


@njit(cache=True, nogil=True)
def _finish_range(
    step: F64,
    mid: F64,
    heading: F64,
    theta: F64,
    lo: int,
    turned: int,
    hi: int,
    x0: float,
    y0: float,
    poly: bool,
) -> tuple[float, float]:  # pragma: no cover - compiled
    """Phases B and C on samples ``lo`` to ``hi`` (no sideways motion), one after the other while
    the block is in cache, the steps before ``turned`` already turned; returns the position at
    sample ``hi - 1``."""
    _turn_steps(step[turned:hi], mid[turned:hi], poly)
    _wrap_headings(heading[lo:hi], theta[lo:hi])
    return _accumulate_range(step, mid, lo, hi, x0, y0)


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


def pipelined_ticks(
    t: F64,
    left: I64,
    right: I64,
    counts: Counts,
    c: F64,
    arc: bool,
    start: tuple[float, float, float],
    out: tuple[F64, F64, F64, F64, F64],
    block: int,
) -> tuple[int, int, int]:
    """Phases A, B and C of a log without sideways motion as a two-stage pipeline on two threads.

    The calling thread runs phase A block by block (``block`` samples), carrying the heading,
    and turns the first ``PIPELINE_SHARE`` of each block's steps (phase B's sin/cos); a second
    thread runs the rest of phase B and phase C on each block the first has finished, carrying
    the position, while the block is still in cache. Every sample takes the same operations in the
    same order as the passes one after the other, so the poses are bit-identical to theirs,
    except that the choice between the polynomial sin/cos and libm's (``SINCOS_LIMIT``) is made
    per block instead of once for the log. ``counts``: as :func:`_model_steps` takes them;
    ``out`` is (t, x, y, theta, heading); ``start`` is (x0, y0, h0). Returns phase A's (code,
    index, value) (see :func:`_steps_from_ticks`); after a problem, the arrays past it are not
    filled."""
    import queue
    import threading

    tt, x, y, theta, heading = out
    x0, y0, hh = start
    modulus, max_d, kl, kr = counts
    no_lat = np.empty(0)
    blocks: queue.SimpleQueue[tuple[int, int, int, float] | None] = queue.SimpleQueue()
    failure: list[BaseException] = []

    def positions() -> None:
        xx, yy = x0, y0
        while (item := blocks.get()) is not None:
            if failure:
                continue
            lo, turned, hi, big = item
            try:
                xx, yy = _finish_range(
                    x, y, heading, theta, lo, turned, hi, xx, yy, big < SINCOS_LIMIT
                )
            except BaseException as exc:  # handed to the calling thread
                failure.append(exc)

    worker = threading.Thread(target=positions, name="odolab-positions", daemon=True)
    worker.start()
    code, i, d = 0, -1, 0
    try:
        for lo in range(0, left.shape[0], block):
            hi = min(left.shape[0], lo + block)
            code, i, d, big, hh = _steps_from_ticks(
                t, left, right, modulus, max_d, kl, kr, c, arc, hh, lo, hi,
                tt, heading, x, no_lat, y,
            )  # fmt: skip
            if code != 0:
                break
            turned = lo + int((hi - lo) * PIPELINE_SHARE)
            _turn_steps(x[lo:turned], y[lo:turned], big < SINCOS_LIMIT)
            blocks.put((lo, turned, hi, big))
    finally:
        blocks.put(None)
        worker.join()
    if failure:
        raise failure[0]
    return code, i, d
