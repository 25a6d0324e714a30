"""Encoder runs with a gyro: wheel angles and a yaw rate, read from the logs a user has.

A :class:`GyroRun` is what ``odolab calibrate imu`` estimates from: one or more
:class:`GyroSegment` (an encoder log's wheel angles on its clock, and a gyro's yaw rate on the
gyro's clock), sharing one gyro bias and one clock offset. Readers:

- :func:`read_gyro_csv`: a plain ``t,wz`` CSV (s, rad/s), e.g. ``NAME_imu.csv`` beside
  ``NAME.csv`` (:func:`gyro_beside`, found the way ``NAME_gt.csv`` is);
- a SensorLog CSV (the phone of ``odolab validate``, and the ``imu.csv`` a 2014 Jaguar's robot run
  writes in the same columns) through :func:`odolab.io.sensorlog.read_sensorlog`;
- :func:`read_drive_windows`: the DRIVE project's Husky window table (``imu_yaw`` and the wheel
  speeds, 2 s windows, each its own segment);
- :func:`read_bag_gyro_run`: a ROS 1/2 bag or MCAP file: the wheels' joint states and
  ``sensor_msgs/Imu`` (``/imu/data``) from the same bag;
- :func:`read_gyro_run`: an encoder log (or a robot run folder, a bag) with its gyro, whichever
  of the above it has.

Conventions: wheel angles in rad (cumulative, counter-clockwise wheel turn forward), yaw rate in
rad/s counter-clockwise positive about the vertical; the gyro's clock reads ``clock_offset``
seconds more than the encoders' (as :mod:`odolab.validation.align`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odolab.core.arrays import FloatArray
from odolab.core.errors import ImuLogError, LogFormatError
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io.csv_run import ground_truth_beside
from odolab.io.encoder_csv import read_encoder_csv
from odolab.io.rosbag import is_bag
from odolab.io.run import ReadOptions
from odolab.io.sensorlog import ImuLog, read_sensorlog
from odolab.io.tabular import is_csv_with, read_columns, read_header
from odolab.io.trajectory_csv import read_trajectory
from odolab.io.windows import wheel_angles

__all__ = [
    "DRIVE_COLUMNS",
    "GYRO_COLUMNS",
    "GyroRun",
    "GyroSegment",
    "gyro_beside",
    "gyro_run_from_log",
    "is_drive_table",
    "read_bag_gyro_run",
    "read_drive_windows",
    "read_gyro",
    "read_gyro_csv",
    "read_gyro_run",
]


#: The plain gyro CSV's columns: time (s) and yaw rate (rad/s).
GYRO_COLUMNS = ("t", "wz")
#: The DRIVE window table's columns that the gyro calibration reads.
DRIVE_COLUMNS = (
    "window",
    "calib_step",
    "t",
    "left_wheel_vel",
    "right_wheel_vel",
    "icp_yaw",
    "imu_yaw",
)
_GYRO_SUFFIXES = ("_imu.csv",)


@dataclass(frozen=True, eq=False)
class GyroSegment:
    """A stretch of encoder log and the gyro beside it.

    ``t`` (s, encoder clock, shape (n,), increasing), ``left``/``right``: cumulative wheel
    angles (rad, shape (n,)); ``gyro_t`` (s, gyro clock, shape (m,), increasing) and ``wz``
    (rad/s, shape (m,)). ``heading``: a reference heading (rad, unwrapped) at ``heading_t``
    (encoder clock), where the log has one (a tracker, a lidar), else None.
    """

    t: FloatArray
    left: FloatArray
    right: FloatArray
    gyro_t: FloatArray
    wz: FloatArray
    heading_t: FloatArray | None = None
    heading: FloatArray | None = None
    group: int = 0  #: segments of one group were recorded together (a DRIVE command step)

    def __post_init__(self) -> None:
        n, m = self.t.size, self.gyro_t.size
        if self.left.shape != (n,) or self.right.shape != (n,) or self.wz.shape != (m,):
            raise LogFormatError("a gyro segment's arrays must be 1-D and as long as their times")
        if n < 2 or m < 2:
            raise LogFormatError("a gyro segment needs at least two encoder and two gyro samples")


@dataclass(frozen=True, eq=False)
class GyroRun:
    """One run: its segments (one for a plain log), named for messages.

    ``same_clock``: the gyro is stamped on the encoders' clock (a robot's own IMU, the DRIVE
    table): the clock offset is only refined near 0, never searched wide.
    """

    name: str
    source: str
    imu_source: str
    segments: tuple[GyroSegment, ...]
    same_clock: bool = False

    @property
    def duration(self) -> float:
        return float(sum(s.t[-1] - s.t[0] for s in self.segments))


def gyro_beside(path: Path) -> Path | None:
    """The gyro file next to an encoder log (``NAME_imu.csv``), or for a robot run folder's
    ``encoders.csv`` its ``imu.csv``; None when there is none."""
    for suffix in _GYRO_SUFFIXES:
        q = path.with_name(path.stem + suffix)
        if q.is_file():
            return q
    if path.name == "encoders.csv" and (path.parent / "imu.csv").is_file():
        return path.parent / "imu.csv"
    return None


def _check_increasing(p: Path, t: FloatArray, what: str) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ImuLogError(
            f"{p}: line {i + 2}: {what} time {t[i]:g} s does not increase (the line before: "
            f"{t[i - 1]:g} s); expected increasing times"
        )


def read_gyro_csv(path: str | Path) -> ImuLog:
    """A plain gyro CSV ``t,wz`` (s, rad/s) as an :class:`ImuLog` (yaw: the rate's integral).

    Raises:
        ImuLogError: the table has fewer than two gyro samples or a bad time.
    """
    p = Path(path)
    cols = read_columns(p, GYRO_COLUMNS)
    t = np.asarray(cols["t"], dtype=np.float64)
    wz = np.asarray(cols["wz"], dtype=np.float64)
    if t.size < 2:
        raise ImuLogError(f"{p}: {t.size} gyro sample(s); expected at least two rows of t,wz")
    _check_increasing(p, t, "gyro")
    yaw = np.concatenate(([0.0], np.cumsum(0.5 * (wz[1:] + wz[:-1]) * np.diff(t))))
    return ImuLog(t, yaw, wz, source=str(p), heading_column="wz", rate_column="wz", time_column="t")


def read_gyro(path: str | Path) -> ImuLog:
    """A gyro log by its header: ``t,wz``, else a SensorLog CSV (the phone's, or a robot run's
    ``imu.csv``). The log must have a yaw RATE column (a heading alone is not a gyro).

    Raises:
        ImuLogError: the file has no yaw-rate column.
    """
    p = Path(path)
    header = read_header(p)
    if all(c in header for c in GYRO_COLUMNS):
        return read_gyro_csv(p)
    log = read_sensorlog(p)
    if log.yaw_rate is None:
        raise ImuLogError(
            f"{p}: no yaw-rate column (wz, motionRotationRateZ(rad/s) or gyroRotationZ(rad/s)); "
            f"the gyro calibration needs the gyro's rate, not only a heading "
            f"({log.heading_column})"
        )
    return log


def _segment_from_log(
    t: FloatArray,
    left: FloatArray,
    right: FloatArray,
    imu: ImuLog,
    truth: Trajectory | None,
) -> GyroSegment:
    assert imu.yaw_rate is not None
    return GyroSegment(
        t,
        left,
        right,
        imu.t,
        imu.yaw_rate,
        None if truth is None else truth.t,
        None if truth is None else truth.heading,
    )


def read_bag_gyro_run(
    path: str | Path,
    *,
    ticks_per_rev: float,
    imu_topic: str = "/imu/data",
    options: ReadOptions | None = None,
) -> GyroRun:
    """A ROS bag or MCAP file: the wheels' joint states (or the robot's odometry, as
    :func:`odolab.io.rosbag.read_bag` reads them) and ``sensor_msgs/Imu`` on ``imu_topic``,
    both on the header stamps' clock."""
    from odolab.io.rosbag import read_bag, read_bag_gyro

    p = Path(path)
    o = options or ReadOptions(ticks_per_rev=ticks_per_rev)
    run = read_bag(p, o)
    gyro = read_bag_gyro(p, imu_topic)
    scale = 2.0 * math.pi / float(o.ticks_per_rev)
    seg = _segment_from_log(
        np.asarray(run.t, dtype=np.float64),
        scale * np.cumsum(run.dticks_left),
        scale * np.cumsum(run.dticks_right),
        gyro,
        run.ground_truth,
    )
    return GyroRun(p.stem, str(p), gyro.source, (seg,), same_clock=True)


def read_gyro_run(
    path: str | Path,
    *,
    ticks_per_rev: float,
    modulus: int | None = None,
    imu: str | Path | None = None,
    imu_topic: str = "/imu/data",
) -> GyroRun:
    """An encoder log with its gyro: ``imu`` when given, else ``NAME_imu.csv`` beside
    ``NAME.csv`` (a robot run folder or its ``encoders.csv``: the folder's ``imu.csv``). A DRIVE
    window table is read whole (:func:`read_drive_windows`); a ROS bag or MCAP file gives both
    from its topics (:func:`read_bag_gyro_run`). Ticks become wheel angles with
    ``ticks_per_rev``. A ground truth beside the log (``NAME_gt.csv``) gives the reference
    heading.

    Raises:
        ImuLogError: no gyro log lies beside the run.
        LogFormatError: a folder has no encoders.csv, or a log cannot be read.
    """
    p = Path(path)
    if imu is None and is_bag(p):
        return read_bag_gyro_run(p, ticks_per_rev=ticks_per_rev, imu_topic=imu_topic)
    if p.is_dir():
        if not (p / "encoders.csv").is_file():
            raise LogFormatError(
                f"{p}: a folder without encoders.csv; expected a robot run folder or an encoder "
                "log CSV"
            )
        p = p / "encoders.csv"
    if imu is None and p.is_file() and is_drive_table(p):
        return read_drive_windows(p)
    gyro_path = Path(imu) if imu is not None else gyro_beside(p)
    if gyro_path is None:
        raise ImuLogError(
            f"{p}: no gyro log beside it (expected {p.stem}_imu.csv with columns t,wz, or a "
            "robot run folder's imu.csv); name one with {{imu}}"
        )
    log = read_encoder_csv(p, modulus=modulus)
    gyro = read_gyro(gyro_path)
    gt_path = ground_truth_beside(p)
    truth = read_trajectory(gt_path) if gt_path is not None else None
    same = gyro_path.name == "imu.csv" or gyro_path.name.endswith("_imu.csv")
    name = p.parent.name if p.name == "encoders.csv" else p.stem
    run = gyro_run_from_log(
        name, log, gyro, ticks_per_rev, source=str(p), same_clock=same, truth=truth
    )
    return GyroRun(name, str(p), str(gyro_path), run.segments, same_clock=same)


def gyro_run_from_log(
    name: str,
    log: EncoderLog,
    imu: ImuLog,
    ticks_per_rev: float,
    *,
    source: str = "encoder log",
    same_clock: bool = False,
    truth: Trajectory | None = None,
) -> GyroRun:
    """An encoder log (raw counters, unwrapped here) and a gyro log with rates as a one-piece
    :class:`GyroRun`; ``same_clock``: the gyro is stamped on the encoders' clock.

    Raises:
        ImuLogError: the IMU log has no yaw rate.
    """
    from odolab.core.encoders import dticks_from_ticks

    if imu.yaw_rate is None:
        raise ImuLogError(f"{imu.source}: no yaw rate; the gyro calibration needs the gyro's rate")
    scale = 2.0 * math.pi / float(ticks_per_rev)
    left = np.concatenate(([0.0], np.cumsum(dticks_from_ticks(log.left_ticks, log.modulus))))
    right = np.concatenate(([0.0], np.cumsum(dticks_from_ticks(log.right_ticks, log.modulus))))
    seg = _segment_from_log(
        np.asarray(log.t, dtype=np.float64), scale * left, scale * right, imu, truth
    )
    return GyroRun(name, source, imu.source, (seg,), same_clock=same_clock)


def is_drive_table(path: str | Path) -> bool:
    """Whether a CSV has the DRIVE window table's columns."""
    return is_csv_with(path, DRIVE_COLUMNS)


def read_drive_windows(path: str | Path) -> GyroRun:
    """The DRIVE window table (``shared/data/drive-husky/husky_windows.csv``): one segment per
    window (2 s at 20 Hz), wheel angles integrated from the measured wheel speeds (trapezoid),
    the gyro ``imu_yaw`` on the same clock, ``icp_yaw`` (lidar, unwrapped per window) as the
    reference heading, and the command step as the segment's group.

    Raises:
        LogFormatError: no window has two or more rows, or the table cannot be read.
    """
    p = Path(path)
    cols = read_columns(p, DRIVE_COLUMNS)
    window = np.asarray(cols["window"], dtype=np.float64)
    starts = np.flatnonzero(np.concatenate(([True], np.diff(window) != 0)))
    ends = np.concatenate((starts[1:], [window.size]))
    segments = []
    for a, b in zip(starts, ends, strict=True):
        t = np.asarray(cols["t"][a:b], dtype=np.float64)
        if t.size < 2:
            continue
        _check_increasing(p, t, f"window {int(window[a])}:")
        wl = np.asarray(cols["left_wheel_vel"][a:b], dtype=np.float64)
        wr = np.asarray(cols["right_wheel_vel"][a:b], dtype=np.float64)
        left = wheel_angles(t, wl)  # (one rule with the window-table run reader)
        right = wheel_angles(t, wr)
        segments.append(
            GyroSegment(
                t,
                left,
                right,
                t.copy(),
                np.asarray(cols["imu_yaw"][a:b], dtype=np.float64),
                t.copy(),
                np.unwrap(np.asarray(cols["icp_yaw"][a:b], dtype=np.float64)),
                group=int(cols["calib_step"][a]),
            )
        )
    if not segments:
        raise LogFormatError(f"{p}: no window with two or more rows")
    return GyroRun(p.stem, str(p), str(p), tuple(segments), same_clock=True)
