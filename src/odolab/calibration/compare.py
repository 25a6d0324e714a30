"""Which kinematic model does my robot need? Fit every model, score it on held-out runs.

:func:`compare_models` fits each model of :data:`odolab.calibration.lsq.FIT_MODELS` on training
runs (:func:`~odolab.calibration.lsq.calibrate_lsq`) and evaluates the fit on runs it did not
see. Without separate held-out runs every run is held out once (k-fold cross-validation over
runs, at most 5 folds).

**The decision** is made on many numbers, not a few: every held-out run is cut into consecutive,
non-overlapping segments, each ending after 1 m of ground-truth path or 90 degrees of turn (so
turns in place count), and each model's relative pose error on each segment is computed: its
translation error ``e_t`` and heading error ``e_r`` combined as ``sqrt(e_t^2 + (1 m e_r)^2)``
(a heading error weighs as the sideways error it makes over the next metre). The segments of
all held-out runs are pooled; a model's score is the mean of its segment errors (the mean, not
the RMS: on real logs a few segments with a ground-truth glitch would dominate an RMS).
Models are compared in pairs on the *same* segments: the ratio of a model's mean to the best
model's, with a 95 % CI from a paired bootstrap (with 10 held-out runs or more, the runs are
resampled, each with all its segments: segments of one run share its ground truth's frame and
its stretch of ground; with fewer, each run's segments are resampled within it, so each run
keeps its weight). With ``delta`` = 5 % (:data:`NOT_WORSE`), from the simplest model
(diff < extended < icr < slip) on:

- CI of the ratio at most ``1 + delta``: the model is *not worse* than the best; it is chosen;
- CI above 1 (and not within ``1 + delta``): it is worse; the next model is tried;
- otherwise (the CI reaches from below 1 to above ``1 + delta``): the data cannot tell whether it
  is as good as the best, and the result is ``"undecided"`` (:attr:`ModelComparison.decided` is
  False), never a guess. Fewer than :data:`MIN_SEGMENTS` held-out segments are undecided too.

So a more complex model is recommended only with a held-out gain its CI supports, and a simpler
one only where the data show it is (within 5 %) as good. Before, the decision was the end-point
error of each held-out run with a percentile bootstrap over runs: with two held-out runs its
"95 % CI" was the two per-run values, and it chose the differential drive in 3 of 5 seeds where
the ICR model's held-out RPE was 5-7 times lower.

Per-run figures (end-point error, RPE over 1 m, drift per metre) are reported as means over the
held-out runs with a Student-t 95 % interval (none from a single run; wide, as it must be, from
two or three). On the training residuals the BIC ``n ln(RSS / n) + k ln(n)`` (n residuals, k
fitted parameters including the ground truth's yaw offsets) and its difference to the
differential drive are given with a bootstrap CI over training runs (the fit is not repeated
per resample: the CI shows how much the runs disagree, not the whole uncertainty).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.calibration.lsq import (
    FIT_MODELS,
    LsqCalibration,
    LsqOptions,
    PreparedRun,
    calibrate_lsq,
    find_fit_and_held_out,
    fit_model,
    prepare_run,
)
from odolab.core.errors import CalibrationError, InsufficientDataError, opt
from odolab.core.params import RobotParams
from odolab.core.trajectory import Trajectory
from odolab.io.registry import LogFormat, read_run
from odolab.io.run import OdometryRun, ReadOptions
from odolab.metrics.runs import RUN_OPTIONS, Progress, evaluate_run, parallel_map
from odolab.metrics.truthnoise import TruthNoise

__all__ = [
    "DEFAULT_MODELS",
    "MIN_SEGMENTS",
    "MODEL_ORDER",
    "NOT_WORSE",
    "UNDECIDED",
    "Estimate",
    "ModelComparison",
    "ModelScore",
    "SegmentTruth",
    "compare_model_files",
    "compare_models",
    "learning_curve",
    "parse_curve",
    "segment_errors",
    "segment_truth",
    "truth_near",
]

#: Models from the simplest to the most complex (the recommendation prefers the left). The
#: slip model (issue 29) is last: learned from data, it is recommended only where every
#: kinematic model's held-out error is worse than its own.
MODEL_ORDER = ("diff", "extended", "icr", "slip")
#: The models compared unless told otherwise: the kinematic ones (add ``"slip"`` to score the
#: slip model too; with it, a noisy slip fit that is best by a little can make the choice among
#: the kinematic models undecided, so it is asked for, not default).
DEFAULT_MODELS = ("diff", "extended", "icr")
#: A model whose held-out segment RPE is within this fraction of the best's is "not worse".
NOT_WORSE = 0.05
#: Fewer held-out segments than this decide nothing.
MIN_SEGMENTS = 10
#: :attr:`ModelComparison.recommended` when the data cannot separate the models.
UNDECIDED = "undecided"
#: A decision segment ends after this much ground-truth path (m) ...
SEGMENT_M = 1.0
#: ... or this much turning (rad), whichever comes first.
SEGMENT_RAD = math.pi / 2
_METRICS = ("endpoint_error", "rpe_rmse", "drift_pct", "drift_deg_per_m")
#: Where the ground truth's own noise is most of what the held-out segments measure (its
#: expected share of the best model's mean squared segment error above this), each segment's
#: end poses are the truth fitted over :data:`SMOOTH_S` either side (:class:`SegmentTruth`).
NOISE_SHARE = 0.5
#: Seconds either side of a segment's end over which a noisy truth is fitted (:func:`truth_near`).
SMOOTH_S = 1.0


@dataclass(frozen=True)
class Estimate:
    """A mean with its 95 % confidence interval."""

    value: float
    low: float
    high: float

    def to_dict(self) -> dict[str, float]:
        return {"value": self.value, "ci95": [self.low, self.high]}  # type: ignore[dict-item]


@dataclass(frozen=True)
class ModelScore:
    """One model: its fit on the training runs and its scores on the held-out runs."""

    model: str
    n_params: int
    fit: LsqCalibration | None
    #: why the model could not be fitted (not identifiable from these runs), else None
    problem: str | None = None
    #: per held-out run: metric name -> value (runs in ModelComparison.held_out order)
    per_run: dict[str, list[float]] = field(default_factory=dict)
    held_out: dict[str, Estimate] = field(default_factory=dict)
    bic: float = math.nan
    delta_bic: Estimate | None = None  #: BIC minus the differential drive's (negative: better)
    #: held-out segment RPE / the best model's on the same segments, paired bootstrap CI
    ratio_to_best: Estimate | None = None
    #: mean pose error over every held-out segment (m), bootstrap CI over segments
    segment_error: Estimate | None = None
    #: per held-out run: the RPE (m) of each of its segments (runs in held_out order)
    segment_errors: list[list[float]] = field(default_factory=list)
    #: the same segments with their end poses the truth fitted over :data:`SMOOTH_S` either
    #: side (what the decision uses where the truth is noisy: :class:`SegmentTruth`)
    smoothed_errors: list[list[float]] = field(default_factory=list, repr=False)
    #: "best", "not worse", "worse" or "undecided": this model against the best
    verdict: str = ""
    #: the risk per run: on how many held-out runs (with segments) this model's mean segment
    #: error is above the best kinematic model's (by pooled mean), and of how many; None for
    #: that model itself, or without a kinematic model
    runs_worse: tuple[int, int] | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "model": self.model,
            "n_params": self.n_params,
            "problem": self.problem,
            "warnings": self.fit.warnings if self.fit else [],
            "values": self.fit.values if self.fit else None,
            "stderr": self.fit.stderr if self.fit else None,
            "held_out": {k: v.to_dict() for k, v in self.held_out.items()},
            "per_run": self.per_run,
            "segment_error": self.segment_error.to_dict() if self.segment_error else None,
            "segments": sum(len(e) for e in self.segment_errors),
            "bic": self.bic,
            "delta_bic": self.delta_bic.to_dict() if self.delta_bic else None,
            "ratio_to_best": self.ratio_to_best.to_dict() if self.ratio_to_best else None,
            "verdict": self.verdict,
            "runs_worse_than_best_kinematic": (
                {"runs": self.runs_worse[0], "of": self.runs_worse[1]} if self.runs_worse else None
            ),
        }


@dataclass(frozen=True)
class SegmentTruth:
    """The ground truth the held-out segments were scored against.

    A segment's error against a noisy truth carries the truth's noise at both ends: about
    ``4 xy^2 + 3 (SEGMENT_M yaw)^2`` of squared error (its two end positions, and the start
    heading turning a metre of path besides the heading error itself), the same for every model.
    With 5 cm and 0.1 rad that is 0.2 m a segment, and every model's mean error is mostly that
    noise: their ratios all near 1, and the rule says "not worse" or "undecided" whatever the
    models do. Where that ``share`` of the best model's mean squared segment error is above
    :data:`NOISE_SHARE`, each segment's end poses are the truth fitted over :data:`SMOOTH_S`
    either side instead (``smoothed_s``; :func:`truth_near`), which divides the noise's variance
    by the updates in the window."""

    noise: TruthNoise
    #: what the truth's noise adds to a segment's squared error at most (the formula above)
    #: over the best model's mean squared segment error
    share: float
    #: seconds either side over which the truth was fitted (0: each end's own truth pose)
    smoothed_s: float

    def describe(self) -> str:
        """One sentence for the output."""
        what = (
            f"the ground truth's noise ({self.noise.xy * 1000:.3g} mm, {self.noise.yaw:.3g} rad"
            f"{', as given' if self.noise.given else ', estimated from its updates'}) adds up "
            f"to {self.share:.2g} times the best model's mean squared segment error to each "
            "segment's"
        )
        if self.smoothed_s > 0:
            return (
                f"{what}, so each segment's end poses are the truth fitted over "
                f"{self.smoothed_s:g} s either side (a line in time through its updates)"
            )
        return f"{what}: each segment's end poses are the truth's own"

    def to_dict(self) -> dict[str, object]:
        return {
            "noise_xy_m": self.noise.xy,
            "noise_yaw_rad": self.noise.yaw,
            "given": self.noise.given,
            "share": self.share,
            "smoothed_s": self.smoothed_s,
        }


@dataclass(frozen=True)
class ModelComparison:
    """Result of :func:`compare_models`: ``recommended`` is a model, or :data:`UNDECIDED`;
    ``best`` the model with the lowest held-out segment RPE; ``segments`` how many held-out
    segments decided."""

    scores: list[ModelScore]
    recommended: str
    reason: str
    train: list[str]
    held_out: list[str]
    cross_validated: bool
    best: str = ""
    segments: int = 0
    #: held-out end-point error against seconds of the first training run (an exploration run):
    #: rows ``{"seconds", "model", "endpoint_error", "problem"}``; empty unless asked for
    learning_curve: list[dict[str, object]] = field(default_factory=list)
    #: the truth's noise against the segments' errors, and whether it was fitted near the ends (None: no
    #: estimate of it, too few updates or ``truth_noise`` off)
    truth: SegmentTruth | None = None

    @property
    def decided(self) -> bool:
        """False when the held-out data cannot separate the models."""
        return self.recommended != UNDECIDED

    def score(self, model: str) -> ModelScore:
        """The score of one model."""
        for s in self.scores:
            if s.model == model:
                return s
        raise KeyError(model)

    def to_dict(self) -> dict[str, object]:
        return {
            "recommended": self.recommended,
            "decided": self.decided,
            "reason": self.reason,
            "best": self.best,
            "criterion": (
                f"mean over {self.segments} held-out segments (each {SEGMENT_M:g} m of path or "
                f"{math.degrees(SEGMENT_RAD):g} deg of turn) of the segment's pose error "
                f"sqrt(e_t^2 + ({SEGMENT_M:g} m e_r)^2); paired bootstrap 95 % CI (runs "
                f"resampled, or segments within runs under {CLUSTER_RUNS} runs) of each "
                f"model's ratio to the best; not worse: CI "
                f"within 1 + {NOT_WORSE:g}"
            ),
            "segments": self.segments,
            "train": self.train,
            "held_out": self.held_out,
            "cross_validated": self.cross_validated,
            "models": [s.to_dict() for s in self.scores],
            **({"learning_curve": self.learning_curve} if self.learning_curve else {}),
            "segment_truth": self.truth.to_dict() if self.truth else None,
        }


def _t_interval(values: NDArray[np.float64]) -> Estimate:
    """Mean of non-negative values with its Student-t 95 % interval, clipped at 0 (none from
    fewer than two values).

    A percentile bootstrap over two runs gave the two values themselves as the "CI"."""
    from odolab.core.distributions import t_ppf

    mean = float(values.mean())
    if values.size < 2:
        return Estimate(mean, math.nan, math.nan)
    half = t_ppf(0.975, values.size - 1) * float(values.std(ddof=1)) / math.sqrt(values.size)
    return Estimate(mean, max(mean - half, 0.0), mean + half)  # errors are >= 0


#: With at least this many held-out runs that have segments, the bootstrap resamples runs
#: (each with all its segments); with fewer, the segments within each run.
CLUSTER_RUNS = 10


def _resample_weights(
    sizes: Sequence[int], rng: np.random.Generator, n: int
) -> NDArray[np.float64]:
    """``n`` bootstrap resamples of the pooled segments as weights (rows: how many times each
    segment is drawn). Segments of one run are not independent (one ground-truth frame, one
    stretch of terrain), so with :data:`CLUSTER_RUNS` runs or more the *runs* are resampled,
    each keeping all its segments: a table of short windows (one segment each) resampled within
    its runs would have no spread at all. With fewer runs, each run's segments are resampled
    within it (so each run keeps its number of segments)."""
    total = int(sum(sizes))
    used = [k for k, size in enumerate(sizes) if size]
    w = np.zeros((n, total))
    if not used:
        return w
    starts = np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.int64)
    if len(used) >= CLUSTER_RUNS:
        counts = rng.multinomial(len(used), np.full(len(used), 1.0 / len(used)), size=n)
        for c, k in enumerate(used):
            w[:, starts[k] : starts[k] + sizes[k]] = counts[:, c : c + 1]
        return w
    for k in used:
        size = sizes[k]
        w[:, starts[k] : starts[k] + size] = rng.multinomial(
            size, np.full(size, 1.0 / size), size=n
        )
    return w


def _mean(e: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.mean(e, axis=-1), dtype=np.float64)


def _weighted(e: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """The mean of ``e`` under each row of weights ``w``."""
    return np.asarray((w @ e) / w.sum(axis=1), dtype=np.float64)


def _segment_mean(errors: NDArray[np.float64], w: NDArray[np.float64]) -> Estimate:
    value = float(_mean(errors))
    if errors.size < 2:
        return Estimate(value, math.nan, math.nan)
    lo, hi = np.percentile(_weighted(errors, w), [2.5, 97.5])
    return Estimate(value, float(lo), float(hi))


def _paired_ratio(
    a: NDArray[np.float64], b: NDArray[np.float64], w: NDArray[np.float64]
) -> Estimate:
    """Mean of a / mean of b on the same segments; the same resamples for both."""
    rb = float(_mean(b))
    value = float(_mean(a)) / rb if rb > 0 else (1.0 if float(_mean(a)) == 0 else math.inf)
    if a.size < 2:
        return Estimate(value, math.nan, math.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        boot = _weighted(a, w) / _weighted(b, w)
    boot = np.where(np.isnan(boot), 1.0, boot)  # 0/0: both exact on that resample
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return Estimate(value, float(lo), float(hi))


#: Residual variance floor of the BIC (m^2, 1 um RMS): below any ground truth's resolution. A
#: noiseless (simulated) fit would otherwise score -inf; at the floor, fits that are all exact
#: tie on the residuals and the parameter count decides.
BIC_VARIANCE_FLOOR = 1e-12


def _bic(rss: NDArray[np.float64], sizes: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """BIC over axis -1 sums (works on bootstrap matrices)."""
    n = sizes.sum(axis=-1)
    variance = np.maximum(rss.sum(axis=-1) / n, BIC_VARIANCE_FLOOR)
    return np.asarray(n * np.log(variance) + k * np.log(n), dtype=np.float64)


def _fit(
    runs: Sequence[PreparedRun], nominal: RobotParams, options: LsqOptions, model: str
) -> tuple[LsqCalibration | None, str | None]:
    try:
        return calibrate_lsq(runs, nominal, replace(options, model=model)), None
    except (CalibrationError, InsufficientDataError) as err:
        return None, str(err)


def _metrics(run: OdometryRun, params: RobotParams) -> dict[str, float]:
    ev = evaluate_run(run, params, RUN_OPTIONS).evaluation
    return {
        "endpoint_error": ev.drift.endpoint_error,
        "rpe_rmse": ev.rpe.rmse,
        "drift_pct": ev.drift.translation_pct,
        "drift_deg_per_m": ev.drift.rotation_deg_per_m,
    }


def _segment_bounds(ref: Trajectory) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Consecutive, non-overlapping segments ``(i, j)`` of a trajectory: each ends where it has
    driven :data:`SEGMENT_M` of path or turned :data:`SEGMENT_RAD`, whichever comes first."""
    from odolab.metrics.pose_error import path_distances, turn_distances

    dist = np.asarray(path_distances(ref), dtype=np.float64)
    turn = np.asarray(turn_distances(ref), dtype=np.float64)
    starts: list[int] = []
    ends: list[int] = []
    i, n = 0, len(dist)
    while i < n - 1:
        reach = np.flatnonzero(
            (dist[i + 1 :] - dist[i] >= SEGMENT_M) | (turn[i + 1 :] - turn[i] >= SEGMENT_RAD)
        )
        if reach.size == 0:
            break
        j = i + 1 + int(reach[0])
        starts.append(i)
        ends.append(j)
        i = j
    return np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64)


def segment_errors(
    run: OdometryRun, params: RobotParams, smooth_s: float = 0.0
) -> NDArray[np.float64]:
    """The error (m) of ``params``' odometry on each segment of the run (see
    :func:`_segment_bounds`; they depend on the ground truth only, so every model is scored on
    the same ones): ``sqrt(e_t^2 + (SEGMENT_M e_r)^2)``, the relative pose's translation error
    ``e_t`` (m) and its heading error ``e_r`` (rad) weighted as the sideways error it makes over
    the next :data:`SEGMENT_M` of driving (turns in place count too). ``smooth_s`` > 0: each
    segment's end poses are the truth fitted over that many seconds either side
    (:func:`truth_near`), for a noisy truth (:class:`SegmentTruth`)."""
    return _segment_errors(run, params, (smooth_s,))[0]


def _segment_errors(
    run: OdometryRun, params: RobotParams, smooth: Sequence[float]
) -> list[NDArray[np.float64]]:
    """:func:`segment_errors` for each of ``smooth``, from one odometry of the run."""
    from odolab.metrics.alignment import align
    from odolab.metrics.association import associate
    from odolab.metrics.pose_error import rpe_errors

    o = RUN_OPTIONS
    ref, est = associate(
        run.require_ground_truth(), run.odometry(params), method=o.sync, max_diff=o.max_diff
    )
    est, _ = align(ref, est, o.alignment)
    i, j = _segment_bounds(ref)
    out: list[NDArray[np.float64]] = []
    for h in smooth:
        if i.size == 0:
            out.append(np.zeros(0))
            continue
        et, er = rpe_errors(truth_near(ref, est, np.union1d(i, j), h) if h > 0 else ref, est, i, j)
        out.append(np.asarray(np.hypot(et, SEGMENT_M * er), dtype=np.float64))
    return out


def truth_near(ref: Trajectory, est: Trajectory, at: NDArray[np.int64], half: float) -> Trajectory:
    """``ref`` with its poses at the indices ``at`` replaced by the truth estimated from its
    poses within ``half`` seconds either side (``ref`` and ``est`` on the same stamps).

    Near an instant ``i``, the truth differs from ``est`` by a rigid motion that changes slowly:
    a heading offset ``phi_k = h_ref_k - h_est_k`` and, about ``est``'s own position at ``i``,
    a shift ``c_k = p_ref_k - p_est_i - R(phi_k) (p_est_k - p_est_i)``. A model that has drifted
    by a fixed rotation and shift has the same ``phi`` and ``c`` at every ``k``, turning or
    not. Each is fitted by a straight line in time over the window and taken at ``t_i`` (the
    window's mean where the stamps are even), so the truth's noise is averaged over the window's
    updates; the end pose is then ``p_est_i + c``, ``h_est_i + phi``. The window is symmetric,
    shortened at a run's ends (none at the first and last stamp)."""
    from odolab.core.kinematics import wrap_angle

    t = np.asarray(ref.t, dtype=np.float64)
    phi = np.unwrap(wrap_angle(ref.heading - est.heading))
    cos, sin = np.cos(phi), np.sin(phi)
    # c_k = (p_ref_k - R(phi_k) p_est_k) - p_est_i + R(phi_k) p_est_i: window lines of the
    # per-stamp parts, combined at each i
    gx = ref.x - (cos * est.x - sin * est.y)
    gy = ref.y - (sin * est.x + cos * est.y)
    reach = np.minimum(half, np.minimum(t[at] - t[0], t[-1] - t[at]))
    lo = np.minimum(np.searchsorted(t, t[at] - reach, side="left"), at)
    hi = np.maximum(np.searchsorted(t, t[at] + reach, side="right"), at + 1)
    fit = _window_lines(t - t[0], lo, hi, t[at] - t[0])
    dh, mx, my, mc, ms = (fit(v) for v in (phi, gx, gy, cos, sin))
    ex, ey = est.x[at], est.y[at]
    x, y, h = (np.array(v, dtype=np.float64) for v in (ref.x, ref.y, ref.heading))
    x[at] = mx + mc * ex - ms * ey
    y[at] = my + ms * ex + mc * ey
    h[at] = est.heading[at] + dh
    return Trajectory.from_xyh(t, x, y, h)


def _window_lines(
    t: NDArray[np.float64], lo: NDArray[np.int64], hi: NDArray[np.int64], at: NDArray[np.float64]
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """For windows ``[lo, hi)`` of the stamps ``t``: a function giving, for a series, each
    window's least-squares line in time taken at ``at`` (the window's mean where its stamps
    are symmetric about ``at``; the mean where there is one stamp)."""

    def sums(v: NDArray[np.float64]) -> NDArray[np.float64]:
        c = np.concatenate(([0.0], np.cumsum(v)))
        return c[hi] - c[lo]

    n = (hi - lo).astype(np.float64)
    mt = sums(t) / n
    var = np.maximum(sums(t * t) / n - mt * mt, 0.0)
    spread = var > 1e-12 * np.maximum(mt * mt, 1.0)

    def fit(v: NDArray[np.float64]) -> NDArray[np.float64]:
        mv = sums(v) / n
        slope = np.where(spread, (sums(t * v) / n - mt * mv) / np.where(spread, var, 1.0), 0.0)
        return np.asarray(mv + slope * (at - mt), dtype=np.float64)

    return fit


def _score(
    run: OdometryRun, params: RobotParams
) -> tuple[dict[str, float], list[float], list[float]]:
    raw, smooth = _segment_errors(run, params, (0.0, SMOOTH_S))
    return _metrics(run, params), raw.tolist(), smooth.tolist()


def _check_seed(seed: int) -> None:
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CalibrationError(f"seed is {seed!r}; expected an integer >= 0")


def compare_models(
    train: Sequence[OdometryRun],
    held_out: Sequence[OdometryRun] = (),
    nominal: RobotParams | None = None,
    *,
    models: Sequence[str] = DEFAULT_MODELS,
    options: LsqOptions | None = None,
    folds: int = 5,
    n_boot: int = 2000,
    seed: int = 0,
    curve: Sequence[float] = (),
) -> ModelComparison:
    """Fit every model on ``train`` and score it on ``held_out`` (see the module).

    Without ``held_out`` the runs of ``train`` are split into ``min(folds, len(train))`` folds
    (run i in fold i mod k); each fold is held out once from a fit on the others.
    ``curve`` (seconds): also the learning curve, each model fitted on the first that many
    seconds of ``train[0]`` (an exploration run) and its mean end-point error on the held-out
    runs (:func:`learning_curve`)."""
    o = options or LsqOptions()
    _check_seed(seed)
    if not train:
        raise InsufficientDataError("no runs to compare the models on; expected at least one")
    for m in models:
        fit_model(m)
    order = [m for m in MODEL_ORDER if m in models] + [m for m in models if m not in MODEL_ORDER]
    base = nominal or train[0].params
    if base is None:
        raise CalibrationError(f"{train[0].source}: the run has no nominal parameters")
    _check_curve(curve, train[0])
    prepared = [prepare_run(r, o.segment_s) for r in train]
    rng = np.random.default_rng(seed)
    cv = not held_out
    fold_of: list[int] | None = None
    if cv:
        k = min(folds, len(train))
        if k < 2:
            raise InsufficientDataError(
                "one run cannot be both fitted and held out; expected at least two runs or "
                "held-out runs ({{validate}})"
            )
        test_runs = list(train)
        fold_of = [i % k for i in range(len(train))]
    else:
        test_runs = list(held_out)
        names = {r.source for r in train} & {r.source for r in held_out}
        if names:
            raise CalibrationError(
                f"{sorted(names)[0]} is both a training and a held-out run; expected held-out runs"
            )
    scores = [_score_model(model, prepared, base, o, test_runs, fold_of) for model in order]
    if all(sc.problem is not None for sc in scores):
        why: dict[str, list[str]] = {}
        for sc in scores:
            why.setdefault(str(sc.problem), []).append(sc.model)
        raise CalibrationError(
            f"no model could be fitted to these runs with segments of {o.segment_s:g} s: "
            + "; ".join(f"{', '.join(ms)}: {problem}" for problem, ms in why.items())
        )
    noise = held_out_truth_noise(test_runs, o)
    result = _recommend(scores, train, test_runs, cv, rng, n_boot, noise)
    if curve:
        curve_rows = learning_curve(train[0], test_runs, base, tuple(curve), tuple(order))
        result = replace(result, learning_curve=[dict(r) for r in curve_rows])
    return result


def parse_curve(text: str) -> tuple[float, ...]:
    """The learning curve's seconds from a face's text (``10,20,30,60``; empty: none), each a
    positive number (:func:`compare_runs` checks them against the training run)."""
    items = [x.strip() for x in text.split(",")] if text.strip() else []
    curve: list[float] = []
    for item in items:
        if not item:
            raise CalibrationError(
                f"{opt('learning_curve')} {text!r} has an empty item; expected seconds "
                "separated by commas, e.g. 10,20,30,60",
                option="learning_curve",
                value=text,
                allowed="seconds separated by commas, e.g. 10,20,30,60",
            )
        try:
            value = float(item)
        except ValueError:
            value = math.nan
        _check_seconds(value, item)
        curve.append(value)
    return tuple(curve)


def _check_seconds(seconds: float, given: object) -> None:
    """One learning-curve point: a positive number of seconds (``given``: as the user wrote it)."""
    if not (math.isfinite(seconds) and seconds > 0):
        raise CalibrationError(
            f"{opt('learning_curve')}: {given!r} is not a positive number of seconds; expected "
            "e.g. 10,20,30,60",
            option="learning_curve",
            value=given,
            allowed="a positive number of seconds, e.g. 10,20,30,60",
        )


def learning_curve(
    exploration: object,
    held_out: Sequence[object],
    nominal: RobotParams,
    seconds: Sequence[float] = (10.0, 20.0, 30.0, 45.0, 60.0),
    models: Sequence[str] = ("diff", "icr", "slip"),
) -> list[dict[str, object]]:
    """Held-out mean end-point error (m) of each model fitted on the first ``s`` seconds of an
    exploration run, for each ``s``: rows ``{"seconds", "model", "endpoint_error", "problem"}``
    (``endpoint_error`` None where the model could not be fitted, ``problem`` says why)."""
    from odolab.calibration.slipfit import endpoint_error, first_seconds

    rows: list[dict[str, object]] = []
    for s in seconds:
        part = first_seconds(exploration, s)
        for m in models:
            try:
                fit = calibrate_lsq([part], nominal, LsqOptions(model=m))  # type: ignore[list-item]
            except (CalibrationError, InsufficientDataError) as err:
                rows.append({"seconds": s, "model": m, "endpoint_error": None, "problem": str(err)})
                continue
            errs = [endpoint_error(r, fit.params) for r in held_out]
            rows.append(
                {"seconds": s, "model": m, "endpoint_error": float(np.mean(errs)), "problem": None}
            )
    return rows


def _score_model(
    model: str,
    prepared: list[PreparedRun],
    base: RobotParams,
    o: LsqOptions,
    test_runs: Sequence[OdometryRun],
    fold_of: list[int] | None,
) -> ModelScore:
    """``model`` fitted on ``prepared`` and scored on ``test_runs`` (``fold_of``: each test
    run's fold in cross-validation, scored by the fit without its fold; None: held-out runs)."""
    fit, problem = _fit(prepared, base, o, model)
    if fit is None:
        return ModelScore(model, len(FIT_MODELS[model].names), None, problem)
    rows: list[tuple[dict[str, float], list[float], list[float]]] = []
    if fold_of is not None:
        fold_params: dict[int, RobotParams] = {}
        for f in sorted(set(fold_of)):
            part = [p for p, g in zip(prepared, fold_of, strict=True) if g != f]
            fold_fit, fold_problem = _fit(part, base, o, model)
            if fold_fit is None:
                problem = f"fold {f + 1}: {fold_problem}"
                break
            fold_params[f] = fold_fit.params
        if problem is None:
            rows = [_score(r, fold_params[g]) for r, g in zip(test_runs, fold_of, strict=True)]
    else:
        rows = [_score(r, fit.params) for r in test_runs]
    if problem is not None:
        return ModelScore(model, len(fit.stderr), fit, problem)
    per_run = {m: [row[m] for row, _, _ in rows] for m in _METRICS}
    held = {m: _t_interval(np.array(v, dtype=np.float64)) for m, v in per_run.items()}
    bic = float(_bic(np.array(fit.run_rss), np.array(fit.run_sizes, float), fit.n_params))
    return ModelScore(
        model, len(fit.stderr), fit, None, per_run, held, bic,
        segment_errors=[seg for _, seg, _ in rows],
        smoothed_errors=[seg for _, _, seg in rows],
    )  # fmt: skip


def _check_curve(curve: Sequence[float], run: OdometryRun) -> None:
    """The learning curve's seconds: positive, each once, none beyond the first training run
    (a point past its end was the whole run under another label)."""
    t = np.asarray(run.t, dtype=np.float64)
    span = float(t[-1] - t[0]) if t.size else 0.0
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    seen: set[float] = set()
    for s in curve:
        _check_seconds(s, s)
        if s in seen:
            raise CalibrationError(
                f"{opt('learning_curve')}: {s:g} s is given twice; expected each once"
            )
        seen.add(s)
        if s > span + step:
            raise CalibrationError(
                f"{opt('learning_curve')}: {s:g} s is longer than the first training run "
                f"{run.source} ({span:.4g} s); expected at most its length"
            )


#: The kinematic models (the per-run risk of the others is counted against the best of them).
KINEMATIC = ("diff", "extended", "icr")
#: Two mean errors this close (relative) tie: two fits that reach the same model (the extended
#: model with its extra terms at zero is the differential drive) differ only by rounding.
TIE = 1e-6


def _best(scores: Sequence[ModelScore], errors: dict[str, NDArray[np.float64]]) -> ModelScore:
    """The model with the lowest mean segment error; of models that tie with it (``TIE``), the
    one with the fewest parameters, so that which is best does not hang on the last bit."""
    mean = {s.model: float(_mean(errors[s.model])) for s in scores}
    low = min(mean.values())
    tied = [s for s in scores if mean[s.model] <= low * (1.0 + TIE)] or list(scores)
    return min(tied, key=lambda s: s.n_params)


def _runs_worse(s: ModelScore, best_kin: ModelScore | None) -> tuple[int, int] | None:
    """On how many held-out runs with segments ``s``'s mean segment error is above
    ``best_kin``'s, and of how many (None for that model itself)."""
    if best_kin is None or s.model == best_kin.model:
        return None
    pairs = [
        (float(np.mean(a)), float(np.mean(b)))
        for a, b in zip(s.segment_errors, best_kin.segment_errors, strict=True)
        if len(a)
    ]
    # (above by more than TIE: two fits of the same model to rounding tie)
    return sum(a > b * (1.0 + TIE) for a, b in pairs), len(pairs)


def _ratio_text(r: Estimate) -> str:
    return f"{r.value:.3f}, 95 % CI [{r.low:.3f}, {r.high:.3f}]"


def _recommend(
    scores: list[ModelScore],
    train: Sequence[OdometryRun],
    test_runs: Sequence[OdometryRun],
    cv: bool,
    rng: np.random.Generator,
    n_boot: int,
    noise: TruthNoise | None = None,
) -> ModelComparison:
    ok = [s for s in scores if s.problem is None]
    if not ok:
        raise CalibrationError(
            "no model could be fitted to these runs: " + "; ".join(str(s.problem) for s in scores)
        )
    truth = segment_truth(ok, noise)
    if truth is not None and truth.smoothed_s > 0:
        scores = [replace(s, segment_errors=s.smoothed_errors) if s.problem is None else s
                  for s in scores]  # fmt: skip
        ok = [s for s in scores if s.problem is None]
    sizes = [len(e) for e in ok[0].segment_errors]
    n_segments = sum(sizes)
    errors = {
        s.model: np.array([e for run in s.segment_errors for e in run], dtype=np.float64)
        for s in ok
    }
    idx = _resample_weights(sizes, rng, n_boot)
    train_idx = rng.integers(0, len(train), size=(n_boot, len(train)))
    out = _verdicts(scores, errors, idx, train_idx, n_segments)
    fitted = [s for s in out if s.problem is None]
    best = next(s for s in fitted if s.verdict == "best") if n_segments else fitted[0]
    what = f"{n_segments} held-out segments ({SEGMENT_M:g} m or {math.degrees(SEGMENT_RAD):g} deg)"
    if n_segments < MIN_SEGMENTS:
        recommended = UNDECIDED
        reason = (
            f"undecided: {what}; expected at least {MIN_SEGMENTS} to compare the models on "
            "(longer or more held-out runs)"
        )
    else:
        recommended, reason = _choose(fitted, best, what)
        recommended, reason = _never_worse(out, errors, idx, recommended, reason, what)
    return ModelComparison(
        out,
        recommended,
        reason,
        [r.name for r in train],
        [r.name for r in test_runs],
        cv,
        best=best.model,
        segments=n_segments,
        truth=truth,
    )


def held_out_truth_noise(runs: Sequence[OdometryRun], o: LsqOptions) -> TruthNoise | None:
    """The noise of the held-out runs' ground truth: the user's (``o.truth_sigma``), else
    estimated from its own updates (None where ``o.truth_noise`` is off or there are too few)."""
    from odolab.metrics.consistency import runs_truth_noise

    return runs_truth_noise(runs, o.truth_sigma, o.truth_noise)


def segment_truth(ok: Sequence[ModelScore], noise: TruthNoise | None) -> SegmentTruth | None:
    """Whether the fitted models' held-out segments are scored against the truth fitted near
    their ends (see :class:`SegmentTruth`): where the truth's noise is more than
    :data:`NOISE_SHARE` of the best model's mean squared segment error (None: no noise known,
    or no segments)."""
    errors = [np.array([e for run in s.segment_errors for e in run], dtype=np.float64) for s in ok]
    if noise is None or not errors or errors[0].size == 0:
        return None
    added = 4.0 * noise.xy**2 + 3.0 * (SEGMENT_M * noise.yaw) ** 2
    best = min(float(np.mean(e * e)) for e in errors)
    share = added / best if best > 0 else (math.inf if added > 0 else 0.0)
    return SegmentTruth(noise, share, SMOOTH_S if share > NOISE_SHARE else 0.0)


def _verdicts(
    scores: list[ModelScore],
    errors: dict[str, NDArray[np.float64]],
    idx: NDArray[np.float64],
    train_idx: NDArray[np.int64],
    n_segments: int,
) -> list[ModelScore]:
    """Every fitted model's mean segment error, ratio to the best, verdict, BIC against the
    differential drive and per-run risk against the best kinematic model (see the module)."""
    ok = [s for s in scores if s.problem is None]
    best = _best(ok, errors) if n_segments else ok[0]
    kinematic = [s for s in ok if s.model in KINEMATIC]
    best_kin = _best(kinematic, errors) if kinematic and n_segments else None
    diff = next((s for s in ok if s.model == "diff"), None)
    out: list[ModelScore] = []
    for s in scores:
        if s.problem is not None or s.fit is None:
            out.append(s)
            continue
        ratio = segment = None
        verdict = UNDECIDED
        if n_segments:
            segment = _segment_mean(errors[s.model], idx)
            ratio = _paired_ratio(errors[s.model], errors[best.model], idx)
            if s.model == best.model:
                verdict = "best"
            elif n_segments >= MIN_SEGMENTS and ratio.high <= 1.0 + NOT_WORSE:
                verdict = "not worse"
            elif n_segments >= MIN_SEGMENTS and ratio.low > 1.0:
                verdict = "worse"
        dbic = None
        if diff is not None and diff.fit is not None:
            rss_m, size_m = np.array(s.fit.run_rss), np.array(s.fit.run_sizes, float)
            rss_d, size_d = np.array(diff.fit.run_rss), np.array(diff.fit.run_sizes, float)
            boot = _bic(rss_m[train_idx], size_m[train_idx], s.fit.n_params) - _bic(
                rss_d[train_idx], size_d[train_idx], diff.fit.n_params
            )
            lo, hi = np.percentile(boot, [2.5, 97.5])
            dbic = Estimate(s.bic - diff.bic, float(lo), float(hi))
        risk = _runs_worse(s, best_kin)
        out.append(
            replace(
                s,
                delta_bic=dbic,
                ratio_to_best=ratio,
                segment_error=segment,
                verdict=verdict,
                runs_worse=risk,
            )
        )
    return out


def _choose(fitted: list[ModelScore], best: ModelScore, what: str) -> tuple[str, str]:
    """The simplest model not worse than the best, or "undecided" (see the module), and why."""
    chosen: ModelScore | None = None
    worse: list[ModelScore] = []
    for s in fitted:  # simplest first
        if s.verdict in ("best", "not worse"):
            chosen = s
            break
        if s.verdict == "worse":
            worse.append(s)
            continue
        break  # undecided: cannot say whether this simpler model suffices
    if chosen is None:
        s = next(x for x in fitted if x.verdict == UNDECIDED)
        assert s.ratio_to_best is not None
        return UNDECIDED, (
            f"undecided: on {what}, {s.model}'s segment error relative to {best.model}'s is "
            f"{_ratio_text(s.ratio_to_best)}: the data allow it to be as good and to be more "
            f"than {NOT_WORSE:.0%} worse; more held-out runs would decide"
        )
    if chosen.model == best.model:
        reason = f"{best.model} has the lowest mean error on {what}"
        if worse:
            reason += "; " + ", ".join(
                f"{w.model} is worse (error ratio {_ratio_text(w.ratio_to_best)})"
                for w in worse
                if w.ratio_to_best is not None
            )
        return best.model, reason
    r = chosen.ratio_to_best
    assert r is not None
    return chosen.model, (
        f"{chosen.model} is not worse than {best.model} on {what} (error ratio "
        f"{_ratio_text(r)}, within {NOT_WORSE:.0%}) and is simpler"
    )


def _never_worse(
    out: list[ModelScore],
    errors: dict[str, NDArray[np.float64]],
    idx: NDArray[np.float64],
    recommended: str,
    reason: str,
    what: str,
) -> tuple[str, str]:
    """A learned (not kinematic) model is recommended only where it is not worse than the best
    kinematic model on the held-out data by either measure that reaches beyond one segment:
    the mean end-point error of the held-out runs, and on most of them one by one
    (:attr:`ModelScore.runs_worse`). Where it is, the choice among the kinematic models alone
    stands instead (its verdicts against their own best), and the reason says why."""
    rec = next((x for x in out if x.problem is None and x.model == recommended), None)
    kin = [x for x in out if x.problem is None and x.model in KINEMATIC]
    if rec is None or rec.model in KINEMATIC or not kin:
        return recommended, reason
    best_kin = _best(kin, errors)
    if rec.runs_worse:
        k, n = rec.runs_worse
        reason += (
            f"; per run, {rec.model} is worse than {best_kin.model} (the best kinematic model) "
            f"on {k} of {n} held-out runs"
        )
    end = {s.model: s.held_out["endpoint_error"].value for s in (rec, *kin) if s.held_out}
    kin_end = min((v for m, v in end.items() if m in KINEMATIC), default=math.nan)
    by_run = rec.runs_worse is not None and rec.runs_worse[0] * 2 > rec.runs_worse[1]
    by_end = math.isfinite(end.get(rec.model, math.nan)) and end[rec.model] > kin_end
    if not (by_run or by_end):
        return recommended, reason
    why = (
        f"its held-out mean end-point error {end[rec.model]:.3g} m is above the best "
        f"kinematic model's {kin_end:.3g} m"
        if by_end
        else f"it is worse than {best_kin.model} on most held-out runs"
    )
    ranked = [_rescored(s, errors, idx, best_kin) for s in kin]
    choice, because = _choose(ranked, ranked[kin.index(best_kin)], what)
    return choice, (
        f"{rec.model} has the lowest mean segment error, but {why}: a learned model is not "
        f"recommended where it is worse than the best kinematic one; among the kinematic "
        f"models, {because}"
    )


def _rescored(
    s: ModelScore, errors: dict[str, NDArray[np.float64]], idx: NDArray[np.float64],
    best: ModelScore,
) -> ModelScore:  # fmt: skip
    """``s``'s verdict against ``best`` (the best kinematic model) instead of the best of all."""
    ratio = _paired_ratio(errors[s.model], errors[best.model], idx)
    if s.model == best.model:
        verdict = "best"
    elif ratio.high <= 1.0 + NOT_WORSE:
        verdict = "not worse"
    elif ratio.low > 1.0:
        verdict = "worse"
    else:
        verdict = UNDECIDED
    return replace(s, ratio_to_best=ratio, verdict=verdict)


@dataclass(frozen=True)
class _ReadJob:
    path: Path
    fmt: LogFormat
    options: ReadOptions


def _read(job: _ReadJob) -> OdometryRun:
    return read_run(job.path, job.fmt, job.options)


def compare_model_files(
    paths: Sequence[str | Path],
    fmt: LogFormat | str,
    *,
    validate: Sequence[str | Path] = (),
    nominal: RobotParams | None = None,
    models: Sequence[str] = DEFAULT_MODELS,
    options: LsqOptions | None = None,
    read_options: ReadOptions | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    seed: int = 0,
    curve: Sequence[float] = (),
    where: list[str] | None = None,
) -> ModelComparison:
    """:func:`compare_models` on every run found under ``paths`` (and ``validate``). ``where``
    (when given) gets where odolab chose to read them, and why
    (:func:`odolab.metrics.runs.parallel_map`)."""
    _check_seed(seed)  # before any file is read
    f = LogFormat(fmt)
    ro = read_options or ReadOptions()
    train_paths, held_paths = find_fit_and_held_out(paths, validate, f)
    jobs = [_ReadJob(p, f, ro) for p in [*train_paths, *held_paths]]
    runs = parallel_map(
        _read, jobs, workers=workers, progress=progress, label=lambda j: str(j.path),
        where=where, what="the runs read",
    )  # fmt: skip
    train, held = runs[: len(train_paths)], runs[len(train_paths) :]
    return compare_models(
        train, held, nominal, models=models, options=options, seed=seed, curve=curve
    )
