"""Fit the slip model (:mod:`odolab.models.slip`) by Bayesian linear regression.

Each run with ground truth is cut into windows of :data:`WINDOW_S` seconds. Over a window from
sample i to j the ground truth's displacement in its start frame, minus what the differential
drive of the ``[robot]`` table predicts, is linear in the slip coefficients when each cycle's
motion is turned by the ground truth's own heading (mid-cycle, relative to the window's start)::

    R(-g_i) (q_j - q_i) - sum_k R(m_k) (ds_k, 0)   =  sum_k dt_k R(m_k) (phi_k . beta_fwd,
                                                                        phi_k . beta_lat)
    (g_j - g_i) - sum_k dtheta_k                   =  sum_k dt_k phi_k . beta_yaw

(``phi_k`` the basis at cycle k's measured speeds). The forward and lateral coefficients are
fitted together on the x and y rows, the yaw ones on the heading rows; each with a Gaussian prior
``beta ~ N(0, tau^2)`` per coefficient, ``tau`` the size of a slip as large as the robot's typical
speed (``rms(v) / rms(phi_j)``: a weak prior that keeps the fit finite on a few seconds of data),
and a Gaussian noise whose variance is found by expectation-maximisation. The posterior is closed
form (``Sigma = (X^T X / s^2 + T^-1)^-1``, ``mu = Sigma X^T y / s^2``); the noise variance per
window of ``T`` seconds becomes the model's white body-velocity noise ``q = s^2 / T``.

The ground truth's yaw offset is not fitted (its frame is taken as the robot's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.errors import InsufficientDataError
from odolab.models.slip import FEATURES, SlipModel
from odolab.params import RobotParams

__all__ = ["WINDOW_S", "SlipDesign", "fit_slip_model", "slip_design"]

FloatArray = NDArray[np.float64]
#: Length of a regression window (s).
WINDOW_S = 0.5
_EM_ITERATIONS = 30


@dataclass(frozen=True)
class SlipDesign:
    """The regression of one or more runs: x/y rows (16 columns: fwd then lat coefficients),
    heading rows (8 columns), and the windows' durations."""

    a_xy: FloatArray
    y_xy: FloatArray
    a_yaw: FloatArray
    y_yaw: FloatArray
    durations: FloatArray
    v_rms: float
    w_rms: float
    phi_rms: FloatArray


def slip_design(
    runs: Sequence[object], nominal: RobotParams, window_s: float = WINDOW_S
) -> SlipDesign:
    """The regression rows of prepared runs (:class:`odolab.calibration.lsq.PreparedRun`)."""
    axy, yxy, ayaw, yyaw, dur = [], [], [], [], []
    v_sq, w_sq, n_steps = 0.0, 0.0, 0
    phi_sq = np.zeros(len(FEATURES))
    b = nominal.track_width
    for run in runs:
        t = np.asarray(run.t, dtype=np.float64)  # type: ignore[attr-defined]
        dsl = np.asarray(run.dticks_left) * nominal.left_metres_per_tick  # type: ignore[attr-defined]
        dsr = np.asarray(run.dticks_right) * nominal.right_metres_per_tick  # type: ignore[attr-defined]
        gx = np.asarray(run.gt_x, dtype=np.float64)  # type: ignore[attr-defined]
        gy = np.asarray(run.gt_y, dtype=np.float64)  # type: ignore[attr-defined]
        gh = np.unwrap(np.asarray(run.gt_heading, dtype=np.float64))  # type: ignore[attr-defined]
        n = t.size
        if n < 2:
            continue
        dt = np.diff(t, prepend=t[0])
        ds = 0.5 * (dsl + dsr)
        dth = (dsr - dsl) / b
        ds[0] = dth[0] = 0.0
        timed = dt > 0
        tt = np.where(timed, dt, 1.0)
        phi = SlipModel.features(ds / tt, dth / tt)
        phi[4:, ~timed] = 0.0
        phi[:, 0] = 0.0
        big_phi = phi * tt[None, :]  # dt * phi, (8, n)
        v_sq += float(np.sum((ds / tt)[timed] ** 2))
        w_sq += float(np.sum((dth / tt)[timed] ** 2))
        phi_sq += np.sum(phi[:, timed] ** 2, axis=1)
        n_steps += int(timed.sum())
        a = np.empty(n)  # absolute mid-cycle heading of the ground truth
        a[0] = gh[0]
        a[1:] = 0.5 * (gh[1:] + gh[:-1])
        ca, sa = np.cos(a), np.sin(a)
        # world-frame running sums: commanded motion, and the regressors of fwd and lat
        cum = _cumulative
        cx, cy = cum(ca * ds), cum(sa * ds)
        fxx, fxy = cum(ca * big_phi), cum(sa * big_phi)  # fwd: (cos, sin) * Phi
        cth = cum(dth)
        cphi = cum(big_phi)
        edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + window_s, window_s)))
        edges = edges[edges < n]
        if edges[-1] != n - 1:
            edges = np.append(edges, n - 1)
        i, j = edges[:-1], edges[1:]

        def s(c: FloatArray, i: NDArray[np.int64] = i, j: NDArray[np.int64] = j) -> FloatArray:
            return _window_sum(c, i, j)  # sums over cycles i+1..j

        c0, s0 = np.cos(gh[i]), np.sin(gh[i])
        px, py = s(cx), s(cy)
        ex, ey = gx[j] - gx[i] - px, gy[j] - gy[i] - py  # world frame
        # into the window's start frame
        yx = c0 * ex + s0 * ey
        yy = -s0 * ex + c0 * ey
        wx_f, wy_f = s(fxx), s(fxy)  # world-frame regressors of beta_fwd: (8, m)
        # beta_lat moves the body left: world (-sin, cos) * Phi
        wx_l, wy_l = -wy_f, wx_f
        rx_f = c0 * wx_f + s0 * wy_f
        ry_f = -s0 * wx_f + c0 * wy_f
        rx_l = c0 * wx_l + s0 * wy_l
        ry_l = -s0 * wx_l + c0 * wy_l
        axy.append(np.vstack((np.hstack((rx_f.T, rx_l.T)), np.hstack((ry_f.T, ry_l.T)))))
        yxy.append(np.concatenate((yx, yy)))
        ayaw.append(s(cphi).T)
        yyaw.append((gh[j] - gh[i]) - s(cth))
        dur.append(t[j] - t[i])
    if not axy or n_steps == 0:
        raise InsufficientDataError("no motion with ground truth to fit the slip model on")
    return SlipDesign(
        np.vstack(axy),
        np.concatenate(yxy),
        np.vstack(ayaw),
        np.concatenate(yyaw),
        np.concatenate(dur),
        float(np.sqrt(v_sq / n_steps)),
        float(np.sqrt(w_sq / n_steps)),
        np.sqrt(phi_sq / n_steps),
    )


def _cumulative(v: FloatArray) -> FloatArray:
    """Running sums along the last axis with a leading 0: ``out[k] = sum(v[..., :k])``."""
    zero = np.zeros((*v.shape[:-1], 1))
    return np.asarray(np.concatenate((zero, np.cumsum(v, axis=-1)), axis=-1), dtype=np.float64)


def _window_sum(c: FloatArray, i: NDArray[np.int64], j: NDArray[np.int64]) -> FloatArray:
    """Sums over cycles ``i+1 .. j`` of running sums ``c`` (see :func:`_cumulative`)."""
    return np.asarray(c[..., j + 1] - c[..., i + 1], dtype=np.float64)


def _blr(x: FloatArray, y: FloatArray, tau: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """Posterior mean, covariance and noise variance (EM) of ``y = X beta + e``,
    ``beta ~ N(0, diag(tau^2))``, ``e ~ N(0, s2)``."""
    n = y.size
    prior = 1.0 / tau**2
    xtx = x.T @ x
    xty = x.T @ y
    s2 = max(float(np.mean(y**2)), 1e-18)
    mu = np.zeros(x.shape[1])
    sigma: FloatArray = np.diag(tau**2)
    for _ in range(_EM_ITERATIONS):
        sigma = np.asarray(np.linalg.inv(xtx / s2 + np.diag(prior)), dtype=np.float64)
        mu = sigma @ xty / s2
        r = y - x @ mu
        s2 = max(float(r @ r + np.trace(xtx @ sigma)) / n, 1e-18)
    return mu, sigma, s2


def fit_slip_model(
    runs: Sequence[object],
    nominal: RobotParams,
    *,
    window_s: float = WINDOW_S,
    prior_scale: float = 1.0,
) -> tuple[SlipModel, FloatArray, int]:
    """The slip model of prepared runs: (model with its posterior, 24 x 24 posterior
    covariance in :attr:`SlipModel.COEF_KEYS` order, number of windows)."""
    d = slip_design(runs, nominal, window_s)
    k = len(FEATURES)
    if d.y_yaw.size < 2:
        raise InsufficientDataError(
            f"{d.y_yaw.size} window of {window_s:g} s for the slip model; expected longer runs"
        )
    phi_rms = np.where(d.phi_rms > 0, d.phi_rms, 1.0)
    tau_v = prior_scale * max(d.v_rms, 1e-3) / phi_rms
    tau_w = prior_scale * max(d.w_rms, 1e-3) / phi_rms
    mu_xy, sig_xy, s2_xy = _blr(d.a_xy, d.y_xy, np.concatenate((tau_v, tau_v)))
    mu_yaw, sig_yaw, s2_yaw = _blr(d.a_yaw, d.y_yaw, tau_w)
    cov = np.zeros((3 * k, 3 * k))
    cov[: 2 * k, : 2 * k] = sig_xy
    cov[2 * k :, 2 * k :] = sig_yaw
    beta = np.concatenate((mu_xy, mu_yaw))
    mean_t = float(np.mean(d.durations)) if d.durations.size else window_s
    limit = SlipModel.LIMIT
    values = {
        key: float(np.clip(v, -limit, limit))
        for key, v in zip(SlipModel.COEF_KEYS, beta, strict=True)
    }
    model = SlipModel(
        **values,
        q_fwd=s2_xy / mean_t,
        q_lat=s2_xy / mean_t,
        q_yaw=s2_yaw / mean_t,
        posterior=tuple(cov.ravel().tolist()),
    )
    return model, cov, int(d.y_yaw.size)
