"""The whole lab, end to end: what ``odolab demo`` (and ``make demo``) runs.

:func:`run_lab` reads as its table of contents: one typed step per item below, each reported
through ``progress(step, done, total)``; the notebook is open in one ``with`` block.

1. A fresh lab notebook (SQLite) in a new timestamped run folder (``OUT/<stamp>/``, with a
   ``latest`` link beside it); the nominal parameters are its first parameter version.
2. The lab report's campaign (section V: rotations pi..20 pi and 18 x 20 pi, straight runs 1 m and
   2.5 m forward and reverse, outdoor runs on concrete and grass) on the virtual Jaguar. The
   campaign runs on the simulator's vectorized Monte Carlo (every trial at once, same physics as
   behind the virtual board); its trials are recorded AWAITING, then the instruments measure them
   (compass with counted turns, meterstick, tape) and the readings are entered.
3. The UMBmark squares (5 clockwise, 5 counter-clockwise) and five 20 pi rotations with a phone
   taped on top are driven through the live stack: control loop, driver, Jaguar protocol codec
   and the virtual Jaguar board, in simulated time. They are measured and entered the same way;
   the phone runs are their own validation campaign, never part of Table I.
4. Analysis (systematic and random error, growth, terrains, outliers) and Table I.
5. Calibration: ``ratios`` (the lab's section VIII, done right), then ``umbmark`` (iterated on
   the squares' encoder logs, starting from the ratios result: UMBmark fixes the track width and
   the left/right diameter ratio, not the scale); each is a new parameter version in the
   notebook and a TOML file.
6. Validation (the lab's Fig. 21): each phone run's log against the old and the new
   parameters, and every run's final heading error against the random error Table I predicts
   (:mod:`odolab.validation.runs`): what the runs show and what they cannot.
7. A re-run of the campaign with the calibrated parameters (same seed): the systematic ratios
   after calibration.
8. Models and covariance: six free runs (straight legs, curves, pivots, turns in place) recorded
   with ground truth, as a motion-capture system would; every kinematic model is fitted on four
   and scored on two (:func:`odolab.calibration.compare.compare_models`), and the NEES of all six
   says whether the covariance the calibrated ``[noise]`` propagates is honest
   (:mod:`odolab.metrics.consistency`). When the truth has speed-dependent slip
   (``jaguar-lab-tracked``) a one-minute exploration is driven too and diff, extended, icr and
   the slip model are fitted on it plus the four training runs, scored on the same two held-out
   runs, with a learning curve and the speed question from the slip model's coefficients
   (:func:`odolab.app.models.slip_comparison`; the runs are written to ``runs/``).
9. The report: HTML, PNGs and ``results.json``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from odolab.analysis.reference import LAB_REPORT_TABLE1, LAB_REPORT_Y_SIGMA
from odolab.analysis.table1 import pooled_y_sigmas
from odolab.core import numfmt
from odolab.core.errors import OdolabError
from odolab.core.params import PRESETS, RobotParams, save_params
from odolab.core.trials import Command, Measurement, MotionKind, Trial, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.analysis.questions import ExperimentResult
    from odolab.calibration import CalibrationResult, UmbmarkResult
    from odolab.io.run import OdometryRun
    from odolab.io.sensorlog import ImuLog
    from odolab.metrics.consistency import RunNees
    from odolab.report.models_section import ModelEvidence
    from odolab.robot.loop import CycleInfo, LoopStats
    from odolab.sim.physics import TrueParams, VirtualRobot
    from odolab.store import Notebook
    from odolab.validation import ValidationResult
    from odolab.validation.runs import RandomBand, RunsSummary

__all__ = [
    "LAB_REPORT_TABLE1",
    "LAB_REPORT_Y_SIGMA",
    "STEPS",
    "LabResult",
    "Progress",
    "pooled_y_sigmas",
    "run_lab",
]

PHONE_CAMPAIGN = "imu-validation"
PHONE_CAMPAIGN_NOTES = (
    "validation: a phone rode on this run to check the calibration (the lab's Fig. 21); "
    "it is not one of the characterization trials"
)
#: the simulated phone's clock minus the robot's (s); the validation searches +-5 s around it
PHONE_CLOCK_OFFSET = 12.5

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
    "models",
    "report",
)

#: the motion-capture runs of step 8: how many, how many of them held out, legs per run
MOCAP_RUNS = 6
MOCAP_HELD_OUT = 2
MOCAP_LEGS = 20


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
    table1: list[dict[str, object]]
    after_calibration: dict[str, float]
    validation_rms: tuple[float, float]
    phone_log: Path | None = None  #: the phone's SensorLog CSV (for ``odolab validate``)
    loop: dict[str, object] = field(default_factory=dict)
    phone_runs: RunsSummary | None = (
        None  #: the phone runs against the predicted random error (RunsSummary)
    )
    #: the model comparison and NEES of step 8 (odolab.report.models_section.ModelEvidence)
    evidence: ModelEvidence | None = None
    #: the phone runs' gyro calibration beside the ratios one (_gyro; docs/imu.md)
    gyro: dict[str, object] | None = None


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


def _record(nb: Notebook, trials: list[Trial]) -> None:
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
                direction="cw" if r.clockwise[0] else "ccw",  # the way the turns were counted
            )
        else:
            xy = stick.read(np.array([true.x, true.y]), rng)
            m = translation_measurement(float(xy[0]), float(xy[1]), sigma=stick.sigma)
        out.append(replace(trial, measured=m, status=TrialStatus.MEASURED))
    return out


def _truth_recorder(
    plant: VirtualRobot, times: list[float], headings: list[float]
) -> Callable[[CycleInfo], None]:
    """A loop callback that samples the plant's true heading every cycle (what a phone sees)."""

    def on_cycle(info: CycleInfo) -> None:
        times.append(float(info.t))
        headings.append(float(plant.true_pose.heading))

    return on_cycle


# -- the steps, each a typed value in and out ----------------------------------------------------


@dataclass(frozen=True)
class LabConfig:
    """What a lab run is asked to do (validated by :func:`_config`)."""

    out: Path
    seed: int
    truth: str
    nominal: RobotParams
    true_params: TrueParams
    square_side: float
    square_runs: int
    phone_runs: int
    rate: float
    #: the face's flag for a setting, for the command lines in results.json (None: left out)
    flag: Callable[[str], str] | None = None


@dataclass
class LiveRuns:
    """The runs driven through the live stack: squares, then rotations with a phone on top."""

    squares: list[Trial]
    phone: list[Trial]
    phone_truth: list[tuple[np.ndarray, np.ndarray]]  #: (t, true heading) per phone run
    loop: dict[str, Any]


@dataclass
class Calibrated:
    """The two calibrations and the files they were written to."""

    ratios: CalibrationResult
    umbmark: UmbmarkResult
    files: dict[str, Path]
    #: where each started (odolab.app.calibration.BaseChoice.reason)
    starts: dict[str, str] = field(default_factory=dict)


@dataclass
class Validated:
    """The phone runs against the old and the new parameters."""

    first: ValidationResult  #: the first run's ValidationResult (the report's Fig. 21)
    runs: RunsSummary  #: over every phone run
    checks: list[ValidationResult]
    band: RandomBand
    phone_log: Path
    imus: list[ImuLog] = field(default_factory=list)  #: each phone run's ImuLog


def _config(
    out: str | Path,
    seed: int | None,
    truth: str,
    nominal: RobotParams | None,
    square_side: float,
    square_runs: int,
    phone_runs: int,
    rate: float,
    flag: Callable[[str], str] | None = None,
) -> LabConfig:
    from odolab.sim.presets import LAB_REPORT_SEED, TRUTH_PRESETS

    seed = LAB_REPORT_SEED if seed is None else seed
    if seed < 0:
        raise OdolabError(f"seed is {seed}; expected an integer >= 0")
    if truth not in TRUTH_PRESETS:
        raise OdolabError(
            f"unknown truth preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    if phone_runs < 1:
        raise OdolabError(f"phone_runs is {phone_runs}; expected at least 1")
    return LabConfig(
        Path(out),
        seed,
        truth,
        nominal or PRESETS["jaguar-lite"],
        TRUTH_PRESETS[truth],
        square_side,
        square_runs,
        phone_runs,
        rate,
        flag,
    )


def _campaign(cfg: LabConfig, nb: Notebook, progress: Progress) -> list[Trial]:
    """Step 2: the lab report's campaign on the vectorized simulator, recorded and measured."""
    from odolab.sim.protocols import load_protocol, run_protocol

    trials = run_protocol(
        load_protocol("lab-report"),
        cfg.true_params,
        cfg.nominal,
        seed=cfg.seed,
        progress=lambda d, t, _what: progress("campaign", d, t),
    )
    _record(nb, trials)
    return trials


def _live_commands(cfg: LabConfig) -> list[tuple[str, Command]]:
    cmds: list[tuple[str, Command]] = []
    for direction in ("cw", "ccw"):
        for k in range(cfg.square_runs):
            square = Command(MotionKind.SQUARE, side=cfg.square_side, direction=direction)
            cmds.append((f"umbmark-{direction}-{k + 1:02d}", square))
    for k in range(cfg.phone_runs):
        suffix = "" if k == 0 else f"-{k + 1}"
        cmds.append(
            (f"imu-rotation-20pi{suffix}", Command(MotionKind.ROTATION, angle=20 * math.pi))
        )
    return cmds


def _live_runs(cfg: LabConfig, nb: Notebook, progress: Progress) -> LiveRuns:
    """Step 3: squares and phone rotations through loop, driver, codec and virtual board."""
    from odolab.robot.session import run_motion_simulated
    from odolab.sim.plants import make_plant

    cmds = _live_commands(cfg)
    live: list[Trial] = []
    starts: list[float] = []
    stats: list[LoopStats] = []
    truth: list[tuple[np.ndarray, np.ndarray]] = []
    for i, (trial_id, cmd) in enumerate(cmds):
        progress("live runs", i, len(cmds))
        plant = make_plant(cfg.true_params, cfg.nominal, "tile", seed=cfg.seed * 1000 + i)
        starts.append(plant.true_pose.heading)
        phone = cmd.kind is MotionKind.ROTATION
        t_h: tuple[list[float], list[float]] = ([], [])
        trial, st = run_motion_simulated(
            cmd,
            cfg.true_params,
            cfg.nominal,
            "tile",
            seed=cfg.seed * 1000 + i,
            rate=cfg.rate,
            plant=plant,
            campaign=PHONE_CAMPAIGN if phone else "umbmark",
            on_cycle=_truth_recorder(plant, *t_h) if phone else None,
        )
        live.append(replace(trial, trial_id=trial_id))
        stats.append(st)
        if phone:
            truth.append((np.asarray(t_h[0]), np.asarray(t_h[1])))
    progress("live runs", len(cmds), len(cmds))
    rng = np.random.default_rng(cfg.seed + 1)
    live = _measure_live(live, rng, starts)
    # the phone runs check a calibration: their own campaign, marked so that no analysis of the
    # notebook counts them among the characterization trials (Table I, the calibrations)
    nb.add_campaign(PHONE_CAMPAIGN, "rotation", "tile", notes=PHONE_CAMPAIGN_NOTES)
    _record(nb, live)
    loop = {
        "runs": len(stats),
        "cycles": int(sum(s.cycles for s in stats)),
        "rate_hz": cfg.rate,
        "sensor_packets": int(sum(s.sensor_packets for s in stats)),
        "decode_errors": int(sum(s.decode_errors for s in stats)),
        "overruns": int(sum(s.overruns for s in stats)),
    }
    squares = [t for t in live if t.command.kind is MotionKind.SQUARE]
    phone_trials = [t for t in live if t.campaign == PHONE_CAMPAIGN]
    return LiveRuns(squares, phone_trials, truth, loop)


def _analysis(
    nb: Notebook, progress: Progress
) -> tuple[LabAnalysis, list[Trial], list[dict[str, object]]]:
    """Step 4: every characterization trial in the notebook (validation runs left out), as
    ``odolab analyze`` and the web's Table I select them (:func:`odolab.app.analysis.analyze`)."""
    from odolab.app.analysis import analyze

    progress("analysis", 0, 1)
    result = analyze(nb)
    progress("analysis", 1, 1)
    return result.analysis, result.selection.trials, result.table1


def _calibrate(cfg: LabConfig, nb: Notebook, folder: Path, progress: Progress) -> Calibrated:
    """Step 5: ratios on tile, then UMBmark iterated from the ratios result; each a parameter
    version (:func:`odolab.app.calibration.calibrate`, as ``odolab calibrate`` and the web)."""
    from odolab.app.calibration import CalibrationRequest, calibrate

    progress("calibration", 0, 2)
    by_ratio = calibrate(nb, CalibrationRequest("ratios", terrain="tile"))
    progress("calibration", 1, 2)
    # UMBmark corrects the track and the left/right diameter ratio, never the scale: it starts
    # from the ratios result and iterates on the squares' encoder logs (the rule of every face,
    # odolab.app.calibration.umbmark_start)
    by_umbmark = calibrate(nb, CalibrationRequest("umbmark", terrain="tile"))
    assert by_umbmark.umbmark is not None
    files: dict[str, Path] = {}
    for name, cal in (("ratios", by_ratio.result), ("umbmark", by_umbmark.result)):
        files[name] = save_params(
            folder / f"params-{name}.toml", cal.params, provenance=_toml_safe(cal.provenance)
        )
    progress("calibration", 2, 2)
    starts = {"ratios": by_ratio.base.reason, "umbmark": by_umbmark.base.reason}
    return Calibrated(by_ratio.result, by_umbmark.umbmark, files, starts)


def _phone_log(t_run: np.ndarray, h_run: np.ndarray, seed: int) -> ImuLog:
    """The phone's log: from 10 s before the run to 10 s after it (the robot stands still)."""
    from odolab.validation import simulate_phone_log

    before = t_run[0] - np.arange(200, 0, -1) * 0.05
    after = t_run[-1] + np.arange(1, 201) * 0.05
    t_true = np.concatenate([before, t_run, after])
    h_true = np.concatenate([np.full(200, h_run[0]), h_run, np.full(200, h_run[-1])])
    return simulate_phone_log(t_true, h_true, clock_offset=PHONE_CLOCK_OFFSET, seed=seed)


def _validate(
    cfg: LabConfig,
    live: LiveRuns,
    new: RobotParams,
    rows: list[dict[str, object]],
    folder: Path,
    progress: Progress,
) -> Validated:
    """Step 6 (the lab's Fig. 21): every phone run against the old and the new parameters,
    and the final heading errors against the random error Table I predicts."""
    from odolab.validation import validate, write_sensorlog
    from odolab.validation.runs import summarize_runs

    progress("validation", 0, len(live.phone))
    checks = []
    imus = []
    phone_csv = folder / "phone-sensorlog.csv"
    for k, (trial, (t_run, h_run)) in enumerate(zip(live.phone, live.phone_truth, strict=True)):
        assert trial.encoder_log is not None
        imu = _phone_log(t_run, h_run, cfg.seed + k)
        imus.append(imu)
        if k == 0:  # the first run's phone log is kept for `odolab validate`
            assert imu.yaw_rate is not None
            write_sensorlog(phone_csv, imu.t, imu.yaw, imu.yaw_rate)
        checks.append(
            validate(
                trial.encoder_log,
                imu,
                cfg.nominal,
                new,
                offset=PHONE_CLOCK_OFFSET,
                max_offset=5.0,
            )
        )
        progress("validation", k + 1, len(live.phone))
    band = _random_band(rows)
    runs = summarize_runs(checks, band, offset_true=PHONE_CLOCK_OFFSET)
    return Validated(checks[0], runs, checks, band, phone_csv, imus)


def _gyro(live: LiveRuns, val: Validated, ratios: CalibrationResult) -> dict[str, object]:
    """Step 6b: the phone runs' gyro calibrates the rotation part (docs/imu.md), beside the
    ratios calibration: the same radii (the distance scale the gyro cannot see), the phone's
    bias from its still seconds before each run, its scale taken as 1 +- 1 %."""
    from odolab.calibration.imu import Z95, ImuOptions, calibrate_imu
    from odolab.io.gyro import gyro_run_from_log

    params = ratios.params
    runs, still = [], []
    for trial, imu in zip(live.phone, val.imus, strict=True):
        assert trial.encoder_log is not None and imu.yaw_rate is not None
        runs.append(
            gyro_run_from_log(
                trial.trial_id,
                trial.encoder_log,
                imu,
                params.ticks_per_rev,
                source=f"trial {trial.trial_id}",
            )
        )
        # the robot stood still for 10 s before the run; the clock offset is known to +-5 s
        before = imu.t < float(trial.encoder_log.t[0]) + PHONE_CLOCK_OFFSET - 5.5
        still.append(imu.yaw_rate[before])
    w = np.concatenate(still)
    bias, bias_sd = float(w.mean()), float(w.std(ddof=1) / math.sqrt(w.size))
    gyro = calibrate_imu(
        runs,
        params,
        options=ImuOptions(offset=PHONE_CLOCK_OFFSET, max_offset=5.0, bias=bias, bias_sd=bias_sd),
        radii_source=(
            f"the ratios calibration's mean wheel radius {params.left_wheel_radius:.6g} m (the "
            "straight runs measured in the notebook)"
        ),
    )
    b, (b0, b1) = gyro.track_width, gyro.track_width_ci95
    rci = ratios.provenance.get("track_width_ci95")
    rb = params.track_width
    rows = [
        ("runs", f"{len(runs)} phone runs (20 pi in place), the phone's gyro at 100 Hz"),
        ("effective track, gyro", f"{b:.4f} m, 95 % [{b0:.4f}, {b1:.4f}]"),
    ]
    out: dict[str, object] = {"track_width": b, "track_width_ci95": [b0, b1], "ratios": rb}
    if isinstance(rci, list | tuple) and len(rci) == 2:
        r0, r1 = float(rci[0]), float(rci[1])
        se = math.hypot(math.log(b1 / b0) / (2 * Z95), math.log(r1 / r0) / (2 * Z95))
        z = abs(math.log(b / rb)) / se
        agree = z < Z95
        rows.append(
            ("effective track, ratios calibration", f"{rb:.4f} m, 95 % [{r0:.4f}, {r1:.4f}]")
        )
        rows.append(
            (
                "agreement",
                f"the difference is {z:.2f} combined standard errors: "
                + ("they agree" if agree else "they DISAGREE"),
            )
        )
        out.update({"ratios_ci95": [r0, r1], "z": z, "agree": agree})
    else:
        rows.append(("effective track, ratios calibration", f"{rb:.4f} m (no interval)"))
    rows += [
        ("gyro bias", f"{bias:+.5f} rad/s from {w.size} samples standing still before the runs"),
        ("gyro scale", gyro.scale_source),
        ("clock offset (phone - robot)", "; ".join(o.describe() for o in gyro.offsets[:1])),
        ("radius ratio", f"{gyro.radius_ratio:.5f} ({gyro.ratio_note or 'fitted'})"),
        ("distance scale", gyro.radii_source),
    ]
    out["section"] = {
        "title": "The phone's gyro: the effective track from the phone runs, beside the ratios",
        "rows": [list(r) for r in rows],
    }
    return out


def _random_band(rows: list[dict[str, Any]]) -> RandomBand:
    """σ(θ) of a rotation from Table I: the spread at the largest repeated angle, growing
    with the fitted power p (0.5, a random walk, when no growth fit)."""
    from odolab.validation.runs import RandomBand

    rot = next((r for r in rows if r["motion"] == "rotation" and r["terrain"] == "tile"), None)
    if rot is None or "sigma" not in rot:
        raise OdolabError("the validation needs Table I's rotation spread on tile")
    p = float(rot.get("growth_p", 0.5))
    return RandomBand(float(rot["sigma"]), abs(float(rot["sigma_at"])), p if p > 0 else 0.5)


def _rerun(cfg: LabConfig, new: RobotParams, progress: Progress) -> dict[str, float]:
    """Step 7: the campaign again with the calibrated parameters (same seed, same robot)."""
    from odolab.analysis import analyze_trials
    from odolab.sim.protocols import load_protocol, run_protocol

    rerun = run_protocol(
        load_protocol("lab-report"),
        cfg.true_params,
        new,
        seed=cfg.seed,
        progress=lambda d, t, _what: progress("re-run", d, t),
    )
    after = analyze_trials(rerun)
    ratios: dict[str, float] = {}
    for motion in ("rotation", "x"):
        fit = after.get(motion, "tile")
        if fit is not None:
            ratios[f"{motion}_tile"] = fit.ratio
    return ratios


def _mocap_runs(
    cfg: LabConfig, progress: Progress, total: int = MOCAP_RUNS + 1
) -> list[OdometryRun]:
    """Free runs of the true robot on tile, each with its ground truth (motion capture)."""
    from odolab.core.trajectory import Trajectory
    from odolab.io.run import OdometryRun
    from odolab.sim.drives import drive, random_legs

    runs = []
    for k in range(MOCAP_RUNS):
        progress("models", k, total)
        seed = cfg.seed * 1000 + 500 + k
        legs = random_legs(
            np.random.default_rng(seed), MOCAP_LEGS, track_width=cfg.nominal.track_width
        )
        d = drive(cfg.true_params, cfg.nominal, legs, terrain="tile", seed=seed)
        gt = Trajectory.from_xyh(d.t, d.x, d.y, d.heading)
        name = f"mocap-{k + 1:02d}"
        runs.append(OdometryRun(name, name, d.t, d.dticks_left, d.dticks_right, ground_truth=gt))
    return runs


def _models(cfg: LabConfig, new: RobotParams, folder: Path, progress: Progress) -> ModelEvidence:
    """Step 8: which kinematic model the robot needs, and whether the propagated covariance of
    the calibrated ``[noise]`` is honest, both on free runs with ground truth; on a truth with
    speed-dependent slip also the slip model learned from a one-minute exploration
    (:func:`odolab.app.models.slip_comparison`, the rule ``calibrate compare`` shares)."""
    from odolab.app.models import CompareRequest, compare_runs, exploration_reason
    from odolab.core.errors import InsufficientDataError
    from odolab.metrics.consistency import choose_nees_piece
    from odolab.report.models_section import ModelEvidence

    why_not = exploration_reason(cfg.true_params, cfg.truth)
    total = MOCAP_RUNS + (2 if why_not is None else 1)
    runs = _mocap_runs(cfg, progress, total)
    train, held = runs[: MOCAP_RUNS - MOCAP_HELD_OUT], runs[MOCAP_RUNS - MOCAP_HELD_OUT :]
    missing: list[str] = []
    comparison = compare_runs(train, held, cfg.nominal, CompareRequest(seed=cfg.seed, n_boot=1000))
    about_models = (
        f"{MOCAP_RUNS} free runs of {MOCAP_LEGS} legs each (straight, curves of 0.3 to 5 m "
        "radius, pivots on either track, turns in place, both directions) on tile, recorded "
        f"with ground truth as a motion-capture system would; truth preset {cfg.truth}. "
        f"Each model is fitted from the nominal parameters on {len(train)} runs by least "
        f"squares (odolab calibrate lsq) and scored on {len(held)} it did not see."
    )
    nees: list[RunNees] = []
    about_nees = ""
    if new.noise is None:
        missing.append(
            "No NEES: the calibrated parameters have no [noise] table (the analysis could not "
            "estimate the per-wheel noise)."
        )
    else:
        chosen = ""
        try:
            _, nees, chosen = choose_nees_piece(runs, new)
        except InsufficientDataError as err:
            missing.append(f"No NEES: {err}")
        n = new.noise
        about_nees = (
            f"The ratios-calibrated parameters with the [noise] the analysis measured (k_left "
            f"{numfmt.plain(n.k_left, 3)} m, k_right {numfmt.plain(n.k_right, 3)} m, k_scrub "
            f"{numfmt.plain(n.k_scrub, 3)} rad), on pieces of all {MOCAP_RUNS} runs (none of "
            f"them was used to measure the noise).{f' {chosen}.' if chosen else ''}"
        )
    questions, about_questions = _open_questions(cfg)
    slip: dict[str, object] | None = None
    slip_note = why_not or ""
    if why_not is None:
        progress("models", MOCAP_RUNS + 1, total)
        slip, slip_note = _slip(cfg, held, questions, folder)
    progress("models", total, total)
    return ModelEvidence(
        comparison, tuple(nees), about_models, about_nees, tuple(missing), questions,
        about_questions, slip, slip_note,
    )  # fmt: skip


def _slip(
    cfg: LabConfig, held: list[OdometryRun], questions: tuple[ExperimentResult, ...], folder: Path
) -> tuple[dict[str, object] | None, str]:
    """The slip model against the kinematic ones, from a one-minute exploration (the runs
    written to ``runs/`` so that ``calibrate compare`` can repeat it); a failure is a note."""
    from odolab.app.models import slip_comparison

    try:
        result = slip_comparison(
            cfg.true_params, cfg.nominal, held, seed=cfg.seed, terrain="tile",
            questions=questions, folder=folder / "runs", base=folder,
        )  # fmt: skip
    except OdolabError as err:
        return None, f"No slip comparison: {err}"
    return result.to_dict(cfg.flag), ""


def _open_questions(cfg: LabConfig) -> tuple[tuple[ExperimentResult, ...], str]:
    """The lab's open questions (section IX) answered on the true robot, when its truth has the
    slips they ask about (turn, speed, stop: ``jaguar-lab-tracked``); none otherwise."""
    from odolab.analysis.questions import builtin_experiments, run_open_questions

    tp = cfg.true_params
    if not (tp.turn_slip > 0 or tp.speed_slip > 0 or tp.stop_slide > 0):
        return (), ""
    results = run_open_questions(tp, cfg.nominal, seed=cfg.seed)
    about = (
        f"The built-in experiments ({', '.join(sorted(builtin_experiments()))}, as odolab sim "
        f"questions runs them), driven by odometry on the truth preset {cfg.truth} (seed "
        f"{cfg.seed}) and measured as the lab would. These are properties of the simulator's "
        "truth, shown as the lab would measure them on a real robot."
    )
    return tuple(results), about


def _report(
    cfg: LabConfig,
    folder: Path,
    db: Path,
    analysis: LabAnalysis,
    cal: Calibrated,
    val: Validated,
    live: LiveRuns,
    after: dict[str, float],
    evidence: ModelEvidence,
    progress: Progress,
    gyro: dict[str, object] | None = None,
) -> Path:
    """Step 9: report.html, figures and results.json."""
    from odolab.report import write_report
    from odolab.validation.compare import plot_validation
    from odolab.validation.runs import plot_validation_runs

    progress("report", 0, 1)
    validation = val.first.to_dict(series=False)
    validation["phone_runs"] = val.runs.to_dict()
    extra = {
        "seed": cfg.seed,
        "truth": cfg.truth,
        "true_params": dataclasses.asdict(cfg.true_params),
        "after_calibration": {
            "method": "ratios",
            "ratios": after,
            "note": "the lab-report campaign re-run with the ratios-calibrated parameters, same seed",
        },
        "calibrated_from": cal.starts.get("ratios"),
        "umbmark_from": cal.starts.get("umbmark"),
        "live_runs": live.loop,
        "notebook": str(db),
        "phone_log": str(val.phone_log),
        "phone_trial": live.phone[0].trial_id,
    }
    if gyro is not None:  # the gyro's calibration, a section of its own
        extra["ground_truth"] = [gyro["section"]]
        extra["gyro_calibration"] = {k: v for k, v in gyro.items() if k != "section"}
    html = write_report(
        folder,
        analysis,
        {"ratios": cal.ratios, "umbmark": cal.umbmark},
        validation,
        validation_figure=lambda ax: plot_validation(val.first, ax=ax, kind="heading"),
        extra_figures={
            "validation_runs": (
                f"{val.runs.runs} phone runs against the predicted random error",
                "Heading error (odometry − IMU) of every phone run against the rotation so far, "
                "old and new parameters, on the ±1.96 σ band of the random error Table I "
                "predicts; the table above says what the runs show and cannot prove.",
                lambda ax: plot_validation_runs(val.checks, val.band, ax=ax),
            )
        },
        extra=extra,
        reference=LAB_REPORT_TABLE1,
        evidence=evidence,
    )
    progress("report", 1, 1)
    return html


def run_lab(
    out: str | Path = "odolab-out",
    *,
    seed: int | None = None,
    truth: str = "jaguar-lab",
    nominal: RobotParams | None = None,
    square_side: float = 4.0,
    square_runs: int = 5,
    phone_runs: int = 5,
    rate: float = 20.0,
    progress: Progress = _noop,
    flag: Callable[[str], str] | None = None,
) -> LabResult:
    """Run the whole lab on the virtual Jaguar; return where the results are. ``flag`` gives a
    face's flag for a setting (``odolab.cli.wording.flag``): results.json then carries the command
    lines that repeat the slip comparison and its NEES; without it they are left out."""
    from odolab.store import Notebook

    cfg = _config(out, seed, truth, nominal, square_side, square_runs, phone_runs, rate, flag)
    progress("notebook", 0, 1)
    folder = _new_run_folder(cfg.out)
    db = folder / "odolab.db"
    with Notebook(db) as nb:
        nb.add_params_version(cfg.nominal, method="nominal preset", notes="not measured: calibrate")
        progress("notebook", 1, 1)
        _campaign(cfg, nb, progress)
        live = _live_runs(cfg, nb, progress)
        analysis, _trials, rows = _analysis(nb, progress)
        cal = _calibrate(cfg, nb, folder, progress)
    val = _validate(cfg, live, cal.ratios.params, rows, folder, progress)
    gyro = _gyro(live, val, cal.ratios)
    after = _rerun(cfg, cal.ratios.params, progress)
    evidence = _models(cfg, cal.ratios.params, folder, progress)
    html = _report(cfg, folder, db, analysis, cal, val, live, after, evidence, progress, gyro)
    return LabResult(
        folder=folder,
        notebook=db,
        report=html,
        results=folder / "results.json",
        params_files=cal.files,
        table1=rows,
        after_calibration=after,
        validation_rms=(val.first.old.rms, val.first.new.rms),
        phone_log=val.phone_log,
        loop=live.loop,
        phone_runs=val.runs,
        evidence=evidence,
        gyro=gyro,
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
