"""OptiOdom reader on the real data: layout, metadata, the README's sanity check."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from odolab.core.errors import LogFormatError
from odolab.io import LogFormat, find_optiodom_runs, find_runs, read_optiodom_run, read_run


def test_square_run_reads_with_metadata(optiodom_dir: Path) -> None:
    path = optiodom_dir / "square" / "231220200029" / "231220200029_run-01.csv"
    run = read_optiodom_run(path)
    assert run.name == "square/231220200029/run-01"
    assert run.kind == "square"
    assert run.meta["side_length"] == 1.7
    p = run.params
    assert p is not None
    assert p.left_wheel_radius == pytest.approx(0.042)  # Di = 0.084 is a diameter
    assert p.track_width == pytest.approx(0.2)
    assert p.ticks_per_rev == pytest.approx(43.7 * 64)
    raw = np.loadtxt(path, delimiter=",")
    np.testing.assert_array_equal(run.dticks_left[1:], raw[1:, 5])  # left is the LAST column
    np.testing.assert_array_equal(run.dticks_right[1:], raw[1:, 4])
    assert run.ground_truth is not None
    np.testing.assert_array_equal(run.ground_truth.x, raw[:, 1])


@pytest.mark.parametrize("nn", ["01", "04"])
def test_square_closes_with_nominal_params(optiodom_dir: Path, nn: str) -> None:
    run = read_optiodom_run(optiodom_dir / "square" / "231220200029" / f"231220200029_run-{nn}.csv")
    end = run.odometry().final
    assert math.hypot(end.x, end.y) < 0.05  # closes within a few cm
    assert abs(abs(end.heading) - 2 * math.pi) < 0.1  # one full turn, either way
    gt = run.ground_truth
    assert gt is not None
    assert np.sign(gt.heading[-1]) == np.sign(end.heading)


def test_find_runs_in_folders(optiodom_dir: Path) -> None:
    runs = find_optiodom_runs(optiodom_dir / "square" / "231220200029")
    assert [p.name for p in runs] == [f"231220200029_run-0{k}.csv" for k in range(1, 7)]
    assert len(find_runs([optiodom_dir / "free"], LogFormat.OPTIODOM)) == 7
    run = read_run(runs[0], LogFormat.OPTIODOM)
    assert len(run) == 1388


def test_bad_optiodom_paths(tmp_path: Path) -> None:
    with pytest.raises(LogFormatError, match="no OptiOdom runs"):
        find_optiodom_runs(tmp_path)
    bad = tmp_path / "foo.csv"
    bad.write_text("1,2,3\n")
    with pytest.raises(LogFormatError, match="not an OptiOdom run file"):
        read_optiodom_run(bad)
    run = tmp_path / "x_run-01.csv"
    # a missing log is named as the log (issue 38, item 13: it was "x_metadata.csv: no such
    # OptiOdom metadata file")
    with pytest.raises(LogFormatError, match=r"x_run-01\.csv: no such OptiOdom run log$"):
        read_optiodom_run(run)
    run.write_text("0,0,0,0,0,0\n0.05,0,0,0,1,1\n")
    with pytest.raises(
        LogFormatError, match=r"x_run-01\.csv: its OptiOdom metadata file x_metadata"
    ):
        read_optiodom_run(run)
    (tmp_path / "x_metadata.csv").write_text("type,diff\nngear,43.7\nencRes,64\nLi,0.2\n")
    with pytest.raises(LogFormatError, match="missing value 1 of key 'Di'"):
        read_optiodom_run(run)


def test_optiodom_time_going_back_names_the_file_line(tmp_path: Path) -> None:
    (tmp_path / "x_metadata.csv").write_text(
        "type,diff\nngear,43.7\nencRes,64\nLi,0.2\nDi,0.084,0.084\n"
    )
    run = tmp_path / "x_run-01.csv"
    # no header: line 3 is the third sample, the one that goes back
    run.write_text("0,0,0,0,0,0\n0.05,0,0,0,1,1\n0.01,0,0,0,1,1\n")
    with pytest.raises(LogFormatError, match=r"x_run-01\.csv: time goes backwards at line 3 "):
        read_optiodom_run(run)
