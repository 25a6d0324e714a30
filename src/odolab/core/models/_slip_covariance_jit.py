"""The compiled loops of the slip model's covariance (:mod:`odolab.core.models.slip_covariance`):
the first-order propagation cycle by cycle and the second-order share over the pairs of steps.
In their own module, loaded on the first call where numba is installed, so that importing the
model does not import numba; without numba the numpy loops of ``slip_covariance`` run (these,
as plain Python, would be slower). ``tests/core/test_slip_covariance_kernels.py`` holds each
equal to its numpy twin."""

from __future__ import annotations

import math

import numpy as np

from odolab.core._jit import njit
from odolab.core.arrays import FloatArray, IntArray


@njit(cache=True, inline="always")
def _white_step(
    white: FloatArray, tmp: FloatArray, g: FloatArray, dx: float, dy: float, col: int, mw: float
) -> None:  # pragma: no cover
    """One white term's pose covariance ``W`` (3 x 3) through a cycle: ``F W F^T`` (``F`` the
    identity but ``F[0, 2] = -dy``, ``F[1, 2] = dx``) plus the cycle's variance ``mw`` entering
    through ``G``'s column ``col``; ``tmp``: scratch."""
    for a in range(3):
        for b in range(3):
            tmp[a, b] = white[a, b]
    for b in range(3):
        tmp[0, b] += -dy * white[2, b]
        tmp[1, b] += dx * white[2, b]
    for a in range(3):
        white[a, 0] = tmp[a, 0] - dy * tmp[a, 2]
        white[a, 1] = tmp[a, 1] + dx * tmp[a, 2]
        white[a, 2] = tmp[a, 2]
    for a in range(3):
        for b in range(3):
            white[a, b] += mw * g[a, col] * g[b, col]


@njit(cache=True, inline="always")
def _posterior_step(
    jac: FloatArray,
    sj: FloatArray,
    g: FloatArray,
    dx: float,
    dy: float,
    dphi: FloatArray,
    sigma: FloatArray,
    post: FloatArray,
) -> None:  # pragma: no cover
    """The pose's sensitivity to the coefficients ``jac`` (3 x 24) through a cycle (``F jac``
    plus ``G``'s columns times ``dphi``, the body motion's by each coefficient), and the
    posterior's share of the pose covariance ``post = jac sigma jac^T``; ``sj``: scratch."""
    k = dphi.size
    for q in range(3 * k):
        jac[0, q] += -dy * jac[2, q]
        jac[1, q] += dx * jac[2, q]
    for j in range(3):
        for q in range(k):
            for a in range(3):
                jac[a, j * k + q] += g[a, j] * dphi[q]
    for a in range(3):
        for q in range(3 * k):
            acc = 0.0
            for r in range(3 * k):
                acc += jac[a, r] * sigma[r, q]
            sj[a, q] = acc
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for q in range(3 * k):
                acc += sj[a, q] * jac[b, q]
            post[a, b] = acc


@njit(cache=True)
def first_order(
    start: FloatArray,
    fwd: FloatArray,
    lat: FloatArray,
    dth: FloatArray,
    mult: FloatArray,
    drift: FloatArray,
    big_phi: FloatArray,
    sigma: FloatArray,
    with_sigma: bool,
    noise_output: IntArray,
    drift_output: IntArray,
    poses: FloatArray,
    basis: FloatArray,
    post: FloatArray,
    drift_heading: FloatArray,
    coef_heading: FloatArray,
) -> None:  # pragma: no cover
    """``slip_covariance.propagate_terms``'s loop (its ``_cycle`` each cycle): fills ``poses``
    (n, 3), ``basis`` (n, T, 3, 3), ``post`` (n, 3, 3), ``drift_heading`` (n, 4) and
    ``coef_heading`` (n, 24) from the body motion per cycle and its multipliers."""
    n = fwd.size
    nw = noise_output.size
    k = big_phi.shape[1]
    white = np.zeros((nw, 3, 3))
    jd = np.zeros((drift_output.size, 3))
    jac = np.zeros((3, 3 * k))
    tmp = np.zeros((3, 3))
    g = np.zeros((3, 3))
    sj = np.zeros((3, 3 * k))
    x, y, h = start[0], start[1], start[2]
    if n:
        poses[0, 0], poses[0, 1], poses[0, 2] = x, y, h
    for i in range(1, n):
        m = h + 0.5 * dth[i]
        c = math.cos(m)
        s = math.sin(m)
        dx = fwd[i] * c - lat[i] * s
        dy = fwd[i] * s + lat[i] * c
        # G's columns: the forward, lateral and heading motion's effect on the pose
        g[0, 0], g[0, 1], g[0, 2] = c, -s, -0.5 * dy
        g[1, 0], g[1, 1], g[1, 2] = s, c, 0.5 * dx
        g[2, 0], g[2, 1], g[2, 2] = 0.0, 0.0, 1.0
        for w in range(nw):
            _white_step(white[w], tmp, g, dx, dy, noise_output[w], mult[i, w])
            for a in range(3):
                for b in range(3):
                    basis[i, w, a, b] = white[w, a, b]
        for r in range(drift_output.size):  # d(pose) / d(drift rate): F jd + drift G's column
            col = drift_output[r]
            j0 = jd[r, 0] - dy * jd[r, 2] + drift[i, r] * g[0, col]
            j1 = jd[r, 1] + dx * jd[r, 2] + drift[i, r] * g[1, col]
            jd[r, 0], jd[r, 1] = j0, j1
            jd[r, 2] += drift[i, r] * g[2, col]
            for a in range(3):
                for b in range(3):
                    basis[i, nw + r, a, b] = jd[r, a] * jd[r, b]
            drift_heading[i, r] = jd[r, 2]
        if with_sigma:
            _posterior_step(jac, sj, g, dx, dy, big_phi[i], sigma, post[i])
            for q in range(3 * k):
                coef_heading[i, q] = jac[2, q]
        x += dx
        y += dy
        h += dth[i]
        poses[i, 0], poses[i, 1], poses[i, 2] = x, y, h


@njit(cache=True)
def second_order(
    white: FloatArray,
    u: FloatArray,
    v: FloatArray,
    s: FloatArray,
    half: FloatArray,
    a: FloatArray,
    out: FloatArray,
    cross: FloatArray,
) -> None:  # pragma: no cover
    """``SlipPropagation._second_order``'s loop: per cycle ``j + 1`` the heading's share of the
    position block (``out``, n x 2 x 2), summed over the pairs of steps so far, and of the
    position's covariance with the heading (``cross``, n x 2); ``white`` (n,), ``u``, ``v``
    (n, 28), ``s``, ``half`` (n - 1,), ``a`` (n - 1, 2) as there."""
    n = out.shape[0]
    nu = u.shape[1]
    f = np.zeros(n)
    gg = np.zeros(n)
    # cb[k]: the covariance of step k's heading with the heading at the cycle in hand; each
    # iteration's cross term leaves it for the next cycle, so each pair's product is made once
    cb = np.zeros(n)
    acc = np.zeros((2, 2))
    for j in range(n - 1):
        c = white[j]
        for q in range(nu):
            c += u[j, q] * v[j, q]
        cb[j] = c
        fa0 = fa1 = ga0 = ga1 = 0.0
        for k in range(j + 1):
            m = -0.5 * (s[k] + s[j])
            up = math.exp(m + cb[k])
            down = math.exp(m - cb[k])
            f[k] = 0.5 * (up + down) - half[k] - half[j] + 1.0
            gg[k] = 0.5 * (up - down) - cb[k]
            # along the steps and across them (the steps turned left by 90 degrees)
            fa0 += f[k] * a[k, 0]
            fa1 += f[k] * a[k, 1]
            ga0 += gg[k] * -a[k, 1]
            ga1 += gg[k] * a[k, 0]
        a0, a1 = a[j, 0], a[j, 1]
        p0, p1 = -a1, a0
        fj, gj = f[j], gg[j]
        acc[0, 0] += 2.0 * fa0 * a0 - fj * a0 * a0 + 2.0 * ga0 * p0 - gj * p0 * p0
        acc[0, 1] += fa0 * a1 + a0 * fa1 - fj * a0 * a1 + ga0 * p1 + p0 * ga1 - gj * p0 * p1
        acc[1, 1] += 2.0 * fa1 * a1 - fj * a1 * a1 + 2.0 * ga1 * p1 - gj * p1 * p1
        acc[1, 0] = acc[0, 1]
        out[j + 1, 0, 0] = acc[0, 0]
        out[j + 1, 0, 1] = acc[0, 1]
        out[j + 1, 1, 0] = acc[1, 0]
        out[j + 1, 1, 1] = acc[1, 1]
        x0 = x1 = 0.0
        for k in range(j + 1):
            c = white[k]
            for q in range(nu):
                c += u[k, q] * v[j + 1, q]
            cb[k] = c
            w = (half[k] - 1.0) * c
            x0 += w * -a[k, 1]
            x1 += w * a[k, 0]
        cross[j + 1, 0] = x0
        cross[j + 1, 1] = x1
