"""``odolab odometry RUN --format optiodom`` (issue 30): a recorded run of any registry format is
integrated, with the run's own nominal parameters when no --params is given, and says so."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from tests.worded import raises_worded

import shared_data
from odolab.app.odometry import choose_params, resolve_formats
from odolab.cli import main
from odolab.cli.core import LogFormatChoice
from odolab.core.defaults import LogFormat
from odolab.core.errors import OdolabError
from odolab.io import read_trajectory
from odolab.io.registry import READERS


def _optiodom_run(d: Path) -> Path:
    """A straight 1 s drive: 20 ticks a cycle on both wheels, 2796.8 counts/rev, D = 0.084 m."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "1_metadata.csv").write_text(
        "type,diff\nngear,43.7\nencRes,64\nLi,0.2\nDi,0.084,0.084\nN,1\n"
    )
    t = np.arange(21) * 0.05
    rows = [f"{ti:.2f},0,0,0,{20 if i else 0},{20 if i else 0}" for i, ti in enumerate(t)]
    run = d / "1_run-01.csv"
    run.write_text("\n".join(rows) + "\n")
    return run


def test_format_names_come_from_the_registry() -> None:
    assert {c.value for c in LogFormatChoice} == {f.value for f in READERS} | {"tum"}
    assert set(READERS) == set(LogFormat)


def test_optiodom_run_with_its_metadata(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _optiodom_run(tmp_path / "square" / "1")
    out = tmp_path / "traj.csv"
    assert main(["odometry", str(run), "--format", "optiodom", "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"from {tmp_path / 'square' / '1' / '1_metadata.csv'}" in said
    assert "parameters optiodom-1 (wheel radius L/R 0.042/0.042 m, track 0.2 m)" in said
    assert "read by odolab" in said and "the optiodom run's metadata names them" in said
    traj = read_trajectory(out)
    expected = 20 * 20 / 2796.8 * 2 * math.pi * 0.042  # 20 cycles of 20 counts
    assert len(traj) == 21
    assert traj.x[-1] == pytest.approx(expected, rel=1e-12)
    assert abs(traj.y[-1]) < 1e-12


def test_user_params_win_and_tum_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _optiodom_run(tmp_path / "1")
    out = tmp_path / "traj.tum"
    args = ["odometry", str(run), "-f", "optiodom", "-p", "jaguar-lite", "--to", "tum"]
    assert main([*args, "-o", str(out)]) == 0
    assert "from preset jaguar-lite" in capsys.readouterr().out
    assert len(out.read_text().splitlines()) == 21 and not out.read_text().startswith("t,")


def test_refusals_are_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _optiodom_run(tmp_path / "1")
    out = tmp_path / "o.csv"
    assert main(["odometry", str(run), "-f", "optiodom", "--covariance", "-o", str(out)]) == 1
    assert "covariance is propagated for encoder logs only" in capsys.readouterr().err
    assert main(["odometry", str(tmp_path), "-f", "optiodom", "-o", str(out)]) == 1
    assert "integrates one run file at a time" in capsys.readouterr().err
    assert not out.exists()
    with raises_worded(OdolabError, match="--format tum with --to csv"):
        resolve_formats("tum", "csv")
    assert resolve_formats("tum", None) == (LogFormat.CSV, "tum")


def test_real_optiodom_square_closes(tmp_path: Path) -> None:
    root = shared_data.require("optiodom")
    run = sorted((root / "square").glob("*/*_run-01.csv"))[0]
    choice = choose_params([run], None, "optiodom")
    assert choice.by == "log" and choice.source.endswith("_metadata.csv")
    out = tmp_path / "t.csv"
    assert main(["odometry", str(run), "--format", "optiodom", "-o", str(out)]) == 0
    traj = read_trajectory(out)
    gt = np.loadtxt(run, delimiter=",")
    # nominal parameters close a square to within a few cm (the data set's README)
    assert math.hypot(traj.x[-1] - gt[-1, 1], traj.y[-1] - gt[-1, 2]) < 0.05
    assert abs(abs(traj.heading[-1]) - 2 * math.pi) < 0.2
