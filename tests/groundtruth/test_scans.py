"""Laser scans to motion: ray casting, the LaserScan bag reader and writer, scan matching, CLI.

One synthetic drive (the virtual Jaguar in a room with boxes, a 270 degree 541-beam laser with
1 cm range noise mounted at (0.15, -0.05) m and 0.1 rad) is written to an MCAP with
/joint_states, read back and matched; the truth is the simulator's sensor poses.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from odolab.calibration.scanmatch import MIN_POINTS, ScanMotions, scan_motions
from odolab.cli import main
from odolab.core.errors import CalibrationError, InsufficientDataError, LogFormatError
from odolab.io import read_trajectory_csv
from odolab.io.rosbag import read_bag
from odolab.io.run import ReadOptions
from odolab.io.scans import LaserScans, read_scans, write_scan_mcap
from odolab.sim.laser import (
    LaserDrive,
    LaserModel,
    World,
    cast_scans,
    room_world,
    simulate_laser_drive,
)

MOUNT = (0.15, -0.05, 0.1)


def _scans(drive: LaserDrive) -> LaserScans:
    lz = drive.laser
    return LaserScans(
        drive.scan_t, drive.ranges, lz.angle_min, lz.angle_increment, lz.range_min, lz.range_max
    )


def _relative(p: np.ndarray) -> np.ndarray:
    """True motion between consecutive poses, in the earlier pose's frame."""
    d = p[1:] - p[:-1]
    c, s = np.cos(p[:-1, 2]), np.sin(p[:-1, 2])
    return np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]))


@pytest.fixture(scope="module")
def drive() -> LaserDrive:
    return simulate_laser_drive(mount=MOUNT, seed=7)


@pytest.fixture(scope="module")
def bag(drive: LaserDrive, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("scans") / "drive.mcap"
    write_scan_mcap(path, _scans(drive), joint_t=drive.joint_t, wheel_angles=drive.wheel_angles)
    return path


@pytest.fixture(scope="module")
def matched(bag: Path) -> ScanMotions:
    return scan_motions(read_scans(bag, "/scan"))


# --- ray casting -------------------------------------------------------------------------------


def test_ray_casting_hits_the_walls_of_a_square_room_where_geometry_says() -> None:
    room = World(np.array([[0, 0, 4, 0], [4, 0, 4, 4], [4, 4, 0, 4], [0, 4, 0, 0]], float))
    laser = LaserModel(beams=5, angle_min=-math.pi / 2, angle_max=math.pi / 2, range_sigma=0.0)
    # at (1, 1) facing +x: beams at -90, -45, 0, 45, 90 degrees
    (r,) = cast_scans(room, [(1.0, 1.0, 0.0)], laser)
    np.testing.assert_allclose(r, [1.0, math.sqrt(2), 3.0, 3.0 * math.sqrt(2), 3.0], rtol=1e-12)
    # turned by 90 degrees: the beam straight ahead now hits the top wall
    (r,) = cast_scans(room, [(1.0, 1.0, math.pi / 2)], laser)
    np.testing.assert_allclose(r[2], 3.0, rtol=1e-12)
    # beyond range_max: inf
    short = LaserModel(beams=5, angle_min=-1, angle_max=1, range_max=2.0, range_sigma=0.0)
    (r,) = cast_scans(room, [(1.0, 1.0, 0.0)], short)
    assert math.isinf(r[2])


@settings(max_examples=25)
@given(
    x=st.floats(0.5, 7.5),
    y=st.floats(0.5, 5.5),
    yaw=st.floats(-math.pi, math.pi),
    shift=st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    turn=st.floats(-math.pi, math.pi),
)
def test_moving_world_and_scanner_together_changes_no_range(
    x: float, y: float, yaw: float, shift: tuple[float, float], turn: float
) -> None:
    world = room_world()
    c, s = math.cos(turn), math.sin(turn)

    def move(px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return c * px - s * py + shift[0], s * px + c * py + shift[1]

    seg = world.segments
    a, b = move(seg[:, 0], seg[:, 1]), move(seg[:, 2], seg[:, 3])
    moved = World(np.column_stack((a[0], a[1], b[0], b[1])))
    px, py = move(np.array(x), np.array(y))
    laser = LaserModel(beams=91, range_sigma=0.0)
    here = cast_scans(world, [(x, y, yaw)], laser)
    there = cast_scans(moved, [(float(px), float(py), yaw + turn)], laser)
    finite = np.isfinite(here)
    assert (finite == np.isfinite(there)).all()
    np.testing.assert_allclose(there[finite], here[finite], rtol=1e-9, atol=1e-9)


def test_simulated_ranges_scatter_by_the_laser_noise(drive: LaserDrive) -> None:
    clean = cast_scans(
        World(np.array([[0, 0, 8, 0], [8, 0, 8, 6], [8, 6, 0, 6], [0, 6, 0, 0]], float)),
        drive.sensor[:1],
        LaserModel(range_sigma=0.0),
    )
    assert clean.shape == (1, 541)
    noisy = cast_scans(
        World(np.array([[0, 0, 8, 0], [8, 0, 8, 6], [8, 6, 0, 6], [0, 6, 0, 0]], float)),
        np.repeat(drive.sensor[:1], 20, axis=0),
        LaserModel(range_sigma=0.01),
        seed=1,
    )
    assert np.std(noisy - clean) == pytest.approx(0.01, rel=0.05)


# --- the bag -----------------------------------------------------------------------------------


def test_mcap_round_trip_keeps_scans_and_wheels(drive: LaserDrive, bag: Path) -> None:
    scans = read_scans(bag, "/scan")
    assert len(scans) == len(drive.scan_t) and scans.beams == 541
    np.testing.assert_allclose(scans.t, drive.scan_t, atol=1e-9)
    np.testing.assert_allclose(scans.angles, drive.laser.angles, atol=1e-6)
    # ranges are float32 in the message
    np.testing.assert_allclose(scans.ranges, drive.ranges, rtol=1e-6)
    assert scans.points(0).shape == (541, 2)
    # the wheels come back through odolab's own bag reader as ticks (1 tick per radian)
    run = read_bag(bag, ReadOptions(joint_topic="/joint_states", ground_truth_topic="/none"))
    np.testing.assert_allclose(run.t, drive.joint_t, atol=1e-9)
    wheels = np.column_stack((np.cumsum(run.dticks_left), np.cumsum(run.dticks_right)))
    np.testing.assert_allclose(wheels, drive.wheel_angles - drive.wheel_angles[0], atol=1e-9)


def _rosbags_scan_bag(path: Path, scans: LaserScans, *, ros1: bool) -> Path:
    """The same scans written by rosbags' own ROS 1 / ROS 2 (sqlite3) writers, not odolab's."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ty = store.types
    msgs = []
    for k, (ti, r) in enumerate(zip(scans.t, scans.ranges, strict=True)):
        sec = math.floor(ti)
        stamp = ty["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((ti - sec) * 1e9))
        extra = {"seq": k} if ros1 else {}
        header = ty["std_msgs/msg/Header"](stamp=stamp, frame_id="laser", **extra)
        msgs.append(
            ty["sensor_msgs/msg/LaserScan"](
                header=header,
                angle_min=scans.angle_min,
                angle_max=scans.angle_min + scans.angle_increment * (scans.beams - 1),
                angle_increment=scans.angle_increment,
                time_increment=0.0,
                scan_time=0.1,
                range_min=scans.range_min,
                range_max=scans.range_max,
                ranges=r.astype(np.float32),
                intensities=np.zeros(0, dtype=np.float32),
            )
        )
    typ = "sensor_msgs/msg/LaserScan"
    if ros1:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(path) as w1:
            c1 = w1.add_connection("/base_scan", typ, typestore=store)
            for ti, msg in zip(scans.t, msgs, strict=True):
                w1.write(c1, int(ti * 1e9), store.serialize_ros1(msg, typ))
        return path
    from rosbags.rosbag2 import Writer

    with Writer(path, version=9) as w2:
        c2 = w2.add_connection("/base_scan", typ, typestore=store)
        for ti, msg in zip(scans.t, msgs, strict=True):
            w2.write(c2, int(ti * 1e9), store.serialize_cdr(msg, typ))
    return path


@pytest.mark.parametrize("ros1", [True, False], ids=["ros1-bag", "ros2-folder"])
def test_ros1_bag_and_ros2_folder_give_the_same_scans(
    drive: LaserDrive, tmp_path: Path, ros1: bool
) -> None:
    first = _scans(drive)
    few = LaserScans(
        first.t[:5],
        first.ranges[:5],
        first.angle_min,
        first.angle_increment,
        first.range_min,
        first.range_max,
    )
    path = _rosbags_scan_bag(tmp_path / ("drive.bag" if ros1 else "drive"), few, ros1=ros1)
    back = read_scans(path, "/base_scan")
    np.testing.assert_allclose(back.t, few.t, atol=1e-9)
    np.testing.assert_allclose(back.ranges, few.ranges, rtol=1e-6)
    assert back.angle_min == pytest.approx(few.angle_min, abs=1e-6)
    assert back.frame_id == "laser"


def test_missing_topic_names_the_topics_the_bag_has(bag: Path) -> None:
    with pytest.raises(
        LogFormatError, match=r"no topic '/laser'.*/scan \(sensor_msgs/msg/LaserScan\)"
    ):
        read_scans(bag, "/laser")


def test_wrong_message_type_is_one_sentence(bag: Path) -> None:
    with pytest.raises(
        LogFormatError, match=r"carries sensor_msgs/msg/JointState; expected .*LaserScan"
    ):
        read_scans(bag, "/joint_states")


def test_too_few_scans(drive: LaserDrive, tmp_path: Path) -> None:
    one = _scans(drive)
    path = tmp_path / "one.mcap"
    write_scan_mcap(
        path,
        LaserScans(
            one.t[:1],
            one.ranges[:1],
            one.angle_min,
            one.angle_increment,
            one.range_min,
            one.range_max,
        ),
    )
    with pytest.raises(LogFormatError, match=r"has 1 laser scans; expected at least 2"):
        read_scans(path)


def test_not_a_bag(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file")
    with pytest.raises(LogFormatError, match=r"junk\.mcap"):
        read_scans(junk)
    with pytest.raises(LogFormatError, match="no such bag"):
        read_scans(tmp_path / "missing.mcap")


# --- scan matching ------------------------------------------------------------------------------


def test_pairwise_motions_match_the_true_sensor_motion(
    drive: LaserDrive, matched: ScanMotions
) -> None:
    truth = _relative(drive.sensor)
    assert len(matched) == len(truth) == len(drive.scan_t) - 1
    err = matched.motions - truth
    exy = np.hypot(err[:, 0], err[:, 1])
    eyaw = np.abs(err[:, 2])
    assert np.median(exy) < 0.01  # measured 1.1 mm (worst 3.6 mm)
    assert np.median(eyaw) < math.radians(0.5)  # measured 0.013 deg (worst 0.054)
    assert exy.max() < 0.01 and eyaw.max() < math.radians(0.2)
    # the sensor's motion is not the robot's: the mount's offset shows in a turn in place
    turning = np.abs(truth[:, 2]) > 0.05
    robot = _relative(drive.robot)
    assert np.abs(matched.motions[turning, 1] - robot[turning, 1]).max() > 0.003
    assert not matched.outliers().any()
    assert matched.converged.all() and (matched.fitness > 0.95).all()


def test_composed_trajectory_follows_the_truth(drive: LaserDrive, matched: ScanMotions) -> None:
    traj = matched.trajectory
    np.testing.assert_allclose(traj.t, drive.scan_t, atol=1e-9)
    p = drive.sensor
    c, s = math.cos(p[0, 2]), math.sin(p[0, 2])
    q = p - p[0]
    x, y = c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]
    drift = np.hypot(traj.x - x, traj.y - y)
    assert drift.max() < 0.05  # measured 34 mm after 6 m
    assert np.abs(traj.heading - q[:, 2]).max() < math.radians(0.5)  # measured 0.26 deg
    assert traj.path_length() == pytest.approx(
        np.hypot(*np.diff(p[:, :2], axis=0).T).sum(), rel=0.01
    )


def test_a_scan_from_elsewhere_is_flagged(drive: LaserDrive) -> None:
    scans = _scans(drive)
    ranges = scans.ranges.copy()
    # scan 40 replaced by one taken 2 m away, turned half round: both pairs around it fail
    far = drive.sensor[40] + (0.0, 0.0, math.pi)
    far[0] -= 1.0
    ranges[40] = cast_scans(World(np.array([[0, 0, 8, 0], [8, 0, 8, 6]], float)), [far])[0]
    bad = LaserScans(
        scans.t, ranges, scans.angle_min, scans.angle_increment, scans.range_min, scans.range_max
    )
    result = scan_motions(bad)
    flagged = result.outliers().nonzero()[0].tolist()
    assert 39 in flagged or 40 in flagged
    assert len(flagged) <= 3


def test_every_and_skipped_scans(drive: LaserDrive) -> None:
    scans = _scans(drive)
    ranges = scans.ranges.copy()
    ranges[4, MIN_POINTS - 1 :] = np.inf  # too few valid ranges left
    ranges[4, :5] = np.nan  # drivers' 'no return'
    ranges[4, 5:10] = 0.05  # below range_min
    sparse = LaserScans(
        scans.t, ranges, scans.angle_min, scans.angle_increment, scans.range_min, scans.range_max
    )
    result = scan_motions(sparse, every=2)
    assert result.skipped == (4,)
    assert result.index[:4].tolist() == [0, 2, 6, 8]
    truth = drive.sensor
    # motion from scan 2 to scan 6 bridges the skipped one
    rel = _relative(truth[[2, 6]])[0]
    np.testing.assert_allclose(result.motions[1], rel, atol=0.01)


def test_bad_options_and_empty_scans(drive: LaserDrive) -> None:
    scans = _scans(drive)
    with pytest.raises(CalibrationError, match="voxel is 0"):
        scan_motions(scans, voxel=0)
    with pytest.raises(CalibrationError, match="every is 0"):
        scan_motions(scans, every=0)
    empty = LaserScans(
        scans.t,
        np.full_like(scans.ranges, np.inf),
        scans.angle_min,
        scans.angle_increment,
        scans.range_min,
        scans.range_max,
    )
    with pytest.raises(InsufficientDataError, match=r"0 of 180 scans have at least 20 valid"):
        scan_motions(empty)


# --- the CLI -----------------------------------------------------------------------------------


def test_cli_writes_the_sensor_trajectory(
    bag: Path, matched: ScanMotions, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sensor.csv"
    assert main(["scans", str(bag), "--scan-topic", "/scan", "-o", str(out)]) == 0
    traj = read_trajectory_csv(out)
    np.testing.assert_allclose(traj.x, matched.trajectory.x, atol=1e-12)
    np.testing.assert_allclose(traj.heading, matched.trajectory.heading, atol=1e-12)
    assert "180 scans, 179 pairs matched" in capsys.readouterr().out


def test_cli_bad_topic_is_one_line(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["scans", str(bag), "--scan-topic", "/laser", "-o", str(tmp_path / "s.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no topic '/laser'" in err and "/scan" in err
    assert not (tmp_path / "s.csv").exists()


def test_cli_sim_scans_writes_a_bag_the_scans_command_reads(tmp_path: Path) -> None:
    bag = tmp_path / "lab.mcap"
    truth = tmp_path / "truth.csv"
    assert main(["sim", "scans", str(bag), "--seed", "2", "--truth", str(truth)]) == 0
    assert len(read_scans(bag)) == 180
    assert len(read_trajectory_csv(truth)) == 180


def test_points_keep_only_valid_ranges() -> None:
    r = np.array([[np.nan, 0.05, 1.0, np.inf, 40.0, 2.0, 12.0]])
    scans = LaserScans(np.array([0.0]), r, -math.pi / 2, math.pi / 6, 0.1, 30.0)
    # beams at -90, -60, -30, 0, 30, 60, 90 degrees; valid: 1.0 m at -30, 2.0 m at 60, 12 m at 90
    np.testing.assert_allclose(
        scans.points(0),
        [[math.cos(-math.pi / 6), -0.5], [1.0, 2.0 * math.sin(math.pi / 3)], [0.0, 12.0]],
        atol=1e-6,
    )
    assert len(scans.points(0, max_range=10.0)) == 2
