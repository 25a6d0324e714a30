"""A gyro calibration from runs (``odolab calibrate imu``): which runs and gyro logs, which
parameters it starts from, which reference fixes the gyro's scale; recorded in the notebook.

:func:`calibrate_gyro` takes an :class:`ImuRequest` and returns an :class:`ImuOutcome` that says
what it chose (the parameters and where they came from, the reference or its absence, the
notebook version it wrote).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from odolab.calibration.imu import (
    ImuCalibration,
    ImuOptions,
    TurnReference,
    calibrate_imu,
    reference_from_heading,
)
from odolab.core.errors import CalibrationError
from odolab.io.gyro import GyroRun, read_gyro_run
from odolab.robot.session import RobotRun

__all__ = ["ImuOutcome", "ImuRequest", "calibrate_gyro", "gyro_after_run", "gyro_run_of"]


@dataclass(frozen=True)
class ImuRequest:
    """What the user asked: ``runs`` (encoder logs, robot run folders, a DRIVE table),
    ``params`` (a TOML or preset; None: a run folder's own, else the default preset), ``imu``
    (the gyro log of the one run), ``turned`` (reference turns, rad, one per run in order) with
    ``reference_sd`` (rad), ``gt_reference`` (the ground truth beside each log as the reference),
    the estimator's ``options`` and the notebook ``db`` to record the new version in."""

    runs: Sequence[Path]
    params: str | None = None
    imu: Path | None = None
    turned: Sequence[float] = ()
    reference_sd: float = math.radians(1.0)
    gt_reference: bool = False
    options: ImuOptions = field(default_factory=ImuOptions)
    db: Path | None = None
    imu_topic: str = "/imu/data"  #: a bag's sensor_msgs/Imu topic


@dataclass(frozen=True, eq=False)
class ImuOutcome:
    """The calibration, the parameters it started from (in words) and the notebook version."""

    calibration: ImuCalibration
    params_from: str
    version: int | None = None
    source_trials: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, object]:
        return {
            **self.calibration.to_dict(),
            "params_from": self.params_from,
            "version": self.version,
            "source_trials": list(self.source_trials),
        }


def _trial_id(path: Path) -> str | None:
    folder = path if path.is_dir() else path.parent
    doc = folder / "run.json"
    if not doc.is_file():
        return None
    try:
        value = json.loads(doc.read_text(encoding="utf-8")).get("trial_id")
    except (OSError, ValueError, AttributeError):
        return None
    return value if isinstance(value, str) else None


def _references(req: ImuRequest, runs: Sequence[GyroRun]) -> list[TurnReference]:
    if req.turned and req.gt_reference:
        raise CalibrationError(
            "give the reference turns or the ground truth as the reference, not both"
        )
    if req.turned:
        if len(req.turned) != len(runs):
            raise CalibrationError(
                f"{len(req.turned)} reference turn(s) for {len(runs)} run(s); expected one per "
                "run, in the runs' order"
            )
        return [
            TurnReference(float(v), req.reference_sd, "turns given", i)
            for i, v in enumerate(req.turned)
        ]
    if req.gt_reference:
        return [
            reference_from_heading(r, i, req.reference_sd, "the ground truth's heading")
            for i, r in enumerate(runs)
        ]
    return []


def calibrate_gyro(req: ImuRequest) -> ImuOutcome:
    """Read the runs and their gyros, estimate, and record a new version when ``db`` is given."""
    from odolab.app.odometry import choose_params

    if not req.runs:
        raise CalibrationError("no runs given; expected encoder logs with a gyro")
    if req.imu is not None and len(req.runs) != 1:
        raise CalibrationError(
            f"one gyro log for {len(req.runs)} runs; a gyro log given by name is for one run "
            "(put NAME_imu.csv beside each NAME.csv for several)"
        )
    first = Path(req.runs[0])
    choice = choose_params([first / "encoders.csv" if first.is_dir() else first], req.params)
    params = choice.params
    runs = [
        read_gyro_run(
            p,
            ticks_per_rev=params.ticks_per_rev,
            modulus=params.encoder_modulus,
            imu=req.imu,
            imu_topic=req.imu_topic,
        )
        for p in req.runs
    ]
    refs = _references(req, runs)
    if not refs and req.db is not None:
        refs = _notebook_references(req.db, [Path(p) for p in req.runs])
    cal = calibrate_imu(
        runs,
        params,
        options=req.options,
        references=refs,
        sources=[str(p) for p in req.runs],
    )
    version = None
    trials: tuple[str, ...] = ()
    if req.db is not None:
        version, trials = _record(req.db, cal, [Path(p) for p in req.runs])
    return ImuOutcome(cal, choice.describe(), version, trials)


def _notebook_references(db: Path, paths: Sequence[Path]) -> list[TurnReference]:
    """The notebook's measured turns of the runs' trials (a compass and counted turns), when
    every run is a robot run folder whose trial is measured there; else none."""
    from odolab.app.selection import open_notebook
    from odolab.core.errors import StoreError
    from odolab.core.measurement import COMPASS_SIGMA_RAD
    from odolab.core.trials import TrialStatus

    ids = [_trial_id(p) for p in paths]
    if any(i is None for i in ids):
        return []
    refs = []
    with open_notebook(db) as nb:
        for k, trial_id in enumerate(ids):
            assert trial_id is not None
            try:
                trial = nb.get_trial(trial_id)
            except StoreError:
                return []
            m = trial.measured
            if trial.status is not TrialStatus.MEASURED or m is None or m.rotation is None:
                return []
            sd = m.sigma_rotation or math.sqrt(2.0) * COMPASS_SIGMA_RAD
            refs.append(
                TurnReference(
                    float(m.rotation),
                    float(sd),
                    f"the notebook's measurement of trial {trial_id} ({m.instrument})",
                    k,
                )
            )
    return refs


def _notes(cal: ImuCalibration) -> str:
    b0, b1 = cal.track_width_ci95
    q0, q1 = cal.radius_ratio_ci95
    return (
        f"gyro calibration from {cal.provenance['source']} (gyro: {cal.provenance['imu']}); "
        f"track {cal.track_width:.6g} m, 95 % [{b0:.6g}, {b1:.6g}]; radius ratio "
        f"{cal.radius_ratio:.6g}, 95 % [{q0:.6g}, {q1:.6g}]; gyro scale: {cal.scale_source}; "
        f"distance scale: {cal.radii_source}"
    )


def _record(db: Path, cal: ImuCalibration, paths: Sequence[Path]) -> tuple[int, tuple[str, ...]]:
    from odolab.app.selection import open_notebook

    with open_notebook(db) as nb:
        ids = [t for t in (_trial_id(p) for p in paths) if t is not None]
        known = {t.trial_id for t in nb.load_trials(with_logs=False)}
        used = tuple(t for t in ids if t in known)
        base = cal.old_params
        version = nb.add_params_version(
            cal.params.with_(name=base.name),
            method="imu",
            source_trials=used,
            notes=_notes(cal),
        )
    return version, used


def gyro_run_of(run: RobotRun) -> GyroRun | None:
    """A robot run's encoder log and its own gyro (a link with an IMU) as a :class:`GyroRun`,
    or None when the run has no gyro rates."""
    import numpy as np

    from odolab.io.gyro import gyro_run_from_log
    from odolab.io.sensorlog import ImuLog

    log = run.trial.encoder_log
    rates = [(t, r) for t, _, r in run.headings if r is not None]
    if log is None or len(log) < 2 or len(rates) < 2:
        return None
    g = np.asarray(rates, dtype=np.float64)
    keep = np.concatenate(([True], np.diff(g[:, 0]) > 0))
    t, wz = g[keep, 0], g[keep, 1]
    yaw = np.concatenate(([0.0], np.cumsum(0.5 * (wz[1:] + wz[:-1]) * np.diff(t))))
    imu = ImuLog(t, yaw, wz, source="the robot's gyro")
    return gyro_run_from_log(
        "this run",
        log,
        imu,
        run.trial.params.ticks_per_rev,
        source="the run's encoders",
        same_clock=True,
    )


def gyro_after_run(run: RobotRun) -> list[str]:
    """What ``odolab robot rotate|square|explore`` prints after a run on a link with an IMU: the
    gyro's effective track with its interval beside the parameters in use (the bias fitted when
    the run turned both ways or stood still, else taken as 0 +- 0.005 rad/s, said), and the drift
    monitor's flags. Empty for a run without a gyro."""
    from odolab.core.errors import OdolabError

    gyro = gyro_run_of(run)
    if gyro is None:
        return []
    params = run.trial.params
    lines: list[str] = []
    try:
        try:
            cal = calibrate_imu([gyro], params, options=ImuOptions(min_turn=1.0))
        except CalibrationError as err:
            if "in each direction" not in str(err):
                raise
            cal = calibrate_imu([gyro], params, options=ImuOptions(min_turn=1.0, bias=0.0))
    except OdolabError as err:
        lines.append(f"gyro: no estimate of the effective track: {err}")
    else:
        lo, hi = cal.track_width_ci95
        inside = lo <= params.track_width <= hi
        verdict = (
            "inside its interval"
            if inside
            else "outside its interval: calibrate (odolab calibrate imu on the saved run)"
        )
        lines.append(
            f"gyro: effective track {cal.track_width:.4f} m, 95 % [{lo:.4f}, {hi:.4f}]; the "
            f"parameters in use ({params.name}) say {params.track_width:.4f} m: {verdict} "
            f"(gyro scale taken as 1 +- 1 %; bias {cal.bias_how})"
        )
    drift = run.extra.get("drift") if isinstance(run.extra, dict) else None
    sense = run.extra.get("sense_check") if isinstance(run.extra, dict) else None
    if isinstance(sense, str):  # odometry against the gyro over the whole run
        lines.append(f"sense check: {sense}")
    flags = drift.get("flags", []) if isinstance(drift, dict) else []
    for t, message in flags:
        lines.append(f"drift monitor at {float(t):.1f} s: {message}")
    if isinstance(drift, dict) and not flags:
        lines.append("drift monitor: no change of the yaw-rate ratio seen")
    return lines
