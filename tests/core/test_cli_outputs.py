"""An output path that is a folder stops with one line (exit 1), never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main


def _gt(tmp_path: Path) -> str:
    p = tmp_path / "gt.csv"
    p.write_text("t,x,y,theta\n0,0,0,0\n1,1,0,0\n2,2,0,0\n")
    return str(p)


def _log(tmp_path: Path) -> str:
    p = tmp_path / "log.csv"
    p.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05,10,12\n0.1,20,24\n")
    return str(p)


@pytest.mark.parametrize(
    "args",
    [
        lambda d: ["odometry", _log(d), "-p", "jaguar-lite", "-o", str(d)],
        lambda d: ["odometry", _log(d), "-p", "jaguar-lite", "--format", "tum", "-o", str(d)],
        lambda d: [
            "calibrate",
            "ratios",
            "-p",
            "jaguar-lite",
            "--distance-ratio",
            "0.9",
            "--rotation-ratio",
            "0.9",
            "-o",
            str(d),
        ],
        lambda d: ["evaluate", _gt(d), _gt(d), "--json", str(d)],
    ],
    ids=["odometry-csv", "odometry-tum", "calibrate-ratios", "evaluate-json"],
)
def test_output_to_a_folder_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: object
) -> None:
    argv = args(tmp_path)  # type: ignore[operator]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("odolab: error: ") and err.count("\n") == 1
    assert str(tmp_path) in err


def test_trials_export_to_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = str(tmp_path / "lab.db")
    assert main(["notebook", "init", "--db", db]) == 0
    capsys.readouterr()
    out = tmp_path / "out"
    out.mkdir()
    assert main(["trials", "export", str(out), "--db", db]) == 1
    err = capsys.readouterr().err
    assert "is a folder" in err and err.count("\n") == 1
