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

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from odolab._fastmath import SINCOS_LIMIT, sincos_poly
from odolab.encoders import as_tick_array, default_max_dticks, unwrap_diff
from odolab.errors import EncoderJumpError, LogFormatError, OdolabError, ParamsError
from odolab.kinematics import Method, body_motion, chord, chord_derivative
from odolab.params import NoiseParams, RobotParams

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


@njit(cache=True, inline="always")
def _cov_step(  # pragma: no cover - compiled
    pxx: float,
    pxy: float,
    pxh: float,
    pyy: float,
    pyh: float,
    phh: float,
    heading: float,
    dsl: float,
    dsr: float,
    c: NDArray[np.float64],
    arc: bool,
    k_left: float,
    k_right: float,
    k_scrub: float,
    track: float,
) -> tuple[float, float, float, float, float, float, float]:
    """One cycle of covariance propagation; returns the six terms and the new heading."""
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
    dx = ch * gx
    dy = ch * gy
    # F P F^T with F = [[1, 0, -dy], [0, 1, dx], [0, 0, 1]]
    a = -dy
    b = dx
    nxx = pxx + 2.0 * a * pxh + a * a * phh
    nxy = pxy + a * pyh + b * pxh + a * b * phh
    nxh = pxh + a * phh
    nyy = pyy + 2.0 * b * pyh + b * b * phh
    nyh = pyh + b * phh
    nhh = phh
    # d pose' / d (forward, lateral, dtheta)
    j00 = ch * cs
    j01 = -ch * sn
    j02 = dch * gx - 0.5 * ch * gy
    j10 = ch * sn
    j11 = ch * cs
    j12 = dch * gy + 0.5 * ch * gx
    # d (forward, lateral, dtheta) / d ds_l, d ds_r, d n  (lateral = c[5] * dtheta)
    inv = 1.0 / c[4]
    ul_f, ul_t = c[0], -c[2] * inv
    ur_f, ur_t = c[1], c[3] * inv
    q = (k_left * abs(dsl), k_right * abs(dsr), k_scrub * abs(dsr - dsl) / track)
    cols = ((ul_f, c[5] * ul_t, ul_t), (ur_f, c[5] * ur_t, ur_t), (0.0, c[5], 1.0))
    for k in range(3):
        qk = q[k]
        if qk == 0.0:
            continue
        uf, ul, ut = cols[k]
        g0 = j00 * uf + j01 * ul + j02 * ut
        g1 = j10 * uf + j11 * ul + j12 * ut
        g2 = ut
        nxx += qk * g0 * g0
        nxy += qk * g0 * g1
        nxh += qk * g0 * g2
        nyy += qk * g1 * g1
        nyh += qk * g1 * g2
        nhh += qk * g2 * g2
    return nxx, nxy, nxh, nyy, nyh, nhh, heading + dth


@njit(cache=True)
def _propagate(  # pragma: no cover - compiled
    dleft: NDArray[np.float64],
    dright: NDArray[np.float64],
    kl: float,
    kr: float,
    c: NDArray[np.float64],
    arc: bool,
    k: NDArray[np.float64],
    track: float,
    h0: float,
    out: NDArray[np.float64],
) -> None:
    n = dleft.shape[0]
    if n == 0:
        return
    pxx, pxy, pxh, pyy, pyh, phh = out[0, 0], out[0, 1], out[0, 2], out[0, 3], out[0, 4], out[0, 5]
    h = h0
    for i in range(1, n):
        pxx, pxy, pxh, pyy, pyh, phh, h = _cov_step(
            pxx, pxy, pxh, pyy, pyh, phh, h, dleft[i] * kl, dright[i] * kr,
            c, arc, k[0], k[1], k[2], track,
        )  # fmt: skip
        out[i, 0] = pxx
        out[i, 1] = pxy
        out[i, 2] = pxh
        out[i, 3] = pyy
        out[i, 4] = pyh
        out[i, 5] = phh


@njit(cache=True)
def _propagate_ticks(  # pragma: no cover - compiled
    left: NDArray[np.int64],
    right: NDArray[np.int64],
    modulus: int,
    max_d: int,
    kl: float,
    kr: float,
    c: NDArray[np.float64],
    arc: bool,
    k: NDArray[np.float64],
    track: float,
    h0: float,
    out: NDArray[np.float64],
) -> tuple[int, int, int]:
    """As :func:`_propagate`, unwrapping raw counters on the way; returns (code, index, value)
    with code 0 = ok, 1/2 = left/right jump larger than ``max_d``."""
    n = left.shape[0]
    if n == 0:
        return 0, -1, 0
    half = modulus // 2
    pxx, pxy, pxh, pyy, pyh, phh = out[0, 0], out[0, 1], out[0, 2], out[0, 3], out[0, 4], out[0, 5]
    h = h0
    for i in range(1, n):
        dl = unwrap_diff(left[i] - left[i - 1], modulus, half)
        dr = unwrap_diff(right[i] - right[i - 1], modulus, half)
        if max_d >= 0:
            if abs(dl) > max_d:
                return 1, i, dl
            if abs(dr) > max_d:
                return 2, i, dr
        pxx, pxy, pxh, pyy, pyh, phh, h = _cov_step(
            pxx, pxy, pxh, pyy, pyh, phh, h, dl * kl, dr * kr,
            c, arc, k[0], k[1], k[2], track,
        )  # fmt: skip
        out[i, 0] = pxx
        out[i, 1] = pxy
        out[i, 2] = pxh
        out[i, 3] = pyy
        out[i, 4] = pyh
        out[i, 5] = phh
    return 0, -1, 0


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
) -> NDArray[np.float64]:
    """Covariance of (x, y, heading) after each sample, shape (n, 6) in :data:`COV_COLUMNS`.

    ``dticks_*``: shape (n,), counter increments per cycle (``dticks[0]`` is ignored, as in
    :func:`odolab.odometry.integrate_increments`). ``noise`` defaults to ``params.noise``.
    ``cov0``: the start covariance (3x3 or the six terms; default zero)."""
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
    _propagate(
        dl, dr, params.left_metres_per_tick, params.right_metres_per_tick,
        np.array(params.coefficients, dtype=np.float64), Method(method) is Method.ARC,
        np.array([k.k_left, k.k_right, k.k_scrub]), params.track_width, float(heading0), out,
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
    code, i, d = _propagate_ticks(
        left, right, params.encoder_modulus or 0, -1 if max_dticks is None else int(max_dticks),
        params.left_metres_per_tick, params.right_metres_per_tick,
        np.array(params.coefficients, dtype=np.float64), Method(method) is Method.ARC,
        np.array([k.k_left, k.k_right, k.k_scrub]), params.track_width, float(heading0), out,
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
        self._c = np.array(params.coefficients, dtype=np.float64)
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
        p = self.terms
        r = _cov_step(
            p[0], p[1], p[2], p[3], p[4], p[5], heading, ds_left, ds_right,
            self._c, self._arc, self._k[0], self._k[1], self._k[2], self._track,
        )  # fmt: skip
        self.terms = (r[0], r[1], r[2], r[3], r[4], r[5])
