"""Window tables (``--format drive``): the DRIVE Husky and small tables written here."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from tests.shared_data import require

from odolab.calibration.lsq import LsqOptions, calibrate_lsq, prepare_run
from odolab.cli import main
from odolab.core.errors import InsufficientDataError, LogFormatError
from odolab.core.params import NoiseParams, RobotParams, save_params
from odolab.io import find_runs, read_run
from odolab.io.registry import detect_format
from odolab.io.run import ReadOptions
from odolab.io.windows import read_window_run, truth_updates, wheel_angles
from odolab.metrics.consistency import choose_nees_piece, nees_of_runs

HEADER = "window,calib_step,t,left_wheel_vel,right_wheel_vel,icp_x,icp_y,icp_yaw,imu_yaw\n"


def _write_table(path: Path, windows: list[tuple[int, int, int]], *, hold: int = 2) -> Path:
    """A table of windows ``(window, step, rows)`` at 20 Hz: window w's wheels at 2 + 0.5 w and
    3 + 0.2 w rad/s (0.1 m radius, 0.5 m track), the truth that motion exactly, held for
    ``hold`` rows at a time."""
    lines = [HEADER]
    for w, step, n in windows:
        t = 0.05 * np.arange(n)
        left, right = 2.0 + 0.5 * w, 3.0 + 0.2 * w
        v, om = 0.1 * (left + right) / 2, 0.1 * (right - left) / 0.5
        held = (np.arange(n) // hold) * hold * 0.05
        x, y, yaw = np.sin(om * held) * v / om, (1 - np.cos(om * held)) * v / om, om * held
        for i in range(n):
            lines.append(
                f"{w},{step},{float(t[i])!r},{left!r},{right!r},{float(x[i])!r},{float(y[i])!r},"
                f"{math.remainder(float(yaw[i]), 2 * math.pi)!r},0.2\n"
            )
    path.write_text("".join(lines))
    return path


def test_held_truth_values_are_one_measurement_and_ticks_are_the_integrated_angle(
    tmp_path: Path,
) -> None:
    table = _write_table(tmp_path / "w.csv", [(0, 0, 40), (1, 1, 40)], hold=2)
    run = read_window_run(f"{table}#window-1", ticks_per_rev=100.0)
    gt = run.ground_truth
    assert gt is not None
    np.testing.assert_allclose(gt.t, 0.05 * np.arange(0, 40, 2))  # every second row is new
    assert run.meta["calib_step"] == 1 and run.meta["truth_updates"] == 20
    # 2.5 rad/s for 1.95 s, in ticks of 100 a turn
    assert float(np.sum(run.dticks_left)) == pytest.approx(2.5 * 1.95 * 100 / (2 * math.pi))
    np.testing.assert_array_equal(truth_updates(*(np.array([0.0, 0, 1, 1, 2]),) * 3), [0, 2, 4])
    np.testing.assert_allclose(
        wheel_angles(np.array([0, 0.5, 1.0]), np.array([0, 2, 2.0])), [0, 0.5, 1.5]
    )
    # the odometry of the table's own robot follows the truth's arc
    p = RobotParams(
        left_wheel_radius=0.1, right_wheel_radius=0.1, track_width=0.5, ticks_per_rev=100.0
    )
    end = run.odometry(p).final
    assert (end.x, end.y) == pytest.approx((gt.x[-1], gt.y[-1]), abs=0.02)  # 0.05 s after it


def test_selectors_split_by_command_step_and_detection_names_the_format(tmp_path: Path) -> None:
    table = _write_table(tmp_path / "w.csv", [(0, 0, 5), (1, 0, 5), (2, 1, 5), (3, 2, 5)])
    assert [p.name for p in find_runs([f"{table}#even"], "drive")] == [
        "w.csv#window-0",
        "w.csv#window-1",
        "w.csv#window-3",
    ]
    assert len(find_runs([f"{table}#odd"], "drive")) == 1
    assert len(find_runs([table], "drive")) == 4
    assert len(find_runs([f"{table}#steps-1-2"], "drive")) == 2
    fmt, why = detect_format([f"{table}#odd"])
    assert fmt == "drive" and "window table" in why


@pytest.mark.parametrize(
    ("body", "selector", "expected"),
    [
        ("window,t\n0,0\n", "", "missing column 'calib_step'"),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n1,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n",
            "",
            "line 4, window 0 starts again",
        ),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,1,0.05,1,1,0,0,0,0\n",
            "",
            "line 3, window 0 changes its calib_step",
        ),
        (HEADER + "0.5,0,0,1,1,0,0,0,0\n", "", "line 2, column 'window' is 0.5"),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n",
            "#window-0",
            "line 4, window 0: time 0.05 s does not advance",
        ),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1e308,1,0,0,0,0\n",
            "#window-0",
            "line 3, window 0: left_wheel_vel is 1e+308; expected at most 1000 rad/s either way",
        ),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,1e308,0,0\n",
            "#window-0",
            "window 0: line 3, position y is 1e+308 m",
        ),
        (
            HEADER + "0,0,1e308,1,1,0,0,0,0\n0,0,1e308,1,1,0,0,0,0\n",
            "#window-0",
            "window 0: time at line 2 is 1e+308 s",
        ),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n",
            "#window-7",
            "no window 7 in the table",
        ),
        (
            HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n",
            "#evens",
            "expected #window-N, #even",
        ),
        (HEADER + "0,0,0,1,1,0,0,0,0\n0,0,0.05,1,1,0,0,0,0\n", "#odd", "selects no window"),
    ],
)
def test_malformed_tables_are_refused_with_the_line(
    tmp_path: Path, body: str, selector: str, expected: str
) -> None:
    table = tmp_path / "bad.csv"
    table.write_text(body)
    with pytest.raises(LogFormatError, match=re.escape(expected)) as err:
        for p in find_runs([f"{table}{selector}"], "drive"):
            read_run(p, "drive")
    assert str(table) in str(err.value)


def test_a_frame_of_windows_fits_as_the_windows_one_by_one(tmp_path: Path) -> None:
    """Joining a table's windows for the fit (one integration) changes no residual."""
    table = _write_table(tmp_path / "w.csv", [(w, w, 30) for w in range(6)], hold=1)
    nominal = RobotParams(
        left_wheel_radius=0.11, right_wheel_radius=0.1, track_width=0.55, ticks_per_rev=100.0
    )
    runs = [
        read_run(p, "drive", ReadOptions(ticks_per_rev=100.0)) for p in find_runs([table], "drive")
    ]
    o = LsqOptions(segment_s=0.7, fit_gt_yaw_offset=False)
    joined = calibrate_lsq(runs, nominal, o)
    alone = calibrate_lsq([replace(prepare_run(r, 0.7), frame="") for r in runs], nominal, o)
    assert joined.rms_before > 0.005  # the nominal's residuals: the same numbers both ways
    assert joined.rms_before == pytest.approx(alone.rms_before, rel=1e-12)
    assert joined.values["left_wheel_radius"] == pytest.approx(0.1, abs=1e-6)
    assert alone.values["left_wheel_radius"] == pytest.approx(0.1, abs=1e-6)
    assert joined.run_sizes == alone.run_sizes == [9] * 6
    shared = calibrate_lsq(runs, nominal, LsqOptions(segment_s=0.7))
    assert len(shared.gt_yaw_offsets) == 1  # one lidar, one offset for every window


def test_nees_skips_runs_shorter_than_a_piece_and_says_how_many(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    table = _write_table(tmp_path / "w.csv", [(0, 0, 80), (1, 1, 20), (2, 2, 80)])
    p = RobotParams(
        left_wheel_radius=0.1,
        right_wheel_radius=0.1,
        track_width=0.5,
        ticks_per_rev=100.0,
        noise=NoiseParams(1e-3, 1e-3),
    )
    runs = [read_run(q, "drive", ReadOptions(params=p)) for q in find_runs([table], "drive")]
    results, skipped, note = nees_of_runs(runs, lambda _r: p, segment_s=2.0)
    assert [r.name for r in results] == ["w/step-0/window-0", "w/step-2/window-2"]
    assert skipped == ["w/step-1/window-1"]
    assert note is not None and note.startswith("1 of 3 runs skipped")
    with pytest.raises(
        InsufficientDataError, match="all 3 runs are shorter than one NEES piece of 9 s"
    ):
        nees_of_runs(runs, lambda _r: p, segment_s=9.0)
    save_params(tmp_path / "p.toml", p)
    argv = ["evaluate", str(table), "-f", "drive", "-p", str(tmp_path / "p.toml"), "--workers", "1"]
    assert main([*argv, "--nees", "--nees-segment", "2"]) == 0
    assert "note: 1 of 3 runs skipped: shorter than one 2 s piece" in capsys.readouterr().out


def test_the_husky_table_reads_as_603_windows_with_only_real_truth_updates() -> None:
    table = require("drive-husky") / "husky_windows.csv"
    paths = find_runs([table], "drive")
    assert len(paths) == 603
    even, odd = find_runs([f"{table}#even"], "drive"), find_runs([f"{table}#odd"], "drive")
    assert len(even) + len(odd) == 603 and not set(even) & set(odd)
    run = read_run(paths[0], "drive")
    gt = run.ground_truth
    assert gt is not None
    assert run.meta["truth_rows"] == 40 and run.meta["truth_updates"] == 19  # about 10 Hz
    steps = np.diff(np.c_[gt.x, gt.y, gt.heading], axis=0)
    assert np.all(np.any(steps != 0, axis=1))  # no held value left


def test_nees_pieces_are_the_longest_where_the_first_order_covariance_holds(
    tmp_path: Path,
) -> None:
    """Issue 38, item 12 (the rule the demo uses): 4 s windows, a small noise: 10 s pieces do
    not exist, 5 s neither, 2 s hold."""
    table = _write_table(tmp_path / "w.csv", [(0, 0, 81), (1, 1, 81)])
    p = RobotParams(
        left_wheel_radius=0.1,
        right_wheel_radius=0.1,
        track_width=0.5,
        ticks_per_rev=100.0,
        noise=NoiseParams(1e-5, 1e-5),
    )
    runs = [read_run(q, "drive", ReadOptions(params=p)) for q in find_runs([table], "drive")]
    length, results, why = choose_nees_piece(runs, p)
    assert length == 2.0 and len(results) == 2
    assert why.startswith("Pieces of 2 s: the longest of 10, 5, 2, 1 s at which at most 10%")
    assert "at 10 s, every run is shorter than a piece; at 5 s, every run is shorter" in why


def test_run_lists_name_a_tables_windows_in_ranges() -> None:
    """calibrate lsq's fitted/held-out lines: every window named, in ranges, not a wall."""
    from odolab.cli.evaluate import _run_list

    paths = [Path(f"w.csv#window-{n}") for n in (0, 1, 2, 6, 8, 9)]
    assert _run_list([*paths[:4], Path("b.csv"), *paths[4:]]) == (
        "w.csv#window-0-2,6,8-9 (6 windows), b.csv"
    )
