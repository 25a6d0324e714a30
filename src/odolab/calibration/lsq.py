"""Least-squares calibration of wheel radii and track width from runs with ground truth.

Parameters ``theta = (left_wheel_radius, right_wheel_radius, track_width)`` for the differential
drive (``model="diff"``); the other kinematic models of :mod:`odolab.core.models` fit their own
(:data:`FIT_MODELS`): ``extended`` its scales and track factor with the radii held (they multiply
the radii, so both cannot be fitted), ``icr`` both radii and the three ICR coordinates
(``y_icr_left``, ``y_icr_right``, ``x_icr``). Each run is cut into
segments of ``segment_s`` seconds; for a segment from sample i to j the residual is the odometry's
relative motion minus the ground truth's, both in the segment's start frame::

    r = [ R(h_i)^T (p_j - p_i) - R(g_i)^T (q_j - q_i),        (m, 2 values)
          heading_scale * ((h_j - h_i) - (g_j - g_i)) ]       (rad -> m, 1 value)

where p, h are odometry positions and heading (integrated with theta) and q, g the ground truth
interpolated at the odometry stamps. ``heading_scale`` (m/rad, default half the nominal track
width: the wheel travel that the heading error stands for) puts both kinds in metres.
:func:`scipy.optimize.least_squares` minimises the sum of squares; standard errors come from the
Jacobian at the solution, ``sqrt(diag((J^T J)^-1) s^2)`` with ``s^2 = sum r^2 / (m - k)``: segments
use disjoint encoder increments, so treating their residuals as independent is reasonable, but
the numbers are only as good as that assumption.

A parameter the runs cannot determine (its Jacobian column is, within 1e-4 of its variance, a
combination of the others: variance inflation above 1e4; or its standard error is above 5 % of
its size, for ``x_icr`` of a tenth of the track width) stops the fit with one sentence naming it,
its standard error and what data would determine it (models other than the differential drive,
which keeps its original sentence).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.errors import CalibrationError, InsufficientDataError, opt
from odolab.core.kinematics import Method
from odolab.core.models import DIFF_DRIVE, ExtendedDiffDrive, IcrModel, SlipModel, neutral_values
from odolab.core.models.slip import DRIFT_KEYS, NOISE_KEYS
from odolab.core.odometry import integrate_increments
from odolab.core.params import RobotParams, plausible_range
from odolab.io.registry import LogFormat, find_runs, read_run
from odolab.io.run import OdometryRun, ReadOptions
from odolab.metrics.association import interpolate_trajectory
from odolab.metrics.cluster import Cluster, one_local_cluster
from odolab.metrics.runs import RUN_OPTIONS, Progress, RunEvaluation, evaluate_run, parallel_map
from odolab.metrics.truthnoise import (
    TruthNoise,
    allowed,
    truth_residuals,
    variance_factors,
)

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult

__all__ = [
    "FIT_MODELS",
    "LOSSES",
    "PARAM_NAMES",
    "FitModel",
    "LsqCalibration",
    "LsqOptions",
    "PreparedRun",
    "Provenance",
    "RunComparison",
    "calibrate_lsq",
    "calibrate_lsq_files",
    "compare_runs",
    "kinematic_base",
    "prepare_run",
    "segment_residuals",
    "slip_truth_noise",
]

PARAM_NAMES = ("left_wheel_radius", "right_wheel_radius", "track_width")

#: variance inflation factor above which a parameter counts as not determined by the runs (the
#: others explain the same motion: the runs lack the motion that tells it apart)
_VIF_LIMIT = 100.0
#: a standard error above this fraction of the parameter's typical size (its value; 0.1 x the
#: track width for x_icr) is said: the parameter is fitted but poorly determined (the runs'
#: noise, or the model's misfit, is large for what they contain)
_SE_LIMIT = 0.05


@dataclass(frozen=True)
class FitModel:
    """What :func:`calibrate_lsq` fits for one kinematic model: names, start, bounds, scales."""

    kind: str
    names: tuple[str, ...]
    #: what data determines each parameter (for the "not identifiable" sentence)
    needs: tuple[str, ...]

    def start(self, nominal: RobotParams) -> FloatArray:
        """The start values: the nominal parameters (the neutral model where it has none)."""
        v = self.values(nominal)
        return np.array([v[k] for k in self.names], dtype=np.float64)

    def values(self, params: RobotParams) -> dict[str, float]:
        """This model's fitted quantities as ``params`` has them (neutral for other models)."""
        b = params.track_width
        model = params.model
        out = {
            "left_wheel_radius": params.left_wheel_radius,
            "right_wheel_radius": params.right_wheel_radius,
            "track_width": b,
        }
        out.update(neutral_values(model, b))  # its own kind's values, the others' neutral ones
        return {k: out[k] for k in self.names}

    def bounds(self, x0: FloatArray, nominal: RobotParams) -> tuple[FloatArray, FloatArray]:
        """Lower and upper bounds of each parameter."""
        b = nominal.track_width
        fixed = {
            "y_icr_left": (1e-3 * b, 4.0 * b),
            "y_icr_right": (-4.0 * b, -1e-3 * b),
            "x_icr": (-2.0 * b, 2.0 * b),
        }
        pairs = [fixed.get(n, (0.5 * v, 2.0 * v)) for n, v in zip(self.names, x0, strict=True)]
        # inside the plausible ranges, or the solver tries parameters that refuse to be built
        ranges = [plausible_range(n) for n in self.names]
        lower = [max(p[0], r[0]) for p, r in zip(pairs, ranges, strict=True)]
        upper = [min(p[1], r[1]) for p, r in zip(pairs, ranges, strict=True)]
        return np.array(lower), np.array(upper)

    def scales(self, x0: FloatArray, nominal: RobotParams) -> FloatArray:
        """Typical size of each parameter (step of the numerical Jacobian, solver scaling)."""
        b = nominal.track_width
        return np.array(
            [0.1 * b if n == "x_icr" else abs(v) for n, v in zip(self.names, x0, strict=True)]
        )

    def params(self, template: RobotParams, theta: FloatArray) -> RobotParams:
        """``template`` with the fitted values ``theta`` (in :attr:`names` order)."""
        v = dict(zip(self.names, (float(t) for t in theta), strict=True))
        if self.kind == "diff":
            return template.with_(
                left_wheel_radius=v["left_wheel_radius"],
                right_wheel_radius=v["right_wheel_radius"],
                track_width=v["track_width"],
                model=DIFF_DRIVE,
            )
        if self.kind == "slip":
            return template.with_(model=SlipModel(**v))  # type: ignore[arg-type]
        if self.kind == "extended":
            return template.with_(
                model=ExtendedDiffDrive(v["scale_left"], v["scale_right"], v["track_scale"])
            )
        return template.with_(
            left_wheel_radius=v["left_wheel_radius"],
            right_wheel_radius=v["right_wheel_radius"],
            model=IcrModel(v["y_icr_left"], v["y_icr_right"], v["x_icr"]),
        )


_RADII_NEED = "straight driving"
#: The models :func:`calibrate_lsq` can fit, by ``kind``.
FIT_MODELS: dict[str, FitModel] = {
    "diff": FitModel("diff", PARAM_NAMES, (_RADII_NEED, _RADII_NEED, "turning")),
    "extended": FitModel(
        "extended",
        ("scale_left", "scale_right", "track_scale"),
        (_RADII_NEED, _RADII_NEED, "turning"),
    ),
    "icr": FitModel(
        "icr",
        ("left_wheel_radius", "right_wheel_radius", "y_icr_left", "y_icr_right", "x_icr"),
        (
            _RADII_NEED,
            _RADII_NEED,
            "turns with each track at several speeds (curves and pivots, not only turns in place)",
            "turns with each track at several speeds (curves and pivots, not only turns in place)",
            "turns of both signs at speed",
        ),
    ),
    # Bayesian linear regression (odolab.calibration.slipfit): the prior keeps every
    # coefficient finite, so none is reported as not identifiable
    "slip": FitModel("slip", SlipModel.COEF_KEYS, ("driving",) * len(SlipModel.COEF_KEYS)),
}


def fit_model(kind: str) -> FitModel:
    """The :class:`FitModel` of a model kind, or one clear sentence."""
    try:
        return FIT_MODELS[kind]
    except KeyError:
        raise CalibrationError(
            f"unknown model {kind!r} to fit; expected one of {', '.join(FIT_MODELS)}"
        ) from None


#: The losses of the kinematic fit (scipy's ``least_squares``): plain least squares and the
#: robust ones, which weigh a large residual less than its square.
LOSSES = ("linear", "huber", "soft_l1", "cauchy", "arctan")


@dataclass(frozen=True)
class LsqOptions:
    """Settings of the fit."""

    segment_s: float = 2.0
    heading_scale: float | None = None
    method: Method = Method.MIDPOINT
    loss: str = "linear"
    fit_gt_yaw_offset: bool = True
    model: str = "diff"
    #: the ground truth's noise, as the user gives it; None: estimated from
    #: the truth's own updates (:mod:`odolab.metrics.truthnoise`) where ``truth_noise``
    truth_sigma: TruthNoise | None = None
    #: whether the slip fit allows for the truth's noise at all
    truth_noise: bool = True

    def __post_init__(self) -> None:
        fit_model(self.model)
        if not (np.isfinite(self.segment_s) and self.segment_s > 0):
            raise CalibrationError(
                f"segment length is {self.segment_s!r} s; expected a positive number of seconds"
            )
        if self.loss not in LOSSES:
            raise CalibrationError(f"loss is {self.loss!r}; expected one of {', '.join(LOSSES)}")
        hs = self.heading_scale
        if hs is not None and not (np.isfinite(hs) and hs > 0):
            raise CalibrationError(f"heading scale is {hs!r} m/rad; expected a positive number")


@dataclass(frozen=True, eq=False)
class PreparedRun:
    """A run cut to its ground truth's time range, with ground truth at the odometry stamps."""

    name: str
    t: FloatArray
    dticks_left: FloatArray
    dticks_right: FloatArray
    gt_x: FloatArray
    gt_y: FloatArray
    gt_heading: FloatArray
    starts: NDArray[np.int64]
    ends: NDArray[np.int64]
    #: runs with one ``frame`` share one ground-truth yaw offset (the windows of one table were
    #: measured by one mounted sensor); "" means the run's own
    frame: str = ""
    #: the ground truth's real updates' deviations from their neighbours (position, heading)
    #: and the spacings between them: what its noise is estimated from
    #: (:func:`odolab.metrics.truthnoise.truth_residuals`)
    truth_xy: FloatArray = field(default_factory=lambda: np.zeros(0))
    truth_yaw: FloatArray = field(default_factory=lambda: np.zeros(0))
    truth_dt: FloatArray = field(default_factory=lambda: np.zeros(0))
    #: the truth's variance at each stamp per unit variance of a real update (1 at one, 0.5
    #: halfway between two: :func:`odolab.metrics.truthnoise.variance_factors`)
    truth_var: FloatArray = field(default_factory=lambda: np.zeros(0))

    def truth_parts(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(:attr:`truth_xy`, :attr:`truth_yaw`, :attr:`truth_dt`)."""
        return self.truth_xy, self.truth_yaw, self.truth_dt


def prepare_run(run: OdometryRun, segment_s: float = 2.0) -> PreparedRun:
    """Keep the samples inside the ground truth's time range; cut into ``segment_s`` segments."""
    if not (np.isfinite(segment_s) and segment_s > 0):
        raise CalibrationError(
            f"segment length is {segment_s!r} s; expected a positive number of seconds"
        )
    gt = run.require_ground_truth()
    inside = (run.t >= gt.t[0]) & (run.t <= gt.t[-1])
    idx = np.flatnonzero(inside)
    if idx.size < 2:
        raise InsufficientDataError(
            f"{run.source}: odometry ({run.t[0]:.6g}..{run.t[-1]:.6g} s) and ground truth "
            f"({gt.t[0]:.6g}..{gt.t[-1]:.6g} s) do not overlap in time; expected overlapping logs"
        )
    t = run.t[idx[0] : idx[-1] + 1]
    dl = run.dticks_left[idx[0] : idx[-1] + 1].copy()
    dr = run.dticks_right[idx[0] : idx[-1] + 1].copy()
    dl[0] = dr[0] = 0.0
    spacing = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    if segment_s < spacing * (1.0 - 1e-9):  # finer than the samples: empty segments, a huge grid
        raise CalibrationError(
            f"{run.source}: segment length {segment_s:g} s is shorter than the log's sample "
            f"spacing ({spacing:.3g} s); expected a segment length of at least {spacing:.3g} s"
        )
    g = interpolate_trajectory(gt, t)
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + segment_s, segment_s)))
    edges = edges[edges < t.size]
    if edges[-1] != t.size - 1:
        edges = np.append(edges, t.size - 1)
    if edges.size < 2:
        raise InsufficientDataError(f"{run.source}: too short for one {segment_s:g} s segment")
    txy, tyaw, tdt = truth_residuals(gt.t, gt.x, gt.y, gt.heading)
    tvar = variance_factors(gt.t, gt.x, gt.y, gt.heading, t)
    return PreparedRun(
        run.name,
        t,
        dl,
        dr,
        g.x,
        g.y,
        g.heading,
        edges[:-1].copy(),
        edges[1:].copy(),
        frame=str(run.meta.get("truth_frame", "")),
        truth_xy=txy,
        truth_yaw=tyaw,
        truth_dt=tdt,
        truth_var=tvar,
    )


def _relative(
    x: FloatArray, y: FloatArray, h: FloatArray, i: NDArray[np.int64], j: NDArray[np.int64]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    c, s = np.cos(h[i]), np.sin(h[i])
    dx, dy = x[j] - x[i], y[j] - y[i]
    return c * dx + s * dy, -s * dx + c * dy, h[j] - h[i]


def segment_residuals(
    theta: FloatArray,
    run: PreparedRun,
    template: RobotParams,
    heading_scale: float,
    method: Method = Method.MIDPOINT,
    gt_yaw_offset: float = 0.0,
    model: str = "diff",
) -> FloatArray:
    """Residuals of one run (shape (3k,) for k segments) at parameters ``theta``.

    ``theta`` holds the parameters of ``model`` (``FIT_MODELS[model].names``; for the
    differential drive the two radii and the track width).
    ``gt_yaw_offset`` (rad): the robot's forward axis as seen in the ground truth's body frame;
    the ground-truth displacement is expressed in the frame at heading ``g_i + gt_yaw_offset``.
    """
    spec = fit_model(model)
    p = spec.params(template, theta[: len(spec.names)])
    return _residuals(p, run, heading_scale, method, gt_yaw_offset)


def _residuals(
    params: RobotParams,
    run: PreparedRun,
    heading_scale: float,
    method: Method,
    gt_yaw_offset: float,
) -> FloatArray:
    """:func:`segment_residuals` with the parameters already built."""
    odo = integrate_increments(run.t, run.dticks_left, run.dticks_right, params, method)
    ox, oy, oh = _relative(odo.x, odo.y, odo.heading, run.starts, run.ends)
    gx, gy, gh = _relative(run.gt_x, run.gt_y, run.gt_heading + gt_yaw_offset, run.starts, run.ends)
    return np.concatenate((ox - gx, oy - gy, heading_scale * (oh - gh)))


def _difference(
    f: Callable[[float], FloatArray], value: float, h: float, lower: float, upper: float
) -> FloatArray:
    """Central difference of ``f`` at ``value`` with step ``h``; one-sided where a step would
    cross a bound (it would build parameters outside their plausible range)."""
    up, down = value + h <= upper, value - h >= lower
    if up and down:
        return (f(value + h) - f(value - h)) / (2.0 * h)
    if up:
        return (f(value + h) - f(value)) / h
    return (f(value) - f(value - h)) / h


@dataclass(frozen=True)
class RunComparison:
    """A held-out run evaluated with the nominal and with the calibrated parameters."""

    nominal: RunEvaluation
    calibrated: RunEvaluation

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary (end-point error, drift, APE rmse for both). A value that is
        undefined for the run (drift per metre of a run that turns in place) is ``None``, and
        ``notes`` says why."""

        def row(e: RunEvaluation) -> dict[str, object]:
            d = e.evaluation.drift
            values = {
                "endpoint_error": d.endpoint_error,
                "endpoint_heading_error": d.endpoint_heading_error,
                "drift_pct": d.translation_pct,
                "drift_deg_per_m": d.rotation_deg_per_m,
                "drift_rotation_pct_of_turn": d.rotation_pct_of_turn,
                "rpe_rmse": e.evaluation.rpe.rmse,
                "ape_rmse": e.evaluation.ape.rmse,
            }
            out: dict[str, object] = {k: None if math.isnan(v) else v for k, v in values.items()}
            out["notes"] = list(e.evaluation.notes)
            return out

        return {
            "name": self.nominal.name,
            "kind": self.nominal.kind,
            "nominal": row(self.nominal),
            "calibrated": row(self.calibrated),
        }


class Provenance(dict[str, object]):
    """A ``[provenance]`` table. Calling it returns itself: compatibility with the time when
    :attr:`LsqCalibration.provenance` was a method (``result.provenance()``)."""

    def __call__(self) -> Provenance:
        return self


@dataclass(frozen=True)
class LsqCalibration:
    """Result of :func:`calibrate_lsq`."""

    params: RobotParams
    nominal: RobotParams
    stderr: dict[str, float]
    covariance: FloatArray
    rms_before: float
    rms_after: float
    runs: list[str]
    segments: int
    heading_scale: float
    gt_yaw_offsets: list[float] = field(default_factory=list)
    validation: list[RunComparison] = field(default_factory=list)
    model: str = "diff"
    #: sum of squared residuals of each run at the solution (same order as ``runs``)
    run_rss: list[float] = field(default_factory=list)
    #: number of residuals of each run (same order as ``runs``)
    run_sizes: list[int] = field(default_factory=list)
    #: sentences on what the fit could not determine well (poorly determined parameters)
    warnings: list[str] = field(default_factory=list)
    #: sentences on what the fit chose for the user (the slip model's prior centre)
    notes: list[str] = field(default_factory=list)

    @property
    def n_params(self) -> int:
        """Number of fitted parameters (model and ground-truth yaw offsets)."""
        return len(self.stderr) + len(self.gt_yaw_offsets)

    @property
    def values(self) -> dict[str, float]:
        """The fitted parameters by name (as :attr:`stderr`)."""
        return fit_model(self.model).values(self.params)

    @property
    def nominal_values(self) -> dict[str, float]:
        """The same quantities in the nominal parameters (neutral for a model they lack)."""
        return fit_model(self.model).values(self.nominal)

    @property
    def provenance(self) -> Provenance:
        """The ``[provenance]`` table: a field, as in every other calibration result (calling it,
        as when it was a method, still works)."""
        return Provenance(self.provenance_table())

    def provenance_table(self) -> dict[str, object]:
        """A ``[provenance]`` table for the saved parameters file."""
        return {
            "method": (
                "Bayesian linear regression of the body slip on 0.5 s windows "
                "(odolab calibrate lsq, the slip model)"
                if self.model == "slip"
                else "least squares on segment relative motion (odolab calibrate lsq)"
            ),
            "model": self.model,
            "runs": self.runs,
            "segments": self.segments,
            "heading_scale_m_per_rad": self.heading_scale,
            "residual_rms_before": self.rms_before,
            "residual_rms_after": self.rms_after,
            "stderr": self.stderr,
            "gt_yaw_offsets_rad": self.gt_yaw_offsets,
            "warnings": self.warnings,
            "notes": self.notes,
            "nominal": self.nominal.to_dict(),
        }

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict."""
        return {
            "params": self.params.to_dict(),
            **self.provenance(),
            "validation": [v.to_dict() for v in self.validation],
        }


def calibrate_lsq(
    runs: Sequence[OdometryRun | PreparedRun],
    nominal: RobotParams,
    options: LsqOptions | None = None,
) -> LsqCalibration:
    """Fit the kinematic model ``options.model`` to the runs' ground truth (see the module).

    For the differential drive ``theta = (r_left, r_right, track_width)``. With a robust
    ``options.loss`` (``"huber"``, ``"soft_l1"``, ``"cauchy"``, ...: scipy's), the fit is made
    twice: by plain least squares, then with the loss at :data:`ROBUST_TUNING` times the plain
    fit's residuals' robust standard deviation (1.4826 times their median absolute deviation),
    so that a scan-matcher glitch of a metre weighs as a residual of that size, not squared."""
    o = options or LsqOptions()
    spec = fit_model(o.model)
    prepared = [r if isinstance(r, PreparedRun) else prepare_run(r, o.segment_s) for r in runs]
    if not prepared:
        raise InsufficientDataError("no runs to calibrate on; expected at least one run")
    scale = o.heading_scale if o.heading_scale is not None else nominal.track_width / 2.0
    if spec.kind == "slip":
        return _calibrate_slip(prepared, nominal, o, scale)
    problem = _Problem(spec, nominal, o, scale, prepared)
    return problem.result(problem.solve(), prepared)


#: A robust loss's scale: this many robust standard deviations of the plain fit's residuals
#: (Huber's 1.345: 95 % of least squares' efficiency on Gaussian residuals).
ROBUST_TUNING = 1.345


class _Problem:
    """One kinematic least-squares fit: the model's parameters and the ground-truth yaw
    offsets, the residuals and their Jacobian (see :func:`calibrate_lsq`)."""

    def __init__(
        self,
        spec: FitModel,
        nominal: RobotParams,
        o: LsqOptions,
        scale: float,
        prepared: list[PreparedRun],
    ) -> None:
        self.spec, self.nominal, self.o, self.scale = spec, nominal, o, scale
        self.k_model = len(spec.names)
        x0 = spec.start(nominal)
        lo, hi = spec.bounds(x0, nominal)
        # one offset a run, or a frame's runs share one (PreparedRun.frame); a frame's runs are
        # integrated as one (their residuals are the same, each segment in its own start frame)
        self.units, self.unit_runs = _units(prepared)
        self.n_off = n_off = len(self.units) if o.fit_gt_yaw_offset else 0
        self.x_scale = np.concatenate((spec.scales(x0, nominal), np.full(n_off, 0.01)))
        self.x0 = np.concatenate((x0, np.zeros(n_off)))
        self.lower = np.concatenate((lo, np.full(n_off, -0.5)))
        self.upper = np.concatenate((hi, np.full(n_off, 0.5)))
        parts0 = self.per_unit(self.x0)
        self.r0 = np.concatenate(parts0)
        self.m = self.r0.size
        if self.m <= self.x0.size:
            raise InsufficientDataError(
                f"{self.m} residuals for {self.x0.size} parameters; expected longer runs"
            )
        self.steps = 1e-6 * self.x_scale
        self.edges = np.cumsum([0] + [r.size for r in parts0])

    def per_unit(self, theta: FloatArray) -> list[FloatArray]:
        p = self.spec.params(self.nominal, theta[: self.k_model])  # built once for every run
        return [
            _residuals(
                p, u, self.scale, self.o.method, theta[self.k_model + k] if self.n_off else 0.0
            )
            for k, u in enumerate(self.units)
        ]

    def fun(self, theta: FloatArray) -> FloatArray:
        return np.concatenate(self.per_unit(theta))

    def jac(self, theta: FloatArray) -> FloatArray:
        # differences with steps fixed to each parameter's scale (see _difference)
        k_model, lower, upper, steps = self.k_model, self.lower, self.upper, self.steps
        cols = []
        for k in range(k_model):

            def moved(v: float, k: int = k) -> FloatArray:
                t = theta.copy()
                t[k] = v
                return self.fun(t)

            cols.append(_difference(moved, theta[k], steps[k], lower[k], upper[k]))
        # a ground-truth yaw offset moves only its unit's residuals: its column is zero
        # elsewhere (exactly, as the full difference gave), so only that unit is integrated
        p = self.spec.params(self.nominal, theta[:k_model])
        off_cols = [np.zeros(self.m) for _ in range(self.n_off)]
        for k, unit in enumerate(self.units[: self.n_off]):
            i = k_model + k

            def rotated(v: float, unit: PreparedRun = unit) -> FloatArray:
                return _residuals(p, unit, self.scale, self.o.method, v)

            off_cols[k][self.edges[k] : self.edges[k + 1]] = _difference(
                rotated, theta[i], steps[i], lower[i], upper[i]
            )
        cols.extend(off_cols)
        return np.column_stack(cols)

    def solve(self) -> OptimizeResult:
        """scipy's solution: plain least squares, then (a robust loss) the robust fit."""
        from scipy.optimize import least_squares

        bounds = (self.lower, self.upper)
        sol = least_squares(self.fun, self.x0, jac=self.jac, x_scale=self.x_scale, bounds=bounds)
        if sol.success and self.o.loss != "linear":
            r = sol.fun
            sd = 1.4826 * float(np.median(np.abs(r - np.median(r))))
            if sd > 0:
                sol = least_squares(
                    self.fun, sol.x, jac=self.jac, x_scale=self.x_scale, bounds=bounds,
                    loss=self.o.loss, f_scale=ROBUST_TUNING * sd,
                )  # fmt: skip
        if not sol.success:
            raise CalibrationError(f"least squares did not converge: {sol.message}")
        return sol

    def result(self, sol: OptimizeResult, prepared: list[PreparedRun]) -> LsqCalibration:
        """The fit's :class:`LsqCalibration` (standard errors from the Jacobian)."""
        spec, k_model, m = self.spec, self.k_model, self.m
        jmat = self.jac(sol.x)
        s2 = float(np.sum(sol.fun**2)) / (m - self.x0.size)
        jtj = jmat.T @ jmat
        norms = np.linalg.norm(jmat, axis=0)
        # a parameter's typical size: its start's scale, or its fitted value where that is
        # larger (a start at 1 mm does not make a 0.28 m result uncertain)
        typical = np.maximum(self.x_scale[:k_model], np.abs(sol.x[:k_model]))
        warnings = _check_identifiable(spec, jmat, norms, s2, k_model, typical)
        cov: FloatArray = np.asarray(np.linalg.inv(jtj) * s2, dtype=np.float64)
        theta = sol.x
        params = spec.params(self.nominal, theta[:k_model]).with_(name=f"{self.nominal.name}-lsq")
        residuals = _split_units(self.per_unit(sol.x), self.unit_runs)
        return LsqCalibration(
            params=params,
            nominal=self.nominal,
            stderr={k: float(np.sqrt(cov[i, i])) for i, k in enumerate(spec.names)},
            covariance=cov[:k_model, :k_model],
            rms_before=float(np.sqrt(np.mean(self.r0**2))),
            rms_after=float(np.sqrt(np.mean(sol.fun**2))),
            runs=[r.name for r in prepared],
            segments=m // 3,
            heading_scale=self.scale,
            gt_yaw_offsets=[float(v) for v in theta[k_model:]],
            model=spec.kind,
            run_rss=[float(np.sum(r**2)) for r in residuals],
            run_sizes=[int(r.size) for r in residuals],
            warnings=warnings,
        )


def _units(
    prepared: list[PreparedRun],
) -> tuple[list[PreparedRun], list[list[tuple[int, int]]]]:
    """The runs as the fit integrates them: a run alone, or the runs of one
    :attr:`PreparedRun.frame` joined end to end (each run's first increment is zero, so every
    segment's motion in its own start frame is the same as in its run alone; one integration
    instead of hundreds for a table of short windows). Also each unit's runs as (index,
    number of segments)."""
    groups: dict[str, list[int]] = {}
    for k, r in enumerate(prepared):
        groups.setdefault(r.frame or f"\0run {k}", []).append(k)
    units: list[PreparedRun] = []
    for members in groups.values():
        rs = [prepared[k] for k in members]
        if len(rs) == 1:
            units.append(rs[0])
            continue
        ts, starts, ends = [], [], []
        shift, offset = 0.0, 0
        for r in rs:
            ts.append(r.t - r.t[0] + shift)
            shift = float(ts[-1][-1]) + 1.0  # (a gap: the joined times keep increasing)
            starts.append(r.starts + offset)
            ends.append(r.ends + offset)
            offset += r.t.size
        dl = [r.dticks_left.copy() for r in rs]
        dr = [r.dticks_right.copy() for r in rs]
        for a, b in zip(dl, dr, strict=True):
            a[0] = b[0] = 0.0
        units.append(
            PreparedRun(
                rs[0].name,
                np.concatenate(ts),
                np.concatenate(dl),
                np.concatenate(dr),
                np.concatenate([r.gt_x for r in rs]),
                np.concatenate([r.gt_y for r in rs]),
                np.concatenate([r.gt_heading for r in rs]),
                np.concatenate(starts),
                np.concatenate(ends),
                frame=rs[0].frame,
                truth_xy=np.concatenate([r.truth_xy for r in rs]),
                truth_yaw=np.concatenate([r.truth_yaw for r in rs]),
                truth_dt=np.concatenate([r.truth_dt for r in rs]),
                truth_var=np.concatenate([r.truth_var for r in rs]),
            )
        )
    sizes = [[(k, int(prepared[k].starts.size)) for k in members] for members in groups.values()]
    return units, sizes


def _split_units(
    parts: list[FloatArray], unit_runs: list[list[tuple[int, int]]]
) -> list[FloatArray]:
    """Residuals of each unit back to each run, in the runs' order (a unit's residuals are
    its segments' x, then y, then heading components, as a run's)."""
    out: dict[int, FloatArray] = {}
    for part, members in zip(parts, unit_runs, strict=True):
        xyh = part.reshape(3, -1)
        at = 0
        for k, size in members:
            out[k] = xyh[:, at : at + size].reshape(-1)
            at += size
    return [out[k] for k in range(len(out))]


def _calibrate_slip(
    prepared: list[PreparedRun], nominal: RobotParams, o: LsqOptions, scale: float
) -> LsqCalibration:
    """The slip model by Bayesian linear regression (closed form, no yaw offsets) or, with a
    truth noisier than the model, the Kalman filter (:func:`odolab.calibration.slipfit.filtered`),
    its segment residuals as every other model's (so its BIC compares)."""
    from odolab.calibration.slipfit import estimator_note, fit_slip_model, undetermined

    truth = slip_truth_noise(prepared, o)
    model, cov, windows, centre, spread, filter_scale = fit_slip_model(
        prepared, nominal, centre=kinematic_base(prepared, nominal, o.loss), truth=truth
    )
    base = nominal.with_(model=DIFF_DRIVE)
    params = nominal.with_(model=model, name=f"{nominal.name}-lsq")
    before = [_residuals(base, r, scale, o.method, 0.0) for r in prepared]
    after = [_residuals(params, r, scale, o.method, 0.0) for r in prepared]
    r0, r1 = np.concatenate(before), np.concatenate(after)
    flag = undetermined(spread, windows, centre)
    return LsqCalibration(
        params=params,
        nominal=nominal,
        stderr={k: float(np.sqrt(cov[i, i])) for i, k in enumerate(SlipModel.COEF_KEYS)},
        covariance=cov,
        rms_before=float(np.sqrt(np.mean(r0**2))),
        rms_after=float(np.sqrt(np.mean(r1**2))),
        runs=[r.name for r in prepared],
        segments=windows,
        heading_scale=scale,
        model="slip",
        run_rss=[float(np.sum(r**2)) for r in after],
        run_sizes=[int(r.size) for r in after],
        warnings=[flag] if flag else [],
        notes=[
            f"the slip coefficients' prior is centred on the {centre} model fitted to the same "
            "runs (what the runs do not determine stays with it)"
            if centre != "none"
            else "no kinematic model could be fitted to these runs: the slip coefficients' "
            "prior is centred on the nominal differential drive",
            "the slip model's predictive variance, fitted to how far models fitted without "
            "a piece are off "
            "after 1 s and 3 s (docs/models.md): white noise "
            + ", ".join(f"{k} {getattr(model, k):.3g}" for k in NOISE_KEYS)
            + "; drift "
            + ", ".join(f"{k} {getattr(model, k):.3g}" for k in DRIFT_KEYS),
            *([truth.describe()] if truth is not None else []),
            estimator_note(filter_scale),
        ],
    )


def kinematic_base(
    runs: Sequence[object], nominal: RobotParams, loss: str = "linear"
) -> tuple[FloatArray, str]:
    """The prior mean of the slip coefficients: the first of
    :data:`odolab.calibration.slipfit.BASE_MODELS` that can be fitted to the runs by least
    squares (with ``loss``; no ground-truth yaw offsets, as the slip fit), as slip coefficients
    (:func:`odolab.calibration.slipfit.base_coefficients`); and its name ("none", all zeros:
    the nominal differential drive, when none can)."""
    from odolab.calibration.slipfit import BASE_MODELS, base_coefficients
    from odolab.core.errors import ParamsError
    from odolab.core.models.slip import FEATURES

    for kind in BASE_MODELS:
        try:
            fit = calibrate_lsq(
                runs,  # type: ignore[arg-type]
                nominal,
                LsqOptions(model=kind, fit_gt_yaw_offset=False, loss=loss),
            )
        except (CalibrationError, InsufficientDataError, ParamsError):
            continue
        return base_coefficients(fit.params, nominal), kind
    return np.zeros(3 * len(FEATURES)), "none"


def slip_truth_noise(prepared: Sequence[PreparedRun], o: LsqOptions) -> TruthNoise | None:
    """The ground truth's noise the slip fit allows for: the user's (``o.truth_sigma``), else
    the estimate from the runs' own truth updates (None where ``o.truth_noise`` is off or the
    runs have too few updates to tell)."""
    noise: TruthNoise | None = allowed(
        o.truth_sigma, lambda: [r.truth_parts() for r in prepared], o.truth_noise
    )
    if o.truth_sigma is not None and noise is not None:  # the updates' spacing from the runs
        dt = np.concatenate([r.truth_dt for r in prepared]) if prepared else np.zeros(0)
        noise = replace(noise, spacing=float(np.median(dt)) if dt.size else 0.0)
    return noise


def _check_identifiable(
    spec: FitModel,
    jmat: FloatArray,
    norms: FloatArray,
    s2: float,
    k_model: int,
    typical: FloatArray,
) -> list[str]:
    """Raise one sentence when the runs do not determine a parameter (see the module): the
    other parameters explain the same motion. Return a sentence for each parameter that is
    determined but poorly (its standard error above :data:`_SE_LIMIT` of its typical size)."""
    if spec.kind == "diff":  # the original sentence for the original model
        if not np.all(norms > 0) or np.linalg.cond(jmat / norms) > 1e5:
            raise CalibrationError(
                "the runs do not determine both radii and the track width (singular Jacobian); "
                "expected runs with both straight driving and turning"
            )
        return []
    for i in range(k_model):
        if not norms[i] > 0:
            raise CalibrationError(
                f"{spec.names[i]} is not identifiable from these runs (it does not change the "
                f"odometry at all); expected runs with {spec.needs[i]}"
            )
    nz = norms > 0
    jn = jmat[:, nz] / norms[nz]
    ginv = np.linalg.pinv(jn.T @ jn)
    vif = np.diag(ginv)[:k_model]
    se = np.sqrt(np.maximum(vif * s2, 0.0)) / norms[:k_model]
    bad = [i for i in range(k_model) if not (np.isfinite(vif[i]) and vif[i] <= _VIF_LIMIT)]
    if not bad:
        return [
            f"{spec.names[i]} is poorly determined by these runs (standard error {se[i]:.3g}, "
            f"{100 * se[i] / typical[i]:.0f} % of its typical size {typical[i]:.3g}): their "
            "noise, or the model's misfit, is large for what they contain; held-out runs "
            "tell whether the model helps"
            for i in range(k_model)
            if se[i] > _SE_LIMIT * typical[i]
        ]
    groups: dict[str, list[str]] = {}
    for i in sorted(bad, key=lambda i: spec.names[i] != "x_icr"):  # x_icr's sentence first
        groups.setdefault(spec.needs[i], []).append(f"{spec.names[i]} (standard error {se[i]:.3g})")
    parts = [
        f"{', '.join(names)} {'is' if len(names) == 1 else 'are'} not identifiable without {need}"
        for need, names in groups.items()
    ]
    raise CalibrationError(
        "; ".join(parts) + " (the other parameters explain the same motion); expected runs "
        "that have them"
    )


def compare_runs(
    runs: Sequence[OdometryRun], nominal: RobotParams, calibrated: RobotParams
) -> list[RunComparison]:
    """Each run evaluated (end-point error, drift per metre) with both parameter sets."""
    return [
        RunComparison(
            evaluate_run(r, nominal, RUN_OPTIONS), evaluate_run(r, calibrated, RUN_OPTIONS)
        )
        for r in runs
    ]


@dataclass(frozen=True)
class _ReadJob:
    path: Path
    fmt: LogFormat
    options: ReadOptions
    segment_s: float


def _read_and_prepare(job: _ReadJob) -> tuple[OdometryRun, PreparedRun]:
    run = read_run(job.path, job.fmt, job.options)
    return run, prepare_run(run, job.segment_s)


@dataclass(frozen=True)
class _CompareJob:
    path: Path
    fmt: LogFormat
    options: ReadOptions
    nominal: RobotParams
    calibrated: RobotParams


def _compare_job(job: _CompareJob) -> RunComparison:
    run = read_run(job.path, job.fmt, job.options)
    return compare_runs([run], job.nominal, job.calibrated)[0]


def find_fit_and_held_out(
    paths: Sequence[str | Path],
    validate: Sequence[str | Path],
    fmt: LogFormat,
    *,
    roles: tuple[str, str] = ("training", "held-out"),
) -> tuple[list[Path], list[Path]]:
    """The run files under ``paths`` (to fit on) and under ``validate`` (held out), refusing a
    run that is in both (``roles`` name the two sets in the sentence).

    Runs are told apart by their resolved path: ``runs/a`` and ``/home/me/runs/a`` are one run,
    kept once (a run fitted twice would weigh double, and in cross-validation be held out
    from a fit that saw it)."""
    fit = _unique(find_runs(paths, fmt))
    held = _unique(find_runs(validate, fmt)) if validate else []
    seen = {p.resolve(): p for p in fit}
    overlap = [(p, seen[p.resolve()]) for p in held if p.resolve() in seen]
    if overlap:
        p, q = overlap[0]
        same = "" if p == q else f" (as {q})"
        raise CalibrationError(
            f"{p}{same} is both a {roles[0]} and a {roles[1]} run; expected held-out runs"
        )
    return fit, held


def _unique(paths: list[Path]) -> list[Path]:
    """``paths`` without a second path to the same file (first kept, order kept)."""
    seen: set[Path] = set()
    out = []
    for p in paths:
        r = p.resolve()
        if r not in seen:
            seen.add(r)
            out.append(p)
    return out


def calibrate_lsq_files(
    paths: Sequence[str | Path],
    fmt: LogFormat | str,
    *,
    nominal: RobotParams | None = None,
    validate: Sequence[str | Path] = (),
    options: LsqOptions | None = None,
    read_options: ReadOptions | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    cluster: Cluster | None = None,
    where: list[str] | None = None,
) -> LsqCalibration:
    """Calibrate on every run under ``paths``; then compare nominal vs calibrated on ``validate``.

    ``nominal`` defaults to the first run's own parameters (OptiOdom metadata). Reading and
    validation run in ``workers`` processes (a local Dask cluster) or on ``cluster``;
    ``progress(done, total, name)`` is called per run. ``where`` (when given) gets where odolab
    chose to read and to evaluate them, and why (:func:`odolab.metrics.runs.parallel_map`).
    """
    with one_local_cluster():  # the fitted and the held-out runs: one local cluster, if any
        return _calibrate_lsq_files(
            paths, fmt, nominal, validate, options, read_options, workers, progress, cluster, where
        )


def _calibrate_lsq_files(
    paths: Sequence[str | Path],
    fmt: LogFormat | str,
    nominal: RobotParams | None,
    validate: Sequence[str | Path],
    options: LsqOptions | None,
    read_options: ReadOptions | None,
    workers: int | None,
    progress: Progress | None,
    cluster: Cluster | None,
    where: list[str] | None,
) -> LsqCalibration:
    """:func:`calibrate_lsq_files`' work."""
    o = options or LsqOptions()
    ro = read_options or ReadOptions()
    f = LogFormat(fmt)
    train, held = find_fit_and_held_out(paths, validate, f, roles=("calibration", "validation"))
    total = len(train) + len(held)

    def shifted(offset: int) -> Progress | None:
        if progress is None:
            return None
        report = progress
        return lambda done, _total, name: report(done + offset, total, name)

    loaded = parallel_map(
        _read_and_prepare,
        [_ReadJob(p, f, ro, o.segment_s) for p in train],
        workers=workers,
        progress=shifted(0),
        label=lambda j: str(j.path),
        cluster=cluster,
        where=where,
        what="the fitted runs read",
    )
    base = nominal or loaded[0][0].params
    if base is None:
        raise CalibrationError(
            f"{train[0]}: the log has no nominal parameters; expected {opt('params')}"
        )
    result = calibrate_lsq([prep for _, prep in loaded], base, o)
    if not held:
        return result
    comparisons = parallel_map(
        _compare_job,
        [_CompareJob(p, f, ro, base, result.params) for p in held],
        workers=workers,
        progress=shifted(len(train)),
        label=lambda j: str(j.path),
        cluster=cluster,
        where=where,
        what="the held-out runs evaluated",
    )
    return LsqCalibration(**{**result.__dict__, "validation": comparisons})
