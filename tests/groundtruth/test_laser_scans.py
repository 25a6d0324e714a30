"""Laser path: LaserScan messages in a ROS 2 bag -> small_gicp scan matching -> calibrate sensor."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.io.laserscan import read_laser_scans, scan_trajectory
from odolab.params import PRESETS
from odolab.sim.drives import calibration_drive, record_drive
from odolab.sim.physics import TrueParams

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from bench_scan_matching import scan

pytest.importorskip("small_gicp")

NOMINAL = PRESETS["jaguar-lite"]
MOUNT = (0.20, -0.05, 0.3)
TRUE = (0.085, 0.082, 0.60)


def _bag(path: Path) -> tuple[Path, np.ndarray]:
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    rl, rr, b = TRUE
    d = record_drive(TrueParams(rl, rl, rr, rr, b), NOMINAL, calibration_drive(), rate=5)
    tr = d.truth
    c, s = np.cos(tr.heading), np.sin(tr.heading)
    lx, ly, lth = MOUNT
    sx, sy, sh = tr.x + c * lx - s * ly - 1.0, tr.y + s * lx + c * ly - 0.5, tr.heading + lth
    store = get_typestore(Stores.ROS2_HUMBLE)
    ty = store.types
    rng = np.random.default_rng(4)
    k = 2 * math.pi / NOMINAL.ticks_per_rev
    with Writer(path, version=9) as w:
        joints = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        laser = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        for i, ti in enumerate(d.t):
            sec = math.floor(ti)
            stamp = ty["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((ti - sec) * 1e9))
            header = ty["std_msgs/msg/Header"](stamp=stamp, frame_id="base")
            js = ty["sensor_msgs/msg/JointState"](
                header=header, name=["left_wheel_joint", "right_wheel_joint"],
                position=np.array([d.counts_left[i] * k, d.counts_right[i] * k]),
                velocity=np.zeros(0), effort=np.zeros(0),
            )  # fmt: skip
            pts = scan(sx[i], sy[i], sh[i], rng)
            ranges = np.full(541, np.inf, dtype=np.float32)
            ang = np.arctan2(pts[:, 1], pts[:, 0])
            idx = np.clip(np.rint((np.degrees(ang) + 135) * 2).astype(int), 0, 540)
            ranges[idx] = np.hypot(pts[:, 0], pts[:, 1])
            ls = ty["sensor_msgs/msg/LaserScan"](
                header=header, angle_min=math.radians(-135), angle_max=math.radians(135),
                angle_increment=math.radians(0.5), time_increment=0.0, scan_time=0.1,
                range_min=0.05, range_max=10.0, ranges=ranges,
                intensities=np.zeros(0, dtype=np.float32),
            )  # fmt: skip
            ns = int(ti * 1e9)
            w.write(joints, ns, store.serialize_cdr(js, "sensor_msgs/msg/JointState"))
            w.write(laser, ns, store.serialize_cdr(ls, "sensor_msgs/msg/LaserScan"))
    return path, np.column_stack((sx, sy, sh))


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    return _bag(tmp_path_factory.mktemp("laser") / "drive")


def test_scan_matching_follows_the_sensor(bag: tuple[Path, np.ndarray]) -> None:
    path, truth = bag
    scans = read_laser_scans(path, "/scan")
    assert len(scans.points) == truth.shape[0]
    assert scans.t[1] - scans.t[0] == pytest.approx(0.2)
    traj = scan_trajectory(scans)
    # each match against the true relative motion: centimetres and fractions of a degree
    from odolab.calibration.sensor import relative_motions

    i = np.arange(truth.shape[0] - 1)
    got = relative_motions(traj.x, traj.y, traj.heading, i, i + 1)
    want = relative_motions(truth[:, 0], truth[:, 1], truth[:, 2], i, i + 1)
    rms = np.sqrt(np.mean((got - want) ** 2, axis=0))
    assert rms[0] < 0.03 and rms[1] < 0.03, rms
    assert math.degrees(rms[2]) < 0.5, rms
    # no rotation bias: the turns are as large as they were
    turn = np.abs(want[:, 2]) > 0.05
    assert np.sum(got[turn, 2] * want[turn, 2]) / np.sum(want[turn, 2] ** 2) == pytest.approx(
        1.0, abs=0.01
    )


def test_calibrate_sensor_from_scans(bag: tuple[Path, np.ndarray], tmp_path: Path) -> None:
    path, _ = bag
    js = tmp_path / "r.json"
    code = main(
        ["calibrate", "sensor", str(path), "-f", "bag", "--scan-topic", "/scan", "-p",
         "jaguar-lite", "-o", str(tmp_path / "new.toml"), "--json", str(js)]
    )  # fmt: skip
    assert code == 0
    r = json.loads(js.read_text())
    for key, true in zip(
        ("left_wheel_radius", "right_wheel_radius", "track_width"), TRUE, strict=True
    ):
        assert r["params"][key] == pytest.approx(true, rel=0.01), key
        assert abs(r["params"][key] - true) < 4 * r["stderr"][key], key
    assert r["values"]["sensor_yaw"] == pytest.approx(MOUNT[2], abs=0.03)
