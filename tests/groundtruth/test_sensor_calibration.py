"""Odometry + sensor calibration (Censi et al. 2013): the model, the closed form, the statistics,
the identifiability sentences, and ``odolab calibrate sensor``."""

from __future__ import annotations

import json
import math
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from odolab.calibration.sensor import (
    NO_ROTATION,
    NO_TRANSLATION,
    PARAM_NAMES,
    SINGULAR,
    SensorMotions,
    calibrate_sensor,
    check_identifiable,
    closed_form,
    cramer_rao_bound,
    motions_from_trajectory,
    predict_motions,
    relative_motions,
)
from odolab.cli import main
from odolab.core.errors import CalibrationError
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.trajectory_csv import write_trajectory
from odolab.sim.drives import record_drive
from odolab.sim.physics import TrueParams

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from bench_sensor_calibration import MOUNT, SIGMA, TRUE_ROBOT, clean_motions, noisy

NOMINAL = PRESETS["jaguar-lite"]


@pytest.fixture(scope="module")
def clean() -> tuple[SensorMotions, np.ndarray]:
    return clean_motions()


def sensor_of(truth: Trajectory, mount: tuple[float, float, float]) -> Trajectory:
    c, s = np.cos(truth.heading), np.sin(truth.heading)
    lx, ly, lth = mount
    return Trajectory.from_xyh(
        truth.t, truth.x + c * lx - s * ly, truth.y + s * lx + c * ly, truth.heading + lth
    )


def test_predicted_motion_of_a_quarter_turn_in_place_by_hand() -> None:
    # r = 0.1 m both, b = 0.5 m: a quarter turn in place needs phi_R = -phi_L = (pi/2) b / (2 r)
    phi = (math.pi / 2) * 0.5 / 0.2
    steps = 7
    data = SensorMotions(
        np.zeros(1), np.ones(1), np.zeros((1, 3)),
        np.full(steps, -phi / steps), np.full(steps, phi / steps), np.zeros(steps, dtype=np.int64),
    )  # fmt: skip
    # sensor 1 m ahead, facing forward: it moves from (1, 0) to (0, 1): (-1, 1) in its frame
    got = predict_motions([0.1, 0.1, 0.5, 1.0, 0.0, 0.0], data)[0]
    assert got == pytest.approx([-1.0, 1.0, math.pi / 2], abs=1e-12)
    # the same sensor facing left (yaw pi/2): the displacement (-1, 1) is (1, 1) in its frame
    got = predict_motions([0.1, 0.1, 0.5, 1.0, 0.0, math.pi / 2], data)[0]
    assert got == pytest.approx([1.0, 1.0, math.pi / 2], abs=1e-12)


def test_predicted_straight_line_is_radius_times_angle() -> None:
    data = SensorMotions(
        np.zeros(1), np.ones(1), np.zeros((1, 3)),
        np.array([2.0, 3.0]), np.array([2.0, 3.0]), np.zeros(2, dtype=np.int64),
    )  # fmt: skip
    # 5 rad of wheel at r = 0.1 m: 0.5 m forward; a sensor at yaw 0.3 sees it rotated by -0.3
    got = predict_motions([0.1, 0.1, 0.5, 0.2, -0.1, 0.3], data)[0]
    assert got == pytest.approx([0.5 * math.cos(0.3), -0.5 * math.sin(0.3), 0.0], abs=1e-12)


def test_relative_motions_by_hand() -> None:
    rel = relative_motions([1.0, 1.0], [0.0, 2.0], [math.pi / 2, math.pi], [0], [1])
    assert rel[0] == pytest.approx([2.0, 0.0, math.pi / 2])


def test_closed_form_recovers_the_truth_without_sensor_noise() -> None:
    # continuous wheel angles (no count rounding): only the model's sub-step arcs remain
    drive = record_drive(TrueParams(0.085, 0.085, 0.082, 0.082, 0.60), NOMINAL, _legs())
    k = 2 * math.pi / NOMINAL.ticks_per_rev
    data = motions_from_trajectory(
        drive.t, drive.ticks_left * k, drive.ticks_right * k, sensor_of(drive.truth, MOUNT)
    )
    theta, cost = closed_form(data)
    assert theta == pytest.approx([0.085, 0.082, 0.60, *MOUNT], rel=1e-4, abs=1e-4)
    assert cost < 1e-6


def test_two_hundred_seeds_summarised_by_twenty(clean: tuple[SensorMotions, np.ndarray]) -> None:
    """A short version of benchmarks/bench_sensor_calibration.py (200 seeds there)."""
    m, true = clean
    est, se = [], []
    for seed in range(20):
        r = calibrate_sensor(noisy(m, seed), NOMINAL)
        est.append([r.values[k] for k in PARAM_NAMES])
        se.append([r.stderr[k] for k in PARAM_NAMES])
    e, s = np.array(est), np.array(se)
    inside = np.abs(e - true) <= 2 * s
    assert inside.mean() >= 0.9
    spread = e.std(axis=0, ddof=1)
    ratio = s.mean(axis=0) / spread
    # 20 seeds estimate a standard deviation to ~16 %: allow 0.65..1.5
    assert np.all((ratio > 0.65) & (ratio < 1.5)), ratio
    crb = np.sqrt(np.diag(cramer_rao_bound(true, m, SIGMA)))
    assert s.mean(axis=0) == pytest.approx(crb, rel=0.1)


def test_outliers_are_trimmed(clean: tuple[SensorMotions, np.ndarray]) -> None:
    m, true = clean
    plain = calibrate_sensor(noisy(m, 3), NOMINAL)
    r = calibrate_sensor(noisy(m, 3, outliers=0.08), NOMINAL)
    assert r.outliers >= 0.05 * len(m)
    for i, k in enumerate(PARAM_NAMES):
        assert abs(r.values[k] - true[i]) < 3 * plain.stderr[k], k
    # without trimming the gross errors ruin the fit
    from odolab.calibration.sensor import SensorOptions

    raw = calibrate_sensor(noisy(m, 3, outliers=0.08), NOMINAL, SensorOptions(max_outliers=0.0))
    assert raw.outliers == 0
    assert abs(raw.values["track_width"] - true[2]) > abs(r.values["track_width"] - true[2])


def _legs() -> list[tuple[float, float, float]]:
    from odolab.sim.drives import calibration_drive

    return calibration_drive()


def _motions(legs: list[tuple[float, float, float]]) -> SensorMotions:
    drive = record_drive(TrueParams(0.085, 0.085, 0.082, 0.082, 0.60), NOMINAL, legs)
    k = 2 * math.pi / NOMINAL.ticks_per_rev
    m = motions_from_trajectory(
        drive.t, drive.counts_left * k, drive.counts_right * k, sensor_of(drive.truth, MOUNT)
    )
    return noisy(m, 0)


def test_straight_only_names_the_track() -> None:
    with pytest.raises(CalibrationError, match=NO_ROTATION):
        check_identifiable(_motions([(0.4, 0.4, 10.0), (-0.4, -0.4, 10.0)]))


def test_turns_in_place_only_name_the_radii() -> None:
    with pytest.raises(CalibrationError, match=NO_TRANSLATION):
        calibrate_sensor(_motions([(-0.4, 0.4, 10.0), (0.4, -0.4, 10.0)]), NOMINAL)


def test_one_curvature_only_is_the_singular_matrix() -> None:
    with pytest.raises(CalibrationError, match=SINGULAR):
        calibrate_sensor(_motions([(0.2, 0.4, 20.0)]), NOMINAL)


# --------------------------------------------------------------------------- the command


def _files(tmp_path: Path, shift: float = 0.0) -> tuple[Path, Path]:
    rl, rr, b = TRUE_ROBOT
    drive = record_drive(TrueParams(rl, rl, rr, rr, b), NOMINAL, _legs() * 2)
    enc = write_encoder_csv(
        tmp_path / "enc.csv", EncoderLog(drive.t, drive.counts_left, drive.counts_right)
    )
    sensor = sensor_of(drive.truth, MOUNT)
    rng = np.random.default_rng(5)
    noisy_sensor = Trajectory.from_xyh(
        sensor.t + shift,
        sensor.x + rng.normal(0, 0.002, sensor.t.size),
        sensor.y + rng.normal(0, 0.002, sensor.t.size),
        sensor.heading + rng.normal(0, 0.003, sensor.t.size),
    )
    return enc, write_trajectory(tmp_path / "laser.tum", noisy_sensor, "tum")


def test_cli_writes_params_with_standard_errors(tmp_path: Path) -> None:
    enc, sensor = _files(tmp_path)
    out, js = tmp_path / "new.toml", tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(enc), str(sensor), "-p", "jaguar-lite", "-o", str(out),
         "--json", str(js)]
    )  # fmt: skip
    assert code == 0
    doc = tomllib.loads(out.read_text())
    robot, prov = doc["robot"], doc["provenance"]
    rl, rr, b = TRUE_ROBOT
    assert robot["left_wheel_radius"] == pytest.approx(rl, rel=0.01)
    assert robot["right_wheel_radius"] == pytest.approx(rr, rel=0.01)
    assert robot["track_width"] == pytest.approx(b, rel=0.01)
    assert robot["ticks_per_rev"] == NOMINAL.ticks_per_rev
    assert prov["sensor_pose"]["yaw"] == pytest.approx(MOUNT[2], abs=0.02)
    assert set(prov["stderr"]) == set(PARAM_NAMES)
    report = json.loads(js.read_text())
    assert report["values"]["sensor_x"] == pytest.approx(MOUNT[0], abs=0.01)


def test_cli_finds_the_time_offset(tmp_path: Path) -> None:
    enc, sensor = _files(tmp_path, shift=2.35)
    out, js = tmp_path / "new.toml", tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(enc), str(sensor), "-p", "jaguar-lite", "-o", str(out),
         "--time-offset", "auto", "--json", str(js)]
    )  # fmt: skip
    assert code == 0
    report = json.loads(js.read_text())
    assert report["time_offset_s"] == pytest.approx(2.35, abs=0.02)
    assert report["params"]["track_width"] == pytest.approx(TRUE_ROBOT[2], rel=0.01)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--time-offset", "soon"], "--time-offset is 'soon'"),
        (["--interval", "nan"], "--interval is nan"),
        (["--max-outliers", "1.5"], "max_outliers is 1.5"),
    ],
)
def test_cli_bad_options_are_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], needle: str
) -> None:
    enc = tmp_path / "enc.csv"
    enc.write_text("t,left_ticks,right_ticks\n0,0,0\n1,1,1\n")
    code = main(
        ["calibrate", "sensor", str(enc), str(enc), "-p", "jaguar-lite", "-o",
         str(tmp_path / "o.toml"), *args]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert needle in err
    assert err.count("\n") == 1


def test_cli_names_a_drive_without_turns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    drive = record_drive(TrueParams(0.085, 0.085, 0.082, 0.082, 0.6), NOMINAL, [(0.4, 0.4, 20.0)])
    enc = write_encoder_csv(
        tmp_path / "enc.csv", EncoderLog(drive.t, drive.counts_left, drive.counts_right)
    )
    sensor = write_trajectory(tmp_path / "s.csv", sensor_of(drive.truth, MOUNT))
    code = main(
        ["calibrate", "sensor", str(enc), str(sensor), "-p", "jaguar-lite", "-o",
         str(tmp_path / "o.toml")]
    )  # fmt: skip
    assert code == 1
    assert NO_ROTATION in capsys.readouterr().err


@pytest.mark.slow
def test_acceptance_two_hundred_seeds() -> None:
    """Issue 15's acceptance: every parameter within 2 SE in >= 90 % of 200 seeds, standard
    errors within 20 % of the Monte Carlo spread, and close to the Cramér-Rao bound."""
    from bench_sensor_calibration import study

    for name, row in study(200).items():
        assert row["within_2se"] >= 0.9, name
        assert 0.8 <= row["se_over_spread"] <= 1.2, name
        assert row["crb_over_spread"] == pytest.approx(row["se_over_spread"], rel=0.05), name


def test_cli_reads_a_ros2_bag_with_the_sensor_on_an_odometry_topic(tmp_path: Path) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
    from bag_fixtures import write_bag

    rl, rr, b = TRUE_ROBOT
    drive = record_drive(TrueParams(rl, rl, rr, rr, b), NOMINAL, _legs() * 2, rate=10)
    k = 2 * math.pi / NOMINAL.ticks_per_rev
    rng = np.random.default_rng(9)
    s = sensor_of(drive.truth, MOUNT)
    s = Trajectory.from_xyh(
        s.t, s.x + rng.normal(0, 0.002, s.t.size), s.y + rng.normal(0, 0.002, s.t.size),
        s.heading + rng.normal(0, 0.003, s.t.size),
    )  # fmt: skip
    bag = write_bag(
        tmp_path / "drive", drive.t, drive.counts_left * k, drive.counts_right * k, s,
        gt_topic="/laser_odom", gt_as_odometry=True,
    )  # fmt: skip
    out, js = tmp_path / "new.toml", tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(bag), str(bag), "-f", "bag", "--sensor-topic", "/laser_odom",
         "-p", "jaguar-lite", "-o", str(out), "--json", str(js)]
    )  # fmt: skip
    assert code == 0
    report = json.loads(js.read_text())
    assert report["params"]["track_width"] == pytest.approx(b, rel=0.01)
    assert report["values"]["sensor_yaw"] == pytest.approx(MOUNT[2], abs=0.02)
