"""The fleet commands end to end: simulate, odometry over many logs, evaluate, report."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.odometry import integrate
from odolab.core.params import PRESETS
from odolab.io import read_encoder_csv, read_trajectory


def test_simulate_odometry_many_evaluate_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fleet = tmp_path / "fleet"
    argv = ["fleet", "simulate", str(fleet), "--robots", "3", "--days", "3",
            "--runs-per-day", "2", "--seconds", "6", "--seed", "2"]  # fmt: skip
    assert main(argv) == 0
    logs = sorted(p for p in fleet.rglob("*.csv") if not p.stem.endswith("_gt"))
    assert len(logs) == 18
    out = tmp_path / "traj"
    assert main(["odometry", str(fleet / "**" / "run-00*.csv"), "-o", str(out),
                 "--workers", "1"]) == 0  # fmt: skip
    assert "18 of 18 logs" in capsys.readouterr().out
    log = logs[5]
    rel = log.relative_to(fleet)
    enc = read_encoder_csv(log, modulus=32768)
    want = integrate(enc.t, enc.left_ticks, enc.right_ticks, PRESETS["jaguar-lite"])
    got = read_trajectory(out / rel)
    np.testing.assert_array_equal(got.x, want.x)
    np.testing.assert_array_equal(got.heading, want.heading)
    table = tmp_path / "fleet.arrow"
    assert main(["evaluate", str(fleet), "-f", "csv", "-p", "jaguar-lite", "--workers", "1",
                 "--results", str(table)]) == 0  # fmt: skip
    assert main(["fleet", "report", str(table), "-o", str(tmp_path / "rep")]) == 0
    text = capsys.readouterr().out
    assert "robot-03: RECALIBRATE" in text or "robot-03: ok" in text
    assert (tmp_path / "rep" / "fleet.html").is_file()


def test_many_logs_need_an_output_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = tmp_path / "a.csv"
    a.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05,10,12\n")
    assert main(["odometry", str(a), str(a), "-o", str(tmp_path / "x.csv")]) == 1
    assert "must be a folder" in capsys.readouterr().err
    assert main(["odometry", str(tmp_path / "nothing*.csv"), "-o", str(tmp_path)]) == 1
    assert "no file matches this pattern" in capsys.readouterr().err


def test_bad_scheduler_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evaluate", str(tmp_path), "-f", "csv", "--scheduler", "localhost:1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "tcp://HOST:PORT" in err
