"""Laser path end to end: the simulator's 270 degree laser on the calibration drive, written as a
ROS 2 MCAP (/scan + /joint_states), through `odolab calibrate sensor BAG --scan-topic /scan
--joint-topic /joint_states` (small_gicp scan matching, then Censi et al.): the true wheel radii,
track and laser mount come back."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from odolab.calibration.sensor import relative_motions, robot_trajectory
from odolab.cli import main
from odolab.core.trajectory import Trajectory
from odolab.io.registry import read_trajectory
from odolab.io.scans import LaserScans, write_scan_mcap
from odolab.sim.drives import calibration_drive
from odolab.sim.laser import LaserDrive, room_world, simulate_laser_drive
from odolab.sim.physics import TrueParams

MOUNT = (0.20, -0.05, 0.3)
TRUE = (0.085, 0.082, 0.60)  # left radius, right radius, track (nominal: 0.0835, 0.0835, 0.56)


@pytest.fixture(scope="module")
def drive() -> LaserDrive:
    rl, rr, b = TRUE
    # a 12 m x 8 m room: the calibration drive from (1.5, 2.5) keeps 1.4 m from every wall
    return simulate_laser_drive(
        world=room_world(12.0, 8.0),
        drive=calibration_drive(),
        truth=TrueParams(rl, rl, rr, rr, b),
        mount=MOUNT,
        seed=4,
    )


@pytest.fixture(scope="module")
def bag(drive: LaserDrive, tmp_path_factory: pytest.TempPathFactory) -> Path:
    lz = drive.laser
    scans = LaserScans(
        drive.scan_t, drive.ranges, lz.angle_min, lz.angle_increment, lz.range_min, lz.range_max
    )
    path = tmp_path_factory.mktemp("laser") / "drive.mcap"
    write_scan_mcap(path, scans, joint_t=drive.joint_t, wheel_angles=drive.wheel_angles)
    return path


def test_the_laser_sees_every_turn_of_the_drive(drive: LaserDrive) -> None:
    # the drive turns in place both ways and drives arcs: the calibration needs all of them
    yaw = np.diff(drive.sensor[:, 2])
    assert yaw.max() > 0.05 and yaw.min() < -0.05
    assert drive.scan_t[-1] == pytest.approx(sum(leg.duration for leg in calibration_drive()), 0.01)


def test_calibrate_sensor_from_the_bag_scans(bag: Path, drive: LaserDrive, tmp_path: Path) -> None:
    js = tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(bag), "--scan-topic", "/scan", "--joint-topic",
         "/joint_states", "-p", "jaguar-lite", "-o", str(tmp_path / "new.toml"),
         "--json", str(js), "--truth-out", str(tmp_path / "robot.csv")]
    )  # fmt: skip
    assert code == 0
    r = json.loads(js.read_text())
    for key, true in zip(
        ("left_wheel_radius", "right_wheel_radius", "track_width"), TRUE, strict=True
    ):
        assert r["params"][key] == pytest.approx(true, rel=0.01), key
        assert abs(r["params"][key] - true) < 4 * r["stderr"][key], key
    assert r["values"]["sensor_x"] == pytest.approx(MOUNT[0], abs=0.02)
    assert r["values"]["sensor_y"] == pytest.approx(MOUNT[1], abs=0.02)
    assert r["values"]["sensor_yaw"] == pytest.approx(MOUNT[2], abs=math.radians(1.0))
    assert "track_width" in (tmp_path / "new.toml").read_text()
    # --truth-out: the robot centre's path; its motion over each second is the true robot's
    got = read_trajectory(tmp_path / "robot.csv")
    assert got.t == pytest.approx(drive.scan_t)
    i = np.arange(0, len(got.t) - 10, 10)
    want = relative_motions(drive.robot[:, 0], drive.robot[:, 1], drive.robot[:, 2], i, i + 10)
    have = relative_motions(got.x, got.y, got.heading, i, i + 10)
    assert np.abs(have[:, :2] - want[:, :2]).max() < 0.01  # metres
    assert np.abs(have[:, 2] - want[:, 2]).max() < math.radians(0.3)


def test_laser_clock_offset_found_from_the_yaw_rates(drive: LaserDrive, tmp_path: Path) -> None:
    # the laser's stamps 0.7 s ahead of the wheels' (another computer's clock)
    lz = drive.laser
    scans = LaserScans(
        drive.scan_t + 0.7, drive.ranges, lz.angle_min, lz.angle_increment, lz.range_min,
        lz.range_max,
    )  # fmt: skip
    bag = tmp_path / "late.mcap"
    write_scan_mcap(bag, scans, joint_t=drive.joint_t, wheel_angles=drive.wheel_angles)
    js = tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(bag), "--scan-topic", "/scan", "-p", "jaguar-lite",
         "-o", str(tmp_path / "new.toml"), "--json", str(js), "--time-offset", "auto",
         "--max-offset", "3"]
    )  # fmt: skip
    assert code == 0
    r = json.loads(js.read_text())
    assert r["time_offset_s"] == pytest.approx(0.7, abs=0.02)
    assert r["params"]["track_width"] == pytest.approx(TRUE[2], rel=0.01)


def test_robot_trajectory_by_hand() -> None:
    # the sensor at (1, 2) facing +y, mounted 0.2 m ahead and turned 0.1 rad: the robot
    # faces pi/2 - 0.1 and its centre is 0.2 m behind the sensor along that heading
    sensor = Trajectory.from_xyh(np.array([5.0]), [1.0], [2.0], [math.pi / 2])
    r = robot_trajectory(sensor, (0.2, 0.0, 0.1), time_offset=1.5)
    h = math.pi / 2 - 0.1
    assert r.t[0] == pytest.approx(3.5)
    assert (r.x[0], r.y[0], r.heading[0]) == pytest.approx(
        (1.0 - 0.2 * math.cos(h), 2.0 - 0.2 * math.sin(h), h)
    )


def test_scan_topic_with_sensor_topic_is_one_sentence(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        ["calibrate", "sensor", str(bag), "--scan-topic", "/scan", "--sensor-topic", "/odom",
         "-p", "jaguar-lite", "-o", str(tmp_path / "new.toml")]
    )  # fmt: skip
    assert code == 1
    err = capsys.readouterr().err
    assert "--scan-topic or --sensor-topic, not both" in err
    assert "Traceback" not in err
