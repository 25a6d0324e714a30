"""The report's ground-truth section: summaries of a tracked path and of a calibrate sensor
result (numbers by hand), their one-sentence errors, and `odolab report --ground-truth`."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.cli import main
from odolab.core.errors import LogFormatError
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


PHOTO = (
    "t,x,y,quality\n"
    "2.0,0.0,0.0,0.002\n"
    "2.1,0.3,0.4,0.004\n"  # 0.5 m
    "2.25,0.3,0.4,0.003\n"
)


def _png(path: Path) -> Path:
    """A small real PNG (an overlay stands in for `odolab track-photo --overlay`'s)."""
    import cv2
    import numpy as np

    img = np.zeros((12, 20, 3), dtype=np.uint8)
    img[4:8, 2:18] = 255
    assert cv2.imwrite(str(path), img)
    return path


def test_photo_path_and_overlay_summaries(tmp_path: Path) -> None:
    """`odolab track-photo`'s t,x,y,quality (position only) and its overlay PNG (issue 43: the
    report shows the photo when a run has one); numbers by hand."""
    p = tmp_path / "photo_gt.csv"
    p.write_text(PHOTO)
    g = ground_truth_summary(p)
    rows = dict(g["rows"])
    assert g["title"] == "Read from a long-exposure photo: photo_gt.csv"
    assert rows["rows (start, centre and end of each timed dash)"] == "3"
    assert rows["time"] == "2 to 2.25 s" and rows["path length"] == "0.5 m"
    assert rows["quality, median / worst"] == "3 / 4 mm"
    img = ground_truth_summary(_png(tmp_path / "overlay.png"))
    assert img["title"] == "The photo with the estimated path: overlay.png"
    assert img["image"].startswith("iVBORw0KGgo")  # base64 of the PNG signature
    with pytest.raises(LogFormatError, match=r"photo_bad\.csv: line 3"):
        bad = tmp_path / "photo_bad.csv"
        bad.write_text("t,x,y,quality\n1,0,0,0\n2,x,0,0\n")
        ground_truth_summary(bad)


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
    with raises_worded(LogFormatError, match=re.escape(needle)):
        ground_truth_summary(p)


def test_report_has_the_section(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "lab.sqlite"
    trials = str(tmp_path / "trials.csv")  # not the default, the working folder's trials.csv
    assert main(["sim", "run", "rotation", "--db", str(db), "-o", trials]) == 0
    track, cal = tmp_path / "run_gt.csv", tmp_path / "cal.json"
    track.write_text(TRACK)
    cal.write_text(json.dumps(SENSOR))
    out = tmp_path / "report"
    args = ["report", "--db", str(db), "--out", str(out)]
    photo, overlay = tmp_path / "photo_gt.csv", _png(tmp_path / "overlay.png")
    photo.write_text(PHOTO)
    truths = ["--ground-truth", str(track), "--ground-truth", str(cal)]
    truths += ["--ground-truth", str(photo), "--ground-truth", str(overlay)]
    assert main([*args, *truths]) == 0
    text = html.unescape((out / "report.html").read_text())
    section = text.split("<h2>Ground truth without a motion-capture lab</h2>", 1)[1]
    assert "Tracked by a camera: run_gt.csv" in section
    assert "0.60003 ± 0.00070" in section
    assert "Read from a long-exposure photo: photo_gt.csv" in section
    assert (
        '<figure id="ground-truth-image-4"><img alt="The photo with the estimated path' in section
    )
    # results.json keeps the numbers, not the photo's megabytes
    saved = json.loads((out / "results.json").read_text())["extra"]["ground_truth"]
    assert "image" not in saved[3] and saved[3]["image_base64_chars"] > 0
    # without --ground-truth there is no such section; a wrong file stops before any work
    assert main([*args[:-1], str(tmp_path / "plain")]) == 0
    assert "Ground truth without" not in (tmp_path / "plain" / "report.html").read_text()
    capsys.readouterr()
    assert main([*args[:-1], str(tmp_path / "bad"), "--ground-truth", str(db)]) == 1
    err = capsys.readouterr().err
    assert "lab.sqlite" in err and "Traceback" not in err
    assert not (tmp_path / "bad").exists()
