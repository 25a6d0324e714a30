"""SensorLog CSV: reading by header name, empty cells, clocks, unwrapping, errors, writing."""

from __future__ import annotations

import math
import re
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import ImuLogError, LogFormatError
from odolab.io.sensorlog import (
    WRITTEN_COLUMNS,
    ImuLog,
    rate_aided_unwrap,
    read_sensorlog,
    write_sensorlog,
)


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_round_trip_keeps_times_and_unwrapped_yaw(tmp_path: Path) -> None:
    t = 500.0 + 0.01 * np.arange(1200)
    rate = 3.0 * np.sin(0.5 * t)  # back and forth, several turns each way
    yaw = 0.3 + np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 0.01)))
    p = write_sensorlog(tmp_path / "log.csv", t, yaw, rate)
    imu = read_sensorlog(p)
    assert imu.heading_column == "motionYaw(rad)"
    assert imu.rate_column == "motionRotationRateZ(rad/s)"
    assert imu.time_column == "motionTimestamp_sinceReboot(s)"
    np.testing.assert_allclose(imu.t, t, atol=1e-6)
    np.testing.assert_allclose(imu.yaw, yaw, atol=2e-9)  # yaw0 in [-pi, pi): no 2 pi shift
    assert imu.yaw_rate is not None
    np.testing.assert_allclose(imu.yaw_rate, rate, atol=1e-6)
    assert np.ptp(imu.yaw) > 2 * math.pi  # really went round


def test_written_columns_and_formats(tmp_path: Path) -> None:
    t = 100.0 + 0.01 * np.arange(30)
    yaw = np.linspace(3.0, 3.5, 30)  # crosses +pi: must be written wrapped
    start = datetime(2013, 10, 3, 14, 5, 11, 532000, tzinfo=timezone(timedelta(hours=-7)))
    p = write_sensorlog(tmp_path / "log.csv", t, yaw, np.full(30, 1.7), start_wallclock=start)
    lines = p.read_text(encoding="utf-8").splitlines()
    assert tuple(lines[0].split(",")) == WRITTEN_COLUMNS
    first = lines[1].split(",")
    assert re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} [+-]\d{4}", first[0])
    assert first[0] == "2013-10-03 14:05:11.536 -0700"  # start + 4 ms logging delay
    col = WRITTEN_COLUMNS.index("motionYaw(rad)")
    written = np.array([float(ln.split(",")[col]) for ln in lines[1:]])
    assert written.max() < math.pi and written.min() >= -math.pi
    assert written[-1] == pytest.approx(3.5 - 2 * math.pi, abs=1e-8)
    # the compass is only on some rows: empty cells elsewhere
    comp = WRITTEN_COLUMNS.index("locationTrueHeading(°)")
    cells = [ln.split(",")[comp] for ln in lines[1:]]
    assert cells[0] != "" and cells[1] == "" and sum(c != "" for c in cells) == 3
    # compass = degrees clockwise from north = -(yaw - north)
    assert float(cells[0]) == pytest.approx(math.degrees(-3.0) % 360.0, abs=1e-3)


def test_wallclock_offset_from_logging_time(tmp_path: Path) -> None:
    t = 7000.0 + 0.01 * np.arange(50)
    start = datetime(2013, 10, 3, 14, 5, 11, 532000, tzinfo=timezone(timedelta(hours=-7)))
    p = write_sensorlog(
        tmp_path / "log.csv", t, np.zeros(50), np.zeros(50), start_wallclock=start, logging_delay=0
    )
    imu = read_sensorlog(p)
    # 2013-10-03 21:05:11.532 UTC is POSIX 1380834311.532
    assert imu.wallclock_offset == pytest.approx(1380834311.532 - 7000.0, abs=1e-3)
    wall = imu.on_wallclock()
    assert wall.t[0] == pytest.approx(1380834311.532, abs=1e-3)


def test_logging_time_only_with_time_zones(tmp_path: Path) -> None:
    text = (
        "loggingTime(txt),loggingSample(N),motionYaw(rad)\n"
        "2013-10-03 14:05:11.532 -0700,0,0.1\n"
        "2013-10-03 23:05:12.032 +0200,1,0.2\n"  # same clock, another zone: 0.5 s later
        "2013-10-03 21:05:13.532 +0000,2,0.4\n"
    )
    imu = read_sensorlog(_write(tmp_path / "a.csv", text))
    assert imu.time_column == "loggingTime(txt)"
    np.testing.assert_allclose(imu.t, [1380834311.532, 1380834312.032, 1380834313.532])
    np.testing.assert_allclose(imu.yaw, [0.1, 0.2, 0.4])
    assert imu.yaw_rate is None
    assert imu.wallclock_offset == 0.0


def test_empty_cells_columns_in_any_order_and_duplicates(tmp_path: Path) -> None:
    text = (
        "motionRotationRateZ(rad/s),accelerometerAccelerationX(G),motionYaw(rad),"
        "motionTimestamp_sinceReboot(s),loggingSample(N)\n"
        "0.5,0.01,1.0,10.00,0\n"
        ",0.02,,,1\n"
        "0.5,,1.005,10.01,2\n"
        "0.5,,1.005,10.01,3\n"  # the same motion sample logged twice
        "\n"
        "0.5,0.03,1.010,10.02,4\n"
    )
    imu = read_sensorlog(_write(tmp_path / "b.csv", text))
    np.testing.assert_allclose(imu.t, [10.0, 10.01, 10.02])
    np.testing.assert_allclose(imu.yaw, [1.0, 1.005, 1.01])
    assert imu.yaw_rate is not None
    np.testing.assert_allclose(imu.yaw_rate, 0.5)


def test_semicolon_separated(tmp_path: Path) -> None:
    text = "motionTimestamp_sinceReboot(s);motionYaw(rad)\n1.0;0.0\n2.0;0.5\n"
    imu = read_sensorlog(_write(tmp_path / "c.csv", text))
    np.testing.assert_allclose(imu.yaw, [0.0, 0.5])


def test_rate_aided_unwrap_keeps_a_long_gap(tmp_path: Path) -> None:
    # 4 rad/s with a 1 s gap: the wrapped yaw jumps by 4 rad, which np.unwrap takes as -2.28
    t = np.array([0.0, 0.01, 0.02, 1.02, 1.03])
    true = 4.0 * t
    wrapped = (true + math.pi) % (2 * math.pi) - math.pi
    rate = np.full(5, 4.0)
    np.testing.assert_allclose(rate_aided_unwrap(t, wrapped, rate), true, atol=1e-12)
    assert not np.allclose(np.unwrap(wrapped), true)
    rows = "".join(f"{a},{b},{c}\n" for a, b, c in zip(t, wrapped, rate, strict=True))
    text = "motionTimestamp_sinceReboot(s),motionYaw(rad),motionRotationRateZ(rad/s)\n" + rows
    np.testing.assert_allclose(read_sensorlog(_write(tmp_path / "g.csv", text)).yaw, true)


@given(
    st.lists(st.floats(-30.0, 30.0), min_size=2, max_size=40),
    st.floats(-10.0, 10.0),
)
def test_rate_aided_unwrap_recovers_any_path(rates: list[float], y0: float) -> None:
    rate = np.array(rates)
    t = 0.05 * np.arange(rate.size)
    true = y0 + np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 0.05)))
    wrapped = (true + math.pi) % (2 * math.pi) - math.pi
    out = rate_aided_unwrap(t, wrapped, rate)
    np.testing.assert_allclose(np.diff(out), np.diff(true), atol=1e-9)


def test_compass_fallback_flips_the_sign(tmp_path: Path) -> None:
    # clockwise from north 350 -> 10 -> 30 degrees: the robot turned clockwise by 40 degrees
    text = (
        "loggingTime(txt),locationTrueHeading(°),locationHeadingAccuracy(°)\n"
        "2020-01-01 00:00:00.000 +0000,350,5\n"
        "2020-01-01 00:00:00.500 +0000,,\n"
        "2020-01-01 00:00:01.000 +0000,10,5\n"
        "2020-01-01 00:00:01.500 +0000,-1,-1\n"  # iOS: negative = invalid reading
        "2020-01-01 00:00:02.000 +0000,30,5\n"
    )
    imu = read_sensorlog(_write(tmp_path / "d.csv", text))
    assert imu.heading_column == "locationTrueHeading(°)"
    np.testing.assert_allclose(imu.t - imu.t[0], [0.0, 1.0, 2.0])
    np.testing.assert_allclose(imu.yaw - imu.yaw[0], np.radians([0.0, -20.0, -40.0]), atol=1e-12)


def test_gyro_only_is_integrated(tmp_path: Path) -> None:
    text = (
        "gyroTimestamp_sinceReboot(s),gyroRotationZ(rad/s)\n1.0,0.0\n1.5,1.0\n2.0,1.0\n3.0,-1.0\n"
    )
    imu = read_sensorlog(_write(tmp_path / "e.csv", text))
    # trapezoids: 0.25, 0.5, 0.0
    np.testing.assert_allclose(imu.yaw, [0.0, 0.25, 0.75, 0.75])
    assert imu.heading_column == "integral of gyroRotationZ(rad/s)"


def test_missing_columns_lists_the_header(tmp_path: Path) -> None:
    p = _write(tmp_path / "f.csv", "loggingSample(N),accelerometerAccelerationX(G)\n0,0.1\n")
    with pytest.raises(ImuLogError, match=r"f\.csv: missing columns.*header has: loggingSample"):
        read_sensorlog(p)


def test_text_in_a_number_column_names_line_and_column(tmp_path: Path) -> None:
    text = "motionTimestamp_sinceReboot(s),motionYaw(rad)\n1.0,0.1\n1.1,abc\n"
    with pytest.raises(ImuLogError, match=r"line 3, column 'motionYaw\(rad\)' is 'abc'"):
        read_sensorlog(_write(tmp_path / "h.csv", text))


def test_time_going_back_names_the_line(tmp_path: Path) -> None:
    text = "motionTimestamp_sinceReboot(s),motionYaw(rad)\n1.0,0.1\n\n2.0,0.2\n1.5,0.3\n"
    with pytest.raises(
        ImuLogError, match=r"line 5, column 'motionTimestamp_sinceReboot\(s\)' goes"
    ) as err:
        read_sensorlog(_write(tmp_path / "i.csv", text))
    assert "(1.5 after 2.0)" in str(err.value)  # plain numbers, not np.float64(...)


def test_bad_logging_time_and_missing_stamp(tmp_path: Path) -> None:
    text = "loggingTime(txt),motionYaw(rad)\n2013-10-03 14:05:11.532 -0700,0.1\nyesterday,0.2\n"
    with pytest.raises(ImuLogError, match=r"line 3, column 'loggingTime\(txt\)' is 'yesterday'"):
        read_sensorlog(_write(tmp_path / "j.csv", text))
    text = "motionTimestamp_sinceReboot(s),motionYaw(rad)\n1.0,0.1\n,0.2\n"
    with pytest.raises(
        ImuLogError, match=r"line 3, column 'motionTimestamp_sinceReboot\(s\)' is empty"
    ):
        read_sensorlog(_write(tmp_path / "k.csv", text))


def test_no_file_and_empty_file(tmp_path: Path) -> None:
    with pytest.raises(ImuLogError, match="no such file"):
        read_sensorlog(tmp_path / "nope.csv")
    with pytest.raises(LogFormatError, match="empty file"):
        read_sensorlog(_write(tmp_path / "empty.csv", ""))


def test_imu_log_checks_its_arrays() -> None:
    with pytest.raises(ImuLogError, match="time does not increase at sample 2"):
        ImuLog(np.array([0.0, 1.0, 1.0]), np.zeros(3))
    with pytest.raises(ImuLogError, match="at least 2"):
        ImuLog(np.array([0.0]), np.zeros(1))
    with pytest.raises(ImuLogError, match="no wall-clock"):
        ImuLog(np.array([0.0, 1.0]), np.zeros(2)).on_wallclock()


def test_writer_needs_a_time_zone(tmp_path: Path) -> None:
    naive = datetime(2020, 1, 1)
    with pytest.raises(ImuLogError, match="time zone"):
        write_sensorlog(tmp_path / "x.csv", [0, 1], [0, 0], [0, 0], start_wallclock=naive)
    write_sensorlog(tmp_path / "y.csv", [0, 1], [0, 0], [0, 0], start_wallclock=datetime.now(UTC))


def test_yaw_timed_by_logging_time_takes_the_gyro_on_the_same_clock(tmp_path: Path) -> None:
    # motionYaw has no own clock here; the gyro's since-reboot clock must not be mixed with it
    text = (
        "loggingTime(txt),motionYaw(rad),gyroTimestamp_sinceReboot(s),gyroRotationZ(rad/s)\n"
        "2020-01-01 00:00:00.000 +0000,0.0,50.0,1.0\n"
        "2020-01-01 00:00:01.000 +0000,1.0,51.0,3.0\n"
    )
    imu = read_sensorlog(_write(tmp_path / "m.csv", text))
    assert imu.time_column == "loggingTime(txt)"
    assert imu.yaw_rate is not None
    np.testing.assert_allclose(imu.yaw_rate, [1.0, 3.0])
    np.testing.assert_allclose(imu.t, [1577836800.0, 1577836801.0])


def test_gyro_only_gets_a_wall_clock_offset(tmp_path: Path) -> None:
    text = (
        "loggingTime(txt),gyroTimestamp_sinceReboot(s),gyroRotationZ(rad/s)\n"
        "2020-01-01 00:00:00.000 +0000,50.0,1.0\n"
        "2020-01-01 00:00:01.000 +0000,51.0,1.0\n"
    )
    imu = read_sensorlog(_write(tmp_path / "n.csv", text))
    assert imu.wallclock_offset == pytest.approx(1577836800.0 - 50.0)
    np.testing.assert_allclose(imu.yaw, [0.0, 1.0])


def test_compass_without_its_clock_is_a_clear_error(tmp_path: Path) -> None:
    text = "gyroTimestamp_sinceReboot(s),locationTrueHeading(°)\n1.0,10\n2.0,20\n"
    with pytest.raises(ImuLogError, match=r"no time column for the heading.*header has: gyro"):
        read_sensorlog(_write(tmp_path / "o.csv", text))


def test_iso_logging_time_short_rows_and_repeated_names(tmp_path: Path) -> None:
    text = (
        "loggingTime(txt),motionYaw(rad),note(txt),note(txt)\n"
        "2019-02-15T11:52:43.379+01:00,0.5,a,b\n"
        "2019-02-15T11:52:43.479+01:00,0.6\n"  # a short row: the rest is empty
        "2019-02-15T11:52:43.579+01:00,0.7,c,d\n"
    )
    imu = read_sensorlog(_write(tmp_path / "p.csv", text))
    # 2019-02-15 10:52:43.379 UTC
    assert imu.t[0] == pytest.approx(1550227963.379, abs=1e-6)
    np.testing.assert_allclose(np.diff(imu.t), [0.1, 0.1], atol=1e-6)
    np.testing.assert_allclose(imu.yaw, [0.5, 0.6, 0.7])


def test_a_row_with_too_many_cells_is_one_line(tmp_path: Path) -> None:
    text = "motionTimestamp_sinceReboot(s),motionYaw(rad)\n1.0,0.1\n2.0,0.2,9,9\n"
    with pytest.raises(ImuLogError, match=r"not a readable CSV table.*line 3") as info:
        read_sensorlog(_write(tmp_path / "q.csv", text))
    assert "\n" not in str(info.value)
