"""Sense checks between sensors (issue 38, item 10): on a link with a gyro (the 2014 Jaguar's
IMU) odometry and gyro are compared live; a sign disagreement or a ratio far outside the
calibrated range stops the run with one sentence naming the likely cause, and after a run
the same rule flags it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.cli.wording import said
from odolab.core.params import PRESETS
from odolab.core.trials import Command, MotionKind
from odolab.robot.config import RunConfig
from odolab.robot.drift import (
    EXPECTED_RATIO,
    DriftMonitor,
    SenseCheckError,
    robot_sense_sentence,
    sense_check,
)
from odolab.robot.jaguar2014.board import (
    Board2014Config,
    VirtualJaguar2014,
    VirtualJaguar2014Server,
)
from odolab.robot.plant import IdealPlant
from odolab.robot.session import run_simulated

NOMINAL = PRESETS["jaguar-lite"]
TURN = Command(MotionKind.ROTATION, angle=2 * math.pi, speed=1.0)


def test_a_wrong_variant_stops_the_run_with_the_cause(tmp_path: Path) -> None:
    # variant=track against a wheel board: motors and encoders both reversed, so the robot
    # turns clockwise while the odometry sees the commanded counter-clockwise turn
    flipped = RunConfig(
        left_motor_sign=-1, right_motor_sign=-1, left_encoder_sign=-1, right_encoder_sign=-1
    )
    with pytest.raises(SenseCheckError, match=r"opposite ways.*variant") as err:
        run_simulated(TURN, link="jaguar2014", config=flipped, save_to=tmp_path / "run")
    assert "the run was stopped" in str(err.value)
    # stopped soon after the half radian the check needs (it would have turned 2 pi)
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    assert doc["completed"] is False and "SenseCheckError" in doc["aborted"]
    assert 0.5 < doc["predicted"]["heading"] < 1.5
    # the stopped run keeps why it was stopped and the IMU's headings, as a finished run does
    assert "opposite ways" in doc["sense_check"]
    imu = (tmp_path / "run" / "imu.csv").read_text().splitlines()
    assert imu[0].startswith("motionTimestamp") and len(imu) > 3


def test_a_right_run_passes_and_records_no_flag() -> None:
    run = run_simulated(TURN, link="jaguar2014")
    assert run.trial.predicted.heading == pytest.approx(2 * math.pi, abs=0.1)
    assert run.extra["sense_check"] is None


def test_one_reversed_encoder_is_named() -> None:
    # turning in place with one encoder counting backwards: the odometry sees a straight run
    found = sense_check(0.02, 6.2, 10.0)
    assert found is not None and found.kind == "ratio"
    assert found.ratio == pytest.approx(310.0) and found.expected == EXPECTED_RATIO
    problem = said(robot_sense_sentence(found))  # as the CLI shows it
    assert "one encoder counting backwards" in problem and "--left-encoder-sign" in problem
    assert sense_check(6.349, -6.11, 12.0) is not None  # the variant=track run
    assert sense_check(6.0, 6.1, 12.0) is None  # within the calibrated range, widened
    assert sense_check(6.51, 4.79, 4.0) is None  # the jaguar-lab truth's slip at 2 rad/s
    assert sense_check(0.95, -0.32, 0.5) is not None  # variant=track, lagging gyro, at 0.5 s
    assert sense_check(0.3, -0.3, 1.0) is None  # too little turn to tell
    assert sense_check(0.01, 0.55, 60.0) is None  # a gyro bias of 0.009 rad/s on a straight run


def test_the_cli_stops_a_wrong_variant_on_sim_server(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the run: 'tcp://...?variant=track' against the default (wheel) 2014 board
    board = VirtualJaguar2014(IdealPlant(NOMINAL), Board2014Config.from_params(NOMINAL))
    server = VirtualJaguar2014Server(board)
    server.start()
    host, port = server.address
    try:
        url = f"tcp://{host}:{port}?variant=track"
        args = ["robot", "rotate", "--turns", "1", "--speed", "2", "--robot", url, "--quiet"]
        code = main([*args, "--no-realtime", "--out", str(tmp_path / "run")])
    finally:
        server.close()
    err = capsys.readouterr().err
    assert code == 1
    assert "sense check" in err and "opposite ways" in err and "variant" in err
    assert "robot stopped (its sensor data confirms it)" in err and "Traceback" not in err


def test_the_finding_is_data_and_the_robot_words_it() -> None:
    """Review of issue 38: the check returns a kind and numbers (each face words it); the
    drift monitor and the check share one calibrated range."""
    found = sense_check(6.349, -6.11, 12.0)
    assert found is not None and found.kind == "opposite"
    assert (found.odometry_turn, found.gyro_turn, found.elapsed) == (6.349, -6.11, 12.0)
    sentence = robot_sense_sentence(found)
    assert "opposite ways (odometry +6.35 rad, gyro -6.11 rad over 12.0 s)" in sentence
    assert "variant=" in sentence
    assert DriftMonitor().expected == EXPECTED_RATIO
    assert EXPECTED_RATIO[0] < 1.0 < EXPECTED_RATIO[1]
