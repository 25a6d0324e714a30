"""Marker tracking: geometry by hand, a short synthetic 720p video tracked against its truth,
``odolab track`` / ``markers`` / ``camera calibrate`` and their one-sentence errors."""

from __future__ import annotations

import math
import re
import zlib
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.registry import read_trajectory
from odolab.sim.drives import RecordedDrive, record_drive
from odolab.sim.physics import TrueParams
from odolab.tracking import CameraModel, FloorMarker, load_camera, save_camera, write_floor_csv
from odolab.tracking.camera import TrackingError
from odolab.tracking.markers import marker_cells
from odolab.tracking.render import look_at, render_video
from odolab.tracking.tracker import TrackOptions, _square_fit, track_video

CAMERA = CameraModel(900.0, 900.0, 640.0, 360.0, 1280, 720)
FLOOR = [
    FloorMarker(i, x, y, yaw, 0.2)
    for i, (x, y, yaw) in enumerate(
        [(-2.0, -1.0, 0.0), (2.0, -1.0, 0.5), (2.0, 1.5, 1.0), (-2.0, 1.5, -0.3), (0.0, -1.3, 0.0)]
    )
]
ROBOT = TrackOptions(robot_marker=10, marker_size=0.25, marker_height=0.3)


def test_floor_marker_corners_by_hand() -> None:
    m = FloorMarker(1, 1.0, 2.0, math.pi / 2, 0.2)
    # yaw 90 deg: the marker's x axis is the floor's y; top-left (-0.1, 0.1) -> (-0.1, -0.1)
    assert m.corners() == pytest.approx(
        np.array([[0.9, 1.9, 0], [0.9, 2.1, 0], [1.1, 2.1, 0], [1.1, 1.9, 0]])
    )


def test_square_fit_by_hand() -> None:
    h = 0.1
    yaw = 0.4
    c, s = math.cos(yaw), math.sin(yaw)
    model = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
    pts = model @ np.array([[c, s], [-s, c]]) + [3.0, -1.0]
    x, y, got_yaw, rms = _square_fit(pts, 0.2)
    assert (x, y, got_yaw) == pytest.approx((3.0, -1.0, 0.4))
    assert rms == pytest.approx(0.0, abs=1e-12)
    # a square 10 % too big: every corner 0.1 * h * sqrt(2) off
    _, _, _, rms = _square_fit(pts * 1.1 - np.array([3.0, -1.0]) * 0.1, 0.2)
    assert rms == pytest.approx(0.1 * h * math.sqrt(2))


@pytest.fixture(scope="module")
def drive() -> RecordedDrive:
    legs = [(0.3, 0.3, 1.0), (-0.3, 0.3, 0.6), (0.2, 0.3, 0.6)]
    d = record_drive(TrueParams(0.085, 0.085, 0.082, 0.082, 0.6), PRESETS["jaguar-lite"], legs)
    return d


def _truth(d: RecordedDrive, delay: float = 0.0) -> Trajectory:
    tr = d.truth
    return Trajectory.from_xyh(tr.t + delay, tr.x - 0.8, tr.y - 0.4, tr.heading + 0.2)


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory, drive: RecordedDrive) -> Path:
    out = tmp_path_factory.mktemp("video") / "run.avi"
    scene = look_at(CAMERA, (0.0, -3.0, 3.2), (0.0, 0.3, 0.0))
    return render_video(
        out, _truth(drive), FLOOR, scene, robot_marker=10, marker_size=0.25, marker_height=0.3
    )


def test_tracked_poses_match_the_truth(video: Path, drive: RecordedDrive) -> None:
    r = track_video(video, FLOOR, CAMERA, ROBOT)
    truth = _truth(drive)
    assert r.frames == 67  # 2.2 s at 30 fps, both ends
    assert r.skipped == 0
    assert r.t[1] == pytest.approx(1 / 30)
    # the camera stands where the scene put it
    assert r.camera_pose.position == pytest.approx([0.0, -3.0, 3.2], abs=0.02)
    x = np.interp(r.t, truth.t, truth.x)
    y = np.interp(r.t, truth.t, truth.y)
    h = np.interp(r.t, truth.t, truth.heading)
    assert math.sqrt(np.mean((r.x - x) ** 2 + (r.y - y) ** 2)) <= 0.01
    assert math.degrees(math.sqrt(np.mean((r.heading - h) ** 2))) <= 1.0
    assert np.median(r.quality) < 0.005


def test_a_wrong_height_shows_in_position(video: Path, drive: RecordedDrive) -> None:
    r = track_video(video, FLOOR, CAMERA, TrackOptions(10, 0.25, 0.0))
    truth = _truth(drive)
    x = np.interp(r.t, truth.t, truth.x)
    # the marker seen on the floor instead of 0.3 m up: moved away from the camera by metres
    assert np.mean(np.abs(r.x - x)) > 0.02


def test_cli_track_writes_a_trajectory_on_the_encoder_clock(
    tmp_path: Path, video: Path, drive: RecordedDrive
) -> None:
    cam = save_camera(tmp_path / "camera.toml", CAMERA)
    floor = write_floor_csv(tmp_path / "floor.csv", FLOOR)
    # an encoder log whose clock reads 1.5 s more than the video's
    enc = write_encoder_csv(
        tmp_path / "enc.csv", EncoderLog(drive.t + 1.5, drive.counts_left, drive.counts_right)
    )
    out = tmp_path / "truth.csv"
    code = main(
        ["track", str(video), "--floor", str(floor), "--robot-marker", "10", "--marker-size",
         "0.25", "--marker-height", "0.3", "--camera", str(cam), "-o", str(out),
         "--encoders", str(enc), "-p", "jaguar-lite", "--max-offset", "3"]
    )  # fmt: skip
    assert code == 0
    header = out.read_text().splitlines()[0]
    assert header == "t,x,y,theta,heading,quality,segment"
    traj = read_trajectory(out)
    assert traj.t[0] == pytest.approx(1.5, abs=0.05)
    truth = _truth(drive, delay=1.5)
    assert np.interp(traj.t, truth.t, truth.x) == pytest.approx(traj.x, abs=0.01)


def test_markers_print_and_read_back(tmp_path: Path) -> None:
    import cv2

    assert main(["markers", "3", "17", "--size", "0.1", "--dpi", "150", "-o", str(tmp_path)]) == 0
    assert (tmp_path / "marker_17.pdf").stat().st_size > 500
    img = cv2.imread(str(tmp_path / "marker_17.png"), cv2.IMREAD_GRAYSCALE)
    # the black square is 0.1 m at 150 dpi, the quiet zone one bit (1/6 of it) each side
    assert img.shape[0] == round(0.1 / 0.0254 * 150) + 2 * round(0.1 / 0.0254 * 150 / 6)
    # the PDF draws the marker's cells as vector squares at true size (no raster to resample):
    # one closed square per black cell, each a sixth of the 0.1 m black square, at its cell's
    # place (row 0 at the top, as in the PNG; the quiet zone one cell wide all round)
    pdf = (tmp_path / "marker_17.pdf").read_bytes()
    assert b"/Subtype /Image" not in pdf
    pages = [zlib.decompress(m) for m in re.findall(rb"stream\r?\n(.*?)endstream", pdf, re.S)]
    page = next(p for p in pages if b" re W n" in p)  # the axes' clip, then the marker
    clip, marker = page.split(b" re W n", 1)
    ax_x, ax_y, ax_w, ax_h = map(float, clip.rsplit(b"q ", 1)[1].split())
    number = rb"(-?[\d.]+)"
    squares = re.findall(
        rb" ".join([number] * 2) + rb" m\n" + rb" l\n".join([rb" ".join([number] * 2)] * 3), marker
    )
    cells = marker_cells(17)
    cell_pt = 0.1 / 0.0254 * 72 / 6
    assert ax_w == pytest.approx(cell_pt * (cells.shape[0] + 2)) and ax_h == pytest.approx(ax_w)
    drawn = set()
    for q in squares:
        xs, ys = [float(v) for v in q[0::2]], [float(v) for v in q[1::2]]
        assert (max(xs) - min(xs), max(ys) - min(ys)) == pytest.approx((cell_pt, cell_pt))
        col = round((min(xs) - ax_x) / cell_pt) - 1
        row = round((ax_y + ax_h - max(ys)) / cell_pt) - 1
        drawn.add((row, col))
    assert len(squares) == len(drawn) == int(cells.sum())
    assert drawn == {(int(r), int(c)) for r, c in zip(*np.nonzero(cells), strict=True)}
    det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    _, ids, _ = det.detectMarkers(img)
    assert ids is not None and ids.reshape(-1).tolist() == [17]


def test_camera_calibrate_from_a_board_video(tmp_path: Path) -> None:
    import cv2

    from odolab.tracking.charuco import BoardSpec, board_image
    from odolab.tracking.render import _paste

    spec = BoardSpec(5, 7, 0.04, 0.03)
    board = board_image(spec, dpi=200)
    side = (spec.squares_x + 2) * 0.04, (spec.squares_y + 2) * 0.04  # with the margin
    true = CameraModel(820.0, 820.0, 650.0, 350.0, 1280, 720)
    path = tmp_path / "board.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 10, (1280, 720))
    rng = np.random.default_rng(2)
    for k in range(16):
        # the board on the floor, the camera above it from varied places, looking at it
        eye = (rng.uniform(-0.25, 0.25), rng.uniform(-0.25, 0.25), rng.uniform(0.35, 0.6))
        aim = (rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), 0.0)
        scene = look_at(true, eye, aim)
        w, h = side
        corners = np.array([[-w / 2, h / 2, 0], [w / 2, h / 2, 0], [w / 2, -h / 2, 0],
                            [-w / 2, -h / 2, 0]])  # fmt: skip
        frame = np.full((720, 1280), 128, np.uint8)
        _paste(frame, board, scene.project(corners))
        writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
        assert k >= 0
    writer.release()
    out = tmp_path / "camera.toml"
    code = main(["camera", "calibrate", str(path), "-o", str(out), "--board", "5x7", "--step", "1"])
    assert code == 0
    cam = load_camera(out)
    assert cam.fx == pytest.approx(820.0, rel=0.02)
    assert cam.fy == pytest.approx(820.0, rel=0.02)
    assert (cam.width, cam.height) == (1280, 720)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[camera]\nfx = 900\n", "missing key 'fy' in [camera]"),
        ("[camera]\nfx=1\nfy=1\ncx=1\ncy=1\nwidth=10\nheight=10\nk4=0\n", "unknown key 'k4'"),
        ("[camera]\nfx=-1\nfy=1\ncx=1\ncy=1\nwidth=10\nheight=10\n", "camera fx is -1.0"),
        ("fx = ", "not valid TOML"),
    ],
)
def test_bad_camera_file_is_one_sentence(tmp_path: Path, text: str, needle: str) -> None:
    p = tmp_path / "camera.toml"
    p.write_text(text)
    with pytest.raises(TrackingError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        load_camera(p)


def test_cli_track_errors_name_the_problem(
    tmp_path: Path, video: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cam = save_camera(tmp_path / "camera.toml", CAMERA)
    floor = tmp_path / "floor.csv"
    floor.write_text("id,x,y,yaw,size\n0,0,0,0,0.2\n0,1,1,0,0.2\n")
    base = ["track", str(video), "--floor", str(floor), "--robot-marker", "10", "--marker-size",
            "0.25", "--marker-height", "0.3", "--camera", str(cam), "-o", str(tmp_path / "o.csv")]  # fmt: skip
    assert main(base) == 1
    assert "line 3, marker 0 is also on line 2" in capsys.readouterr().err
    write_floor_csv(floor, FLOOR)
    assert main([*base, "--dictionary", "DICT_9X9_1"]) == 1
    assert "unknown marker dictionary 'DICT_9X9_1'" in capsys.readouterr().err
    assert main([*base[:7], "-1", *base[8:]]) == 1
    err = capsys.readouterr().err
    assert "--marker-size is -1.0" in err
    assert err.count("\n") == 1
    small = save_camera(tmp_path / "small.toml", CameraModel(900, 900, 320, 240, 640, 480))
    assert main([*base[:11], str(small), *base[12:]]) == 1
    assert "frames are 1280x720 px but the camera file is for 640x480" in capsys.readouterr().err
