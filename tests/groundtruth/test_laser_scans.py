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

from odolab.cli import main
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


def test_calibrate_sensor_from_the_bag_scans(bag: Path, tmp_path: Path) -> None:
    js = tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(bag), "--scan-topic", "/scan", "--joint-topic",
         "/joint_states", "-p", "jaguar-lite", "-o", str(tmp_path / "new.toml"),
         "--json", str(js)]
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
