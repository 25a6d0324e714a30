"""The compiled pass of the slip fit's Kalman filter (:mod:`odolab.calibration.slipfilter`), in
its own module so that importing the calibration does not import numba: the filter loads it on
its first call."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from odolab.core._jit import njit
from odolab.core.arrays import FloatArray

BoolArray = NDArray[np.bool_]

#: A truth update whose innovation's squared Mahalanobis distance is beyond this (the 99.9 %
#: quantile of a chi-square with three degrees of freedom) is a glitch (a scan matcher's
#: misregistration), not a measurement: the filter does not take it, and it counts in the
#: likelihood by Huber's loss (linear in the distance beyond the gate's).
GATE = 16.266236196238129
#: The state: the pose (x, y, heading) and the 24 slip coefficients (fwd, lat, yaw; 8 each).
POSE = 3
K = 8
N = POSE + 3 * K


@njit(cache=True)
def _inverse3(m: FloatArray, out: FloatArray) -> float:  # pragma: no cover
    """``out`` = the inverse of the 3 x 3 matrix ``m`` (by its cofactors); returns its
    determinant."""
    c00 = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
    c01 = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
    c02 = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
    det = m[0, 0] * c00 + m[0, 1] * c01 + m[0, 2] * c02
    inv = 1.0 / det
    out[0, 0] = c00 * inv
    out[1, 0] = c01 * inv
    out[2, 0] = c02 * inv
    out[0, 1] = (m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]) * inv
    out[1, 1] = (m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]) * inv
    out[2, 1] = (m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]) * inv
    out[0, 2] = (m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]) * inv
    out[1, 2] = (m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]) * inv
    out[2, 2] = (m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]) * inv
    return float(det)


@njit(cache=True)
def _predict(
    s: FloatArray,
    p: FloatArray,
    jac: FloatArray,
    a: FloatArray,
    corner: FloatArray,
    ds: float,
    dth: float,
    phi: FloatArray,
    var: FloatArray,
) -> None:  # pragma: no cover
    """Move the state ``s`` by one cycle of the slipping model (midpoint heading) and its
    covariance ``p`` by ``F p F^T + G Q G^T``; ``F`` is the identity but for the pose's three
    rows (``jac``), so only those rows and columns change (``a``: scratch, 3 x N; ``corner``:
    scratch, 3 x 3)."""
    f = ds
    lat = 0.0
    rot = dth
    for i in range(K):
        f += phi[i] * s[POSE + i]
        lat += phi[i] * s[POSE + K + i]
        rot += phi[i] * s[POSE + 2 * K + i]
    mid = s[2] + 0.5 * rot
    c = math.cos(mid)
    sn = math.sin(mid)
    dx = c * f - sn * lat
    dy = sn * f + c * lat
    s[0] += dx
    s[1] += dy
    s[2] += rot
    jac[:, :] = 0.0
    jac[0, 0] = 1.0
    jac[1, 1] = 1.0
    jac[2, 2] = 1.0
    jac[0, 2] = -dy
    jac[1, 2] = dx
    for i in range(K):
        g = phi[i]
        jac[0, POSE + i] = c * g
        jac[0, POSE + K + i] = -sn * g
        jac[0, POSE + 2 * K + i] = -0.5 * dy * g
        jac[1, POSE + i] = sn * g
        jac[1, POSE + K + i] = c * g
        jac[1, POSE + 2 * K + i] = 0.5 * dx * g
        jac[2, POSE + 2 * K + i] = g
    # the pose's rows of F p and its corner F p F^T, copied in by np.positive(src, dst): numba
    # compiles an array assigned into a slice (dst[...] = src) in seconds, a ufunc in a fraction
    np.dot(jac, p, a)
    np.dot(a, jac.T, corner)
    np.positive(a[:, POSE:], p[:POSE, POSE:])
    np.positive(a[:, POSE:].T, p[POSE:, :POSE])
    np.positive(corner, p[:POSE, :POSE])
    vf, vl = var[0], var[1]
    p[0, 0] += c * c * vf + sn * sn * vl
    p[0, 1] += c * sn * (vf - vl)
    p[1, 0] += c * sn * (vf - vl)
    p[1, 1] += sn * sn * vf + c * c * vl
    p[2, 2] += var[2]


@njit(cache=True)
def _update(
    s: FloatArray,
    p: FloatArray,
    z: FloatArray,
    r: FloatArray,
    cols: FloatArray,
    rows: FloatArray,
    gain: FloatArray,
    work: FloatArray,
    step: FloatArray,
    big: FloatArray,
) -> tuple[float, bool]:  # pragma: no cover
    """Update the state ``s`` and covariance ``p`` with a measurement ``z`` of the pose of
    variances ``r`` (not beyond :data:`GATE`); return the measurement's log likelihood and
    whether it was taken. Scratch: ``cols``, ``gain``, ``work`` (N x 3), ``rows`` (3 x N),
    ``step`` (N), ``big`` (N x N)."""
    inn = np.empty(POSE)
    sm = np.empty((POSE, POSE))
    si = np.empty((POSE, POSE))
    for i in range(POSE):
        inn[i] = z[i] - s[i]
        for j in range(POSE):
            sm[i, j] = p[i, j]
        sm[i, i] += r[i]
    det = _inverse3(sm, si)
    quad = 0.0
    for i in range(POSE):
        for j in range(POSE):
            quad += inn[i] * si[i, j] * inn[j]
    # Huber's loss on the Mahalanobis distance: beyond the gate it grows linearly, so a filter
    # too sure of itself to take the truth's updates is not made likely by leaving them out
    rho = math.sqrt(GATE * quad) - 0.5 * GATE if quad > GATE else 0.5 * quad
    loglik = -(rho + 0.5 * math.log(det) + 0.5 * POSE * math.log(2 * math.pi))
    if quad > GATE:
        return loglik, False
    np.positive(p[:, :POSE], cols)  # copies (see _predict)
    np.positive(p[:POSE, :], rows)
    np.dot(cols, si, gain)
    np.dot(gain, inn, step)
    s += step
    # Joseph's form, P <- (I - K H) P (I - K H)^T + K R K^T: stays a covariance when the truth
    # is far more precise than the prediction (the plain form loses its symmetry and sign)
    np.dot(gain, rows, big)
    p -= big
    np.positive(p[:, :POSE], cols)
    np.multiply(gain, r, work)
    work -= cols
    np.dot(work, gain.T, big)
    p += big
    np.add(p, p.T, big)
    np.multiply(big, 0.5, p)
    return loglik, True


@njit(cache=True)
def filter_pass(
    ds: FloatArray,
    dth: FloatArray,
    phi: FloatArray,
    var: FloatArray,
    start: BoolArray,
    meas: BoolArray,
    truth: FloatArray,
    r: FloatArray,
    beta0: FloatArray,
    p0: FloatArray,
) -> tuple[FloatArray, FloatArray, float, int, int]:  # pragma: no cover
    """One pass of the extended Kalman filter over cycles (see the module of
    :mod:`odolab.calibration.slipfilter`): ``ds``, ``dth`` each cycle's commanded forward motion
    (m) and turn (rad), ``phi`` (cycles, 8) its basis times its duration, ``var`` (cycles, 3) the
    variance of its body motion (forward, lateral, yaw) that the model does not explain,
    ``start`` where a run starts (the pose is taken from the truth there, the coefficients carry
    over), ``meas`` where the truth ``truth`` (cycles, 3: x, y, unwrapped heading) is a real
    update, of variances ``r`` (3). Returns (the coefficients, their covariance, the log
    likelihood of the truth's updates, the number of updates taken, the number left out as
    glitches)."""
    if beta0.shape[0] != N - POSE or p0.shape[0] != N - POSE or p0.shape[1] != N - POSE:
        raise ValueError("the prior needs the 24 slip coefficients and their 24 x 24 covariance")
    s = np.zeros(N)
    p = np.zeros((N, N))
    for i in range(N - POSE):
        s[POSE + i] = beta0[i]
        for j in range(N - POSE):
            p[POSE + i, POSE + j] = p0[i, j]
    jac = np.zeros((POSE, N))
    a = np.zeros((POSE, N))
    corner = np.zeros((POSE, POSE))
    cols = np.zeros((N, POSE))
    gain = np.zeros((N, POSE))
    work = np.zeros((N, POSE))
    step = np.zeros(N)
    big = np.zeros((N, N))
    loglik = 0.0
    count = 0
    gated = 0
    for k in range(ds.shape[0]):
        if start[k]:  # a run's first pose: the truth's, the coefficients carry over
            for i in range(POSE):
                s[i] = truth[k, i]
                for j in range(N):
                    p[i, j] = 0.0
                    p[j, i] = 0.0
                p[i, i] = r[i]
            continue
        _predict(s, p, jac, a, corner, ds[k], dth[k], phi[k], var[k])
        if meas[k]:
            ll, taken = _update(s, p, truth[k], r, cols, a, gain, work, step, big)
            loglik += ll
            if taken:
                count += 1
            else:
                gated += 1
    return s[POSE:].copy(), p[POSE:, POSE:].copy(), loglik, count, gated
