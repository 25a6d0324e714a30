"""``odolab track`` on a synthetic 720p video: speed against real time, accuracy against the
truth, and ``calibrate lsq`` on the tracked truth against the robot's true parameters.

The virtual robot (true radii 0.0850 / 0.0820 m, true track 0.60 m; nominal jaguar-lite) drives
back and forth with turns of both signs and arcs in view of a camera 3.2 m up and 3 m back
(900 px focal length, 1280x720 at 30 fps, blur 0.7 px, noise 2 grey levels, MJPG quality 90).
Printed: tracking frames per second and its ratio to the video's 30 fps (measured here, in the
same run, on the same video: decoding alone is the baseline), position and heading RMS, and the
calibrated parameters' relative errors.

    .venv/bin/python benchmarks/bench_track.py [--keep FOLDER]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from odolab.calibration.lsq import calibrate_lsq
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io.csv_run import read_csv_run
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.run import ReadOptions
from odolab.sim.drives import record_drive
from odolab.sim.physics import TrueParams
from odolab.tracking import CameraModel, FloorMarker
from odolab.tracking.render import look_at, render_video
from odolab.tracking.tracker import TrackOptions, track_video, write_track_csv

TRUE = (0.0850, 0.0820, 0.60)
CAMERA = CameraModel(900.0, 900.0, 640.0, 360.0, 1280, 720)
FLOOR = [
    FloorMarker(i, x, y, yaw, 0.2)
    for i, (x, y, yaw) in enumerate(
        [(-2.2, -1.1, 0.0), (2.2, -1.1, 0.5), (2.2, 1.6, 1.0), (-2.2, 1.6, -0.3), (0.0, -1.4, 0.0)]
    )
]


def legs() -> list[tuple[float, float, float]]:
    """31.4 s: straight lines, half turns in place of both signs, arcs of both signs, reverse."""
    v = 0.3
    half_turn = math.pi / (v / 0.30)
    return [
        (v, v, 4.0), (-v, v, half_turn), (v, v, 4.0), (v, -v, half_turn),
        (0.6 * v, v, 5.0), (v, 0.6 * v, 5.0), (-v, -v, 2.0), (-v, v, half_turn / 2),
        (v, v, 2.0), (v, -v, half_turn / 2),
    ]  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--keep", type=Path, default=None)
    a = ap.parse_args()
    folder = a.keep or Path(tempfile.mkdtemp(prefix="bench_track_"))
    folder.mkdir(parents=True, exist_ok=True)
    nominal = PRESETS["jaguar-lite"]
    rl, rr, b = TRUE
    drive = record_drive(TrueParams(rl, rl, rr, rr, b), nominal, legs())
    tr = drive.truth
    truth = Trajectory.from_xyh(tr.t, tr.x - 1.1, tr.y - 0.6, tr.heading)
    print(
        f"drive {tr.t[-1]:.1f} s, x {truth.x.min():.2f}..{truth.x.max():.2f} m, "
        f"y {truth.y.min():.2f}..{truth.y.max():.2f} m"
    )
    scene = look_at(CAMERA, (0.0, -3.0, 3.2), (0.0, 0.3, 0.0))
    video = folder / "run.avi"
    t0 = time.perf_counter()
    render_video(video, truth, FLOOR, scene, robot_marker=10, marker_size=0.25, marker_height=0.3)
    print(f"rendered {video} in {time.perf_counter() - t0:.1f} s")

    import cv2

    t0 = time.perf_counter()
    cap = cv2.VideoCapture(str(video))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    decode = time.perf_counter() - t0
    t0 = time.perf_counter()
    r = track_video(video, FLOOR, CAMERA, TrackOptions(10, 0.25, 0.3))
    took = time.perf_counter() - t0
    duration = r.frames / r.fps
    print(
        f"{r.frames} frames ({duration:.1f} s of 1280x720 video): decoding alone "
        f"{r.frames / decode:.1f} fps, tracking {r.frames / took:.1f} fps = "
        f"{duration / took:.2f} x real time ({r.skipped} frames skipped)"
    )
    x = np.interp(r.t, truth.t, truth.x)
    y = np.interp(r.t, truth.t, truth.y)
    h = np.interp(r.t, truth.t, truth.heading)
    pos = math.sqrt(np.mean((r.x - x) ** 2 + (r.y - y) ** 2))
    head = math.degrees(math.sqrt(np.mean((r.heading - h) ** 2)))
    print(f"position RMS {pos * 1000:.2f} mm, heading RMS {head:.3f} deg (limits 10 mm, 1 deg)")

    enc = write_encoder_csv(
        folder / "enc.csv", EncoderLog(drive.t, drive.counts_left, drive.counts_right)
    )
    gt = write_track_csv(folder / "enc_gt.csv", r)
    run = read_csv_run(enc, ReadOptions(ground_truth=str(gt)))
    cal = calibrate_lsq([run], nominal)
    for key, true in zip(
        ("left_wheel_radius", "right_wheel_radius", "track_width"), TRUE, strict=True
    ):
        got = getattr(cal.params, key)
        print(
            f"calibrate lsq on the tracked truth: {key} {got:.5f} (true {true:.5f}, nominal "
            f"{getattr(nominal, key):.5f}): error {100 * (got / true - 1):+.3f} %"
        )


if __name__ == "__main__":
    main()
