"""The report's ground-truth section: summaries of a tracked path and of a calibrate sensor
result (numbers by hand), their one-sentence errors, and `odolab report --ground-truth`."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.errors import LogFormatError
from odolab.report.ground_truth import ground_truth_summary

TRACK = (
    "t,x,y,theta,heading,quality\n"
    "1.0,0.0,0.0,0.0,0.0,0.001\n"
    "1.1,0.3,0.4,0.0,0.0,0.002\n"  # 0.5 m
    "1.2,0.3,0.4,0.0,0.0,0.003\n"
    "1.5,0.3,1.4,0.0,0.0,0.010\n"  # a gap of three frames; 1 m
)
SENSOR = {
    "method": "Censi et al. 2013",
    "sensor": "drive.mcap /scan",
    "intervals": 94,
    "outliers_trimmed": 1,
    "time_offset_s": 0.25,
    "values": {"track_width": 0.600034, "sensor_yaw": 0.0986},
    "stderr": {"track_width": 0.0007, "sensor_yaw": 0.0011},
}


def test_tracked_path_summary_by_hand(tmp_path: Path) -> None:
    p = tmp_path / "run_gt.csv"
    p.write_text(TRACK)
    rows = dict(ground_truth_summary(p)["rows"])
    assert rows["frames tracked"] == "4"
    assert rows["time"] == "1 to 1.5 s (frame every 0.1 s)"
    assert rows["gaps (frames without the robot's marker)"] == "1"
    assert rows["path length"] == "1.5 m"
    assert rows["marker fit quality, median / worst"] == "2.5 / 10 mm"


def test_sensor_calibration_summary_by_hand(tmp_path: Path) -> None:
    p = tmp_path / "cal.json"
    p.write_text(json.dumps(SENSOR))
    s = ground_truth_summary(p)
    rows = dict(s["rows"])
    assert "calibrated together" in s["title"]
    assert rows["intervals (outliers trimmed)"] == "94 (1)"
    assert rows["time offset (sensor minus encoder clock)"] == "0.25 s"
    assert rows["track width (m)"] == "0.60003 ± 0.00070"
    assert rows["sensor yaw (rad)"] == "0.0986 ± 0.0011"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("t,x,y\n0,0,0\n", "line 1 has no column 'heading'"),
        ("t,x,y,heading,quality\n0,0,0,0,0\n0.1,zero,0,0,0\n", "line 3 is"),
        ('{"values": {"track_width": 0.6}}', "not an 'odolab calibrate sensor --json' result"),
        ("{nope", "not valid JSON"),
    ],
)
def test_bad_files_are_one_sentence(tmp_path: Path, text: str, needle: str) -> None:
    p = tmp_path / "gt.txt"
    p.write_text(text)
    with pytest.raises(LogFormatError, match=re.escape(needle)):
        ground_truth_summary(p)


def test_report_has_the_section(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "lab.sqlite"
    assert main(["sim", "run", "rotation", "--db", str(db)]) == 0
    track, cal = tmp_path / "run_gt.csv", tmp_path / "cal.json"
    track.write_text(TRACK)
    cal.write_text(json.dumps(SENSOR))
    out = tmp_path / "report"
    args = ["report", "--db", str(db), "--out", str(out)]
    assert main([*args, "--ground-truth", str(track), "--ground-truth", str(cal)]) == 0
    text = html.unescape((out / "report.html").read_text())
    section = text.split("<h2>Ground truth without a motion-capture lab</h2>", 1)[1]
    assert "Tracked by a camera: run_gt.csv" in section
    assert "0.60003 ± 0.00070" in section
    # without --ground-truth there is no such section; a wrong file stops before any work
    assert main([*args[:-1], str(tmp_path / "plain")]) == 0
    assert "Ground truth without" not in (tmp_path / "plain" / "report.html").read_text()
    capsys.readouterr()
    assert main([*args[:-1], str(tmp_path / "bad"), "--ground-truth", str(db)]) == 1
    err = capsys.readouterr().err
    assert "lab.sqlite" in err and "Traceback" not in err
    assert not (tmp_path / "bad").exists()
