"""Iterated UMBmark: exact recovery of large errors, first-order agreement with one step on
small ones, the virtual Jaguar, the real OptiOdom squares, and refusing runs without logs."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from odolab.calibration import (
    UmbmarkResult,
    umbmark,
    umbmark_errors_from_trials,
    umbmark_iterated,
)
from odolab.core.errors import CalibrationError
from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, RobotParams, load_params
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

NOM = RobotParams(
    left_wheel_radius=0.0835, right_wheel_radius=0.0835, track_width=0.56, ticks_per_rev=380
)


def _truth(e_b: float, e_d: float) -> RobotParams:
    """A robot whose track is ``e_b`` x nominal and whose right/left diameter ratio is ``e_d``,
    with the nominal mean wheel radius (the scale, which UMBmark leaves alone)."""
    r = NOM.left_wheel_radius
    return NOM.with_(
        left_wheel_radius=2 * r / (1 + e_d),
        right_wheel_radius=2 * r * e_d / (1 + e_d),
        track_width=NOM.track_width * e_b,
    )


def _square_dticks(
    side: float, direction: str, rng: np.random.Generator, n: int = 20
) -> tuple[np.ndarray, np.ndarray]:
    """Increments of a square that odometry with NOM closes: 4 legs, 4 turns in place."""
    per_m = NOM.ticks_per_rev / (2 * math.pi * NOM.left_wheel_radius)
    leg, turn = side * per_m / n, (math.pi / 2) * (NOM.track_width / 2) * per_m / n
    s = 1.0 if direction == "ccw" else -1.0
    dl, dr = [0.0], [0.0]
    for _ in range(4):
        dl += list(leg * (1 + rng.normal(0, 0.001, n)))
        dr += list(leg * (1 + rng.normal(0, 0.001, n)))
        dl += [-s * turn] * n
        dr += [s * turn] * n
    return np.array(dl), np.array(dr)


def _square_trials(
    true: RobotParams, side: float = 4.0, seed: int = 0, runs: int = 5
) -> list[Trial]:
    """Measured squares with exact logs: the true end pose integrates the same integer ticks."""
    rng = np.random.default_rng(seed)
    trials = []
    for direction in ("cw", "ccw"):
        for k in range(runs):
            dl, dr = _square_dticks(side, direction, rng)
            t = np.asarray(np.arange(dl.size) * 0.05, dtype=np.float64)
            left = np.round(np.cumsum(dl)).astype(np.int64)
            right = np.round(np.cumsum(dr)).astype(np.int64)
            idl, idr = np.diff(left, prepend=0), np.diff(right, prepend=0)
            odo = integrate_increments(t, idl, idr, NOM).final
            real = integrate_increments(t, idl, idr, true).final
            trials.append(
                Trial(
                    trial_id=f"sq-{direction}-{k}",
                    campaign="umbmark",
                    terrain="tile",
                    command=Command(MotionKind.SQUARE, side=side, direction=direction),
                    predicted=Pose(odo.t, odo.x, odo.y, odo.theta, odo.heading),
                    params=NOM,
                    measured=Measurement("tape", x=real.x, y=real.y),
                    encoder_log=EncoderLog(t, left, right),
                    status=TrialStatus.MEASURED,
                )
            )
    return trials


def _single_step(trials: list[Trial], start: RobotParams) -> UmbmarkResult:
    cw, ccw, side = umbmark_errors_from_trials(trials, start)
    one = umbmark(cw, ccw, side, start)
    return one.with_after(*umbmark_errors_from_trials(trials, one.params)[:2])


@pytest.mark.parametrize(("e_b", "e_d"), [(1.12, 1.01), (1.15, 1.01), (1.10, 0.99)])
def test_large_errors_recover_the_true_robot(e_b: float, e_d: float) -> None:
    true = _truth(e_b, e_d)
    trials = _square_trials(true)
    one = _single_step(trials, NOM)
    it = umbmark_iterated(trials, NOM)
    p = it.params
    # the squares end metres from the start: far outside UMBmark's small-error model
    # measured 2.56-3.35 over seed shifts 0-3 (3 cases); bound 2.5; at seed shift 0 it is 21.3x the
    # spread over seeds away
    assert it.e_max_syst > 2.5
    assert it.e_max_syst == pytest.approx(one.e_max_syst)
    # the logs are exact and the truth integrates the same ticks, so the fixed point is the
    # truth, up to the scale: a step keeps the mean radius only to second order (it moves it by
    # (r_R - r_L)(E_d - 1)/(2(E_d + 1)), about 3e-6 here), so b and the radii are within 1e-5,
    # the scale-free E_d and track/radius within 1e-6
    # measured |value - expected| 9.14e-07-1.82e-06 over seed shifts 0-3 (3 cases); tolerance
    # 6.2e-06/6.3e-06/6.4e-06; at seed shift 0 it is 129x the spread over seeds away
    assert p.track_width == pytest.approx(true.track_width, rel=1e-5)
    # measured |value - expected| 1.38e-07-2.83e-07 over seed shifts 0-3 (3 cases); tolerance
    # 8.3e-07/8.4e-07; at seed shift 0 it is 111x the spread over seeds away
    assert p.left_wheel_radius == pytest.approx(true.left_wheel_radius, rel=1e-5)
    # measured |value - expected| 1.38e-07-2.81e-07 over seed shifts 0-3 (3 cases); tolerance
    # 8.3e-07/8.4e-07; at seed shift 0 it is 109x the spread over seeds away
    assert p.right_wheel_radius == pytest.approx(true.right_wheel_radius, rel=1e-5)
    # measured |value - expected| 1.98e-08-5.1e-08 over seed shifts 0-3 (3 cases); tolerance
    # 1e-06/9.9e-07; at seed shift 0 it is 574x the spread over seeds away
    assert it.e_d == pytest.approx(e_d, rel=1e-6)
    mean_r = (p.left_wheel_radius + p.right_wheel_radius) / 2
    assert p.track_width / mean_r == pytest.approx(true.track_width / NOM.left_wheel_radius, 1e-6)
    # one linearized step is off by about 0.3 % in b and 10 % of the E_d correction
    # measured 0.0027-0.00346 over seed shifts 0-3 (3 cases); bound 0.002; at seed shift 0 it is
    # 4.13x the spread over seeds away
    assert abs(one.params.track_width / true.track_width - 1) > 2e-3
    # measured 0.000706-0.00164 over seed shifts 0-3 (3 cases); bound 0.0005; at seed shift 0 it is
    # 6.96x the spread over seeds away
    assert abs(one.e_d - e_d) > 0.05 * abs(e_d - 1)
    # E_max,syst: one step leaves > 0.1 m, the iteration micrometres
    assert one.e_max_syst_after is not None and it.e_max_syst_after is not None
    # measured 0.109-0.197 over seed shifts 0-3 (3 cases); bound 0.1; at seed shift 0 it is 18.1x
    # the spread over seeds away
    assert one.e_max_syst_after > 0.1
    # measured 1.63e-06-6.25e-06 over seed shifts 0-3 (3 cases); bound 0.0001; at seed shift 0 it is
    # 489x the spread over seeds away
    assert it.e_max_syst_after < 1e-4
    assert it.e_max_syst_after < one.e_max_syst_after / 1000


def test_cumulative_e_b_and_e_d_are_the_products_and_the_parameter_ratios() -> None:
    it = umbmark_iterated(_square_trials(_truth(1.12, 1.01)), NOM)
    prov = it.calibration.provenance
    steps = prov["iterations"][:-1]
    assert len(prov["iterations"]) == prov["n_iterations"] + 1 >= 3
    assert it.e_b == pytest.approx(math.prod(s["step_e_b"] for s in steps), rel=1e-12)
    assert it.e_d == pytest.approx(math.prod(s["step_e_d"] for s in steps), rel=1e-12)
    p = it.params
    assert it.e_b == pytest.approx(p.track_width / NOM.track_width, rel=1e-12)
    assert it.e_d == pytest.approx(p.right_wheel_radius / p.left_wheel_radius, rel=1e-12)
    # each iterate's parameters are the previous ones corrected by its step
    for a, b in zip(prov["iterations"][:-1], prov["iterations"][1:], strict=True):
        assert b["track_width"] == pytest.approx(a["track_width"] * a["step_e_b"], rel=1e-12)
        ratio_a = a["right_wheel_radius"] / a["left_wheel_radius"]
        ratio_b = b["right_wheel_radius"] / b["left_wheel_radius"]
        assert ratio_b == pytest.approx(ratio_a * a["step_e_d"], rel=1e-12)
    first, last = prov["iterations"][0], prov["iterations"][-1]
    assert first["track_width"] == NOM.track_width and first["e_max_syst"] == it.e_max_syst
    assert last["track_width"] == p.track_width and last["e_max_syst"] == it.e_max_syst_after
    # E_max,syst falls at every step on this exactly modelled robot, down to a floor of a few
    # micrometres, set by the second-order drift of the mean radius (~2e-6, see above)
    emax = [s["e_max_syst"] for s in prov["iterations"]]
    above = [e for e in emax if e > 1e-5]
    assert len(above) >= 5 and all(b < a for a, b in itertools.pairwise(above))
    # measured 7.72e-06-8.72e-06 over seed shifts 0-3; bound 1e-05; at seed shift 0 it is 1.98x the
    # spread over seeds away
    assert max(emax[len(above) :]) < 1e-5
    # alpha and beta are the per-turn and per-leg errors that the cumulative E_b, E_d imply
    assert it.e_b == pytest.approx((math.pi / 2) / (math.pi / 2 - it.alpha), rel=1e-12)
    radius = 2.0 / math.sin(it.beta / 2)
    assert it.e_d == pytest.approx((radius + 0.28) / (radius - 0.28), rel=1e-12)


def test_small_errors_agree_with_one_step_to_first_order() -> None:
    diffs = []
    for e_b, e_d in [(1.01, 1.002), (1.005, 1.001)]:
        trials = _square_trials(_truth(e_b, e_d))
        one = _single_step(trials, NOM)
        it = umbmark_iterated(trials, NOM)
        eps = max(abs(one.e_b - 1), abs(one.e_d - 1))
        # they differ only at second order in the errors
        assert abs(it.e_b - one.e_b) < 2 * eps**2
        assert abs(it.e_d - one.e_d) < 2 * eps**2
        assert it.e_max_syst == one.e_max_syst
        diffs.append((abs(it.e_b - one.e_b), abs(it.e_d - one.e_d)))
    # halving the errors quarters the difference
    # measured 3.52-4.01 over seed shifts 0-3; bound 5; at seed shift 0 it is 2x the spread over
    # seeds away
    assert 3.0 < diffs[0][0] / diffs[1][0] < 5.0
    # measured 3.43 at the test's seed; 3.50, 2.76, 3.10 at seed shifts 1-3 (2.76: a first-order
    # rule on two noisy points; this seed is 14 % from its bound)
    assert 3.0 < diffs[0][1] / diffs[1][1] < 5.0


def test_noiseless_virtual_jaguar_recovers_its_effective_track() -> None:
    """jaguar-lab without noise (turns 12.5 % short, radii differ by side and direction): from
    the true mean forward radius, the iteration lands on the effective track."""
    from odolab.sim.presets import TRUTH_PRESETS
    from odolab.sim.protocols import load_protocol, run_protocol

    nominal = PRESETS["jaguar-lite"]
    truth = TRUTH_PRESETS["jaguar-lab"].noiseless
    trials = run_protocol(load_protocol("umbmark"), truth, nominal, seed=0)
    r = (truth.left_radius_forward + truth.right_radius_forward) / 2
    start = nominal.with_(left_wheel_radius=r, right_wheel_radius=r)
    one = _single_step(trials, start)
    it = umbmark_iterated(trials, start)
    # measured 1.58 over seed shifts 0-3; bound 1; at seed shift 0 it is 180x the spread over seeds
    # away
    assert one.e_max_syst > 1.0
    # the model has one radius per side, the truth one per side and direction: b within 0.2 %,
    # the diameter ratio within 0.3 % of the forward one (the legs are driven forward)
    # measured |value - expected| 6.33e-05-0.000223 over seed shifts 0-3; tolerance 0.00117; at seed
    # shift 0 it is 6.08x the spread over seeds away
    assert it.params.track_width == pytest.approx(truth.track_width, rel=2e-3)
    assert it.e_d == pytest.approx(truth.right_radius_forward / truth.left_radius_forward, 3e-3)
    # measured 0.00868-0.00889 over seed shifts 0-3; bound 0.005; at seed shift 0 it is 18.5x the
    # spread over seeds away
    assert abs(one.params.track_width / truth.track_width - 1) > 5e-3
    assert one.e_max_syst_after is not None and it.e_max_syst_after is not None
    # measured 0.375-0.378 over seed shifts 0-3; bound 0.3; at seed shift 0 it is 21x the spread
    # over seeds away
    assert one.e_max_syst_after > 0.3
    # measured 0.0157-0.0244 over seed shifts 0-3; bound 0.05; at seed shift 0 it is 2.95x the
    # spread over seeds away
    assert it.e_max_syst_after < 0.05


def _optiodom_trials(exp: Path) -> list[Trial]:
    from odolab.io.optiodom import find_optiodom_runs, read_optiodom_run

    trials = []
    for f in find_optiodom_runs(exp):
        run = read_optiodom_run(f)
        assert run.params is not None and run.ground_truth is not None
        gt = run.ground_truth
        odo = integrate_increments(run.t, run.dticks_left, run.dticks_right, run.params).final
        trials.append(
            Trial(
                trial_id=run.name,
                campaign="umbmark",
                terrain="lab",
                command=Command(
                    MotionKind.SQUARE,
                    side=float(run.meta["side_length"]),
                    direction="ccw" if gt.heading[-1] > 0 else "cw",
                ),
                predicted=Pose(odo.t, odo.x, odo.y, odo.theta, odo.heading),
                params=run.params,
                measured=Measurement("mocap", x=float(gt.x[-1]), y=float(gt.y[-1])),
                encoder_log=EncoderLog(
                    run.t,
                    np.cumsum(run.dticks_left).astype(np.int64),
                    np.cumsum(run.dticks_right).astype(np.int64),
                ),
                status=TrialStatus.MEASURED,
            )
        )
    return trials


@pytest.mark.parametrize(("exp_id", "e_b"), [("230620202317", 1.00603), ("231220200029", 1.00853)])
def test_optiodom_squares_iteration_agrees_with_one_step(
    optiodom_dir: Path, exp_id: str, e_b: float
) -> None:
    trials = _optiodom_trials(optiodom_dir / "square" / exp_id)
    params = trials[0].params
    one = _single_step(trials, params)
    it = umbmark_iterated(trials, params)
    # measured |value - expected| 1.16e-06-3.14e-06 over seed shifts 0-3 (2 cases); tolerance 2e-05;
    # the same at every seed
    assert it.e_b == pytest.approx(e_b, abs=2e-5)
    # errors of a few cm on 0.75 m and 1.7 m squares: iterating moves E_b and E_d by < 1e-4
    # measured |value - expected| 1.47e-05-6.39e-05 over seed shifts 0-3 (2 cases); tolerance
    # 0.0001; the same at every seed
    assert it.e_b == pytest.approx(one.e_b, abs=1e-4)
    # measured |value - expected| 1.34e-05-2.26e-05 over seed shifts 0-3 (2 cases); tolerance
    # 0.0001; the same at every seed
    assert it.e_d == pytest.approx(one.e_d, abs=1e-4)
    assert one.e_max_syst_after is not None and it.e_max_syst_after is not None
    # measured 0.000959-0.00392 over seed shifts 0-3 (2 cases); bound 0.00597/0.0209; the same at
    # every seed
    assert it.e_max_syst_after < 0.2 * it.e_max_syst
    # measured 0.000959-0.00392 over seed shifts 0-3 (2 cases); bound 0.000972/0.00432; the same at
    # every seed
    assert it.e_max_syst_after <= one.e_max_syst_after * 1.01


def test_without_encoder_logs_it_refuses() -> None:
    trials = _square_trials(_truth(1.01, 1.002), runs=2)
    no_log = [trials[0], replace(trials[1], encoder_log=None), *trials[2:]]
    with pytest.raises(CalibrationError, match=r"encoder log.*1 of 4.*sq-cw-1.*umbmark\(\)"):
        umbmark_iterated(no_log, NOM)
    # the single step still works from the recorded predictions
    cw, ccw, side = umbmark_errors_from_trials(no_log)
    # measured 1.01 over seed shifts 0-3; bound 1; at seed shift 0 it is 567x the spread over seeds
    # away
    assert umbmark(cw, ccw, side, NOM).e_b > 1.0


def test_no_convergence_and_bad_settings_are_refused() -> None:
    trials = _square_trials(_truth(1.12, 1.01), runs=2)
    with pytest.raises(CalibrationError, match="did not converge in 2 steps"):
        umbmark_iterated(trials, NOM, max_iter=2)
    with pytest.raises(CalibrationError, match="max_iter"):
        umbmark_iterated(trials, NOM, max_iter=0)
    with pytest.raises(CalibrationError, match="tol"):
        umbmark_iterated(trials, NOM, tol=-1.0)
    with pytest.raises(CalibrationError, match="both directions"):
        umbmark_iterated([t for t in trials if t.command.direction == "cw"], NOM)


def test_saved_parameters_carry_the_iterations(tmp_path: Path) -> None:
    it = umbmark_iterated(_square_trials(_truth(1.12, 1.01), runs=2), NOM)
    path = it.calibration.save(tmp_path / "umb.toml")
    back = load_params(path)
    assert back.track_width == pytest.approx(it.params.track_width, rel=1e-12)
    text = path.read_text()
    assert "umbmark-iterated" in text and "iterations" in text
    d = it.to_dict()
    assert d["e_b"] == it.e_b and d["e_max_syst_after"] == it.e_max_syst_after


@pytest.mark.parametrize("with_logs", [True, False])
def test_cli_iterates_when_the_notebook_has_logs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], with_logs: bool
) -> None:
    from odolab.cli import main
    from odolab.core.params import save_params
    from odolab.store import Notebook

    true = _truth(1.12, 1.01)
    trials = _square_trials(true, runs=2)
    if not with_logs:
        trials = [replace(t, encoder_log=None) for t in trials]
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_trials(trials)
    nominal = save_params(tmp_path / "nom.toml", NOM)
    out = tmp_path / "umb.toml"
    code = main(["calibrate", "umbmark", "-p", str(nominal), "--db", str(db), "-o", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    got = load_params(out)
    if with_logs:
        assert "iterated on the encoder logs of 4 square trials" in text
        # measured |value - expected| 1.24e-06-1.26e-06 over seed shifts 0-3; tolerance 6.3e-06; at
        # seed shift 0 it is 247x the spread over seeds away
        assert got.track_width == pytest.approx(true.track_width, rel=1e-5)
        assert "umbmark-iterated" in out.read_text()
    else:
        assert "single linearized step: 4 of 4 square trials have no encoder log" in text
        cw, ccw, side = umbmark_errors_from_trials(trials)
        assert got.track_width == pytest.approx(umbmark(cw, ccw, side, NOM).params.track_width)
    assert "E_max,syst" in text
