"""A run on a standalone virtual board (``odolab robot sim-server``) can be measured: the board's
true pose comes through its side channel (odolab.robot.virtual_truth), ``run.json`` records it
and what the instruments would show, and ``odolab trials measure --virtual`` takes those
readings; a real board's run (no side channel) has none, and ``--virtual`` refuses it."""

from __future__ import annotations

import json
import math
import shlex
from collections.abc import Iterator
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.core.trajectory import Pose
from odolab.robot.clock import SimClock
from odolab.robot.jaguar.board import BoardConfig, VirtualJaguar, VirtualJaguarServer
from odolab.robot.jaguar.protocol import MotorSensorData, encode_motor_sensor
from odolab.robot.jaguar2014.board import Board2014Config, InProcessLines, VirtualJaguar2014
from odolab.robot.jaguar2014.driver import Driver2014Config, Jaguar2014Driver
from odolab.robot.plant import IdealPlant
from odolab.robot.virtual_truth import TruthTracker, decode_line, decode_trailer, encode_trailer

NOMINAL = PRESETS["jaguar-lite"]
#: where the board's robot already is when the run starts (an earlier run moved it)
START = Pose(0.0, 1.5, -0.7, 0.9, 0.9)


@pytest.fixture
def sim_server() -> Iterator[tuple[str, IdealPlant]]:
    plant = IdealPlant(NOMINAL)
    plant.reset(START)
    board = VirtualJaguar(plant, BoardConfig.from_params(NOMINAL), seed=0)
    server = VirtualJaguarServer(board)  # what `odolab robot sim-server` serves
    server.start()
    host, port = server.address
    try:
        yield f"udp://{host}:{port}", plant
    finally:
        server.close()


@pytest.mark.slow  # a real-time run over UDP and the CLI: about 4 s
def test_a_sim_server_run_is_measured_by_its_virtual_instruments(
    sim_server: tuple[str, IdealPlant], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, plant = sim_server
    db, out = tmp_path / "lab.db", tmp_path / "run"
    args = ["robot", "rotate", "--turns", "0.25", "--speed", "2", "--robot", url]
    code = main(
        [*args, "--quiet", "--no-realtime", "--rate", "50", "--out", str(out), "--db", str(db)]
    )
    text = capsys.readouterr().out
    assert code == 0, text
    doc = json.loads((out / "run.json").read_text())
    # the true pose in the run's start frame (the board's robot started at START)
    true = plant.true_pose
    assert doc["true"] is not None
    assert doc["true"]["heading"] == pytest.approx(true.heading - START.heading, abs=1e-9)
    assert math.hypot(doc["true"]["x"], doc["true"]["y"]) == pytest.approx(
        math.hypot(true.x - START.x, true.y - START.y), abs=1e-9
    )
    readings = doc["virtual_instruments"]["readings"]
    assert set(readings) == {"compass_initial_deg", "compass_final_deg", "turns", "clockwise"}
    assert "the virtual instruments show: compass" in text and "--virtual" in text
    assert main(["trials", "measure", "--virtual", "--db", str(db)]) == 0
    measured = capsys.readouterr().out
    assert "rot " in measured and "[virtual compass]" in measured
    rot = float(measured.split("rot ")[1].split(" rad")[0])
    # compass read to 0.05 rad twice, 1 degree marks: within 0.3 rad of the true turn
    assert rot == pytest.approx(doc["true"]["heading"], abs=0.3)


def test_the_side_channel_frames_the_pose_at_connect() -> None:
    tracker = TruthTracker()
    tracker.heard((1.0, 2.0, math.pi / 2))
    tracker.heard((1.0, 3.0, math.pi / 2 + 0.25))  # 1 m along the start heading, turned 0.25
    pose = tracker.relative()
    assert pose is not None
    assert (pose.x, pose.y, pose.heading) == pytest.approx((1.0, 0.0, 0.25), abs=1e-12)
    assert decode_trailer(encode_trailer(1.0, -2.0, 30.0)) == (1.0, -2.0, 30.0)
    assert decode_line("ODOLAB-TRUTH 1 -2 30") == (1.0, -2.0, 30.0)


def test_a_real_boards_run_has_no_truth_and_virtual_refuses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a real board's sensor packet: 33 bytes, no trailer; 8 stray bytes are not a truth either
    for extra in (b"", b"\x00" * 8):
        packet = MotorSensorData((0, 0), (0, 0), 0, extra=extra)
        assert len(encode_motor_sensor(packet)) > 0 and decode_trailer(extra) is None
    db = tmp_path / "lab.db"
    assert main(["notebook", "init", "--db", str(db)]) == 0
    add = [
        "trials",
        "add",
        "--id",
        "R1",
        "--campaign",
        "lab",
        "--create-campaign",
        "--terrain",
        "tile",
    ]
    add += ["--kind", "rotation", "--angle", "6.283", "--predicted-heading", "6.3"]
    assert main([*add, "--db", str(db)]) == 0
    capsys.readouterr()
    assert main(["trials", "measure", "R1", "--virtual", "--db", str(db)]) == 1
    err = capsys.readouterr().err
    assert "was not driven on a virtual board" in err and "Traceback" not in err


def test_the_2014_virtual_board_says_its_true_pose_in_a_line() -> None:
    plant = IdealPlant(NOMINAL)
    plant.reset(START)
    clock = SimClock(0.0)
    board = VirtualJaguar2014(plant, Board2014Config.from_params(NOMINAL))
    drv = Jaguar2014Driver(InProcessLines(board, clock.now), clock, Driver2014Config())
    drv.connect()
    for _ in range(20):  # 1 s forward at 0.5 m/s
        clock.sleep_until(clock.now() + 0.05)
        drv.poll()
        drv.set_wheel_speeds(0.5, 0.5)
    assert drv.confirm_stopped(1.0)
    pose = drv.virtual_truth.relative()
    assert pose is not None and drv.decode_errors == 0  # the truth line is not an unknown line
    assert pose.x == pytest.approx(0.5, abs=0.06) and abs(pose.y) < 1e-6
    assert pose.x == pytest.approx(
        math.hypot(plant.true_pose.x - START.x, plant.true_pose.y - START.y)
    )
    drv.close()


def test_a_straight_run_reads_the_meterstick_in_the_start_frame() -> None:
    from odolab.core.trials import Command, MotionKind
    from odolab.robot.session import run_motion_simulated
    from odolab.store.measure import describe_readings, virtual_measurement, virtual_readings

    trial, _ = run_motion_simulated(
        Command(MotionKind.TRANSLATION, distance=-0.5, speed=0.5), nominal=NOMINAL
    )
    assert trial.true is not None
    readings = virtual_readings(trial)
    assert readings is not None and set(readings) == {"x_m", "y_m"}
    assert describe_readings(readings).startswith("meterstick x -0.")
    m = virtual_measurement(trial)
    # the meterstick: 3 mm, read to the mm
    assert m.instrument == "virtual meterstick" and m.x is not None and m.y is not None
    assert abs(m.x - trial.true.x) < 0.015 and abs(m.y - trial.true.y) < 0.015
    assert virtual_readings(trial) == readings  # the same trial always reads the same


def test_sim_server_exits_when_idle_and_refuses_a_bad_idle_exit(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["robot", "sim-server", "--port", "0", "--idle-exit", "1"]) == 0
    err = capsys.readouterr().err
    assert "nothing came from a host for 1 s (--idle-exit): exiting" in err
    assert main(["robot", "sim-server", "--port", "0", "--idle-exit", "0"]) == 1
    err = capsys.readouterr().err
    assert "--idle-exit is 0.0; expected 1 to 3600 s" in err and "Traceback" not in err


def test_the_suggested_measure_command_survives_a_path_with_spaces(tmp_path: Path) -> None:
    from odolab.cli.robot import measure_virtual_command

    db = tmp_path / "my lab's notes" / "lab.db"
    line = measure_virtual_command("R1", db)
    # copied into a shell, the command is the same words: the path stays one argument
    assert shlex.split(line) == ["odolab", "trials", "measure", "R1", "--virtual", "--db", str(db)]
    assert measure_virtual_command("R1", None) == "odolab trials measure R1 --virtual"


def test_a_stalled_turn_is_measured_near_zero_not_a_whole_turn() -> None:
    import dataclasses

    from odolab.core.trials import Command, MotionKind
    from odolab.robot.session import run_motion_simulated
    from odolab.store.measure import describe_readings, virtual_measurement, virtual_readings

    trial, _ = run_motion_simulated(
        Command(MotionKind.ROTATION, angle=0.5, speed=1.0), nominal=NOMINAL
    )
    assert trial.true is not None
    worst, back = 0.0, 0
    for i in range(40):  # the robot stalled: truly (almost) no turn, each id its own noise
        stalled = dataclasses.replace(
            trial, trial_id=f"S{i}", true=Pose(trial.true.t, 0.0, 0.0, 0.0, 0.0)
        )
        readings = virtual_readings(stalled)
        assert readings is not None and readings["turns"] == 0
        back += readings["clockwise"] == 1.0
        if readings["clockwise"]:
            assert describe_readings(readings).endswith("counted clockwise")
        m = virtual_measurement(stalled)  # a hair against the command: not a contradiction
        assert m.rotation is not None
        worst = max(worst, abs(m.rotation))
    assert worst < 0.4  # two readings of 0.05 rad on 1-degree marks: measured worst 0.2 rad
    assert back > 0  # some stalls read a hair clockwise (measured: about half of them)
