"""``odolab validate``: the demo files end to end, the figure and JSON, one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import odolab.cli.validate  # noqa: F401  (registers the command until cli/__init__ imports it)
from odolab.cli import main
from odolab.validation import write_demo


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return write_demo(tmp_path_factory.mktemp("demo"), clock_offset=7217.25)


def test_validate_demo_with_any_offset(
    demo: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    png, out = tmp_path / "fig21.png", tmp_path / "result.json"
    code = main(
        [
            "validate",
            str(demo["encoder_log"]),
            str(demo["imu_log"]),
            "--old",
            "jaguar-lite",
            "--new",
            str(demo["new_params"]),
            "--max-offset",
            "inf",
            "--plot",
            str(png),
            "--json",
            str(out),
        ]
    )
    text = capsys.readouterr().out
    assert code == 0
    assert "clock offset 7217.2" in text
    assert "old (jaguar-lite): RMS heading error" in text
    d = json.loads(out.read_text(encoding="utf-8"))
    assert abs(d["clock_offset_s"] - 7217.25) < 0.01
    assert d["old"]["rms_error_rad"] > 1.0 > 0.1 > d["new"]["rms_error_rad"]
    assert png.stat().st_size > 5000


def test_validate_with_nominal_offset_and_fixed_offset(
    demo: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["validate", str(demo["encoder_log"]), str(demo["imu_log"])]
    new = ["--new", str(demo["new_params"])]
    assert main([*base, *new, "--offset", "7200"]) == 0
    assert "clock offset 7217.2" in capsys.readouterr().out
    assert main([*base, *new, "--offset", "7217.25", "--max-offset", "0"]) == 0
    assert "clock offset 7217.2500 s (phone - robot);" in capsys.readouterr().out


def test_no_overlap_is_one_line_on_stderr(
    demo: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        ["validate", str(demo["encoder_log"]), str(demo["imu_log"]), "--new", "jaguar-lite"]
    )
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "does not overlap" in err and "phone time 7217.250 to" in err
    assert "robot time 0.000 to" in err


def test_bad_imu_file_is_one_line(tmp_path: Path, demo: dict[str, Path], capsys) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.csv"
    bad.write_text("loggingSample(N),foo(x)\n1,2\n", encoding="utf-8")
    code = main(["validate", str(demo["encoder_log"]), str(bad), "--new", "jaguar-lite"])
    err = capsys.readouterr().err
    assert code == 1 and "missing columns" in err and "loggingSample(N), foo(x)" in err
