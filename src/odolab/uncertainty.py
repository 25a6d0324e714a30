"""Pose covariance of odometry under per-wheel slip noise (Chong & Kleeman; Siegwart et al.).

Each wheel's travelled distance is wrong by a zero-mean random amount whose variance grows
with the distance it rolled: ``var(ds_r) = k_right * |ds_r|``, ``var(ds_l) = k_left * |ds_l|``
(``k`` in metres), independent between wheels and between steps. The covariance of the pose
``(x, y, heading)`` is propagated through the lab's midpoint step (eqs. 3.3-3.6) to first order::

    P' = Fp P Fp^T + Fu Q Fu^T,   Q = diag(k_right |ds_r|, k_left |ds_l|)

Closed forms for a straight run and a rotation in place are given for tests and quick checks.

:func:`propagate_covariance` is the general, compiled version used by odometry: any kinematic
model (:mod:`odolab.models`), the midpoint or the exact-arc step, and an optional heading term
for track scrub, ``var = k_scrub * |ds_r - ds_l| / track_width`` (rad^2). Per cycle, with the
body motion ``u = (forward, lateral, dtheta) = M (ds_l, ds_r)`` and ``n`` the scrub noise::

    P' = F P F^T + G Q G^T,   F = d pose' / d pose,   G = d pose' / d u . d u / d (ds_l, ds_r, n)
    Q = diag(k_left |ds_l|, k_right |ds_r|, k_scrub |ds_r - ds_l| / track_width)

The six numbers of the symmetric covariance are kept in the order of :data:`COV_COLUMNS`
(``h`` is the heading): m^2, m^2, m rad, m^2, m rad, rad^2. Streaming odometry
(:class:`odolab.odometry.Odometry` with ``covariance=True``) calls the same compiled step.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange
from numpy.typing import ArrayLike, NDArray

from odolab._fastmath import SINCOS_LIMIT, sincos_poly
from odolab.encoders import as_tick_array, default_max_dticks, unwrap_diff
from odolab.errors import EncoderJumpError, LogFormatError, OdolabError, ParamsError
from odolab.kinematics import Method, body_motion, chord, chord_derivative
from odolab.params import NoiseParams, RobotParams

F64 = NDArray[np.float64]
F64_2D = NDArray[np.float64]
I64 = NDArray[np.int64]

__all__ = [
    "COV_COLUMNS",
    "CovarianceStepper",
    "covariance_from_ticks",
    "covariance_matrix",
    "covariance_terms",
    "pose_covariance",
    "propagate_covariance",
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
    parallel: int | None = None,
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


#: Column names of the propagated covariance (h = heading), in the order of the kernels.
COV_COLUMNS = ("cov_xx", "cov_xy", "cov_xh", "cov_yy", "cov_yh", "cov_hh")


Coef = tuple[float, float, float, float, float, float]
Terms = tuple[float, float, float, float, float, float]

#: From this many samples on, the per-cycle noise terms are computed on several threads.
PARALLEL_MIN_SAMPLES = 100_000


@njit(cache=True, inline="always")
def _add_noise(  # pragma: no cover - compiled
    n6: Terms, qk: float, uf: float, ul: float, ut: float, j: Terms
) -> Terms:
    """``n6 + qk g g^T`` for one noise source: g = J u, u its column (forward, lateral,
    dtheta per unit), J = d pose' / d (forward, lateral, dtheta)."""
    if qk == 0.0:
        return n6
    g0 = j[0] * uf + j[1] * ul + j[2] * ut
    g1 = j[3] * uf + j[4] * ul + j[5] * ut
    g2 = ut
    return (
        n6[0] + qk * g0 * g0,
        n6[1] + qk * g0 * g1,
        n6[2] + qk * g0 * g2,
        n6[3] + qk * g1 * g1,
        n6[4] + qk * g1 * g2,
        n6[5] + qk * g2 * g2,
    )


@njit(cache=True, inline="always")
def _cycle_noise(  # pragma: no cover - compiled
    heading: float,
    dsl: float,
    dsr: float,
    c: Coef,
    arc: bool,
    k_left: float,
    k_right: float,
    k_scrub: float,
    track: float,
) -> tuple[float, float, Terms]:
    """What one cycle (started at ``heading``) does to the covariance, apart from the
    covariance itself: the shear (a, b) of F = [[1, 0, a], [0, 1, b], [0, 0, 1]] and the noise
    G Q G^T it adds. Needs no earlier covariance, so the batch kernels compute it for every
    cycle in parallel; ``c`` is the model's coefficients as a tuple."""
    fwd, lat, dth = body_motion(c[0], c[1], c[2], c[3], c[4], c[5], dsl, dsr)
    ch = chord(dth, arc)
    dch = chord_derivative(dth, arc)
    m = heading + 0.5 * dth
    if abs(m) < SINCOS_LIMIT:
        sn, cs = sincos_poly(m)
    else:
        cs = math.cos(m)
        sn = math.sin(m)
    gx = fwd * cs - lat * sn
    gy = fwd * sn + lat * cs
    # d pose' / d (forward, lateral, dtheta)
    j = (
        ch * cs,
        -ch * sn,
        dch * gx - 0.5 * ch * gy,
        ch * sn,
        ch * cs,
        dch * gy + 0.5 * ch * gx,
    )
    # d (forward, lateral, dtheta) / d ds_l, d ds_r, d n  (lateral = c[5] * dtheta)
    inv = 1.0 / c[4]
    ul_t = -c[2] * inv
    ur_t = c[3] * inv
    q = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    q = _add_noise(q, k_left * abs(dsl), c[0], c[5] * ul_t, ul_t, j)
    q = _add_noise(q, k_right * abs(dsr), c[1], c[5] * ur_t, ur_t, j)
    q = _add_noise(q, k_scrub * abs(dsr - dsl) / track, 0.0, c[5], 1.0, j)
    return -ch * gy, ch * gx, q


@njit(cache=True, inline="always")
def _cycle_apply(  # pragma: no cover - compiled
    p: Terms, a: float, b: float, q: Terms
) -> Terms:
    """F P F^T + Q with F = [[1, 0, a], [0, 1, b], [0, 0, 1]] (a = -dy, b = dx)."""
    pxx, pxy, pxh, pyy, pyh, phh = p
    return (
        pxx + 2.0 * a * pxh + a * a * phh + q[0],
        pxy + a * pyh + b * pxh + a * b * phh + q[1],
        pxh + a * phh + q[2],
        pyy + 2.0 * b * pyh + b * b * phh + q[3],
        pyh + b * phh + q[4],
        phh + q[5],
    )


@njit(cache=True)
def _stream_step(  # pragma: no cover - compiled
    p: Terms,
    heading: float,
    dsl: float,
    dsr: float,
    c: Coef,
    arc: bool,
    k_left: float,
    k_right: float,
    k_scrub: float,
    track: float,
) -> Terms:
    """One cycle for the streaming odometry: the batch passes' two steps in one call."""
    a, b, q = _cycle_noise(heading, dsl, dsr, c, arc, k_left, k_right, k_scrub, track)
    return _cycle_apply(p, a, b, q)


@njit(cache=True, inline="always")
def _noise_row(  # pragma: no cover - compiled
    i: int, out: F64_2D, ab: F64_2D, c: Coef, arc: bool, k: F64, track: float
) -> None:
    """Row i of the noise pass: (dsl, dsr, heading) in out[i, :3] -> the terms and (a, b)."""
    a, b, q = _cycle_noise(out[i, 2], out[i, 0], out[i, 1], c, arc, k[0], k[1], k[2], track)
    ab[i, 0] = a
    ab[i, 1] = b
    out[i, 0] = q[0]
    out[i, 1] = q[1]
    out[i, 2] = q[2]
    out[i, 3] = q[3]
    out[i, 4] = q[4]
    out[i, 5] = q[5]


@njit(cache=True)
def _noise_pass(  # pragma: no cover - compiled
    out: F64_2D, ab: F64_2D, coef: F64, arc: bool, k: F64, track: float
) -> None:
    c = (coef[0], coef[1], coef[2], coef[3], coef[4], coef[5])
    for i in range(1, out.shape[0]):
        _noise_row(i, out, ab, c, arc, k, track)


@njit(cache=True, parallel=True)
def _noise_pass_parallel(  # pragma: no cover - compiled
    out: F64_2D, ab: F64_2D, coef: F64, arc: bool, k: F64, track: float
) -> None:
    c = (coef[0], coef[1], coef[2], coef[3], coef[4], coef[5])
    for i in prange(1, out.shape[0]):
        _noise_row(i, out, ab, c, arc, k, track)


@njit(cache=True)
def _apply_pass(out: F64_2D, ab: F64_2D) -> None:  # pragma: no cover - compiled
    """The recursion P_i = F_i P_(i-1) F_i^T + Q_i, in place over the noise terms."""
    p = (out[0, 0], out[0, 1], out[0, 2], out[0, 3], out[0, 4], out[0, 5])
    for i in range(1, out.shape[0]):
        q = (out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5])
        p = _cycle_apply(p, ab[i, 0], ab[i, 1], q)
        out[i, 0] = p[0]
        out[i, 1] = p[1]
        out[i, 2] = p[2]
        out[i, 3] = p[3]
        out[i, 4] = p[4]
        out[i, 5] = p[5]


@njit(cache=True)
def _headings(  # pragma: no cover - compiled
    dleft: F64, dright: F64, kl: float, kr: float, coef: F64, h0: float, out: F64_2D
) -> None:
    """First pass from increments: (dsl, dsr, heading at the cycle's start) into out[i, :3]."""
    h = h0
    for i in range(1, dleft.shape[0]):
        dsl = dleft[i] * kl
        dsr = dright[i] * kr
        out[i, 0] = dsl
        out[i, 1] = dsr
        out[i, 2] = h
        h = h + body_motion(coef[0], coef[1], coef[2], coef[3], coef[4], coef[5], dsl, dsr)[2]


@njit(cache=True)
def _headings_ticks(  # pragma: no cover - compiled
    left: I64,
    right: I64,
    modulus: int,
    max_d: int,
    kl: float,
    kr: float,
    coef: F64,
    h0: float,
    out: F64_2D,
) -> tuple[int, int, int]:
    """:func:`_headings` from raw counters, unwrapping on the way; returns (code, index, value)
    with code 0 = ok, 1/2 = left/right jump larger than ``max_d``."""
    half = modulus // 2
    h = h0
    for i in range(1, left.shape[0]):
        dl = unwrap_diff(left[i] - left[i - 1], modulus, half)
        dr = unwrap_diff(right[i] - right[i - 1], modulus, half)
        if max_d >= 0:
            if abs(dl) > max_d:
                return 1, i, dl
            if abs(dr) > max_d:
                return 2, i, dr
        dsl = dl * kl
        dsr = dr * kr
        out[i, 0] = dsl
        out[i, 1] = dsr
        out[i, 2] = h
        h = h + body_motion(coef[0], coef[1], coef[2], coef[3], coef[4], coef[5], dsl, dsr)[2]
    return 0, -1, 0


def _propagate_from_headings(
    out: F64_2D, coef: F64, arc: bool, k: F64, track: float, parallel: int | None
) -> None:
    """Passes 2 and 3: the noise of every cycle (independent: on several threads for long
    logs), then the recursion."""
    ab = np.empty((out.shape[0], 2))
    threads = numba.get_num_threads() if parallel is None else max(1, int(parallel))
    if threads > 1 and out.shape[0] >= PARALLEL_MIN_SAMPLES:
        _noise_pass_parallel(out, ab, coef, arc, k, track)
    else:
        _noise_pass(out, ab, coef, arc, k, track)
    _apply_pass(out, ab)


def _noise_of(params: RobotParams, noise: NoiseParams | None) -> NoiseParams:
    chosen = noise if noise is not None else params.noise
    if chosen is None:
        raise ParamsError(
            f"parameters {params.name!r} have no [noise] table; a covariance needs k_left and "
            "k_right (m): run `odolab analyze` / `calibrate`, or add [noise] by hand"
        )
    return chosen


def propagate_covariance(
    dticks_left: ArrayLike,
    dticks_right: ArrayLike,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    noise: NoiseParams | None = None,
    heading0: float = 0.0,
    cov0: ArrayLike | None = None,
    parallel: int | None = None,
) -> NDArray[np.float64]:
    """Covariance of (x, y, heading) after each sample, shape (n, 6) in :data:`COV_COLUMNS`.

    ``dticks_*``: shape (n,), counter increments per cycle (``dticks[0]`` is ignored, as in
    :func:`odolab.odometry.integrate_increments`). ``noise`` defaults to ``params.noise``.
    ``cov0``: the start covariance (3x3 or the six terms; default zero). Three compiled
    passes: the headings (sequential, cheap), each cycle's shear and noise (independent: on
    ``parallel`` threads for long logs, default numba's count), the recursion (sequential)."""
    dl = np.ascontiguousarray(dticks_left, dtype=np.float64)
    dr = np.ascontiguousarray(dticks_right, dtype=np.float64)
    if dl.shape != dr.shape or dl.ndim != 1:
        raise LogFormatError("left and right increments must be 1-D arrays of the same length")
    if not (np.isfinite(dl).all() and np.isfinite(dr).all()):
        raise LogFormatError("counter increments must be finite numbers")
    k = _noise_of(params, noise)
    out = np.zeros((dl.size, 6))
    if dl.size and cov0 is not None:
        out[0] = covariance_terms(cov0)
    coef = np.array(params.coefficients, dtype=np.float64)
    _headings(
        dl, dr, params.left_metres_per_tick, params.right_metres_per_tick, coef,
        float(heading0), out,
    )  # fmt: skip
    _propagate_from_headings(
        out, coef, Method(method) is Method.ARC, np.array([k.k_left, k.k_right, k.k_scrub]),
        params.track_width, parallel,
    )  # fmt: skip
    return out


def covariance_from_ticks(
    left_ticks: ArrayLike,
    right_ticks: ArrayLike,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    noise: NoiseParams | None = None,
    max_dticks: int | None = None,
    heading0: float = 0.0,
    cov0: ArrayLike | None = None,
    parallel: int | None = None,
) -> NDArray[np.float64]:
    """:func:`propagate_covariance` from raw (possibly wrapping) counters, as
    :func:`odolab.odometry.integrate` takes them; shape (n, 6)."""
    if max_dticks is None:
        max_dticks = default_max_dticks(params.encoder_modulus)
    left = as_tick_array(left_ticks, "left_ticks")
    right = as_tick_array(right_ticks, "right_ticks")
    if left.size != right.size:
        raise LogFormatError(f"left has {left.size} samples, right has {right.size}")
    k = _noise_of(params, noise)
    out = np.zeros((left.size, 6))
    if left.size and cov0 is not None:
        out[0] = covariance_terms(cov0)
    coef = np.array(params.coefficients, dtype=np.float64)
    code, i, d = _headings_ticks(
        left, right, params.encoder_modulus or 0, -1 if max_dticks is None else int(max_dticks),
        params.left_metres_per_tick, params.right_metres_per_tick, coef, float(heading0), out,
    )  # fmt: skip
    if code == 0:
        _propagate_from_headings(
            out, coef, Method(method) is Method.ARC, np.array([k.k_left, k.k_right, k.k_scrub]),
            params.track_width, parallel,
        )  # fmt: skip
    if code:
        name = ("left_ticks", "right_ticks")[code - 1]
        raise EncoderJumpError(
            f"{name} jumps by {d} counts between samples {i - 1} and {i}, more than the "
            f"{max_dticks} counts per cycle that a wrap or plausible motion allows"
        )
    return out


def covariance_terms(cov: ArrayLike) -> NDArray[np.float64]:
    """The six terms (:data:`COV_COLUMNS`) of a 3x3 covariance, or six terms checked as given."""
    a = np.asarray(cov, dtype=np.float64)
    if a.shape == (3, 3):
        a = a[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    if a.shape != (6,) or not np.isfinite(a).all():
        raise OdolabError(f"a covariance must be 3x3 or its six terms, finite; got shape {a.shape}")
    return a.copy()


def covariance_matrix(terms: ArrayLike) -> NDArray[np.float64]:
    """The 3x3 covariance (or (n, 3, 3)) from six terms (or (n, 6)) in :data:`COV_COLUMNS`."""
    t = np.asarray(terms, dtype=np.float64)
    idx = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])
    return t[..., idx]


class CovarianceStepper:
    """One cycle of :func:`propagate_covariance` at a time, for streaming odometry.

    Runs the same compiled step as the batch kernel, so both agree to rounding."""

    def __init__(
        self, params: RobotParams, method: Method | str, noise: NoiseParams | None = None
    ) -> None:
        k = _noise_of(params, noise)
        c0, c1, c2, c3, c4, c5 = (float(v) for v in params.coefficients)
        self._c = (c0, c1, c2, c3, c4, c5)
        self._arc = Method(method) is Method.ARC
        self._k = (k.k_left, k.k_right, k.k_scrub)
        self._track = params.track_width
        self.terms: tuple[float, float, float, float, float, float] = (0.0,) * 6

    def reset(self, cov0: ArrayLike | None = None) -> None:
        """Back to the start covariance (default zero)."""
        t = (0.0,) * 6 if cov0 is None else tuple(float(v) for v in covariance_terms(cov0))
        self.terms = t  # type: ignore[assignment]

    def step(self, heading: float, ds_left: float, ds_right: float) -> None:
        """Propagate over one cycle that started at ``heading`` with these wheel displacements."""
        self.terms = _stream_step(
            self.terms, heading, ds_left, ds_right, self._c, self._arc, self._k[0], self._k[1],
            self._k[2], self._track,
        )  # fmt: skip
