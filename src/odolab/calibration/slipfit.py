"""Fit the slip model (:mod:`odolab.core.models.slip`) by Bayesian linear regression.

Each run with ground truth is cut into windows of :data:`WINDOW_S` seconds. Over a window from
sample i to j the ground truth's displacement in its start frame, minus what the differential
drive of the ``[robot]`` table predicts, is linear in the slip coefficients when each cycle's
motion is turned by the ground truth's own heading (mid-cycle, relative to the window's start)::

    R(-g_i) (q_j - q_i) - sum_k R(m_k) (ds_k, 0)   =  sum_k dt_k R(m_k) (phi_k . beta_fwd,
                                                                        phi_k . beta_lat)
    (g_j - g_i) - sum_k dtheta_k                   =  sum_k dt_k phi_k . beta_yaw

(``phi_k`` the basis at cycle k's measured speeds). As DRIVE does, the fit keeps the windows in
steady state (:func:`_steady`: the measured speed and turn rate settled for :data:`SETTLE_S`
seconds before the window and through it), where the slip is a function of the speeds: after a
change of command the body lags the tracks (its inertia), which no function of the speeds
describes (with fewer than :data:`STEADY_SHARE` of the windows steady, all are kept). The
forward and lateral coefficients are
fitted together on the x and y rows, the yaw ones on the heading rows; each with a Gaussian prior
``beta ~ N(beta_0, tau^2)`` per coefficient. Its centre ``beta_0`` is the kinematic model fitted
to the same runs (:func:`odolab.calibration.lsq.kinematic_base`: the ICR model, else the extended one, else the
differential drive, as slip coefficients of degree one, :func:`base_coefficients`), so what the
runs do not determine stays with that model; ``tau`` the size of a slip as large as the robot's
typical speed (``rms(v) / rms(phi_j)``: a weak prior that keeps the fit finite on a few seconds),
and a Gaussian noise whose variance grows with the window's duration ``T``, its track travel
``L`` (m) and (heading rows) its commanded turn ``A`` (rad): ``q T + k L`` (x, y) and
``q T + k A`` (heading), the form of the lab's wheel noise and turn scrub; ``q`` and ``k`` are
found by expectation-maximisation. The posterior is closed form
(``Sigma = (X^T W X + T^-1)^-1``, ``mu = Sigma X^T W y``, ``W`` the inverse noise variances).
Every coefficient's prior variance is found the same way, no larger than ``tau^2`` (automatic
relevance determination: a term the data do not support shrinks back to the kinematic model's
value, so on a robot whose slip does not change with speed the model stays that model). The commanded turn ``A`` is taken over a few cycles (:meth:`SlipModel.noise_multipliers`:
on a straight drive the encoders' last counts flicker between the sides, a turn that is not).

The predictive noise per cycle (the model's ``q_*``, ``k_*``: :data:`NOISE_TERMS`) is then
fitted where it is used: on pieces of :data:`NOISE_PIECE_S` seconds, each started at the ground
truth's pose, the pose covariance :func:`propagate_covariance` gives the piece's end (linear in
the six terms, plus the coefficients' posterior) is made to explain the end errors by maximum
likelihood (:func:`fit_noise`). The errors are those of a model fitted without the piece: each
run is cut into :data:`NOISE_FOLDS` parts and each part is predicted by the model fitted on the
others, so the variance covers the model's own error on new data as well as the noise.

The ground truth is a measurement with noise of its own (:mod:`odolab.metrics.truthnoise`:
estimated from its real updates, or given): the rows of a window difference the truth at its two
ends, and neighbouring windows share one end, so the rows' noise is the model's (diagonal) plus
the truth's (:func:`truth_covariances`, banded), and the regression weighs the rows by the
inverse of the whole (generalised least squares; expectation-maximisation finds the model's part
as what the truth's does not explain).

The ground truth's yaw offset is not fitted (its frame is taken as the robot's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

from odolab.calibration.slipfilter import FilterFit, run_cycles
from odolab.core.arrays import FloatArray
from odolab.core.errors import InsufficientDataError
from odolab.core.models.slip import FEATURES, SlipModel
from odolab.core.params import RobotParams
from odolab.core.slip_uncertainty import (
    HEADING_TERMS,
    TERMS,
    EndPairs,
    end_second_order,
    propagate_covariance,
    propagate_terms,
    terms_of,
)
from odolab.metrics.truthnoise import TruthNoise, material, piece_covariance

__all__ = [
    "UNDETERMINED_SPREAD",
    "WINDOW_S",
    "SlipDesign",
    "endpoint_error",
    "estimator_note",
    "filtered",
    "first_seconds",
    "fit_slip_model",
    "nees_bounds",
    "nees_pieces",
    "propagate_covariance",
    "slip_design",
    "steady_cycles",
    "undetermined",
]

#: Length of a regression window (s).
WINDOW_S = 0.5
_EM_ITERATIONS = 30
#: Steady state (:func:`_steady`): speeds averaged over this many cycles, varying by no more than
#: these (m/s, rad/s) over a window and the seconds before it
SETTLE_CYCLES = 5
STEADY_V = 0.2
STEADY_W = 0.4
SETTLE_S = 0.3
#: A fit keeps only the windows in steady state when at least this share of them is (else all)
STEADY_SHARE = 0.25
#: The kinematic models the slip model's prior is centred on, in order of preference: the first
#: that can be fitted to the runs (see :func:`odolab.calibration.lsq.kinematic_base`)
BASE_MODELS = ("icr", "extended", "diff")
#: Lengths (s) of the pieces the variance terms are fitted on, together.
NOISE_PIECE_S: tuple[float, ...] = (1.0, 3.0)
#: At most this many pieces of each length are fitted on (evenly spread over the runs): ten
#: terms need no more, and the second-order share costs memory as the square of a piece's cycles.
NOISE_PIECES_MAX = 400
#: Parts a run is cut into to fit the noise terms on data the coefficients were not fitted on.
NOISE_FOLDS = 4
#: A slip coefficient is *not determined* by the runs when its standard error moves the body
#: by more than this share of the runs' typical speed (forward and lateral terms) or turn
#: rate (yaw terms): its posterior standard deviation over the weak prior's ``tau``, which is
#: a coefficient as large as the typical speed (module doc). Measured (issue 38, item 11):
#: median share 0.44 (all 24 above) after the documented 12 s exploration, 0.04 after 30 s,
#: 0.02 after 60 s, 0.03 on the DRIVE Husky's 289 windows.
UNDETERMINED_SPREAD = 0.1
#: Degrees of freedom of the rows' Student-t noise in the regression (None: Gaussian); see
#: docs/models.md for what each measured.
ROBUST_NU: float | None = None
#: Shrinkage toward the kinematic centre (:func:`_shrinkage`): each coefficient group's (x/y,
#: heading) weak-prior scale is one of these multiples of ``tau`` (0: the kinematic model
#: itself), chosen by grouped K-fold cross-validation over contiguous blocks of the fitting
#: windows (:data:`SHRINK_FOLDS`); None (the default): no choice, the weak prior. Off because
#: measured worse (docs/models.md, benchmarks/bench_truth_noise.py --shrink): the windows'
#: held-out squared residuals are dominated by the truth's noise and do not rank the fits as
#: their end points do.
SHRINK_GRID_MEASURED: tuple[float, ...] = (0.0, 0.03, 0.1, 0.3, 1.0)
SHRINK_GRID: tuple[float, ...] | None = None
SHRINK_FOLDS = 5
#: Length (s) of the held-out pieces the shrinkage's cross-validation scores (:func:`_shrinkage`)
SHRINK_PIECE_S = 4.0


@dataclass(frozen=True, eq=False)
class _Windows:
    """The regression rows of windows, of one run (:class:`_RunRows`) or of all of a design's
    (:class:`SlipDesign`): x/y rows (16 columns: fwd then lat coefficients), heading rows (8
    columns), and the windows' durations."""

    a_xy: FloatArray
    y_xy: FloatArray
    a_yaw: FloatArray
    y_yaw: FloatArray
    durations: FloatArray
    #: per window: track travel (m, mean of |ds_l| and |ds_r|) and commanded turn (rad, |dtheta|)
    travel: FloatArray
    turn: FloatArray


@dataclass(frozen=True)
class SlipDesign(_Windows):
    """The regression of one or more runs (:class:`_Windows`: the rows and the windows'
    durations), with the speeds' and features' root mean squares over the timed cycles."""

    v_rms: float
    w_rms: float
    phi_rms: FloatArray
    #: windows the runs were cut into, before any was left out for not being in steady state
    windows_seen: int = 0
    #: per window: its x and y rows in ``a_xy`` (its heading row is its own index), the window
    #: before it when that one ends where it starts (-1: none; the two share a ground-truth
    #: pose, so its noise enters both), the truth's heading change from that window's start to
    #: this one's (rad), and the truth's displacement over the window in its start frame (m)
    row_x: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    row_y: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    previous: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    turn_from_previous: FloatArray = field(default_factory=lambda: np.zeros(0))
    shift: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))


def _steady(
    t: FloatArray, v: FloatArray, w: FloatArray, i: NDArray[np.int64], j: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """Which windows (cycles ``i+1 .. j``) are in steady state: the measured speed and turn rate
    (averaged over :data:`SETTLE_CYCLES` cycles) vary by no more than :data:`STEADY_V` m/s and
    :data:`STEADY_W` rad/s over the window and the :data:`SETTLE_S` seconds before it."""
    from scipy.ndimage import uniform_filter1d

    if i.size == 0:
        return np.ones(0, dtype=bool)
    vs = uniform_filter1d(v, SETTLE_CYCLES, mode="nearest")
    ws = uniform_filter1d(w, SETTLE_CYCLES, mode="nearest")
    first = np.searchsorted(t, t[i] - SETTLE_S)
    vmax, vmin, wmax, wmin = vs[j], vs[j], ws[j], ws[j]
    for o in range(1, int(np.max(j - first)) + 1):  # each window's samples, from its end back
        k = np.maximum(j - o, 0)
        inside = j - o >= first
        vmax = np.where(inside, np.maximum(vmax, vs[k]), vmax)
        vmin = np.where(inside, np.minimum(vmin, vs[k]), vmin)
        wmax = np.where(inside, np.maximum(wmax, ws[k]), wmax)
        wmin = np.where(inside, np.minimum(wmin, ws[k]), wmin)
    return np.asarray(((vmax - vmin) <= STEADY_V) & ((wmax - wmin) <= STEADY_W))


def steady_cycles(t: FloatArray, v: FloatArray, w: FloatArray) -> NDArray[np.bool_]:
    """Per cycle: :func:`_steady`'s rule for a window of that one cycle (the Kalman filter's,
    :mod:`odolab.calibration.slipfilter`)."""
    k = np.arange(t.size)
    return _steady(t, v, w, np.maximum(k - 1, 0), k)


def slip_design(
    runs: Sequence[object],
    nominal: RobotParams,
    window_s: float = WINDOW_S,
    *,
    steady: bool = False,
    memo: RowsMemo | None = None,
) -> SlipDesign:
    """The regression rows of prepared runs (:class:`odolab.calibration.lsq.PreparedRun`);
    ``steady``: only the windows in steady state (:func:`_steady`). ``memo``: each run's rows
    kept for the next design of the same runs with the same nominal parameters (a fit's
    cross-fitting folds share their parts: :func:`fit_slip_model`)."""

    def rows_of(run: object) -> _RunRows | None:
        if memo is None:
            rows = _run_rows(run, nominal, window_s)
        else:
            key = (id(run), window_s)
            kept = memo.get(key)
            if kept is None or kept[0] is not run:  # (an id is reused only once its run is gone)
                kept = memo[key] = (run, _run_rows(run, nominal, window_s))
            rows = kept[1]
        return rows.only(rows.steady) if steady and rows is not None else rows

    parts = [p for p in map(rows_of, runs) if p is not None]
    n_steps = sum(p.steps for p in parts)
    full = [p for p in parts if p.durations.size]
    if not full or n_steps == 0:
        raise InsufficientDataError("no motion with ground truth to fit the slip model on")
    row_x, row_y, previous = [], [], []
    rows = wins = 0
    for p in full:  # each run's x rows, then its y rows; windows in order
        m = p.durations.size
        row_x.append(rows + np.arange(m))
        row_y.append(rows + m + np.arange(m))
        previous.append(np.where(p.chained, wins + np.arange(m) - 1, -1))
        rows += 2 * m
        wins += m

    def cat(name: str) -> FloatArray:
        return np.concatenate([getattr(p, name) for p in full])

    return SlipDesign(
        np.vstack([p.a_xy for p in full]),
        cat("y_xy"),
        np.vstack([p.a_yaw for p in full]),
        cat("y_yaw"),
        cat("durations"),
        cat("travel"),
        cat("turn"),
        float(np.sqrt(sum(p.v_sq for p in parts) / n_steps)),
        float(np.sqrt(sum(p.w_sq for p in parts) / n_steps)),
        np.sqrt(sum((p.phi_sq for p in parts), np.zeros(len(FEATURES))) / n_steps),
        sum(p.seen for p in parts),
        np.concatenate(row_x),
        np.concatenate(row_y),
        np.concatenate(previous),
        cat("turn_from_previous"),
        np.vstack([p.shift for p in full]),
    )


#: :func:`slip_design`'s rows of each run, by the run's id and window
RowsMemo = dict[tuple[int, float], tuple[object, "_RunRows | None"]]
#: :class:`_RunRows`' arrays of one entry a window (``a_xy`` and ``y_xy`` have two: x, then y)
_PER_WINDOW = (
    "a_yaw",
    "y_yaw",
    "durations",
    "travel",
    "turn",
    "shift",
    "start",
    "stop",
    "heading",
    "steady",
)


@dataclass(frozen=True, eq=False)
class _RunRows(_Windows):
    """One run's windows in :func:`slip_design` (see :class:`SlipDesign`; ``chained`` and
    ``turn_from_previous`` follow from each window's ``start``, ``stop`` and ``heading``), and the
    run's sums of squared speeds, turn
    rates and features over its ``steps`` timed cycles; ``seen`` windows before the steady
    ones were kept."""

    shift: FloatArray
    v_sq: float
    w_sq: float
    phi_sq: FloatArray
    steps: int
    seen: int
    #: per window: its first and last cycle, the truth's heading at its start, and whether it
    #: is in steady state (:func:`_steady`)
    start: NDArray[np.int64]
    stop: NDArray[np.int64]
    heading: FloatArray
    steady: NDArray[np.bool_]

    @property
    def chained(self) -> NDArray[np.bool_]:
        """Per window: whether it starts where the one before it ended."""
        return np.concatenate(([False], self.start[1:] == self.stop[:-1]))[: self.start.size]

    @property
    def turn_from_previous(self) -> FloatArray:
        """Per window: the truth's heading change from the previous window's start (rad)."""
        h = self.heading
        return np.concatenate(([0.0], h[1:] - h[:-1]))[: h.size]

    def only(self, keep: NDArray[np.bool_]) -> _RunRows:
        """The windows ``keep`` says, as if the run had been cut into those alone."""
        both = np.concatenate((keep, keep))  # the x rows, then the y rows
        cut = {name: getattr(self, name)[keep] for name in _PER_WINDOW}
        return replace(self, a_xy=self.a_xy[both], y_xy=self.y_xy[both], **cut)


def _run_rows(run: object, nominal: RobotParams, window_s: float) -> _RunRows | None:
    """The regression rows of one prepared run (None: fewer than two samples)."""
    c = run_cycles(run, nominal)
    if c is None:
        return None
    t, gx, gy, gh = c.t, c.gx, c.gy, c.gh
    ds, dth, timed, tt, phi = c.ds, c.dth, c.timed, c.tt, c.phi
    n = t.size
    big_phi = phi * tt[None, :]  # dt * phi, (8, n)
    stats = {
        "v_sq": float(np.sum((ds / tt)[timed] ** 2)),
        "w_sq": float(np.sum((dth / tt)[timed] ** 2)),
        "phi_sq": np.sum(phi[:, timed] ** 2, axis=1),
        "steps": int(timed.sum()),
    }
    a = np.empty(n)  # absolute mid-cycle heading of the ground truth
    a[0] = gh[0]
    a[1:] = 0.5 * (gh[1:] + gh[:-1])
    ca, sa = np.cos(a), np.sin(a)
    # world-frame running sums: commanded motion, and the regressors of fwd and lat
    cum = _cumulative
    mult = c.mult
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + window_s, window_s)))
    edges = edges[edges < n]
    if edges[-1] != n - 1:
        edges = np.append(edges, n - 1)
    i, j = edges[:-1], edges[1:]
    seen = int(i.size)

    def s(c: FloatArray) -> FloatArray:
        return _window_sum(c, i, j)  # sums over cycles i+1..j

    c0, s0 = np.cos(gh[i]), np.sin(gh[i])
    dxw, dyw = gx[j] - gx[i], gy[j] - gy[i]
    ex, ey = dxw - s(cum(ca * ds)), dyw - s(cum(sa * ds))  # world frame
    wx_f, wy_f = s(cum(ca * big_phi)), s(cum(sa * big_phi))  # regressors of beta_fwd: (8, m)
    wx_l, wy_l = -wy_f, wx_f  # beta_lat moves the body left: world (-sin, cos) * Phi
    # into the window's start frame
    rx_f, ry_f = c0 * wx_f + s0 * wy_f, -s0 * wx_f + c0 * wy_f
    rx_l, ry_l = c0 * wx_l + s0 * wy_l, -s0 * wx_l + c0 * wy_l
    return _RunRows(
        np.vstack((np.hstack((rx_f.T, rx_l.T)), np.hstack((ry_f.T, ry_l.T)))),
        np.concatenate((c0 * ex + s0 * ey, -s0 * ex + c0 * ey)),
        s(cum(big_phi)).T,
        (gh[j] - gh[i]) - s(cum(dth)),
        t[j] - t[i],
        s(cum(mult[:, 3])),
        s(cum(mult[:, 5])),
        np.column_stack((c0 * dxw + s0 * dyw, -s0 * dxw + c0 * dyw)),
        seen=seen,
        start=i,
        stop=j,
        heading=gh[i],
        steady=_steady(t, ds / tt, dth / tt, i, j),
        **stats,
    )


def _cumulative(v: FloatArray) -> FloatArray:
    """Running sums along the last axis with a leading 0: ``out[k] = sum(v[..., :k])``."""
    zero = np.zeros((*v.shape[:-1], 1))
    return np.asarray(np.concatenate((zero, np.cumsum(v, axis=-1)), axis=-1), dtype=np.float64)


def _window_sum(c: FloatArray, i: NDArray[np.int64], j: NDArray[np.int64]) -> FloatArray:
    """Sums over cycles ``i+1 .. j`` of running sums ``c`` (see :func:`_cumulative`)."""
    return np.asarray(c[..., j + 1] - c[..., i + 1], dtype=np.float64)


def _blr(
    x: FloatArray,
    y: FloatArray,
    tau: FloatArray,
    scales: FloatArray,
    mean: FloatArray | None = None,
    known: object | None = None,
    iterations: int = _EM_ITERATIONS,
    weak: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Posterior mean and covariance of ``y = X beta + e``, ``beta ~ N(mean, diag(tau^2))``
    (``mean`` 0 unless given), with a noise variance per row linear in ``scales`` (n, m):
    ``var_i = scales_i . c``, ``c >= 0`` found by expectation-maximisation (non-negative least
    squares of the expected squared residuals). ``known``: a known noise covariance of the rows
    added to that (a sparse (n, n) matrix: the ground truth's noise, which rows that share a
    truth pose share); the rows are then weighted by the whole covariance's inverse
    (generalised least squares) and ``c`` explains what the known part does not.
    The coefficients' prior variances are found the
    same way, no larger than ``tau^2`` (automatic relevance determination); the covariance returned is the weak prior's posterior at the
    final noise (what the data say of each coefficient, not what the shrinkage assumed).
    Returns (mean, covariance, c)."""
    from scipy.optimize import nnls

    m0 = np.zeros(x.shape[1]) if mean is None else np.asarray(mean, dtype=np.float64)
    prior = np.diag(1.0 / tau**2)
    c = np.full(scales.shape[1], 0.0)
    r0 = y - x @ m0
    k_diag = np.zeros(y.size) if known is None else np.asarray(known.diagonal())  # type: ignore[attr-defined]
    c[0] = max(
        float(np.mean(np.maximum(r0**2 - k_diag, 0.1 * r0**2)))
        / max(float(np.mean(scales[:, 0])), 1e-12),
        1e-18,
    )
    floor = 1e-18 * max(float(np.mean(r0**2)), 1e-30)
    mu = m0.copy()
    sigma: FloatArray = np.diag(tau**2)
    u = np.ones(y.size)  # Student-t weights of the rows (1: Gaussian)
    for _ in range(iterations):
        var = np.maximum(scales @ c, floor)
        xtwx, xtwy = _weighted(x, y, var / u, known)
        sigma = np.asarray(np.linalg.inv(xtwx + prior), dtype=np.float64)
        mu = sigma @ (xtwy + prior @ m0)
        r = y - x @ mu
        expected = r**2 + np.einsum("ij,jk,ik->i", x, sigma, x)
        total = var + k_diag
        if ROBUST_NU is not None:  # a row far off its variance weighs less (a scan-match glitch)
            u = (ROBUST_NU + 1.0) / (ROBUST_NU + expected / total)
        # rows weighted by 1/var: each residual counts as one measurement of its variance (less
        # the known part)
        sol, _ = nnls(scales / total[:, None], u * (expected - k_diag) / total)
        # automatic relevance determination: each coefficient's prior variance is what the data
        # say of its distance from the prior mean (no more than the weak prior's), so what the
        # data do not support shrinks back to the prior mean
        t2 = np.minimum((mu - m0) ** 2 + np.diag(sigma), tau**2)
        prior = np.diag(1.0 / np.maximum(t2, 1e-12 * tau**2))
        if not np.any(sol > 0):
            break
        c = sol
    # the uncertainty that is reported: the weak prior's posterior (a coefficient that the
    # relevance determination holds at the prior mean is not known better for that: with the
    # shrunk prior's, a term the runs barely saw came out certain, and wrong)
    var = np.maximum(scales @ c, floor)
    xtwx, _ = _weighted(x, y, var, known)
    w2 = (tau if weak is None else weak) ** 2
    sigma = np.asarray(np.linalg.inv(xtwx + np.diag(1.0 / w2)), dtype=np.float64)
    return mu, sigma, c


def _shrinkage(
    x: FloatArray,
    y: FloatArray,
    tau: FloatArray,
    scales: FloatArray,
    mean: FloatArray,
    known: object | None,
    d: SlipDesign,
    fold: NDArray[np.int64],
) -> float:
    """The multiple of ``tau`` (one of :data:`SHRINK_GRID`) whose fit predicts held-out
    windows best: the windows are split into folds of contiguous windows (``fold``, per window;
    neighbouring command steps are held out together), each fold is predicted by the fit on the
    others (:func:`_blr`, its known row covariance restricted to them), and the residuals of
    chained held-out windows are summed over pieces of :data:`SHRINK_PIECE_S` seconds (turned
    into the piece's start frame for the x/y rows) before they are squared: a piece's truth
    noise is that of its two ends while the model's error grows with its length, so the longer
    pieces rank the fits as end points do. ``x`` the x/y rows when it has :attr:`SlipDesign`'s
    ``row_x`` and ``row_y``, else the heading rows. A tie keeps the larger multiple."""
    if SHRINK_GRID is None or len(SHRINK_GRID) < 2:
        return 1.0
    folds = int(fold.max()) + 1 if fold.size else 0
    if folds < 2:
        return 1.0
    xy = y.size == 2 * fold.size
    win_of_row = np.zeros(y.size, dtype=np.int64)
    if xy:
        win_of_row[d.row_x] = np.arange(fold.size)
        win_of_row[d.row_y] = np.arange(fold.size)
    else:
        win_of_row[:] = np.arange(fold.size)
    per_piece = max(1, round(SHRINK_PIECE_S / max(float(np.median(d.durations)), 1e-9)))
    scores = np.zeros(len(SHRINK_GRID))
    for f in range(folds):
        test_w = np.flatnonzero(fold == f)
        train = fold[win_of_row] != f
        sub = None if known is None else known[train][:, train]  # type: ignore[index]
        for i, mult in enumerate(SHRINK_GRID):
            if mult <= 0.0:
                mu = mean
            else:
                mu, _, _ = _blr(x[train], y[train], tau * mult, scales[train], mean, sub)
            r = y - x @ mu
            res = np.column_stack((r[d.row_x], r[d.row_y])) if xy else r[:, None]
            scores[i] += _piece_score(res, test_w, d, per_piece)
    best = min(range(len(scores)), key=lambda i: (scores[i], -SHRINK_GRID[i]))
    return float(SHRINK_GRID[best])


def _piece_score(res: FloatArray, wins: NDArray[np.int64], d: SlipDesign, per_piece: int) -> float:
    """Sum of squared residuals of pieces of up to ``per_piece`` chained windows among ``wins``
    (``res`` per window: (x, y) in its start frame, turned into the piece's, or heading)."""
    total = 0.0
    acc = np.zeros(res.shape[1])
    count, heading, last = 0, 0.0, -2
    for w in wins.tolist():
        if count == per_piece or d.previous[w] != last or last < 0:
            total += float(acc @ acc)
            acc[:] = 0.0
            count, heading = 0, 0.0
        else:
            heading += float(d.turn_from_previous[w])
        v = res[w]
        if v.size == 2:
            c, s = np.cos(heading), np.sin(heading)
            v = np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])
        acc += v
        count += 1
        last = w
    return total + float(acc @ acc)


def _weighted(
    x: FloatArray, y: FloatArray, var: FloatArray, known: object | None
) -> tuple[FloatArray, FloatArray]:
    """``X^T C^-1 X`` and ``X^T C^-1 y`` for the row covariance ``C = diag(var) + known``."""
    if known is None:
        w = 1.0 / var
        return (x * w[:, None]).T @ x, (x * w[:, None]).T @ y
    from scipy import sparse
    from scipy.sparse.linalg import splu

    cov = (sparse.diags(var) + known).tocsc()
    lu = splu(cov)
    cx = lu.solve(np.ascontiguousarray(x))
    cy = lu.solve(np.ascontiguousarray(y))
    return np.asarray(x.T @ cx, dtype=np.float64), np.asarray(x.T @ cy, dtype=np.float64)


def truth_covariances(d: SlipDesign, noise: TruthNoise) -> tuple[object, object]:
    """The ground truth's noise in the rows of ``d`` (:func:`slip_design`), as sparse
    covariances of the x/y rows and of the heading rows. A window's rows difference the truth's
    poses at its two ends, so each row has the noise of both (``2 sigma^2``), and a window that
    starts where the one before it ended shares that pose: its noise enters both with opposite
    signs (``-sigma^2``, the position's turned by the heading change between the two windows'
    start frames). The truth's heading noise also turns each cycle's motion (the rows rotate
    it by the truth's own heading): ``sigma_h^2 L^2 min(1, dt / T)`` across the window's
    displacement (``L`` its length, ``T`` its duration, ``dt`` the truth's update spacing: the
    updates within a window are independent)."""
    from scipy import sparse

    n_xy, n_yaw = d.y_xy.size, d.y_yaw.size
    sp, sh = noise.xy**2, noise.yaw**2
    rows: list[NDArray[np.int64]] = []
    cols: list[NDArray[np.int64]] = []
    vals: list[FloatArray] = []

    def put(a: NDArray[np.int64], b: NDArray[np.int64], v: FloatArray) -> None:
        rows.append(a)
        cols.append(b)
        vals.append(np.broadcast_to(v, a.shape).astype(np.float64))

    length = np.hypot(d.shift[:, 0], d.shift[:, 1])
    share = np.minimum(1.0, noise.spacing / np.maximum(d.durations, 1e-9)) if noise.spacing else 1.0
    across = sh * length**2 * share
    unit = d.shift / np.maximum(length, 1e-12)[:, None]
    px, py = -unit[:, 1], unit[:, 0]  # across the displacement
    put(d.row_x, d.row_x, 2 * sp + across * px * px)
    put(d.row_y, d.row_y, 2 * sp + across * py * py)
    put(d.row_x, d.row_y, across * px * py)
    put(d.row_y, d.row_x, across * px * py)
    w = np.flatnonzero(d.previous >= 0)
    p = d.previous[w]
    cd, sd = np.cos(d.turn_from_previous[w]), np.sin(d.turn_from_previous[w])
    # the shared pose's noise n: -R(-h_p) n in the earlier window's rows (its end), R(-h_w) n in
    # this one's (its start): covariance -sigma^2 R(h_w - h_p)
    for a, b, v in (
        (d.row_x[p], d.row_x[w], -sp * cd),
        (d.row_x[p], d.row_y[w], sp * sd),
        (d.row_y[p], d.row_x[w], -sp * sd),
        (d.row_y[p], d.row_y[w], -sp * cd),
    ):
        put(a, b, v)
        put(b, a, v)
    k_xy = sparse.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n_xy, n_xy)
    ).tocsc()
    idx = np.arange(n_yaw)
    k_yaw = sparse.coo_matrix(
        (
            np.concatenate((np.full(n_yaw, 2 * sh), np.full(2 * w.size, -sh))),
            (np.concatenate((idx, p, w)), np.concatenate((idx, w, p))),
        ),
        shape=(n_yaw, n_yaw),
    ).tocsc()
    return k_xy, k_yaw


def base_coefficients(params: RobotParams, nominal: RobotParams) -> FloatArray:
    """The slip model's 24 coefficients (:attr:`SlipModel.COEF_KEYS` order) that move the body
    as the linear kinematic model of ``params`` does, for encoder counts turned into distances
    with ``nominal``'s wheels: its radii's ratios to the nominal ones ``g`` and its model's
    coefficients (:class:`odolab.core.models.ModelCoefficients`) give the terms of degree one in
    ``v`` and ``w`` (the others are 0)::

        fwd_v = w_l g_l + w_r g_r - 1        fwd_w = (w_r g_r - w_l g_l) b / 2
        yaw_v = (e_r g_r - e_l g_l) / D      yaw_w = (e_r g_r + e_l g_l) b / (2 D) - 1
        lat_v = lateral yaw_v                lat_w = lateral (1 + yaw_w)

    (``b`` the nominal track width)."""
    k = len(FEATURES)
    out = np.zeros(3 * k)
    c = params.model.coefficients(params.track_width)
    gl = params.left_metres_per_tick / nominal.left_metres_per_tick
    gr = params.right_metres_per_tick / nominal.right_metres_per_tick
    half = 0.5 * nominal.track_width
    yaw_v = (c.e_right * gr - c.e_left * gl) / c.denominator
    yaw_w = (c.e_right * gr + c.e_left * gl) * half / c.denominator
    out[0] = c.w_left * gl + c.w_right * gr - 1.0
    out[1] = (c.w_right * gr - c.w_left * gl) * half
    out[k] = c.lateral * yaw_v
    out[k + 1] = c.lateral * yaw_w
    out[2 * k] = yaw_v
    out[2 * k + 1] = yaw_w - 1.0
    return out


def _fit_mean(
    runs: Sequence[object],
    nominal: RobotParams,
    window_s: float,
    prior_scale: float,
    base: FloatArray | None = None,
    truth: TruthNoise | None = None,
    shrink: tuple[float, float] | None = None,
    memo: RowsMemo | None = None,
    scale: float | None = None,
) -> tuple[SlipModel, FloatArray, int, FloatArray, tuple[float, float], FilterFit | None]:
    """The coefficients and their posterior by Bayesian linear regression with automatic
    relevance determination about the prior mean ``base`` (0 unless given), and the windows'
    noise by expectation-maximisation (see the module); where the truth's noise dominates
    (:func:`filtered`), the coefficients from the Kalman filter at process-noise ``scale``
    (None: :func:`filtered` decides and the likelihood chooses; 0: the regression): (model,
    posterior covariance, windows, each coefficient's posterior sd over its weak prior's, the
    shrinkage, what the filter found or None)."""
    try:
        d: SlipDesign | None = slip_design(runs, nominal, window_s, steady=True, memo=memo)
    except InsufficientDataError:  # no window in steady state at all
        d = None
    if d is None or d.y_yaw.size < max(2, STEADY_SHARE * d.windows_seen):
        d = slip_design(runs, nominal, window_s, memo=memo)  # too few steady: all of them
    k = len(FEATURES)
    if d.y_yaw.size < 2:
        raise InsufficientDataError(
            f"{d.y_yaw.size} window of {window_s:g} s for the slip model; expected longer runs"
        )
    phi_rms = np.where(d.phi_rms > 0, d.phi_rms, 1.0)
    tau_v = prior_scale * max(d.v_rms, 1e-3) / phi_rms
    tau_w = prior_scale * max(d.w_rms, 1e-3) / phi_rms
    # noise of a window: white velocity noise (duration) plus noise per metre of track travel
    # (xy rows) or per radian of commanded turn (heading rows), as the lab's wheel noise and
    # turn scrub
    sc_xy = np.tile(np.column_stack((d.durations, d.travel)), (2, 1))
    sc_yaw = np.column_stack((d.durations, d.turn))
    m0 = np.zeros(3 * k) if base is None else base
    k_xy, k_yaw = (None, None) if not _noisy(truth) else truth_covariances(d, truth)  # type: ignore[arg-type]
    tau_xy = np.concatenate((tau_v, tau_v))
    if shrink is None:
        n = d.y_yaw.size
        fold = np.minimum(np.arange(n) * SHRINK_FOLDS // max(n, 1), SHRINK_FOLDS - 1)
        shrink = (
            _shrinkage(d.a_xy, d.y_xy, tau_xy, sc_xy, m0[: 2 * k], k_xy, d, fold),
            _shrinkage(d.a_yaw, d.y_yaw, tau_w, sc_yaw, m0[2 * k :], k_yaw, d, fold),
        )
    s_xy, s_yaw = (max(v, 1e-6) for v in shrink)
    # the covariance reported is still the weak prior's (what the data say of each coefficient)
    mu_xy, sig_xy, c_xy = _blr(d.a_xy, d.y_xy, tau_xy * s_xy, sc_xy, m0[: 2 * k], k_xy, weak=tau_xy)
    mu_yaw, sig_yaw, c_yaw = _blr(
        d.a_yaw, d.y_yaw, tau_w * s_yaw, sc_yaw, m0[2 * k :], k_yaw, weak=tau_w
    )
    cov = np.zeros((3 * k, 3 * k))
    cov[: 2 * k, : 2 * k] = sig_xy
    cov[2 * k :, 2 * k :] = sig_yaw
    cov = 0.5 * (cov + cov.T)  # an inverse, symmetric to rounding: exactly so
    beta = np.concatenate((mu_xy, mu_yaw))
    tau = np.concatenate((tau_v, tau_v, tau_w))
    filter_fit = None
    if scale != 0.0 and truth is not None and (scale or filtered(truth, d, c_xy, c_yaw)):
        filter_fit = _filter_mean(runs, nominal, m0, tau, c_xy, c_yaw, truth, scale)
        beta, cov = filter_fit.beta, filter_fit.cov
    limit = SlipModel.LIMIT
    values = {
        key: float(np.clip(v, -limit, limit))
        for key, v in zip(SlipModel.COEF_KEYS, beta, strict=True)
    }
    model = SlipModel(
        **values,
        q_fwd=float(c_xy[0]),
        q_lat=float(c_xy[0]),
        q_yaw=float(c_yaw[0]),
        k_fwd=float(c_xy[1]),
        k_lat=float(c_xy[1]),
        k_yaw=float(c_yaw[1]),
        posterior=tuple(cov.ravel().tolist()),
    )
    spread = np.sqrt(np.maximum(np.diag(cov), 0.0)) / tau
    return model, cov, int(d.y_yaw.size), spread, shrink, filter_fit


def filtered(truth: TruthNoise | None, d: SlipDesign, c_xy: FloatArray, c_yaw: FloatArray) -> bool:
    """Whether the slip coefficients come from the Kalman filter
    (:mod:`odolab.calibration.slipfilter`) rather than the regression: where the truth's noise
    variance is larger than the variance the model's own noise (the regression's window noise
    ``c_xy``, ``c_yaw``: white plus per metre or radian) adds between two of the truth's updates,
    in position or in heading. Then the regression's rows, which difference the truth, are
    mostly the truth's noise, and the filter, which takes the truth as a measurement of a hidden
    pose, uses it as it is. Measured (docs/models.md): the DRIVE Husky's lidar 0.22 (position)
    and 0.008 (heading) of the model's, noise-free simulated truths 0.04 to 0.16, 2 cm / 0.02
    rad of added noise 16 to 64, 5 cm / 0.1 rad 11 to 77. A truth that is not material
    (:func:`odolab.metrics.truthnoise.material`: below 1 mm and 1 mrad) is as good as exact (a
    perfect simulator's, whose model noise is nil, reads 0.1 to 0.8 mm: its own bend)."""
    if not material(truth):  # none, or as good as exact
        return False
    assert truth is not None
    spacing = truth.spacing if truth.spacing > 0 else float(np.median(d.durations))
    seconds = max(float(np.sum(d.durations)), 1e-12)
    speed = float(np.sum(d.travel)) / seconds
    turn_rate = float(np.sum(d.turn)) / seconds
    model_xy = (c_xy[0] + c_xy[1] * speed) * spacing
    model_yaw = (c_yaw[0] + c_yaw[1] * turn_rate) * spacing
    return bool(truth.xy**2 > model_xy or truth.yaw**2 > model_yaw)


def _filter_mean(
    runs: Sequence[object],
    nominal: RobotParams,
    base: FloatArray,
    tau: FloatArray,
    c_xy: FloatArray,
    c_yaw: FloatArray,
    truth: TruthNoise,
    scale: float | None,
) -> FilterFit:
    """:func:`odolab.calibration.slipfilter.filter_coefficients` with the regression's window
    noise as the model's."""
    from odolab.calibration.slipfilter import filter_coefficients

    noise = np.array([c_xy[0], c_xy[0], c_yaw[0], c_xy[1], c_xy[1], c_yaw[1]])
    return filter_coefficients(runs, nominal, base, tau, noise, truth, steady_cycles, scale)


def estimator_note(fit: FilterFit | None) -> str:
    """The note every face prints of which estimator gave the slip coefficients
    (:func:`fit_slip_model`'s last value)."""
    if fit is None:
        return (
            "the slip coefficients by regression on windows of the truth (its noise is smaller "
            "than the model's between two of its updates)"
        )
    return (
        "the slip coefficients by a Kalman filter that takes the truth as a measurement of the "
        "pose (its noise is larger than the model's between two of its updates; "
        f"process noise scaled by {fit.scale:.3g}, by likelihood; {fit.updates} of its "
        f"updates taken, {fit.glitches} left out as glitches beyond the 99.9 % gate)"
    )


def _noisy(truth: TruthNoise | None) -> bool:
    """Whether ``truth`` has any noise to allow for."""
    return truth is not None and (truth.xy > 0 or truth.yaw > 0)


def _blocks(run: object, count: int) -> list[object]:
    """A prepared run cut into ``count`` pieces of equal duration (each a prepared run)."""
    t = np.asarray(run.t, dtype=np.float64)  # type: ignore[attr-defined]
    cuts = np.searchsorted(t, t[0] + (t[-1] - t[0]) * np.arange(1, count) / count)
    bounds = [0, *cuts.tolist(), t.size]
    out = []
    for a, b in pairwise(bounds):
        if b - a < 2:
            continue
        part = slice(a, b)
        out.append(
            replace(
                run,  # type: ignore[type-var]
                t=t[part],
                dticks_left=np.asarray(run.dticks_left)[part],  # type: ignore[attr-defined]
                dticks_right=np.asarray(run.dticks_right)[part],  # type: ignore[attr-defined]
                gt_x=np.asarray(run.gt_x)[part],  # type: ignore[attr-defined]
                gt_y=np.asarray(run.gt_y)[part],  # type: ignore[attr-defined]
                gt_heading=np.asarray(run.gt_heading)[part],  # type: ignore[attr-defined]
                truth_var=np.asarray(run.truth_var)[part],  # type: ignore[attr-defined]
            )
        )
    return out


def fit_slip_model(
    runs: Sequence[object],
    nominal: RobotParams,
    *,
    window_s: float = WINDOW_S,
    prior_scale: float = 1.0,
    folds: int = NOISE_FOLDS,
    piece_s: Sequence[float] = NOISE_PIECE_S,
    centre: tuple[FloatArray, str] | None = None,
    truth: TruthNoise | None = None,
) -> tuple[SlipModel, FloatArray, int, str, FloatArray, FilterFit | None]:
    """The slip model of prepared runs: (model with its posterior, 24 x 24 posterior
    covariance in :attr:`SlipModel.COEF_KEYS` order, number of windows, the kinematic model
    its prior is centred on, each coefficient's posterior standard deviation over its weak
    prior's: :func:`undetermined`, and what the Kalman filter found where the coefficients
    come from it (:func:`filtered`; None: from the regression)).

    The coefficients come from all the runs, their prior centred on ``centre`` (slip
    coefficients and the model's name: the kinematic model fitted to the same runs,
    :func:`odolab.calibration.lsq.kinematic_base`; None: the nominal differential drive): what
    the runs do not determine stays with that model. The variance terms (white
    noise and drift) are fitted to how far the model is off after each of ``piece_s`` seconds
    on data it was not fitted on (:func:`fit_noise`; pieces of several lengths, so that the
    variance grows with the horizon as the errors do): each run is cut into ``folds`` parts of
    equal duration, and each part is predicted by the model fitted on the others
    (cross-fitting), so the predictive variance covers the model's own error on new data, not
    only the noise it saw; with ``folds`` 1 (or runs too short to cut), on the data it was
    fitted on. ``truth``: the ground truth's noise (:mod:`odolab.metrics.truthnoise`), in
    the regression's row covariance (:func:`truth_covariances`: the rows are weighted by it, so
    the coefficients rest on the stretches the truth's noise weighs least on). The predictive
    variance still covers it: it is fitted to, and judged by (``odolab evaluate --nees``),
    errors against the same truth (measured with it taken out: docs/models.md)."""
    mean, kind = centre if centre is not None else (np.zeros(3 * len(FEATURES)), "none")
    parts = [_blocks(r, folds) for r in runs] if folds > 1 else []
    cross = bool(parts) and all(len(p) == folds for p in parts)
    model, cov, windows, spread, shrink, found = _fit_mean(
        runs, nominal, window_s, prior_scale, mean, truth
    )
    pieces: list[_Pieces] = []
    if cross:
        memo: RowsMemo = {}  # each part is in folds - 1 trainings
        for f in range(folds):
            train = [p[i] for p in parts for i in range(folds) if i != f]
            try:
                m = _fit_mean(
                    train,
                    nominal,
                    window_s,
                    prior_scale,
                    mean,
                    truth,
                    shrink,
                    memo,
                    found.scale if found is not None else 0.0,
                )[0]
            except InsufficientDataError:
                pieces = []
                break
            for length in piece_s:
                pieces.append(
                    _piece_errors([p[f] for p in parts], nominal.with_(model=m), length, truth)
                )
    if not pieces:
        pieces = [
            _piece_errors(runs, nominal.with_(model=model), length, truth) for length in piece_s
        ]
    groups = [
        _Pieces.join(pieces[i :: len(piece_s)]).take(NOISE_PIECES_MAX) for i in range(len(piece_s))
    ]
    theta = fit_noise(groups, terms_of(model))
    terms: dict[str, float] = {k: float(v) for k, v in zip(TERMS, theta, strict=True)}
    model = replace(model, **terms)  # type: ignore[arg-type]
    return model, cov, windows, kind, spread, found


def undetermined(spread: FloatArray, windows: int, centre: str) -> str | None:
    """The sentence every face says of a slip fit its runs cannot determine (None when they
    can): the median coefficient's standard error is beyond :data:`UNDETERMINED_SPREAD` of the
    typical speed or turn rate (``spread``: :func:`fit_slip_model`'s fifth value)."""
    share = float(np.median(spread))
    if share <= UNDETERMINED_SPREAD:
        return None
    beyond = int(np.sum(spread > UNDETERMINED_SPREAD))
    keeps = f"the {centre} model's" if centre != "none" else "the nominal differential drive's"
    return (
        f"the slip model is not determined by these runs: {beyond} of its {spread.size} "
        f"coefficients have standard errors that move the robot by more than "
        f"{UNDETERMINED_SPREAD:.0%} of its typical speed or turn rate (median "
        f"{share:.0%}; {windows} windows of {WINDOW_S:g} s); what they cannot tell stays with "
        f"{keeps} values, and its predictions are not to be trusted; expected a longer "
        "exploration (docs/models.md)"
    )


@dataclass(frozen=True, eq=False)
class _Pieces:
    """Pieces of runs with ground truth, each started at the truth's pose: the end pose error
    ``e`` (m, 3); at the end, the first-order covariance per unit variance term ``basis``
    (m, T, 3, 3) and from the posterior ``post`` (m, 3, 3); and what the second-order share
    depends on (:class:`odolab.core.slip_uncertainty.EndPairs`)."""

    e: FloatArray
    basis: FloatArray
    post: FloatArray
    pairs: EndPairs

    @staticmethod
    def join(parts: Sequence[_Pieces]) -> _Pieces:
        return _Pieces(
            np.concatenate([p.e for p in parts]),
            np.concatenate([p.basis for p in parts]),
            np.concatenate([p.post for p in parts]),
            EndPairs.join([p.pairs for p in parts]),
        )

    def take(self, count: int) -> _Pieces:
        """At most ``count`` of the pieces, evenly spread (all of them when there are fewer)."""
        m = self.e.shape[0]
        if m <= count:
            return self
        keep = np.unique(np.linspace(0, m - 1, count).round().astype(np.int64))
        p = self.pairs
        return _Pieces(
            self.e[keep], self.basis[keep], self.post[keep],
            EndPairs(p.steps[keep], p.cc[keep], p.c0[keep], p.ce[keep], p.ce0[keep]),
        )  # fmt: skip

    def covariance(self, theta: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The end covariance (m, 3, 3) with the terms ``theta`` and its derivative by each
        term (m, T, 3, 3)."""
        cov = np.einsum("c,mcij->mij", theta, self.basis) + self.post
        xy, xyh, d_xy, d_xyh = end_second_order(theta, self.pairs)
        cov[:, :2, :2] += xy
        cov[:, :2, 2] += xyh
        cov[:, 2, :2] += xyh
        grad = self.basis.copy()
        grad[:, :, :2, :2] += d_xy
        grad[:, :, :2, 2] += d_xyh
        grad[:, :, 2, :2] += d_xyh
        return cov, grad


def _piece_errors(
    runs: Sequence[object], params: RobotParams, piece_s: float, truth: TruthNoise | None = None
) -> _Pieces:
    """Every ``piece_s`` piece of prepared runs with motion, started at the ground truth's
    pose (:class:`_Pieces`). Where the truth's noise is material
    (:func:`odolab.metrics.truthnoise.material`), what it adds to each piece's error (at its
    start and its end: :func:`~odolab.metrics.truthnoise.piece_covariance`) is a known part of
    the piece's covariance, beside the posterior's: the terms fitted to the pieces are then the
    model's own, not the truth's."""
    errs, bases, posts, pairs = [], [], [], []
    known = truth if material(truth) else None
    for run in runs:
        t = np.asarray(run.t, dtype=np.float64)  # type: ignore[attr-defined]
        f = np.asarray(run.truth_var, dtype=np.float64)  # type: ignore[attr-defined]
        f = f if f.size == t.size else np.ones(t.size)  # (a run made without it: a whole update)
        dsl = np.asarray(run.dticks_left) * params.left_metres_per_tick  # type: ignore[attr-defined]
        dsr = np.asarray(run.dticks_right) * params.right_metres_per_tick  # type: ignore[attr-defined]
        gx = np.asarray(run.gt_x, dtype=np.float64)  # type: ignore[attr-defined]
        gy = np.asarray(run.gt_y, dtype=np.float64)  # type: ignore[attr-defined]
        gh = np.asarray(run.gt_heading, dtype=np.float64)  # type: ignore[attr-defined]
        if t.size < 2:
            continue
        edges = np.searchsorted(t, np.arange(t[0], t[-1] + 1e-9, piece_s))
        edges = np.unique(np.minimum(edges, t.size - 1))
        for a, b in pairwise(edges):
            sl, sr = dsl[a + 1 : b + 1], dsr[a + 1 : b + 1]
            if np.sum(np.abs(sl) + np.abs(sr)) < 1e-3:  # standing: nothing to learn from
                continue
            start = (float(gx[a]), float(gy[a]), float(gh[a]))
            prop = propagate_terms(
                t[a : b + 1], np.concatenate(([0.0], sl)), np.concatenate(([0.0], sr)),
                params, start,
            )  # fmt: skip
            end = prop.poses[-1]
            e = np.array([gx[b] - end[0], gy[b] - end[1], 0.0])
            e[2] = np.angle(np.exp(1j * (gh[b] - end[2])))
            errs.append(e)
            bases.append(prop.basis[-1])
            post = prop.post[-1]
            if known is not None:
                d = np.array([[end[0] - start[0], end[1] - start[1]]])
                post = post + piece_covariance(known, f[a : a + 1], f[b : b + 1], d)[0]
            posts.append(post)
            pairs.append(prop.end_pairs())
    nt = len(TERMS)
    if not errs:
        z = np.zeros
        h = len(HEADING_TERMS)
        return _Pieces(z((0, 3)), z((0, nt, 3, 3)), z((0, 3, 3)),
                       EndPairs(z((0, 0, 2)), z((0, 0, 0, h)), z((0, 0, 0)), z((0, 0, h)),
                                z((0, 0))))  # fmt: skip
    return _Pieces(np.array(errs), np.array(bases), np.array(posts), EndPairs.join(pairs))


def fit_noise(groups: Sequence[_Pieces], start: FloatArray) -> FloatArray:
    """The variance terms (:data:`TERMS`: white noise and drift) that make the slip model's
    predictive covariance (:mod:`odolab.core.slip_uncertainty`, second-order share included) fit how
    far its pose is off at the end of the pieces of ``groups`` (one group a piece length):
    maximum likelihood. Starts from (and with fewer pieces than terms, returns) ``start``."""
    from scipy.optimize import minimize

    groups = [g for g in groups if g.e.shape[0]]
    m = sum(g.e.shape[0] for g in groups)
    if m < len(TERMS):
        return start
    # scale each term by its typical contribution so the search is well conditioned
    size = sum(np.einsum("mcii->c", g.basis) for g in groups) / m
    size = np.where(size > 0, size, 1.0)
    typical = float(sum(np.sum(g.e**2) for g in groups) / (3 * m)) + 1e-18
    floor = 1e-9 * typical / size  # a term this small is no term
    ceiling = 1e6 * typical / size  # a term this large would explain far more than was seen
    theta0 = np.clip(np.maximum(start, 1e-3 * typical / size), floor, ceiling)

    def nll(phi: FloatArray) -> tuple[float, FloatArray]:
        theta = np.exp(phi)
        value, grad = 0.0, np.zeros(theta.size)
        for g in groups:
            p, dp = g.covariance(theta)
            p[:, [0, 1, 2], [0, 1, 2]] += 1e-12 * typical  # keep it positive definite
            _, logdet = np.linalg.slogdet(p)
            pinv = np.linalg.inv(p)
            a = np.einsum("mij,mj->mi", pinv, g.e)
            value += float(np.sum(logdet) + np.einsum("mi,mi->", g.e, a))
            grad += np.einsum("mij,mcji->c", pinv, dp) - np.einsum("mi,mcij,mj->c", a, dp, a)
        return value, grad * theta

    try:
        best = minimize(nll, np.log(theta0), jac=True, method="L-BFGS-B",
                        bounds=[(float(np.log(lo)), float(np.log(hi)))
                                for lo, hi in zip(floor, ceiling, strict=True)])  # fmt: skip
    except np.linalg.LinAlgError:  # a covariance went singular on the way: keep the start
        return start
    if not np.all(np.isfinite(best.x)):
        return start
    return np.asarray(np.exp(best.x), dtype=np.float64)


def nees_pieces(
    runs: Sequence[object],
    params: RobotParams,
    piece_s: float = 10.0,
    truth_sigma: TruthNoise | None = None,
) -> FloatArray:
    """NEES of the end pose of every ``piece_s`` piece of runs with ground truth
    (:class:`odolab.io.run.OdometryRun`), each piece started at the ground truth's pose with zero
    covariance, the ground truth's frame taken as the robot's: `odolab evaluate --nees`'s
    numbers (:func:`odolab.metrics.consistency.run_nees`), pooled; chi-square with 3 degrees of
    freedom where the covariance is honest. The truth's noise as evaluate takes it:
    ``truth_sigma``, else estimated from the runs' truth (added where material)."""
    from odolab.metrics.consistency import run_nees, runs_truth_noise

    truth = runs_truth_noise(runs, truth_sigma)  # type: ignore[arg-type]
    out = [
        run_nees(r, params, segment_s=piece_s, fit_gt_yaw_offset=False, truth=truth).nees  # type: ignore[arg-type]
        for r in runs
    ]
    return np.concatenate(out) if out else np.zeros(0)


def nees_bounds(pieces: int, dof: int = 3) -> tuple[float, float]:
    """Two-sided 95 % bounds of the mean of ``pieces`` NEES values (chi-square, ``dof`` each)."""
    from odolab.core.distributions import chi2_mean_bounds

    return chi2_mean_bounds(dof * pieces, pieces)


def first_seconds(run: object, seconds: float) -> object:
    """The first ``seconds`` of a run with ground truth (:class:`odolab.io.run.OdometryRun`)."""
    from dataclasses import replace

    from odolab.core.trajectory import Trajectory

    t = np.asarray(run.t)  # type: ignore[attr-defined]
    keep = t <= t[0] + seconds
    gt = run.require_ground_truth()  # type: ignore[attr-defined]
    g = gt.t <= t[0] + seconds + 1e-9
    truth = Trajectory.from_xyh(gt.t[g], gt.x[g], gt.y[g], gt.heading[g])
    return replace(
        run,  # type: ignore[type-var]
        name=f"{run.name}-{seconds:g}s",  # type: ignore[attr-defined]
        source=f"{run.source} (first {seconds:g} s)",  # type: ignore[attr-defined]
        t=t[keep],
        dticks_left=np.asarray(run.dticks_left)[keep],  # type: ignore[attr-defined]
        dticks_right=np.asarray(run.dticks_right)[keep],  # type: ignore[attr-defined]
        ground_truth=truth,
    )


def endpoint_error(run: object, params: RobotParams) -> float:
    """Distance (m) between the odometry's and the ground truth's last position, the odometry
    started at the ground truth's first pose (no alignment)."""
    from odolab.metrics.association import interpolate_trajectory

    gt = run.require_ground_truth()  # type: ignore[attr-defined]
    t = np.asarray(run.t, dtype=np.float64)  # type: ignore[attr-defined]
    inside = (t >= gt.t[0]) & (t <= gt.t[-1])
    g = interpolate_trajectory(gt, t[inside])
    from odolab.core.odometry import integrate_increments

    dl = np.asarray(run.dticks_left, dtype=np.float64)[inside]  # type: ignore[attr-defined]
    dr = np.asarray(run.dticks_right, dtype=np.float64)[inside]  # type: ignore[attr-defined]
    dl[0] = dr[0] = 0.0
    odo = integrate_increments(
        t[inside], dl, dr, params, start=(float(g.x[0]), float(g.y[0]), float(g.heading[0]))
    )
    return float(np.hypot(odo.x[-1] - g.x[-1], odo.y[-1] - g.y[-1]))
