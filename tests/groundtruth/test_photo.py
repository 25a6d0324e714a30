"""Issue 43: ground truth from one long-exposure photo of a 2 Hz LED, end to end through the
commands docs/ground-truth.md gives: `odolab sim photo` renders the virtual robot's LED (camera
3 m up, tilted 50 deg, 2000x1500, blur, saturation, noise, PNG or JPEG), `odolab track-photo`
reads the dashes, orders and times them on the encoder log, and its `t,x,y,quality` is ground
truth for `evaluate` and `calibrate lsq`."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.io.registry import read_trajectory

PHASE = 0.13  # `sim photo`'s default: the LED's first ON interval starts 0.13 s into the run


def _run(folder: Path, *sim: str, photo: str = "photo.png") -> Path:
    assert main(["sim", "photo", str(folder), *sim]) == 0
    code = main(
        ["track-photo", str(folder / photo), "--floor-points", str(folder / "points.csv"),
         "--led-hz", "2", "--encoders", str(folder / "run.csv"), "-p", "jaguar-lite",
         "-o", str(folder / "run_gt.csv"), "--overlay", str(folder / "overlay.png")]
    )  # fmt: skip
    assert code == 0
    return folder


def _errors(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """Each row's position error (m) against the truth at the row's time, and the rows' t."""
    rows = np.genfromtxt(folder / "run_gt.csv", delimiter=",", names=True)
    truth = read_trajectory(folder / "truth.csv")
    ex = rows["x"] - np.interp(rows["t"], truth.t, truth.x)
    ey = rows["y"] - np.interp(rows["t"], truth.t, truth.y)
    return np.hypot(ex, ey), rows["t"]


@pytest.fixture(scope="module")
def fig2(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _run(tmp_path_factory.mktemp("photo20"))


def test_a_20_s_photo_every_dash_in_order_within_a_centimetre(fig2: Path) -> None:
    err, t = _errors(fig2)
    # 40 dashes (20 s at 2 Hz), three rows each, every one timed
    assert len(t) == 120
    starts = t[0::3]
    # every dash found in order: dash k starts at PHASE + k / 2 Hz on the encoder clock
    # measured: phase found within 1 ms of the truth (stated 1-sigma 4 ms); bound 20 ms
    assert np.max(np.abs(starts - (PHASE + 0.5 * np.arange(40)))) < 0.02
    # measured RMS 4.6 mm, max 7.2 mm (seed 0); the goals 10 mm and 30 mm
    assert math.sqrt(np.mean(err**2)) <= 0.010
    assert err.max() <= 0.030
    assert (fig2 / "overlay.png").stat().st_size > 10_000


def test_jpeg_80_and_sensor_noise(tmp_path: Path) -> None:
    folder = _run(tmp_path, "--jpeg", "80", "--noise", "4", "--seed", "1", photo="photo.jpg")
    err, t = _errors(folder)
    # measured over seeds 0-2: 40 of 40 dashes timed, RMS 4.6-5.3 mm, max 8.1-8.7 mm;
    # bounds: the 90 % of the dashes, 10 mm and 30 mm
    assert len(t) >= 0.9 * 120
    assert math.sqrt(np.mean(err**2)) <= 0.010
    assert err.max() <= 0.030


def test_a_6_s_photo_as_fig_1(tmp_path: Path) -> None:
    folder = _run(tmp_path, "--seconds", "6")
    err, t = _errors(folder)
    assert len(t) == 36  # 12 dashes
    # measured phase 0.131 s (true 0.13, stated 1-sigma 5 ms); bound 20 ms
    assert abs(t[0] - PHASE) < 0.02
    # measured RMS 4.2 mm, max 6.2 mm; the goals 10 mm and 30 mm
    assert math.sqrt(np.mean(err**2)) <= 0.010
    assert err.max() <= 0.030


def test_evaluate_and_calibrate_lsq_take_the_photo_as_ground_truth(fig2: Path) -> None:
    ev = fig2 / "ev.json"
    assert main(["evaluate", str(fig2 / "run.csv"), "-f", "csv", "-p", "jaguar-lite",
                 "--json", str(ev)]) == 0  # fmt: skip
    ape = json.loads(ev.read_text())["runs"][0]["ape"]["rmse"]
    # measured 0.42 m with the nominal parameters (the true track is 7 % wider); bound 0.1 m
    assert ape > 0.1
    out, js = fig2 / "cal.toml", fig2 / "lsq.json"
    assert main(["calibrate", "lsq", str(fig2 / "run.csv"), "-f", "csv", "-p", "jaguar-lite",
                 "-o", str(out), "--json", str(js)]) == 0  # fmt: skip
    got = json.loads(js.read_text())["params"]
    # true radii 0.085 / 0.082 (nominal 0.0835); measured within 0.5 % on this drive; bound 1 %
    assert got["left_wheel_radius"] == pytest.approx(0.085, rel=0.01)
    assert got["right_wheel_radius"] == pytest.approx(0.082, rel=0.01)


def _refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(args) == 1
    return capsys.readouterr().err.replace("\n", " ")


def test_bad_input_gets_one_sentence(
    fig2: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import cv2

    base = ["--encoders", str(fig2 / "run.csv"), "-p", "jaguar-lite", "-o", str(tmp_path / "o.csv")]
    photo = str(fig2 / "photo.png")
    lines = (fig2 / "points.csv").read_text().splitlines()
    three = tmp_path / "three.csv"
    three.write_text("\n".join(lines[:4]) + "\n")
    msg = _refused(["track-photo", photo, "--floor-points", str(three), *base], capsys)
    assert "3 floor points; expected four or more" in msg
    line = tmp_path / "line.csv"
    line.write_text("u,v,x,y\n100,100,0,0\n200,110,1,0\n300,120,2,0\n400,130,3,0\n")
    msg = _refused(["track-photo", photo, "--floor-points", str(line), *base], capsys)
    assert "lie on one line" in msg
    dark = tmp_path / "dark.png"
    cv2.imwrite(str(dark), np.full((300, 400), 20, np.uint8))
    msg = _refused(["track-photo", str(dark), "--floor-points", str(fig2 / "points.csv"), *base],
                   capsys)  # fmt: skip
    assert "no dashes found" in msg
    msg = _refused(
        ["track-photo", photo, "--floor-points", str(fig2 / "points.csv"), "--led-hz", "1", *base],
        capsys,
    )
    assert "40 dashes span" in msg and "expected at most 21 dashes" in msg


def test_position_only_truth_reads_with_the_tangent_as_heading(tmp_path: Path) -> None:
    p = tmp_path / "gt.csv"
    p.write_text("t,x,y,quality\n0,0,0,0.001\n1,1,0,0.001\n2,1,1,0.001\n3,0,1,0.001\n")
    got = read_trajectory(p)
    assert got.heading.tolist() == pytest.approx([0.0, math.pi / 2, math.pi, math.pi])


def test_a_lamp_and_a_missing_dash_are_said_and_the_others_keep_their_times(
    fig2: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import cv2

    from odolab.tracking.photo import floor_homography, read_floor_points

    img = cv2.imread(str(fig2 / "photo.png"), cv2.IMREAD_GRAYSCALE)
    hom = floor_homography(read_floor_points(fig2 / "points.csv"))
    truth = read_trajectory(fig2 / "truth.csv")
    mid = PHASE + 10.0 + 0.125  # the middle of dash 20
    u, v = hom.pixels_from_floor(
        np.array([[np.interp(mid, truth.t, truth.x), np.interp(mid, truth.t, truth.y)]])
    )[0]
    cv2.circle(img, (round(u), round(v)), 16, 25, -1)  # dash 20 painted over with the floor
    cv2.circle(img, (300, 300), 10, 255, -1)  # a lamp
    cv2.imwrite(str(tmp_path / "photo.png"), img)
    code = main(
        ["track-photo", str(tmp_path / "photo.png"), "--floor-points", str(fig2 / "points.csv"),
         "--encoders", str(fig2 / "run.csv"), "-p", "jaguar-lite", "-o", str(tmp_path / "gt.csv")]
    )  # fmt: skip
    assert code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "39 dashes in order" in out
    assert re.search(r"set aside at \((299|30[012]), (299|30[012])\) px: a round spot", out)
    assert "between dashes 19 and 20" in out and "1 ON interval(s) missing" in out
    rows = np.genfromtxt(tmp_path / "gt.csv", delimiter=",", names=True)
    expected = PHASE + 0.5 * np.array([k for k in range(40) if k != 20])
    # measured: every start within 2 ms of its true ON interval; bound 20 ms
    assert np.max(np.abs(rows["t"][0::3] - expected)) < 0.02
