"""The compiled pass of the slip fit's Kalman filter (:mod:`odolab.calibration.slipfilter`), in
its own module so that importing the calibration does not import numba: the filter loads it on
its first call."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from odolab.core._jit import njit

FloatArray = NDArray[np.float64]
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
def _predict(
    s: FloatArray,
    p: FloatArray,
    jac: FloatArray,
    a: FloatArray,
    ds: float,
    dth: float,
    phi: FloatArray,
    var: FloatArray,
) -> None:  # pragma: no cover
    """Move the state ``s`` by one cycle of the slipping model (midpoint heading) and its
    covariance ``p`` by ``F p F^T + G Q G^T``; ``F`` is the identity but for the pose's three
    rows (``jac``), so only those rows and columns change (``a``: scratch, 3 x N)."""
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
    a[:, :] = jac @ p  # the pose's rows of F p
    p[:POSE, POSE:] = a[:, POSE:]
    p[POSE:, :POSE] = a[:, POSE:].T
    p[:POSE, :POSE] = a @ np.ascontiguousarray(jac.T)
    vf, vl = var[0], var[1]
    p[0, 0] += c * c * vf + sn * sn * vl
    p[0, 1] += c * sn * (vf - vl)
    p[1, 0] += c * sn * (vf - vl)
    p[1, 1] += sn * sn * vf + c * c * vl
    p[2, 2] += var[2]


@njit(cache=True)
def _update(
    s: FloatArray, p: FloatArray, z: FloatArray, r: FloatArray
) -> tuple[float, bool]:  # pragma: no cover
    """Update the state ``s`` and covariance ``p`` with a measurement ``z`` of the pose of
    variances ``r`` (not beyond :data:`GATE`); return the measurement's log likelihood and
    whether it was taken."""
    inn = np.empty(POSE)
    sm = np.empty((POSE, POSE))
    for i in range(POSE):
        inn[i] = z[i] - s[i]
        for j in range(POSE):
            sm[i, j] = p[i, j]
        sm[i, i] += r[i]
    si = np.linalg.inv(sm)
    quad = 0.0
    for i in range(POSE):
        for j in range(POSE):
            quad += inn[i] * si[i, j] * inn[j]
    # Huber's loss on the Mahalanobis distance: beyond the gate it grows linearly, so a filter
    # too sure of itself to take the truth's updates is not made likely by leaving them out
    rho = math.sqrt(GATE * quad) - 0.5 * GATE if quad > GATE else 0.5 * quad
    loglik = -(rho + 0.5 * math.log(np.linalg.det(sm)) + 0.5 * POSE * math.log(2 * math.pi))
    if quad > GATE:
        return loglik, False
    gain = np.ascontiguousarray(p[:, :POSE]) @ si
    s += gain @ inn
    # Joseph's form, P <- (I - K H) P (I - K H)^T + K R K^T: stays a covariance when the truth
    # is far more precise than the prediction (the plain form loses its symmetry and sign)
    p -= gain @ np.ascontiguousarray(p[:POSE, :])
    left = np.ascontiguousarray(p[:, :POSE])
    gt = np.ascontiguousarray(gain.T)
    p += (gain * r) @ gt - left @ gt
    p[:, :] = 0.5 * (p + p.T)
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
    s = np.zeros(N)
    p = np.zeros((N, N))
    s[POSE:] = beta0
    p[POSE:, POSE:] = p0
    jac = np.zeros((POSE, N))
    a = np.zeros((POSE, N))
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
        _predict(s, p, jac, a, ds[k], dth[k], phi[k], var[k])
        if meas[k]:
            ll, taken = _update(s, p, truth[k], r)
            loglik += ll
            if taken:
                count += 1
            else:
                gated += 1
    return s[POSE:].copy(), p[POSE:, POSE:].copy(), loglik, count, gated
