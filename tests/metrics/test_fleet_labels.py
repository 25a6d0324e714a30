"""``odolab evaluate`` over many OptiOdom runs (issue 30): whole ids on an 80-column terminal
(they were cut to ``231220200…``), and each session's date read from its id (DDMMYYYYHHMM)
instead of "(no date)"."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.fleet import robot_and_date


def test_optiodom_session_ids_are_dates() -> None:
    run = "data/optiodom/circular/231220200121/231220200121_run-01.csv"
    assert robot_and_date(run) == ("circular", "2020-12-23")
    assert robot_and_date("x/square/250620202104/r.csv") == ("square", "2020-06-25")
    assert robot_and_date("x/square/020120212354/r.csv") == ("square", "2021-01-02")
    # twelve digits that are no DDMMYYYYHHMM date stay a name
    assert robot_and_date("x/y/202012230121/r.csv") == ("202012230121", "")
    assert robot_and_date("logs/robot-01/2026-03-02/run.csv") == ("robot-01", "2026-03-02")


def _session(root: Path, sid: str, runs: int) -> None:
    d = root / "circular" / sid
    d.mkdir(parents=True)
    (d / f"{sid}_metadata.csv").write_text("ngear,43.7\nencRes,64\nLi,0.2\nDi,0.084,0.084\n")
    step = 40 / 2796.8 * 2 * math.pi * 0.042  # metres per 40 ticks (1.1 m a run)
    for k in range(1, runs + 1):
        rows = [
            f"{i * 0.05:.2f},{i * step * 1.01:.9f},0,0,{40 if i else 0},{40 if i else 0}"
            for i in range(300)
        ]
        (d / f"{sid}_run-{k:02d}.csv").write_text("\n".join(rows) + "\n")


def test_evaluate_shows_whole_ids_and_dates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    _session(tmp_path, "231220200121", 11)  # over 20 runs: the fleet tables
    _session(tmp_path, "250620202104", 10)
    assert main(["evaluate", str(tmp_path), "-f", "optiodom", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "…" not in out and "(no date)" not in out
    assert "fleet: 21 runs, per robot" in out
    assert "231220200121_run-" in out and "2020-12-23" in out
    day = next(line for line in out.splitlines() if line.startswith("┃ robot"))
    assert day.split("┃")[2:4] == [" 2020-06-25 ", " 2020-12-23 "]
    row = [line for line in out.splitlines() if line.startswith("│ circular")][1]  # per day
    assert [c.strip()[-4:] for c in row.split("│")[2:4]] == ["(10)", "(11)"]
