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
truth's body frame is estimated per run (least squares over the pieces, as ``calibrate lsq``
does) unless given.
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
from odolab.uncertainty import covariance_matrix, propagate_covariance

__all__ = [
    "DOF",
    "NeesSummary",
    "RunNees",
    "fit_noise_scale",
    "nees_summary",
    "run_nees",
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "name": self.name,
            "segment_s": self.segment_s,
            "gt_yaw_offset_rad": self.gt_yaw_offset,
            "nees": [float(v) for v in self.nees],
            "mean_nees": float(np.mean(self.nees)) if self.nees.size else math.nan,
        }


@dataclass(frozen=True)
class NeesSummary:
    """NEES over many pieces of many runs, against the chi-square 95 % bounds."""

    n: int
    mean: float
    mean_bounds95: tuple[float, float]
    single_bounds95: tuple[float, float]
    fraction_inside: float
    fraction_above: float
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "n": self.n,
            "dof": DOF,
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
) -> RunNees:
    """NEES of ``run``'s odometry with ``params`` over pieces of ``segment_s`` seconds.

    ``noise`` defaults to ``params.noise``. ``gt_yaw_offset`` (rad): the robot's forward axis in
    the ground truth's body frame; None estimates it from the run."""
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
    if gt_yaw_offset is None:  # rotate the ground truth's pieces onto the odometry's
        cross = float(np.sum(odo[:, 0] * gtr[:, 1] - odo[:, 1] * gtr[:, 0]))
        dot = float(np.sum(odo[:, 0] * gtr[:, 0] + odo[:, 1] * gtr[:, 1]))
        gt_yaw_offset = math.atan2(cross, dot)
    c, s = math.cos(gt_yaw_offset), math.sin(gt_yaw_offset)
    gx = c * gtr[:, 0] + s * gtr[:, 1]
    gy = -s * gtr[:, 0] + c * gtr[:, 1]
    err = np.stack([odo[:, 0] - gx, odo[:, 1] - gy, wrap_angle(odo[:, 2] - gtr[:, 2])], axis=1)
    nees = np.full(len(pieces), np.nan)
    for k in range(len(pieces)):
        if np.linalg.det(covs[k]) > 0:
            nees[k] = float(err[k] @ np.linalg.solve(covs[k], err[k]))
    keep = np.isfinite(nees)  # a piece without motion has no covariance, nor a NEES
    return RunNees(run.name, float(segment_s), gt_yaw_offset, nees[keep], err[keep], dist[keep])


def nees_summary(runs: Sequence[RunNees]) -> NeesSummary:
    """Pool the pieces of ``runs``: mean NEES, its chi-square 95 % bounds, and a verdict."""
    from scipy.stats import chi2

    values = np.concatenate([r.nees for r in runs]) if runs else np.empty(0)
    n = int(values.size)
    if n == 0:
        raise InsufficientDataError("no NEES: no piece of any run moved the robot")
    lo, hi = (float(chi2.ppf(q, DOF * n) / n) for q in (0.025, 0.975))
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
    return NeesSummary(n, mean, (lo, hi), (s_lo, s_hi), inside, above, verdict)


def fit_noise_scale(
    runs: Sequence[OdometryRun],
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    segment_s: float = 10.0,
) -> NoiseParams:
    """The ``[noise]`` that makes the mean NEES of ``runs`` equal to 3 (its expectation).

    Scales ``params.noise`` (or ``k_left = k_right = 1e-4 m`` when it has none) by one factor:
    the covariance is linear in the k's, so the NEES scales by its inverse. Fit it on training
    runs, then judge it with :func:`run_nees` on held-out ones."""
    base = params.noise or NoiseParams(1e-4, 1e-4)
    trial = replace(params, noise=base)
    values = [run_nees(r, trial, method, segment_s=segment_s).nees for r in runs]
    pooled = np.concatenate(values) if values else np.empty(0)
    if pooled.size == 0:
        raise InsufficientDataError("no NEES to fit the noise to: no piece of any run moved")
    factor = float(pooled.mean()) / DOF
    try:
        return NoiseParams(base.k_left * factor, base.k_right * factor, base.k_scrub * factor)
    except ParamsError as err:
        raise InsufficientDataError(
            f"the noise fitted to pieces of {segment_s:g} s is implausible "
            f"(k_left = {base.k_left * factor:.3g} m; {err}): over such pieces the errors are not "
            "the random wheel slip the covariance models; use longer pieces"
        ) from err
