"""Evaluate recorded runs: integrate their wheel increments, compare with their ground truth.

Many runs are read and evaluated on Dask (:mod:`odolab.metrics.cluster`): a local cluster of
``workers`` processes (default 2), or any cluster by its scheduler address; progress goes to an
optional callback ``progress(done, total, name)``. :func:`evaluate_runs` keeps going past runs
that fail and reports each failure with its run; :func:`evaluate_run_files` stops at the first.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from odolab.core.errors import OdolabError
from odolab.core.kinematics import Method
from odolab.core.params import RobotParams
from odolab.core.progress import Progress
from odolab.io.registry import LogFormat, find_runs, read_run
from odolab.io.run import OdometryRun, ReadOptions
from odolab.metrics.alignment import Alignment
from odolab.metrics.association import SyncMethod
from odolab.metrics.cluster import Cluster, MapReport, Outcome, map_outcomes
from odolab.metrics.evaluate import Evaluation, EvaluationOptions, evaluate
from odolab.metrics.pose_error import DeltaUnit

__all__ = [
    "RUN_OPTIONS",
    "Progress",
    "RunEvaluation",
    "evaluate_run",
    "evaluate_run_files",
    "evaluate_runs",
    "parallel_map",
]

#: Defaults for runs: interpolate the ground truth at the odometry stamps, align the start poses,
#: RPE over 1 m of path.
RUN_OPTIONS = EvaluationOptions(
    delta=1.0,
    delta_unit=DeltaUnit.METRES,
    sync=SyncMethod.INTERPOLATE,
    max_diff=0.05,
    alignment=Alignment.ORIGIN,
    pairs_from_reference=True,
)


T = TypeVar("T")
R = TypeVar("R")


def parallel_map(
    func: Callable[[T], R],
    items: Sequence[T],
    *,
    workers: int | None = None,
    progress: Progress | None = None,
    label: Callable[[T], str] = str,
    cluster: Cluster | None = None,
    where: list[str] | None = None,
    what: str | None = None,
) -> list[R]:
    """``[func(x) for x in items]`` on Dask (in order), reporting progress; raises the first error.

    ``cluster`` defaults to a local cluster of ``workers`` processes. ``func`` must be a
    module-level function (it is pickled). With ``workers <= 1`` and no scheduler, or a single
    item, everything runs here, in this process. Where odolab chose where they ran (no
    scheduler, no number of workers), ``where`` (when given) gets that choice with its reason
    (:attr:`MapReport.where`), after ``"{what} in "`` when ``what`` is given, for the faces to
    say.
    """
    report = MapReport("")
    outcomes = map_outcomes(
        func, items, cluster=cluster or Cluster(workers=workers), progress=progress, label=label,
        report=report,
    )  # fmt: skip
    if where is not None and report.chosen:
        where.append(report.where if what is None else f"{what} in {report.where}")
    return _results(outcomes)


def _results(outcomes: list[Outcome[R]]) -> list[R]:
    """The outcomes' results, in order; raises the first error."""
    for o in outcomes:
        if not o.ok:
            if o.exception is not None:
                raise o.exception
            raise OdolabError(f"{o.label}: {o.error}")  # pragma: no cover - always kept
    return [o.result for o in outcomes]  # type: ignore[misc]


@dataclass(frozen=True)
class RunEvaluation:
    """One run's evaluation (odometry with ``params`` against its ground truth)."""

    name: str
    source: str
    kind: str
    params: RobotParams
    evaluation: Evaluation
    duration_s: float = math.nan  #: the log's time span (s)
    #: what the run's data are where a reader says so ("wheels: ...", "reference: ...": a bag's
    #: wheel increments made from the robot's own odometry, AMCL's pose as the reference)
    data_notes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict."""
        out = {
            "name": self.name,
            "source": self.source,
            "kind": self.kind,
            "params": self.params.to_dict(),
            **self.evaluation.to_dict(),
        }
        if self.data_notes:
            out["data_notes"] = list(self.data_notes)
        return out


def evaluate_run(
    run: OdometryRun,
    params: RobotParams | None = None,
    options: EvaluationOptions = RUN_OPTIONS,
    method: Method | str = Method.MIDPOINT,
) -> RunEvaluation:
    """Integrate ``run`` with ``params`` (default its own nominal ones); compare to ground truth."""
    p = params or run.params
    est = run.odometry(p, method)
    assert p is not None  # odometry() raised otherwise
    ev = evaluate(
        run.require_ground_truth(), est, options, names=(f"{run.source} ground truth", "odometry")
    )
    duration = float(run.t[-1] - run.t[0])
    data = tuple(f"{k}: {run.meta[k]}" for k in ("wheels", "reference") if k in run.meta)
    return RunEvaluation(run.name, run.source, run.kind, p, ev, duration, data)


@dataclass(frozen=True)
class _Job:
    path: Path
    fmt: LogFormat
    read_options: ReadOptions
    params: RobotParams | None
    options: EvaluationOptions
    method: Method


def _evaluate_job(job: _Job) -> RunEvaluation:
    run = read_run(job.path, job.fmt, job.read_options)
    return evaluate_run(run, job.params, job.options, job.method)


def _jobs(
    runs: Sequence[str | Path],
    fmt: LogFormat | str,
    params: RobotParams | None,
    options: EvaluationOptions,
    read_options: ReadOptions | None,
    method: Method | str,
) -> list[_Job]:
    """One picklable job per run file."""
    ro = read_options or ReadOptions()
    return [_Job(Path(p), LogFormat(fmt), ro, params, options, Method(method)) for p in runs]


def evaluate_run_files(
    paths: Sequence[str | Path],
    fmt: LogFormat | str,
    *,
    params: RobotParams | None = None,
    options: EvaluationOptions = RUN_OPTIONS,
    read_options: ReadOptions | None = None,
    method: Method | str = Method.MIDPOINT,
    workers: int | None = None,
    progress: Progress | None = None,
    cluster: Cluster | None = None,
) -> list[RunEvaluation]:
    """Evaluate every run found under ``paths`` (see :func:`odolab.io.find_runs`): the
    :func:`evaluate_runs` of those runs (every run is evaluated), then the first failure raised."""
    outcomes = evaluate_runs(
        find_runs(paths, fmt),
        fmt,
        params=params,
        options=options,
        read_options=read_options,
        method=method,
        cluster=cluster or Cluster(workers=workers),
        progress=progress,
    )
    return _results(outcomes)


def evaluate_runs(
    runs: Sequence[str | Path],
    fmt: LogFormat | str,
    *,
    params: RobotParams | None = None,
    options: EvaluationOptions = RUN_OPTIONS,
    read_options: ReadOptions | None = None,
    method: Method | str = Method.MIDPOINT,
    cluster: Cluster | None = None,
    progress: Progress | None = None,
    report: MapReport | None = None,
) -> list[Outcome[RunEvaluation]]:
    """Evaluate each run file in ``runs`` (paths of runs, as :func:`find_runs` lists them).

    One :class:`Outcome` per run, in order: a run that cannot be read or evaluated gets its
    error, the others their evaluation.
    """
    jobs = _jobs(runs, fmt, params, options, read_options, method)
    return map_outcomes(
        _evaluate_job,
        jobs,
        cluster=cluster,
        progress=progress,
        label=lambda j: str(j.path),
        report=report,
    )
