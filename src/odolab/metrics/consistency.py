"""Is the propagated covariance honest? NEES of odometry against ground truth.

For each run, the ground truth is cut into pieces of ``segment_s`` seconds. Over each piece the
odometry is integrated from a zero pose and its covariance propagated from zero
(:func:`odolab.uncertainty.propagate_covariance`, with the parameters' ``[noise]``); the ground
truth's motion over the same piece is expressed in the robot's frame at the piece's start. With
``e`` = odometry - ground truth (x, y, heading; error = predicted - actual) and ``P`` the
propagated covariance, the normalized estimation error squared is ``NEES = e^T P^-1 e``. If the
covariance is honest (right size, errors zero-mean and Gaussian), each NEES follows a chi-square
distribution with 3 degrees of freedom, and the mean of ``N`` independent ones lies within
``chi2.ppf(0.025, 3N) / N`` and ``chi2.ppf(0.975, 3N) / N`` in 95 % of cases. A mean above the
bounds: the covariance is too small (errors larger than claimed, or systematic errors left);
below: too large.

Motion-capture frames rarely point along the robot's forward axis: the yaw offset of the ground
truth's body frame can be estimated per run. By default (``fit_gt_yaw_offset=None``) it is,
unless the ground truth starts in the odometry's own frame (its first pose is the origin with
heading 0: a simulator's truth, where the body frames agree by construction). The fit is the
offset that minimises the run's summed NEES (Gauss-Newton from the unweighted least-squares
angle); the errors then have one degree of freedom less, so the summed NEES of ``N`` pieces of
``R`` runs with fitted offsets follows chi-square(3N - R), and the bounds of the mean are taken
from that distribution. (An offset fitted by unweighted least squares, ignoring the strong
correlation of lateral and heading errors, put the mean NEES of 2,000 pieces made exactly by
the documented model at 3.36, outside [2.89, 3.11]; the weighted fit and its degree of freedom
bring it back inside.)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.errors import InsufficientDataError, OdolabError, ParamsError
from odolab.io.run import OdometryRun
from odolab.kinematics import Method, wrap_angle
from odolab.metrics.association import interpolate_trajectory
from odolab.odometry import integrate_increments
from odolab.params import NoiseParams, RobotParams
from odolab.trajectory import Trajectory
from odolab.uncertainty import covariance_matrix, propagate_covariance

__all__ = [
    "DOF",
    "NeesSummary",
    "RunNees",
    "fit_noise_scale",
    "nees_summary",
    "run_nees",
    "starts_in_odometry_frame",
]

#: Degrees of freedom of one NEES: x, y, heading.
DOF = 3


@dataclass(frozen=True, eq=False)
class RunNees:
    """The NEES of every piece of one run."""

    name: str
    segment_s: float
    gt_yaw_offset: float
    nees: NDArray[np.float64]
    errors: NDArray[np.float64]  #: (k, 3) odometry - ground truth per piece
    distances: NDArray[np.float64]  #: (k,) ground-truth path length per piece (m)
    #: degrees of freedom the run's fitted parameters took from its pieces (1: a fitted offset)
    dof_removed: int = 0
    #: standard error of a fitted offset (rad); None when it was given, not fitted
    gt_yaw_offset_se: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "name": self.name,
            "segment_s": self.segment_s,
            "gt_yaw_offset_rad": self.gt_yaw_offset,
            "gt_yaw_offset_fitted": self.dof_removed > 0,
            "gt_yaw_offset_se_rad": self.gt_yaw_offset_se,
            "dof_removed": self.dof_removed,
            "nees": [float(v) for v in self.nees],
            "mean_nees": float(np.mean(self.nees)) if self.nees.size else math.nan,
        }


@dataclass(frozen=True)
class NeesSummary:
    """NEES over many pieces of many runs, against the chi-square 95 % bounds."""

    n: int
    mean: float
    mean_bounds95: tuple[float, float]
    #: degrees of freedom of the summed NEES: 3 per piece, less one per fitted offset
    dof: int
    single_bounds95: tuple[float, float]
    fraction_inside: float
    fraction_above: float
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "n": self.n,
            "dof_per_piece": DOF,
            "dof": self.dof,
            "expected_mean": self.dof / self.n,
            "mean_nees": self.mean,
            "mean_bounds95": list(self.mean_bounds95),
            "single_bounds95": list(self.single_bounds95),
            "fraction_inside": self.fraction_inside,
            "fraction_above": self.fraction_above,
            "verdict": self.verdict,
        }


def _pieces(t: NDArray[np.float64], segment_s: float) -> list[tuple[int, int]]:
    out = []
    a = 0
    while a < t.size - 1:
        b = int(np.searchsorted(t, t[a] + segment_s, side="left"))
        if b >= t.size:
            break
        out.append((a, b))
        a = b
    return out


def run_nees(
    run: OdometryRun,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    noise: NoiseParams | None = None,
    segment_s: float = 10.0,
    gt_yaw_offset: float | None = None,
    fit_gt_yaw_offset: bool | None = None,
) -> RunNees:
    """NEES of ``run``'s odometry with ``params`` over pieces of ``segment_s`` seconds.

    ``noise`` defaults to ``params.noise``. ``gt_yaw_offset`` (rad): the robot's forward axis in
    the ground truth's body frame, when known. Otherwise ``fit_gt_yaw_offset`` says whether to
    fit it (True), take 0 (False) or decide (None: fit unless the ground truth starts in the
    odometry's frame; module doc)."""
    if not (math.isfinite(segment_s) and segment_s > 0):
        raise OdolabError(f"segment length is {segment_s!r} s; expected a positive number")
    gt_full = run.require_ground_truth()
    inside = (run.t >= gt_full.t[0]) & (run.t <= gt_full.t[-1])
    idx = np.flatnonzero(inside)
    if idx.size < 2:
        raise InsufficientDataError(f"{run.source}: the ground truth does not cover the log")
    t = run.t[idx]
    dl = run.dticks_left[idx].copy()
    dr = run.dticks_right[idx].copy()
    dl[0] = dr[0] = 0.0
    gt = interpolate_trajectory(gt_full, t)
    pieces = _pieces(t, segment_s)
    if not pieces:
        raise InsufficientDataError(
            f"{run.source}: {t[-1] - t[0]:.3g} s of ground truth is shorter than one piece of "
            f"{segment_s:g} s"
        )
    odo = np.empty((len(pieces), 3))
    gtr = np.empty((len(pieces), 3))
    covs = np.empty((len(pieces), 3, 3))
    dist = np.empty(len(pieces))
    step = np.hypot(np.diff(gt.x), np.diff(gt.y))
    for k, (a, b) in enumerate(pieces):
        sl = slice(a, b + 1)
        ddl = dl[sl].copy()
        ddr = dr[sl].copy()
        ddl[0] = ddr[0] = 0.0
        est = integrate_increments(t[sl], ddl, ddr, params, method)
        odo[k] = est.x[-1], est.y[-1], est.heading[-1]
        covs[k] = covariance_matrix(propagate_covariance(ddl, ddr, params, method, noise=noise)[-1])
        c, s = math.cos(gt.heading[a]), math.sin(gt.heading[a])
        dx, dy = gt.x[b] - gt.x[a], gt.y[b] - gt.y[a]
        gtr[k] = c * dx + s * dy, -s * dx + c * dy, gt.heading[b] - gt.heading[a]
        dist[k] = float(step[a:b].sum())
    ok = np.array([np.linalg.det(c) > 0 for c in covs])
    inv = np.zeros_like(covs)
    inv[ok] = np.linalg.inv(covs[ok])
    if fit_gt_yaw_offset is None:
        fit_gt_yaw_offset = not starts_in_odometry_frame(gt_full)
    se: float | None = None
    removed = 0
    if gt_yaw_offset is None:
        if fit_gt_yaw_offset and ok.any():
            gt_yaw_offset, se = _fit_yaw_offset(odo[ok], gtr[ok], inv[ok])
            removed = 1
        else:
            gt_yaw_offset = 0.0
    err = _errors(odo, gtr, gt_yaw_offset)
    nees = np.full(len(pieces), np.nan)
    nees[ok] = np.einsum("ki,kij,kj->k", err[ok], inv[ok], err[ok])
    keep = np.isfinite(nees)  # a piece without motion has no covariance, nor a NEES
    return RunNees(
        run.name,
        float(segment_s),
        float(gt_yaw_offset),
        nees[keep],
        err[keep],
        dist[keep],
        dof_removed=removed,
        gt_yaw_offset_se=se,
    )


def starts_in_odometry_frame(gt: Trajectory, tol: float = 1e-9) -> bool:
    """True when the ground truth's first pose is the origin with heading 0 (m, rad): it was
    made in the odometry's frame (a simulator's truth), so no yaw offset is fitted by default."""
    return bool(
        abs(float(gt.x[0])) <= tol
        and abs(float(gt.y[0])) <= tol
        and abs(float(gt.heading[0])) <= tol
    )


def _errors(
    odo: NDArray[np.float64], gtr: NDArray[np.float64], offset: float
) -> NDArray[np.float64]:
    """odometry - ground truth per piece, the ground truth's motion turned by ``-offset``."""
    c, s = math.cos(offset), math.sin(offset)
    gx = c * gtr[:, 0] + s * gtr[:, 1]
    gy = -s * gtr[:, 0] + c * gtr[:, 1]
    return np.stack([odo[:, 0] - gx, odo[:, 1] - gy, wrap_angle(odo[:, 2] - gtr[:, 2])], axis=1)


def _fit_yaw_offset(
    odo: NDArray[np.float64], gtr: NDArray[np.float64], inv: NDArray[np.float64]
) -> tuple[float, float]:
    """The offset minimising the summed NEES, and its standard error (rad).

    Starts from the unweighted least-squares angle and takes Gauss-Newton steps on
    ``sum e^T P^-1 e``: ``de/d(offset) = (-gy, gx, 0)`` of the turned ground truth."""
    cross = float(np.sum(odo[:, 0] * gtr[:, 1] - odo[:, 1] * gtr[:, 0]))
    dot = float(np.sum(odo[:, 0] * gtr[:, 0] + odo[:, 1] * gtr[:, 1]))
    phi = math.atan2(cross, dot)
    info = math.inf
    for _ in range(20):
        e = _errors(odo, gtr, phi)
        c, s = math.cos(phi), math.sin(phi)
        gx = c * gtr[:, 0] + s * gtr[:, 1]
        gy = -s * gtr[:, 0] + c * gtr[:, 1]
        jac = np.stack([-gy, gx, np.zeros_like(gx)], axis=1)
        pj = np.einsum("kij,kj->ki", inv, jac)
        info = float(np.sum(pj * jac))
        if not info > 0:
            break
        step = -float(np.sum(pj * e)) / info
        phi += step
        if abs(step) < 1e-12:
            break
    return float(wrap_angle(np.array([phi]))[0]), (1.0 / math.sqrt(info) if info > 0 else math.inf)


def nees_summary(runs: Sequence[RunNees]) -> NeesSummary:
    """Pool the pieces of ``runs``: mean NEES, its chi-square 95 % bounds, and a verdict."""
    from scipy.stats import chi2

    values = np.concatenate([r.nees for r in runs]) if runs else np.empty(0)
    n = int(values.size)
    if n == 0:
        raise InsufficientDataError("no NEES: no piece of any run moved the robot")
    # a fitted offset takes one degree of freedom from its run's pieces (module doc)
    dof = max(DOF * n - sum(r.dof_removed for r in runs if r.nees.size), 1)
    lo, hi = (float(chi2.ppf(q, dof) / n) for q in (0.025, 0.975))
    s_lo, s_hi = (float(chi2.ppf(q, DOF)) for q in (0.025, 0.975))
    mean = float(values.mean())
    inside = float(np.mean((values >= s_lo) & (values <= s_hi)))
    above = float(np.mean(values > s_hi))
    if mean > hi:
        verdict = "too small: the errors are larger than the covariance says"
    elif mean < lo:
        verdict = "too large: the errors are smaller than the covariance says"
    else:
        verdict = "honest: the mean NEES is within its chi-square 95 % bounds"
    return NeesSummary(n, mean, (lo, hi), dof, (s_lo, s_hi), inside, above, verdict)


def fit_noise_scale(
    runs: Sequence[OdometryRun],
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    segment_s: float = 10.0,
    fit_gt_yaw_offset: bool | None = None,
) -> NoiseParams:
    """The ``[noise]`` that makes the mean NEES of ``runs`` equal to its expectation (3 a
    piece, less one a run with a fitted yaw offset).

    Scales ``params.noise`` (or ``k_left = k_right = 1e-4 m`` when it has none) by one factor:
    the covariance is linear in the k's, so the NEES scales by its inverse. Fit it on training
    runs, then judge it with :func:`run_nees` on held-out ones."""
    base = params.noise or NoiseParams(1e-4, 1e-4)
    trial = replace(params, noise=base)
    res = [
        run_nees(r, trial, method, segment_s=segment_s, fit_gt_yaw_offset=fit_gt_yaw_offset)
        for r in runs
    ]
    pooled = np.concatenate([r.nees for r in res]) if res else np.empty(0)
    if pooled.size == 0:
        raise InsufficientDataError("no NEES to fit the noise to: no piece of any run moved")
    dof = max(DOF * pooled.size - sum(r.dof_removed for r in res if r.nees.size), 1)
    factor = float(pooled.sum()) / dof
    try:
        return NoiseParams(base.k_left * factor, base.k_right * factor, base.k_scrub * factor)
    except ParamsError as err:
        raise InsufficientDataError(
            f"the noise fitted to pieces of {segment_s:g} s is implausible "
            f"(k_left = {base.k_left * factor:.3g} m; {err}): over such pieces the errors are not "
            "the random wheel slip the covariance models; use longer pieces"
        ) from err
