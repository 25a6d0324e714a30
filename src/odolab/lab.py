"""The whole lab, end to end: what ``odolab demo`` (and ``make demo``) runs.

Steps, each reported through ``progress(step, done, total)``:

1. A fresh lab notebook (SQLite) in a new timestamped run folder (``OUT/<stamp>/``, with a
   ``latest`` link beside it); the nominal parameters are its first parameter version.
2. The lab report's campaign (section V: rotations pi..20 pi and 18 x 20 pi, straight runs 1 m and
   2.5 m forward and reverse, outdoor runs on concrete and grass) on the virtual Jaguar. The
   campaign runs on the simulator's vectorized Monte Carlo (every trial at once, same physics as
   behind the virtual board); its trials are recorded AWAITING, then the instruments measure them
   (compass with counted turns, meterstick, tape) and the readings are entered.
3. The UMBmark squares (5 clockwise, 5 counter-clockwise) and a 20 pi rotation with a phone taped
   on top are driven through the live stack: control loop, driver, Jaguar protocol codec and the
   virtual Jaguar board, in simulated time. They are measured and entered the same way.
4. Analysis (systematic and random error, growth, terrains, outliers) and Table I.
5. Calibration: ``ratios`` (the lab's section VIII, done right), then ``umbmark`` (iterated on
   the squares' encoder logs, starting from the ratios result: UMBmark fixes the track width and
   the left/right diameter ratio, not the scale); each is a new parameter version in the
   notebook and a TOML file.
6. Validation (the lab's Fig. 21): the phone's log against the old and the new parameters.
7. A re-run of the campaign with the calibrated parameters (same seed): the systematic ratios
   after calibration.
8. The report: HTML, PNGs and ``results.json``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from odolab.errors import OdolabError
from odolab.params import PRESETS, RobotParams, save_params
from odolab.trials import Command, Measurement, MotionKind, Trial, TrialStatus

__all__ = ["LabResult", "Progress", "run_lab"]

PHONE_CAMPAIGN = "imu-validation"
#: the simulated phone's clock minus the robot's (s); the validation searches +-5 s around it
PHONE_CLOCK_OFFSET = 12.5

#: The lab report's Table I, for comparison: (motion, terrain) -> (ratio, its stated
#: uncertainty, [(sigma, at, uncertainty), ...]). y rows: error per metre travelled.
LAB_REPORT_TABLE1: dict[tuple[str, str], tuple[float, float, list[tuple[float, float, float]]]] = {
    ("rotation", "tile"): (0.875, 0.005, [(2.94, 20 * math.pi, 0.05)]),
    ("x", "tile"): (0.905, 0.005, []),
    ("x", "concrete"): (0.920, 0.005, []),
    ("x", "grass"): (0.904, 0.005, []),
    ("y_forward", "tile"): (0.03, 0.01, []),
    ("y_reverse", "tile"): (0.09, 0.01, []),
}
#: Table I's sigma of the y error, one figure for forward and reverse runs together (the lab
#: pooled its 5 + 5 runs at each distance): (sigma, distance, uncertainty). Its 1.1 m is our 1 m.
LAB_REPORT_Y_SIGMA: list[tuple[float, float, float]] = [(0.03, 1.1, 0.01), (0.07, 2.5, 0.01)]


def pooled_y_sigmas(rows: list[dict[str, Any]], terrain: str = "tile") -> dict[float, float]:
    """sigma of the y error at each repeated distance, pooled over forward and reverse runs.

    From Table I rows (:func:`odolab.analysis.table1`): the pooled variance is the
    degrees-of-freedom weighted mean of the two directions' group variances.
    """
    acc: dict[float, list[float]] = {}
    for r in rows:
        if r["terrain"] != terrain or r["motion"] not in ("y_forward", "y_reverse"):
            continue
        for g in r["sigmas"]:
            d = round(abs(float(g["commanded"])), 6)
            ss_df = acc.setdefault(d, [0.0, 0.0])
            ss_df[0] += (g["n"] - 1) * g["sigma"] ** 2
            ss_df[1] += g["n"] - 1
    return {d: math.sqrt(ss / df) for d, (ss, df) in sorted(acc.items()) if df > 0}


#: progress(step, done, total): a step's name and how far it is
Progress = Callable[[str, int, int], None]

STEPS = (
    "notebook",
    "campaign",
    "live runs",
    "analysis",
    "calibration",
    "validation",
    "re-run",
    "report",
)


def _noop(step: str, done: int, total: int) -> None:
    return None


@dataclass
class LabResult:
    """Where everything went, and the headline numbers."""

    folder: Path
    notebook: Path
    report: Path
    results: Path
    params_files: dict[str, Path]
    table1: list[dict[str, Any]]
    after_calibration: dict[str, float]
    validation_rms: tuple[float, float]
    phone_log: Path | None = None  #: the phone's SensorLog CSV (for ``odolab validate``)
    loop: dict[str, Any] = field(default_factory=dict)


def _new_run_folder(out: Path) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
    folder = out / stamp
    k = 1
    while folder.exists():
        k += 1
        folder = out / f"{stamp}-{k}"
    try:
        folder.mkdir(parents=True)
    except OSError as err:
        raise OdolabError(
            f"{out}: cannot create the run folder {folder.name} there ({err.strerror or err}); "
            "expected a writable folder"
        ) from err
    latest = out / "latest"
    try:
        if latest.is_symlink() or latest.exists():
            latest.unlink()
        latest.symlink_to(folder.name)
    except OSError:  # a file system without links: the folder name is printed anyway
        pass
    return folder


def _awaiting(trial: Trial) -> tuple[Trial, Measurement | None]:
    """The trial as recorded before anyone measured it, and the measurement to enter."""
    m = trial.measured
    if trial.status is TrialStatus.EXCLUDED:
        return trial, None
    return replace(trial, measured=None, status=TrialStatus.AWAITING), m


def _record(nb: Any, trials: list[Trial]) -> None:
    """Record trials as driven, then enter what the instruments read (the lab's order)."""
    pending = [_awaiting(t) for t in trials]
    nb.add_trials([t for t, _ in pending])
    for t, m in pending:
        if m is not None:
            nb.set_measurement(t.trial_id, m)


def _measure_live(
    trials: list[Trial], rng: np.random.Generator, start_heading: list[float]
) -> list[Trial]:
    """Instruments read the live runs' true poses, as a person would type them in."""
    from odolab.sim.instruments import Compass, Meterstick
    from odolab.store import rotation_measurement_from_compass, translation_measurement

    compass, stick = Compass(), Meterstick()
    out: list[Trial] = []
    for trial, h0 in zip(trials, start_heading, strict=True):
        true = trial.true
        if true is None:
            raise OdolabError(f"trial {trial.trial_id}: the simulator gave no true pose")
        if trial.command.kind is MotionKind.ROTATION:
            r = compass.read_rotation(np.array([h0]), np.array([true.heading]), rng)
            m = rotation_measurement_from_compass(
                float(r.initial_deg[0]),
                float(r.final_deg[0]),
                int(r.turns[0]),
                commanded_angle=trial.command.angle,
            )
        else:
            xy = stick.read(np.array([true.x, true.y]), rng)
            m = translation_measurement(float(xy[0]), float(xy[1]), sigma=stick.sigma)
        out.append(replace(trial, measured=m, status=TrialStatus.MEASURED))
    return out


def _truth_recorder(plant: Any, times: list[float], headings: list[float]) -> Callable[[Any], None]:
    """A loop callback that samples the plant's true heading every cycle (what a phone sees)."""

    def on_cycle(info: Any) -> None:
        times.append(float(info.t))
        headings.append(float(plant.true_pose.heading))

    return on_cycle


def run_lab(
    out: str | Path = "odolab-out",
    *,
    seed: int | None = None,
    truth: str = "jaguar-lab",
    nominal: RobotParams | None = None,
    square_side: float = 4.0,
    square_runs: int = 5,
    rate: float = 20.0,
    progress: Progress = _noop,
) -> LabResult:
    """Run the whole lab on the virtual Jaguar; return where the results are."""
    from odolab.analysis import analyze_trials, table1
    from odolab.calibration import (
        CalibrationResult,
        UmbmarkResult,
        ratios_from_analysis,
        umbmark_iterated,
    )
    from odolab.report import write_report
    from odolab.robot.session import run_motion_simulated
    from odolab.sim.plants import make_plant
    from odolab.sim.presets import LAB_REPORT_SEED, TRUTH_PRESETS
    from odolab.sim.protocols import load_protocol, run_protocol
    from odolab.store import Notebook
    from odolab.validation import simulate_phone_log, validate, write_sensorlog
    from odolab.validation.compare import plot_validation

    nominal = nominal or PRESETS["jaguar-lite"]
    seed = LAB_REPORT_SEED if seed is None else seed
    if seed < 0:
        raise OdolabError(f"seed is {seed}; expected an integer >= 0")
    if truth not in TRUTH_PRESETS:
        raise OdolabError(
            f"unknown truth preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    true_params = TRUTH_PRESETS[truth]
    rng = np.random.default_rng(seed + 1)

    # 1. notebook
    progress("notebook", 0, 1)
    folder = _new_run_folder(Path(out))
    db = folder / "odolab.db"
    nb = Notebook(db)
    nb.add_params_version(nominal, method="nominal preset", notes="not measured: calibrate")
    progress("notebook", 1, 1)

    # 2. the lab report's campaign, vectorized
    protocol = load_protocol("lab-report")
    campaign = run_protocol(
        protocol,
        true_params,
        nominal,
        seed=seed,
        progress=lambda d, t, _what: progress("campaign", d, t),
    )
    _record(nb, campaign)

    # 3. live runs through the control loop, in simulated time
    live_cmds: list[tuple[str, Command]] = []
    for direction in ("cw", "ccw"):
        for k in range(square_runs):
            live_cmds.append(
                (
                    f"umbmark-{direction}-{k + 1:02d}",
                    Command(MotionKind.SQUARE, side=square_side, direction=direction),
                )
            )
    live_cmds.append(("imu-rotation-20pi", Command(MotionKind.ROTATION, angle=20 * math.pi)))
    live: list[Trial] = []
    starts: list[float] = []
    loop_stats: list[Any] = []
    phone_t: list[float] = []
    phone_h: list[float] = []
    for i, (trial_id, cmd) in enumerate(live_cmds):
        progress("live runs", i, len(live_cmds))
        plant = make_plant(true_params, nominal, "tile", seed=seed * 1000 + i)
        starts.append(plant.true_pose.heading)
        is_phone = cmd.kind is MotionKind.ROTATION
        trial, stats = run_motion_simulated(
            cmd,
            true_params,
            nominal,
            "tile",
            seed=seed * 1000 + i,
            rate=rate,
            plant=plant,
            campaign="umbmark" if cmd.kind is MotionKind.SQUARE else PHONE_CAMPAIGN,
            on_cycle=_truth_recorder(plant, phone_t, phone_h) if is_phone else None,
        )
        live.append(replace(trial, trial_id=trial_id))
        loop_stats.append(stats)
    progress("live runs", len(live_cmds), len(live_cmds))
    live = _measure_live(live, rng, starts)
    _record(nb, live)

    # 4. analysis of everything in the notebook
    progress("analysis", 0, 1)
    # the phone run validates a calibration; it is not one of the characterization trials
    trials = [t for t in nb.load_trials() if t.campaign != PHONE_CAMPAIGN]
    analysis = analyze_trials(trials)
    rows = table1(analysis)
    progress("analysis", 1, 1)

    # 5. calibration
    progress("calibration", 0, 2)
    by_ratio = ratios_from_analysis(analysis, nominal, terrain="tile")
    squares = [t for t in trials if t.command.kind is MotionKind.SQUARE]
    # UMBmark corrects the track and the left/right diameter ratio, never the scale: start it
    # from the ratios result, iterate on the squares' encoder logs until it converges
    by_umbmark = umbmark_iterated(squares, by_ratio.params)
    calibrations: dict[str, CalibrationResult | UmbmarkResult] = {
        "ratios": by_ratio,
        "umbmark": by_umbmark,
    }
    params_files: dict[str, Path] = {}
    for name, cal in (("ratios", by_ratio), ("umbmark", by_umbmark.calibration)):
        new = cal.params.with_(name=nominal.name)
        nb.add_params_version(
            new,
            method=name,
            source_trials=[
                t.trial_id
                for t in (squares if name == "umbmark" else trials)
                if t.status is TrialStatus.MEASURED
            ],
            notes=str(cal.provenance.get("source", "")),
        )
        params_files[name] = save_params(
            cal.params, folder / f"params-{name}.toml", provenance=_toml_safe(cal.provenance)
        )
        progress("calibration", len(params_files), 2)

    # 6. validation against the phone (the lab's Fig. 21)
    progress("validation", 0, 1)
    phone_trial = live[-1]
    assert phone_trial.encoder_log is not None
    # the phone logs from 10 s before the run to 10 s after it (the robot stands still then)
    t_run, h_run = np.asarray(phone_t), np.asarray(phone_h)
    before = t_run[0] - np.arange(200, 0, -1) * 0.05
    after = t_run[-1] + np.arange(1, 201) * 0.05
    t_true = np.concatenate([before, t_run, after])
    h_true = np.concatenate([np.full(200, h_run[0]), h_run, np.full(200, h_run[-1])])
    imu = simulate_phone_log(t_true, h_true, clock_offset=PHONE_CLOCK_OFFSET, seed=seed)
    assert imu.yaw_rate is not None
    phone_csv = write_sensorlog(folder / "phone-sensorlog.csv", imu.t, imu.yaw, imu.yaw_rate)
    check = validate(
        phone_trial.encoder_log,
        imu,
        nominal,
        by_ratio.params,
        offset=PHONE_CLOCK_OFFSET,
        max_offset=5.0,
    )
    progress("validation", 1, 1)

    # 7. the campaign again, with the calibrated parameters (same seed, same true robot)
    rerun = run_protocol(
        protocol,
        true_params,
        by_ratio.params,
        seed=seed,
        progress=lambda d, t, _what: progress("re-run", d, t),
    )
    after = analyze_trials(rerun)
    after_ratios: dict[str, float] = {}
    for motion in ("rotation", "x"):
        fit = after.get(motion, "tile")
        if fit is not None:
            after_ratios[f"{motion}_tile"] = fit.ratio

    # 8. report
    progress("report", 0, 1)
    loop_summary = {
        "runs": len(loop_stats),
        "cycles": int(sum(s.cycles for s in loop_stats)),
        "rate_hz": rate,
        "sensor_packets": int(sum(s.sensor_packets for s in loop_stats)),
        "decode_errors": int(sum(s.decode_errors for s in loop_stats)),
        "overruns": int(sum(s.overruns for s in loop_stats)),
    }
    extra = {
        "seed": seed,
        "truth": truth,
        "true_params": dataclasses.asdict(true_params),
        "after_calibration": {
            "method": "ratios",
            "ratios": after_ratios,
            "note": "the lab-report campaign re-run with the ratios-calibrated parameters, same seed",
        },
        "live_runs": loop_summary,
        "notebook": str(db),
        "phone_log": str(phone_csv),
        "phone_trial": phone_trial.trial_id,
    }
    html = write_report(
        folder,
        analysis,
        calibrations,
        check.to_dict(series=False),
        validation_figure=lambda ax: plot_validation(check, ax=ax, kind="heading"),
        extra=extra,
    )
    progress("report", 1, 1)
    nb.close()
    return LabResult(
        folder=folder,
        notebook=db,
        report=html,
        results=folder / "results.json",
        params_files=params_files,
        table1=rows,
        after_calibration=after_ratios,
        validation_rms=(check.old.rms, check.new.rms),
        phone_log=phone_csv,
        loop=loop_summary,
    )


def _toml_safe(value: Any) -> Any:
    """Provenance as TOML can hold it (no None, tuples as lists)."""
    if isinstance(value, dict):
        return {str(k): _toml_safe(v) for k, v in value.items() if v is not None}
    if isinstance(value, list | tuple):
        return [_toml_safe(v) for v in value if v is not None]
    if isinstance(value, np.generic):
        return value.item()
    return value
