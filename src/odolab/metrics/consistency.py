"""Is the propagated covariance honest? NEES of odometry against ground truth.

For each run, the ground truth is cut into pieces of ``segment_s`` seconds. Over each piece the
odometry is integrated from a zero pose and its covariance propagated from zero
(:func:`odolab.core.uncertainty.propagate_covariance`, with the parameters' ``[noise]``; a slip
model's own predictive variance, :mod:`odolab.core.slip_uncertainty`); the ground
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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from odolab.core.distributions import Z95
from odolab.core.errors import InsufficientDataError, OdolabError, ParamsError, opt
from odolab.core.kinematics import Method, wrap_angle
from odolab.core.models import own_covariance
from odolab.core.odometry import integrate_increments
from odolab.core.params import NoiseParams, RobotParams
from odolab.core.trajectory import Trajectory
from odolab.core.uncertainty import (
    covariance_matrix,
    propagate_covariance,
    second_order_index,
)
from odolab.io.run import OdometryRun
from odolab.metrics.association import interpolate_trajectory
from odolab.metrics.truthnoise import (
    TruthNoise,
    allowed,
    material,
    piece_covariance,
    truth_residuals,
    variance_factors,
)

__all__ = [
    "DOF",
    "NeesSummary",
    "NoiseFit",
    "RunNees",
    "ShorterThanPiece",
    "choose_nees_piece",
    "fit_noise",
    "fit_noise_scale",
    "nees_of_runs",
    "nees_summary",
    "run_nees",
    "starts_in_odometry_frame",
]

#: Degrees of freedom of one NEES: x, y, heading.
DOF = 3


class ShorterThanPiece(InsufficientDataError):
    """A run whose ground truth covers less time than one NEES piece."""


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
    #: (k,) second-order index at each piece's end (odolab.core.uncertainty.second_order_index):
    #: above SECOND_ORDER_LIMIT the first-order covariance understates the spread
    second_order: NDArray[np.float64] | None = None
    #: the ground truth's noise added to each piece's covariance (None: taken as exact)
    truth: TruthNoise | None = None

    def to_dict(self) -> dict[str, object]:
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

    def to_dict(self) -> dict[str, object]:
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


@dataclass(frozen=True, eq=False)
class _Pieces:
    """Odometry and ground-truth motion over each piece, and the pieces' covariances."""

    odo: NDArray[np.float64]  #: (k, 3)
    gtr: NDArray[np.float64]  #: (k, 3) ground truth's motion in its frame at the piece's start
    covs: list[NDArray[np.float64]]  #: one (k, 3, 3) per noise asked for
    dist: NDArray[np.float64]  #: (k,)
    gt: Trajectory
    second_order: NDArray[np.float64]  #: (k,) second-order index at each piece's end
    t: NDArray[np.float64]  #: the stamps inside the ground truth's time range
    bounds: NDArray[np.int64]  #: (k, 2) each piece's first and last stamp (indices of t)


def _run_pieces(
    run: OdometryRun,
    params: RobotParams,
    method: Method | str,
    segment_s: float,
    noises: Sequence[NoiseParams | None],
) -> _Pieces:
    if not (math.isfinite(segment_s) and segment_s > 0):
        raise OdolabError(f"segment length is {segment_s!r} s; expected a positive number")
    gt_full = run.require_ground_truth()
    inside = (run.t >= gt_full.t[0]) & (run.t <= gt_full.t[-1])
    idx = np.flatnonzero(inside)
    if idx.size < 2:
        raise InsufficientDataError(f"{run.source}: the ground truth does not cover the log")
    t = run.t[idx]
    spacing = float(np.median(np.diff(t)))
    if segment_s < spacing * (1.0 - 1e-9):  # a piece of one cycle, labelled as shorter
        raise OdolabError(
            f"{run.source}: piece length {segment_s:g} s is shorter than the log's sample "
            f"spacing ({spacing:.3g} s); expected a piece length of at least {spacing:.3g} s"
        )
    dl = run.dticks_left[idx].copy()
    dr = run.dticks_right[idx].copy()
    dl[0] = dr[0] = 0.0
    gt = interpolate_trajectory(gt_full, t)
    pieces = _pieces(t, segment_s)
    if not pieces:
        raise ShorterThanPiece(
            f"{run.source}: {t[-1] - t[0]:.3g} s of ground truth is shorter than one piece of "
            f"{segment_s:g} s"
        )
    own = own_covariance(params.model)  # the model's own covariance (the slip model's)
    slip = own is not None
    if slip and any(n is not None for n in noises):
        raise OdolabError(
            f"the parameters {params.name!r} have a slip model, which carries its own predictive "
            "variance; wheel noise constants ([noise]) do not apply to it"
        )
    odo = np.empty((len(pieces), 3))
    gtr = np.empty((len(pieces), 3))
    covs = [np.empty((len(pieces), 3, 3)) for _ in noises]
    dist = np.empty(len(pieces))
    rho = np.zeros(len(pieces))
    step = np.hypot(np.diff(gt.x), np.diff(gt.y))
    for k, (a, b) in enumerate(pieces):
        sl = slice(a, b + 1)
        ddl = dl[sl].copy()
        ddr = dr[sl].copy()
        ddl[0] = ddr[0] = 0.0
        est = integrate_increments(t[sl], ddl, ddr, params, method)
        odo[k] = est.x[-1], est.y[-1], est.heading[-1]
        for j, (cov, noise) in enumerate(zip(covs, noises, strict=True)):
            if own is not None:
                _, full = own.propagate_covariance(t[sl], ddl, ddr, params)
                terms = full[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
            else:
                terms = propagate_covariance(ddl, ddr, params, method, noise=noise)
            cov[k] = covariance_matrix(terms[-1])
            if j == 0 and not slip:  # how far the piece is past first order's range
                # (odolab.core.uncertainty); the slip model's covariance has its second-order share
                rho[k] = second_order_index(est, terms)[-1]
        c, s = math.cos(gt.heading[a]), math.sin(gt.heading[a])
        dx, dy = gt.x[b] - gt.x[a], gt.y[b] - gt.y[a]
        gtr[k] = c * dx + s * dy, -s * dx + c * dy, gt.heading[b] - gt.heading[a]
        dist[k] = float(step[a:b].sum())
    return _Pieces(odo, gtr, covs, dist, gt_full, rho, t, np.array(pieces, dtype=np.int64))


def run_nees(
    run: OdometryRun,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    noise: NoiseParams | None = None,
    segment_s: float = 10.0,
    gt_yaw_offset: float | None = None,
    fit_gt_yaw_offset: bool | None = None,
    truth: TruthNoise | None = None,
) -> RunNees:
    """NEES of ``run``'s odometry with ``params`` over pieces of ``segment_s`` seconds.

    ``noise`` defaults to ``params.noise``. ``gt_yaw_offset`` (rad): the robot's forward axis in
    the ground truth's body frame, when known. Otherwise ``fit_gt_yaw_offset`` says whether to
    fit it (True), take 0 (False) or decide (None: fit unless the ground truth starts in the
    odometry's frame; module doc). ``truth``: the ground truth's own noise; where it is
    material (:func:`odolab.metrics.truthnoise.material`) what it adds to each piece's error at
    its two ends (:func:`~odolab.metrics.truthnoise.piece_covariance`) is added to the piece's
    covariance (None: the truth taken as exact)."""
    pcs = _run_pieces(run, params, method, segment_s, [noise])
    odo, gtr, covs, dist, gt_full = pcs.odo, pcs.gtr, pcs.covs[0], pcs.dist, pcs.gt
    ok = np.array([np.linalg.det(c) > 0 for c in covs])
    covs = covs + _truth_term(pcs, truth)
    truth = truth if material(truth) else None
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
    nees = np.full(len(odo), np.nan)
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
        second_order=pcs.second_order[keep],
        truth=truth,
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


def runs_truth_noise(
    runs: Sequence[OdometryRun], given: TruthNoise | None = None, enabled: bool = True
) -> TruthNoise | None:
    """The noise of the runs' ground truth to allow for (:func:`odolab.metrics.truthnoise.allowed`):
    ``given``, else estimated from the runs' own updates, pooled (None with too few updates, or
    where ``enabled`` is off)."""

    def parts() -> list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]:
        return [
            truth_residuals(r.ground_truth.t, r.ground_truth.x, r.ground_truth.y,
                            r.ground_truth.heading)
            for r in runs
            if r.ground_truth is not None
        ]  # fmt: skip

    return allowed(given, parts, enabled)


def nees_of_runs(
    runs: Sequence[OdometryRun],
    params_of: Callable[[OdometryRun], RobotParams],
    method: Method | str = Method.MIDPOINT,
    *,
    segment_s: float = 10.0,
    fit_gt_yaw_offset: bool | None = None,
    truth_sigma: TruthNoise | None = None,
) -> tuple[list[RunNees], list[str], str | None]:
    """:func:`run_nees` of every run with ``params_of(run)``, skipping the runs shorter than one
    piece; returns the results, the skipped runs' names and the sentence that says so (None when
    none was skipped). Every run too short is refused with one sentence. The ground truth's
    noise: ``truth_sigma`` as given, else estimated from the runs' truth (:func:`runs_truth_noise`);
    each run's result says whether it was allowed for (:attr:`RunNees.truth`).

    Raises:
        InsufficientDataError: every run is shorter than one NEES piece.
    """
    results: list[RunNees] = []
    skipped: list[str] = []
    longest = 0.0
    truth = runs_truth_noise(runs, truth_sigma)
    for run in runs:
        try:
            results.append(
                run_nees(
                    run,
                    params_of(run),
                    method,
                    segment_s=segment_s,
                    fit_gt_yaw_offset=fit_gt_yaw_offset,
                    truth=truth,
                )
            )
        except ShorterThanPiece:
            skipped.append(run.name)
            if run.ground_truth is not None:
                longest = max(longest, float(run.ground_truth.t[-1] - run.ground_truth.t[0]))
    if not results:
        raise InsufficientDataError(
            f"all {len(skipped)} runs are shorter than one NEES piece of {segment_s:g} s (the "
            f"longest ground truth covers {longest:.3g} s); expected a shorter {opt('nees_segment')}"
        )
    note = None
    if skipped:
        note = (
            f"{len(skipped)} of {len(runs)} runs skipped: shorter than one {segment_s:g} s "
            f"piece (e.g. {skipped[0]})"
        )
    return results, skipped, note


def nees_summary(runs: Sequence[RunNees]) -> NeesSummary:
    """Pool the pieces of ``runs``: mean NEES, its chi-square 95 % bounds, and a verdict.

    Raises:
        InsufficientDataError: no piece of any run moved the robot.
    """
    from odolab.core.distributions import chi2_mean_bounds

    values = np.concatenate([r.nees for r in runs]) if runs else np.empty(0)
    n = int(values.size)
    if n == 0:
        raise InsufficientDataError("no NEES: no piece of any run moved the robot")
    # a fitted offset takes one degree of freedom from its run's pieces (module doc)
    dof = max(DOF * n - sum(r.dof_removed for r in runs if r.nees.size), 1)
    lo, hi = chi2_mean_bounds(dof, n)
    s_lo, s_hi = chi2_mean_bounds(DOF, 1)  # one piece
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


def first_order_note(runs: Sequence[RunNees]) -> tuple[int, str | None]:
    """How many pieces go past the first-order covariance's range (second-order index above
    :data:`odolab.core.uncertainty.SECOND_ORDER_LIMIT`; the ``[noise]`` covariance only: the slip
    model's has the exact second moments), and the sentence every face says about them (None
    when there are none)."""
    from odolab.core.uncertainty import SECOND_ORDER_LIMIT

    n = sum(r.nees.size for r in runs)
    beyond = sum(
        int(np.sum(r.second_order > SECOND_ORDER_LIMIT)) for r in runs if r.second_order is not None
    )
    if not beyond:
        return 0, None
    return beyond, (
        f"{beyond} of {n} pieces go past the first-order covariance's range (second-order index "
        f"> {SECOND_ORDER_LIMIT:g}, docs/ros2.md): there it understates the spread, and their "
        "NEES runs high for that reason alone; shorter pieces ({{nees_segment}}) go past it less often"
    )


#: Piece lengths (s) :func:`choose_nees_piece` tries, the longest first.
NEES_PIECES_S = (10.0, 5.0, 2.0, 1.0)
#: The share of pieces that may go past the first-order range at the chosen length.
PAST_FIRST_ORDER_SHARE = 0.1


def choose_nees_piece(
    runs: Sequence[OdometryRun],
    params: RobotParams,
    lengths: Sequence[float] = NEES_PIECES_S,
) -> tuple[float, list[RunNees], str]:
    """The NEES of ``runs`` on pieces of the longest of ``lengths`` at which the first-order
    covariance holds (at most :data:`PAST_FIRST_ORDER_SHARE` of the pieces past its range,
    :func:`first_order_note`): a verdict on longer pieces would judge the first-order
    approximation, not the noise constants. Returns (the length, the results, the sentence that
    says what was chosen and why, or plainly why none holds)."""
    tried: list[str] = []
    results: list[RunNees] = []
    length = float(lengths[0])
    for length in (float(v) for v in lengths):
        try:
            results, _, _ = nees_of_runs(runs, lambda _r: params, segment_s=length)
        except InsufficientDataError:
            if length == float(lengths[-1]):
                raise
            tried.append(f"at {length:g} s, every run is shorter than a piece")
            continue
        beyond, _ = first_order_note(results)
        n = sum(r.nees.size for r in results)
        if beyond <= PAST_FIRST_ORDER_SHARE * n:
            said = f" ({'; '.join(tried)})" if tried else ""
            return (
                length,
                results,
                (
                    f"Pieces of {length:g} s: the longest of "
                    f"{', '.join(f'{v:g}' for v in lengths)} s at which at most "
                    f"{PAST_FIRST_ORDER_SHARE:.0%} of the pieces go past the first-order covariance's "
                    f"range{said}"
                ),
            )
        tried.append(f"at {length:g} s, {beyond} of {n} pieces went past it")
    return (
        length,
        results,
        (
            f"Pieces of {length:g} s, the shortest tried, though the first-order covariance does not "
            f"hold there either ({'; '.join(tried)}): the heading's spread after a piece's turning is "
            "past first order's range, so this verdict judges the first-order approximation as much "
            "as the noise constants"
        ),
    )


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
    runs, then judge it with :func:`run_nees` on held-out ones.

    Raises:
        InsufficientDataError: no piece moved, or the fitted noise is implausible for pieces of this
            length.
    """
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


#: A piece whose odometry turned at least this much (rad) identifies the scrub; straight
#: driving turns too, by its own noise (some 0.03 rad over 2 s), which identifies nothing.
TURNING_RAD = 0.1

_UNIT_NOISES = (
    NoiseParams(1.0, 0.0, 0.0),
    NoiseParams(0.0, 1.0, 0.0),
    NoiseParams(0.0, 0.0, 1.0),
)


@dataclass(frozen=True)
class NoiseFit:
    """``k_left``, ``k_right``, ``k_scrub`` fitted to pieces with ground truth, by maximum
    likelihood, with 95 % intervals (None: the constant stays unknown, ``unknown`` says why)."""

    noise: NoiseParams
    ci95: dict[str, tuple[float, float]]
    unknown: dict[str, str]
    runs: tuple[str, ...]
    n_pieces: int
    n_turning: int  #: pieces with commanded turning (they identify k_scrub)
    mean_nees: float  #: of the training pieces with the fitted noise
    expected_mean: float
    #: the ground truth's noise, a known term of each piece (None: taken as exact)
    truth: TruthNoise | None = None

    def provenance(self) -> dict[str, object]:
        """A TOML-able table: each constant's value, interval and the runs it came from."""
        out: dict[str, object] = {}
        for key in ("k_left", "k_right", "k_scrub"):
            if key in self.unknown:
                out[key] = {"unknown": self.unknown[key]}
            else:
                out[key] = {"value": getattr(self.noise, key), "ci95": list(self.ci95[key])}
        out["from"] = (
            f"maximum likelihood over {self.n_pieces} pieces of {len(self.runs)} runs "
            f"({self.n_turning} of them turning)"
        )
        out["runs"] = list(self.runs)
        out["mean_nees"] = self.mean_nees
        out["expected_mean_nees"] = self.expected_mean
        return out


def _pieces_of(
    runs: Sequence[OdometryRun],
    params: RobotParams,
    method: Method | str,
    segment_s: float,
    start: NoiseParams,
    fit_gt_yaw_offset: bool | None,
    truth: TruthNoise | None = None,
) -> tuple[
    list[NDArray[np.float64]],
    list[NDArray[np.float64]],
    list[str],
    list[NDArray[np.float64]],
    int,
    list[NDArray[np.float64]],
]:
    """Per run with a usable piece: the pieces' errors, their unit-noise covariances (k, 3, 3,
    3), the run's name, the pieces' turns; how many runs had a yaw offset fitted away; and per
    run the ground truth's noise in each piece (k, 3, 3; zeros where ``truth`` is None)."""
    errs, bases, names, turns, known = [], [], [], [], []
    removed = 0
    for run in runs:
        pcs = _run_pieces(run, params, method, segment_s, [start, *_UNIT_NOISES])
        scaled = pcs.covs[0]
        ok = np.array([np.linalg.det(c) > 0 for c in scaled])
        if not ok.any():
            continue
        truth_cov = _truth_term(pcs, truth)
        fit = fit_gt_yaw_offset
        if fit is None:
            fit = not starts_in_odometry_frame(pcs.gt)
        offset = 0.0
        if fit:
            offset, _ = _fit_yaw_offset(
                pcs.odo[ok], pcs.gtr[ok], np.linalg.inv(scaled[ok] + truth_cov[ok])
            )
            removed += 1
        errs.append(_errors(pcs.odo, pcs.gtr, offset)[ok])
        turns.append(np.abs(pcs.odo[ok, 2]))
        bases.append(np.stack([c[ok] for c in pcs.covs[1:]], axis=1))  # (k, 3, 3, 3)
        known.append(truth_cov[ok])
        names.append(run.name)
    return errs, bases, names, turns, removed, known


def _truth_term(pcs: _Pieces, truth: TruthNoise | None) -> NDArray[np.float64]:
    """The ground truth's noise in each piece's error (k, 3, 3; zeros where it is not material:
    :func:`odolab.metrics.truthnoise.piece_covariance`), in the errors' frame: the odometry's at
    the piece's start (``_errors`` turns the truth's motion into it by a fitted yaw offset), so
    the start heading turns the odometry's own displacement."""
    if not material(truth):
        return np.zeros((pcs.odo.shape[0], 3, 3))
    assert truth is not None
    gt = pcs.gt
    f = variance_factors(gt.t, gt.x, gt.y, gt.heading, pcs.t)
    a, b = pcs.bounds[:, 0], pcs.bounds[:, 1]
    return piece_covariance(truth, f[a], f[b], pcs.odo[:, :2])


def _nll(
    e: NDArray[np.float64], a: NDArray[np.float64], free: list[int], known: NDArray[np.float64]
) -> Callable[[NDArray[np.float64]], float]:
    """The negative log-likelihood of the errors ``e`` over the logarithms of the free
    constants (the others 0); ``known``: the ground truth's part of each piece's covariance."""

    def nll(u: NDArray[np.float64]) -> float:
        if np.any(np.abs(u) > 60):  # e**60: far outside any plausible constant
            return 1e300
        k = np.zeros(3)
        k[free] = np.exp(u)
        cov = np.einsum("j,kjab->kab", k, a) + known
        sign, logdet = np.linalg.slogdet(cov)
        if np.any(sign <= 0):
            return 1e300
        quad = np.einsum("ka,ka->k", e, np.linalg.solve(cov, e[..., None])[..., 0])
        return float(0.5 * np.sum(logdet + quad))

    return nll


def _maximum(
    nll: Callable[[NDArray[np.float64]], float], start: NoiseParams, free: list[int]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The logarithms that minimise ``nll`` from the scale fit's constants, and their standard
    errors (inf where the Hessian cannot be inverted)."""
    from scipy import optimize

    from odolab.core.regression import approx_hess3

    guess = np.log(
        np.maximum(np.array([start.k_left, start.k_right, start.k_scrub or start.k_left]), 1e-12)
    )[free]
    res = optimize.minimize(nll, guess, method="Nelder-Mead", options={"xatol": 1e-8})
    res = optimize.minimize(nll, res.x, method="Nelder-Mead", options={"xatol": 1e-9})
    u = np.asarray(res.x, dtype=np.float64)
    hess = np.asarray(approx_hess3(u, nll), dtype=np.float64)
    try:
        se = np.sqrt(np.maximum(np.diag(np.linalg.inv(hess)), 0.0))
    except np.linalg.LinAlgError:
        se = np.full(u.size, math.inf)
    return u, se


def fit_noise(
    runs: Sequence[OdometryRun],
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    segment_s: float = 10.0,
    fit_gt_yaw_offset: bool | None = None,
    truth_sigma: TruthNoise | None = None,
) -> NoiseFit:
    """``k_left``, ``k_right``, ``k_scrub`` that make the pieces' errors most likely.

    Each piece's covariance is linear in the three constants (``k_l A_l + k_r A_r + k_s A_s``,
    the ``A``'s propagated with unit noise), so the Gaussian log-likelihood of all pieces'
    errors is maximised over their logarithms (scipy), with Wald intervals on the log scale
    (the numerical Hessian, :func:`odolab.core.regression.approx_hess3`). Straight pieces carry the wheels' noise, turning pieces
    the scrub as well; without a turning piece (:data:`TURNING_RAD`) ``k_scrub`` stays unknown
    (written 0 and said).
    A run's yaw offset, when fitted, is fitted first with the scale fit's noise. The ground
    truth's noise (``truth_sigma``, else estimated from the runs' truth: :func:`runs_truth_noise`)
    is a known part of each piece's covariance where it is material, so the constants are the
    wheels' own (:attr:`NoiseFit.truth`)."""
    if not runs:
        raise InsufficientDataError("no runs to fit the noise to")
    start = fit_noise_scale(
        runs, params, method, segment_s=segment_s, fit_gt_yaw_offset=fit_gt_yaw_offset
    )
    truth = runs_truth_noise(runs, truth_sigma)
    truth = truth if material(truth) else None
    errs, bases, names, turns, removed, knowns = _pieces_of(
        runs, params, method, segment_s, start, fit_gt_yaw_offset, truth
    )
    e = np.concatenate(errs)
    a = np.concatenate(bases)
    known = np.concatenate(knowns)
    n = e.shape[0]
    turning = np.concatenate(turns) >= TURNING_RAD
    scrub_known = bool(turning.any())
    free = [0, 1, 2] if scrub_known else [0, 1]
    u, se = _maximum(_nll(e, a, free, known), start, free)
    keys = ("k_left", "k_right", "k_scrub")
    values = dict.fromkeys(keys, 0.0)
    ci: dict[str, tuple[float, float]] = {}
    for j, idx in enumerate(free):
        values[keys[idx]] = math.exp(u[j])
        half = min(Z95 * float(se[j]), 300.0)  # an unidentified constant: [0, inf) in effect
        ci[keys[idx]] = (math.exp(u[j] - half), math.exp(u[j] + half))
    if scrub_known:  # the scrub may be 0 (wheels): its interval on the linear scale
        values["k_scrub"], ci["k_scrub"] = _scrub_interval(e, a, values, known)
    unknown = (
        {}
        if scrub_known
        else {"k_scrub": "no piece turned: the runs' straight motion leaves the scrub unknown"}
    )
    try:
        noise = NoiseParams(**values)
    except ParamsError as err:
        raise InsufficientDataError(
            f"the noise fitted to pieces of {segment_s:g} s is implausible ({err}): over such "
            "pieces the errors are not the random wheel slip the covariance models; use longer "
            "pieces"
        ) from err
    k = np.array([values[key] for key in keys])
    cov = np.einsum("j,kjab->kab", k, a) + known
    nees = np.einsum("ka,ka->k", e, np.linalg.solve(cov, e[..., None])[..., 0])
    return NoiseFit(
        noise=noise,
        ci95=ci,
        unknown=unknown,
        runs=tuple(names),
        n_pieces=n,
        n_turning=int(turning.sum()),
        mean_nees=float(nees.mean()),
        expected_mean=(DOF * n - removed) / n,
        truth=truth,
    )


def _scrub_interval(
    e: NDArray[np.float64],
    a: NDArray[np.float64],
    values: dict[str, float],
    known: NDArray[np.float64],
) -> tuple[float, tuple[float, float]]:
    """``k_scrub`` and its 95 % likelihood interval with the wheels' constants held at theirs
    (0 when no scrub is more likely than the fitted one: a wheeled robot)."""
    from scipy import optimize

    from odolab.core.distributions import chi2_ppf

    wheels = values["k_left"] * a[:, 0] + values["k_right"] * a[:, 1] + known

    def ll(ks: float) -> float:
        cov = wheels + ks * a[:, 2]
        sign, logdet = np.linalg.slogdet(cov)
        if np.any(sign <= 0):
            return -math.inf
        quad = np.einsum("ka,ka->k", e, np.linalg.solve(cov, e[..., None])[..., 0])
        return float(-0.5 * np.sum(logdet + quad))

    ks = values["k_scrub"]
    ll_hat = ll(ks)
    if ll(0.0) >= ll_hat:
        ks, ll_hat = 0.0, ll(0.0)
    cut = ll_hat - 0.5 * chi2_ppf(0.95, 1)
    lo = 0.0
    if ks > 0 and ll(0.0) < cut:
        lo = float(optimize.brentq(lambda k: ll(k) - cut, 0.0, ks, xtol=1e-15))
    top = max(ks, 1e-9) * 2.0
    while ll(top) > cut and top < 1.0:
        top *= 2.0
    hi = (
        float(optimize.brentq(lambda k: ll(k) - cut, ks, top, xtol=1e-15)) if ll(top) < cut else top
    )
    return ks, (lo, hi)
