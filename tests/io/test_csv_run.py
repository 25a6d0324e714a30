"""Encoder-CSV runs, the registry, trajectory files by extension, and bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from odolab.core.errors import LogFormatError
from odolab.core.params import RobotParams
from odolab.core.trajectory import Trajectory
from odolab.io import (
    READERS,
    LogFormat,
    ReadOptions,
    find_runs,
    read_csv_run,
    read_run,
    read_trajectory,
    write_trajectory,
)

PARAMS = RobotParams(
    left_wheel_radius=0.05,
    right_wheel_radius=0.05,
    track_width=0.3,
    ticks_per_rev=100,
    encoder_modulus=1000,
)


def test_every_format_has_a_reader() -> None:
    assert set(READERS) == set(LogFormat)


def test_raw_counters_with_wrap_and_sibling_ground_truth(tmp_path: Path) -> None:
    log = tmp_path / "drive.csv"
    # counters wrap at 1000: 990 -> 10 is +20 counts
    log.write_text("t,left_ticks,right_ticks\n0,990,0\n0.1,10,20\n0.2,30,40\n")
    gt = Trajectory.from_xyh([0, 0.1, 0.2], [0, 0.1, 0.2], [0, 0, 0], [0, 0, 0])
    write_trajectory(tmp_path / "drive_gt.tum", gt, "tum")
    run = read_csv_run(log, ReadOptions(modulus=1000))
    np.testing.assert_array_equal(run.dticks_left, [0, 20, 20])
    np.testing.assert_array_equal(run.dticks_right, [0, 20, 20])
    assert run.ground_truth is not None
    np.testing.assert_allclose(run.ground_truth.x, [0, 0.1, 0.2])
    end = run.odometry(PARAMS).final
    # 40 counts of 2 pi 0.05 / 100 m each
    assert end.x == pytest.approx(40 * 2 * math.pi * 0.05 / 100)
    assert find_runs([tmp_path], LogFormat.CSV) == [log]  # the _gt file is not a run


def test_increments_csv_and_explicit_ground_truth(tmp_path: Path) -> None:
    log = tmp_path / "inc.csv"
    log.write_text("t,dticks_left,dticks_right\n0,0,0\n1,5,7\n2,5,7\n")
    gt_path = write_trajectory(
        tmp_path / "truth.csv", Trajectory.from_xyh([0, 1, 2], [0, 1, 2], [0, 0, 0], [0, 0, 0])
    )
    run = read_run(log, LogFormat.CSV, ReadOptions(ground_truth=str(gt_path)))
    np.testing.assert_array_equal(run.dticks_left, [0, 5, 5])
    np.testing.assert_array_equal(run.dticks_right, [0, 7, 7])
    assert run.ground_truth is not None and len(run.ground_truth) == 3


def test_time_going_backwards_is_one_clear_error(tmp_path: Path) -> None:
    log = tmp_path / "back.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n0.2,1,1\n0.1,2,2\n")
    with pytest.raises(LogFormatError) as err:
        read_run(log, LogFormat.CSV)
    msg = str(err.value)
    assert str(log) in msg and "time goes backwards at line 4" in msg and "(0.1 after 0.2)" in msg


def test_trajectory_by_extension(tmp_path: Path) -> None:
    tr = Trajectory.from_xyh([0, 1, 2], [0, 1, 1], [0, 0, 1], [0, 0.5, 4.0])
    for name in ("a.csv", "a.tum", "a.txt"):
        fmt = "csv" if name.endswith(".csv") else "tum"
        back = read_trajectory(write_trajectory(tmp_path / name, tr, fmt))  # type: ignore[arg-type]
        np.testing.assert_allclose(back.x, tr.x)
        np.testing.assert_allclose(back.theta, tr.theta, atol=1e-12)
    with pytest.raises(LogFormatError, match="no such trajectory file"):
        read_trajectory(tmp_path / "missing.tum")


def test_run_from_arrays_names_a_sample_not_a_line() -> None:
    # a bag or arrays have no lines: the third sample (of 1, 2, 3) goes back
    from odolab.io.run import OdometryRun

    with pytest.raises(LogFormatError, match=r"time goes backwards at sample 3 ") as err:
        OdometryRun(name="r", source="r.bag", t=[0.0, 1.0, 0.5], dticks_left=[0, 1, 1],
                    dticks_right=[0, 1, 1])  # fmt: skip
    assert "line" not in str(err.value)
