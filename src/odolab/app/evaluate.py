"""Evaluating odometry and fitting it to ground truth: ``odolab evaluate`` and
``odolab calibrate lsq`` call :func:`evaluate_trajectories`, :func:`evaluate_run_set` and
:func:`calibrate_lsq_runs`.

The rules that decide their numbers live here once:

- the settings: evo's defaults for two trajectories (nearest stamp, no alignment, RPE over one
  frame); a run's defaults for runs (interpolated ground truth, start poses aligned, RPE over
  1 m of path chosen on the ground truth); a unit given without a step means one of that unit
  (90 deg, pi/2 rad for an angle);
- which parameters a run is integrated with: the ones the user names, else each run's own
  nominal parameters (its log or metadata), and the result says which;
- whether the ground truth's yaw mounting offset is fitted (yes, unless the user says no);
- which runs: a run may not be both fitted and held out (:mod:`odolab.calibration.lsq`).

Every evaluation is planar (x, y, heading): the results say so (:data:`PLANAR_NOTE`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.core.errors import OdolabError, opt
from odolab.core.numfmt import count
from odolab.core.params import covariance_source
from odolab.metrics import (
    PLANAR_NOTE,
    Alignment,
    DeltaUnit,
    EvaluationOptions,
    SyncMethod,
)

if TYPE_CHECKING:
    from odolab.calibration.lsq import LsqCalibration
    from odolab.core.models import CovarianceModel
    from odolab.core.params import RobotParams
    from odolab.core.progress import Progress
    from odolab.io.run import OdometryRun, ReadOptions
    from odolab.metrics import Evaluation, RunEvaluation
    from odolab.metrics.cluster import Cluster, MapReport, Outcome
    from odolab.metrics.consistency import NeesSummary, RunNees
    from odolab.metrics.truthnoise import TruthNoise

__all__ = [
    "DEFAULT_DELTA",
    "PLANAR_NOTE",
    "EvaluationRequest",
    "LsqRequest",
    "LsqResult",
    "NeesOutcome",
    "RunSetEvaluation",
    "TrajectoryEvaluation",
    "calibrate_lsq_runs",
    "evaluate_run_set",
    "evaluate_trajectories",
    "evaluation_options",
    "nees_of_paths",
    "params_source",
    "read_runs",
]

#: The step of each unit when the user gives a unit and no step.
DEFAULT_DELTA: dict[DeltaUnit, float] = {
    DeltaUnit.FRAMES: 1.0,
    DeltaUnit.METRES: 1.0,
    DeltaUnit.DEGREES: 90.0,
    DeltaUnit.RADIANS: math.pi / 2,
}


@dataclass(frozen=True)
class EvaluationRequest:
    """What to evaluate and how; ``None`` is "the default for what is evaluated".

    ``paths``: GT EST (two trajectory files) when ``fmt`` is None, else the run files of that
    format. ``params``: a parameters TOML or preset for runs (None: each run's own).
    ``delta_unit`` is a :class:`DeltaUnit` value (frames, m, deg, rad); ``drift_turn_deg``
    the piece of turning of the drift per angle turned (degrees); ``chunk_rows``: GT EST read in
    chunks of this many rows (0: whole; None: chunks when a file is large)."""

    paths: tuple[Path, ...]
    fmt: str | None = None
    params: str | None = None
    delta: float | None = None
    delta_unit: str | None = None
    all_pairs: bool = False
    pairs_from_reference: bool | None = None
    alignment: str | None = None
    sync: str | None = None
    max_diff: float | None = None
    drift_segment_m: float = 1.0
    drift_turn_deg: float = 90.0
    chunk_rows: int | None = None
    nees: bool = False
    nees_segment_s: float = 10.0


def evaluation_options(request: EvaluationRequest) -> EvaluationOptions:
    """The settings of ``request``: evo's defaults for GT EST, a run's (:data:`RUN_OPTIONS`)
    for runs, changed where the request says."""
    if request.fmt is not None:
        from odolab.metrics.runs import RUN_OPTIONS as base  # (not loaded for GT EST)
    else:
        base = EvaluationOptions()
    changes: dict[str, Any] = {
        "all_pairs": request.all_pairs,
        "drift_delta_m": request.drift_segment_m,
        "drift_turn_rad": math.radians(request.drift_turn_deg),
    }
    if request.delta_unit is not None:
        unit = DeltaUnit(request.delta_unit)
        changes["delta_unit"] = unit
        changes["delta"] = DEFAULT_DELTA[unit]
    if request.delta is not None:
        changes["delta"] = request.delta
    if request.alignment is not None:
        changes["alignment"] = Alignment(request.alignment)
    if request.sync is not None:
        changes["sync"] = SyncMethod(request.sync)
    if request.max_diff is not None:
        changes["max_diff"] = request.max_diff
    if request.pairs_from_reference is not None:
        changes["pairs_from_reference"] = request.pairs_from_reference
    return replace(base, **changes)


def _require_positive(option: str, value: float, allowed: str, spec: str = "") -> None:
    """Refuse ``option``'s ``value`` unless it is a finite number above 0 (``spec``: the format
    the message writes the value in; "" is ``str``'s)."""
    if not (math.isfinite(value) and value > 0):
        raise OdolabError(
            f"{opt(option)} is {value:{spec}}; expected {allowed}",
            option=option,
            value=value,
            allowed=allowed,
        )


def _check(request: EvaluationRequest, robot: RobotParams | None) -> None:
    """Every option checked before any file is read: a typo costs nothing."""
    _require_positive("drift_turn", request.drift_turn_deg, "a positive angle in degrees", "g")
    if request.nees:
        _require_positive("nees_segment", request.nees_segment_s, "a positive number of seconds")
        if robot is not None and covariance_source(robot) is None:
            raise OdolabError(
                f"{opt('nees')}: the parameters {request.params} have no [noise] table (k_left, "
                "k_right) and no slip model; give {{params}} with one (e.g. from `odolab "
                "calibrate noise`, or `odolab calibrate lsq {{model}} slip`)"
            )
    if request.fmt is None:
        if request.nees:
            raise OdolabError(
                "{{nees}} needs runs with encoder increments ({{format}}), not two trajectories"
            )
        if len(request.paths) != 2:
            raise OdolabError(
                f"evaluate takes GT EST (two trajectory files), got "
                f"{count(len(request.paths), 'path')}; use {opt('format')} for runs"
            )
        from odolab.app.odometry import check_chunk_rows

        check_chunk_rows(request.chunk_rows)
    elif request.chunk_rows is not None:
        raise OdolabError(
            "{{chunk_rows}} reads two trajectory files (GT EST) in chunks; runs ({{format}}) are "
            "read whole, one per task"
        )


def load_request_params(request: EvaluationRequest) -> RobotParams | None:
    """The parameters the request names (None: each run's own), checked with the request."""
    from odolab.core.params import load_params

    robot = load_params(request.params) if request.params else None
    _check(request, robot)
    return robot


def params_source(params: str | None) -> str:
    """Which parameters runs are integrated with, in words (every face shows it)."""
    if params:
        return f"parameters: {params}"
    return "parameters: each run's own nominal ones (from its log or metadata)"


@dataclass(frozen=True)
class TrajectoryEvaluation:
    """An estimate against a reference: the evaluation, and how the files were read
    (``chunk_rows`` rows at a time; 0: whole)."""

    reference: Path
    estimate: Path
    evaluation: Evaluation
    chunk_rows: int

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict (the evaluation's, which says it is planar)."""
        return self.evaluation.to_dict()


def chunk_rows_for(request: EvaluationRequest) -> int:
    """Rows per chunk for GT EST (0: both files whole). By default, chunks when a file is large;
    never for all pairs by angle (every pose against every later one)."""
    from odolab.app.odometry import auto_chunk_rows
    from odolab.metrics import ANGLE_UNITS

    o = evaluation_options(request)
    by_angle_all = o.all_pairs and DeltaUnit(o.delta_unit) in ANGLE_UNITS
    if request.chunk_rows is None:
        return 0 if by_angle_all else auto_chunk_rows(*request.paths)
    return request.chunk_rows


def evaluate_trajectories(
    request: EvaluationRequest, *, progress: Progress | None = None
) -> TrajectoryEvaluation:
    """GT EST: the estimate ``paths[1]`` against the reference ``paths[0]`` (evo's definitions,
    planar); ``progress(rows done, rows, file)`` when read in chunks."""
    from odolab.io import read_trajectory
    from odolab.metrics import evaluate

    load_request_params(request)
    if request.fmt is not None:
        raise OdolabError("evaluate_trajectories takes GT EST; runs go to evaluate_run_set")
    options = evaluation_options(request)
    gt, est = request.paths
    rows = chunk_rows_for(request)
    names = (str(gt), str(est))
    if rows > 0:
        from odolab.metrics.chunked import evaluate_files

        ev = evaluate_files(gt, est, options, chunk_rows=rows, names=names, progress=progress)
    else:
        ev = evaluate(read_trajectory(gt), read_trajectory(est), options, names=names)
    return TrajectoryEvaluation(gt, est, ev, rows)


@dataclass(frozen=True)
class RunSetEvaluation:
    """Runs evaluated: one outcome per run (its evaluation, or its error), the settings, and
    which parameters the runs were integrated with (:attr:`params_source`)."""

    outcomes: list[Outcome[RunEvaluation]]
    options: EvaluationOptions
    params: RobotParams | None
    params_source: str
    report: MapReport

    @property
    def done(self) -> list[RunEvaluation]:
        """The runs evaluated (in order)."""
        return [o.result for o in self.outcomes if o.result is not None]

    @property
    def notes(self) -> list[str]:
        """What the numbers are: planar, the parameters, and each kind of undefined number with
        how many runs have it (a run that turns in place has no drift per metre)."""
        out = [PLANAR_NOTE, self.params_source]
        if self.report.chosen:
            out.append(f"computed in {self.report.where}")
        for r in self.done:  # what a reader says its data are (a bag's odometry, AMCL)
            out.extend(f"{n} ({r.name})" for n in r.data_notes if f"{n} ({r.name})" not in out)
        seen: dict[str, tuple[int, str]] = {}  # what is undefined: runs, the first run's reason
        for r in self.done:
            for note in r.evaluation.notes:
                key, _, why = note.partition(": ")
                n, first = seen.get(key, (0, f"{r.name}: {why}"))
                seen[key] = (n + 1, first)
        out.extend(
            f"{key} for {count(n, 'run')} (n/a), e.g. {first}" for key, (n, first) in seen.items()
        )
        return out

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict: ``planar``, ``planar_note``, ``params_source``, ``runs``."""
        return {
            "planar": True,
            "planar_note": PLANAR_NOTE,
            "params_source": self.params_source,
            "runs": [r.to_dict() for r in self.done],
        }


def evaluate_run_set(
    request: EvaluationRequest,
    runs: Sequence[Path],
    *,
    read_options: ReadOptions,
    cluster: Cluster,
    progress: Progress | None = None,
) -> RunSetEvaluation:
    """Each run of ``runs`` (files of ``request.fmt``) integrated with the request's parameters
    (or its own) and compared with its ground truth, on ``cluster``; a run that fails keeps its
    error, the others their results."""
    from odolab.metrics.cluster import MapReport
    from odolab.metrics.runs import evaluate_runs

    if request.fmt is None:
        raise OdolabError("evaluate_run_set takes runs (a format); GT EST: evaluate_trajectories")
    robot = load_request_params(request)
    options = evaluation_options(request)
    report = MapReport(cluster.describe())
    outcomes = evaluate_runs(
        runs,
        request.fmt,
        params=robot,
        options=options,
        read_options=read_options,
        cluster=cluster,
        progress=progress,
        report=report,
    )
    return RunSetEvaluation(outcomes, options, robot, params_source(request.params), report)


# -- least squares ---------------------------------------------------------------------------


@dataclass(frozen=True)
class LsqRequest:
    """A least-squares fit: ``runs`` fitted, ``held_out`` evaluated with the nominal and the
    fitted parameters; ``params`` the nominal ones (None: the first run's own); the ground
    truth's yaw offset fitted unless ``fit_gt_yaw_offset`` is False; ``ground_truth`` replaces
    the one run's own."""

    runs: tuple[Path, ...]
    fmt: str
    params: str | None = None
    held_out: tuple[Path, ...] = ()
    segment_s: float = 2.0
    fit_gt_yaw_offset: bool = True
    model: str = "diff"
    ground_truth: Path | None = None
    #: the ground truth's noise ``"XY,YAW"`` (m, rad; None: estimated from its updates)
    truth_sigma: str | None = None
    #: the kinematic fit's loss (:data:`odolab.calibration.lsq.LOSSES`)
    loss: str = "linear"


@dataclass(frozen=True)
class LsqResult:
    """The fit, and what it was given: the run files fitted and held out, the nominal
    parameters' source."""

    calibration: LsqCalibration
    fitted: list[Path] = field(default_factory=list)
    held_out: list[Path] = field(default_factory=list)
    params_source: str = ""
    #: where odolab chose to read and evaluate the runs, and why (none where the user said)
    computed: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict: the calibration's, with ``fitted`` and ``held_out`` run files."""
        return {
            **self.calibration.to_dict(),
            "fitted": [str(p) for p in self.fitted],
            "held_out": [str(p) for p in self.held_out],
            "params_source": self.params_source,
        }


def _check_lsq(request: LsqRequest) -> None:
    if request.ground_truth is not None:  # checked before any run is read
        if len(request.runs) != 1 or request.held_out:
            extra = " and {{validate}}" if request.held_out else ""
            raise OdolabError(
                f"{opt('ground_truth')} is one run's ground truth; expected exactly one run and no "
                f"{opt('validate')}, got {count(len(request.runs), 'run')}{extra}"
            )
        if not request.ground_truth.is_file():
            raise OdolabError(f"{opt('ground_truth')} {request.ground_truth}: no such file")


def calibrate_lsq_runs(
    request: LsqRequest,
    *,
    read_options: ReadOptions,
    cluster: Cluster,
    workers: int | None = None,
    progress: Progress | None = None,
) -> LsqResult:
    """Fit ``request.model`` to the runs' ground truth; evaluate the held-out runs with the
    nominal and the fitted parameters. A run may not be both fitted and held out."""
    from odolab.calibration.lsq import LsqOptions, calibrate_lsq_files, find_fit_and_held_out
    from odolab.core.params import load_params
    from odolab.io.registry import LogFormat
    from odolab.metrics.truthnoise import parse_truth_sigma

    _check_lsq(request)
    options = LsqOptions(
        segment_s=request.segment_s,
        fit_gt_yaw_offset=request.fit_gt_yaw_offset,
        model=request.model,
        loss=request.loss,
        truth_sigma=parse_truth_sigma(request.truth_sigma)
        if request.truth_sigma is not None
        else None,
    )
    robot = load_params(request.params) if request.params else None
    ro = read_options
    if request.ground_truth is not None:
        ro = replace(ro, ground_truth=str(request.ground_truth))
    fitted, held = find_fit_and_held_out(
        request.runs, request.held_out, LogFormat(request.fmt), roles=("calibration", "validation")
    )
    computed: list[str] = []
    result = calibrate_lsq_files(
        fitted,
        request.fmt,
        nominal=robot,
        validate=held,
        options=options,
        read_options=ro,
        workers=workers,
        progress=progress,
        cluster=cluster,
        where=computed,
    )
    source = (
        f"nominal parameters: {request.params}"
        if request.params
        else "nominal parameters: the first run's own (from its log or metadata)"
    )
    return LsqResult(result, fitted, held, source, computed)


@dataclass
class NeesOutcome:
    """The NEES of runs against their ground truth (:func:`nees_of_paths`): the per-run results,
    their summary, the slip models whose covariance was used, and the notes a reader needs."""

    segment_s: float
    results: list[RunNees]
    summary: NeesSummary
    slip_models: list[CovarianceModel]
    skipped: list[str]
    skip_note: str | None
    pieces_past_first_order: int
    first_order_note: str | None
    #: the ground truth's noise added to each piece's covariance (None: taken as exact)
    truth: TruthNoise | None = None

    def to_dict(self) -> dict[str, object]:
        """The JSON-ready numbers (``evaluate --nees --json``'s ``nees``)."""
        t = self.truth
        head = {
            **self.summary.to_dict(),
            "truth_noise": (
                {"xy_m": t.xy, "yaw_rad": t.yaw, "given": t.given} if t is not None else None
            ),
            "pieces_past_first_order": self.pieces_past_first_order,
            "runs_skipped": len(self.skipped),
            "skipped": self.skipped,
            "skipped_note": self.skip_note,
        }
        return {"summary": head, "runs": [r.to_dict() for r in self.results]}


def read_runs(paths: Sequence[Path], fmt: str, robot: RobotParams | None) -> list[OdometryRun]:
    """The runs found at ``paths`` in format ``fmt``, read with ``robot``'s ticks per turn (else
    the format's own)."""
    from odolab.io.registry import find_runs, read_run
    from odolab.io.run import ReadOptions

    ro = ReadOptions(ticks_per_rev=robot.ticks_per_rev) if robot else ReadOptions()
    return [read_run(p, fmt, ro) for p in find_runs(list(paths), fmt)]


def nees_of_paths(
    paths: Sequence[Path],
    fmt: str,
    robot: RobotParams | None,
    method: str,
    segment: float,
    *,
    fit_gt_yaw_offset: bool | None = None,
    truth_sigma: TruthNoise | None = None,
) -> NeesOutcome:
    """NEES of every run at ``paths`` (pieces of ``segment`` s) against its ground truth, with
    ``robot`` (else each run's own parameters). ``fit_gt_yaw_offset``: as
    :func:`odolab.metrics.consistency.run_nees` (None: fit unless the ground truth starts in the
    odometry's frame). ``truth_sigma``: the ground truth's noise (None: estimated from its
    updates; :func:`odolab.metrics.consistency.nees_of_runs`).

    Raises:
        ParamsError: a run's parameters have neither a [noise] table nor a slip model.
    """
    from odolab.core.errors import ParamsError
    from odolab.core.models import own_covariance
    from odolab.metrics.consistency import first_order_note, nees_of_runs, nees_summary

    runs = read_runs(paths, fmt, robot)
    sources = set()
    slip_models: list[CovarianceModel] = []
    chosen: dict[int, RobotParams] = {}
    for run in runs:
        p = robot or run.params
        source = covariance_source(p) if p is not None else None
        if p is None or source is None:
            raise ParamsError(
                f"{run.source}: NEES needs the parameters' [noise] (k_left, k_right) or a slip "
                "model; give {{params}} with a [noise] table (e.g. from `odolab calibrate noise`)"
            )
        sources.add(source)
        own = own_covariance(p.model)
        if own is not None and own not in slip_models:
            slip_models.append(own)
        chosen[id(run)] = p
    results, skipped, skip_note = nees_of_runs(
        runs,
        lambda run: chosen[id(run)],
        method,
        segment_s=segment,
        fit_gt_yaw_offset=fit_gt_yaw_offset,
        truth_sigma=truth_sigma,
    )
    beyond, note = first_order_note(results)
    summary = nees_summary(results)
    return NeesOutcome(
        segment, results, summary, slip_models, skipped, skip_note, beyond, note, results[0].truth
    )
