"""CLI commands for ground truth without a motion-capture lab: ``odolab calibrate sensor``
(odometry and a sensor calibrated together), ``odolab track`` (a marker filmed by a camera),
``odolab camera calibrate`` and ``odolab markers`` (what to print), and ``odolab sim video`` (a
synthetic 720p video of the virtual robot to try them on)."""

from __future__ import annotations

import math
import statistics
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.app.groundtruth import OptionError, estimate_time_offset
from odolab.cli._apps import app, calibrate_app, sim_app
from odolab.cli._output import echo
from odolab.cli.options import (
    BAG_JOINT_TOPIC,
    BAG_JOINTS,
    EncodersFormatOpt,
    JointsOpt,
    JointTopicOpt,
    NewParamsOutputOpt,
    NominalParamsOpt,
    RunFormat,
)
from odolab.cli.wording import said
from odolab.core.defaults import DEFAULT_CORNERS

if TYPE_CHECKING:
    from odolab.calibration.sensor import SensorCalibration

__all__ = ["OptionError", "estimate_time_offset"]

camera_app = typer.Typer(
    help="Camera intrinsics for marker tracking.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(camera_app, name="camera")


def _time_offset(text: str) -> float | None:
    """``auto`` -> None; else a finite number of seconds."""
    if text.strip().lower() == "auto":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise OptionError(
            f"--time-offset is {text!r}; expected 'auto' or a number of seconds (sensor clock "
            "minus encoder clock)"
        )
    return value


SensorEncodersOpt = Annotated[Path, typer.Argument(help="Encoder log (any format odolab reads).")]
SensorSensorOpt = Annotated[
    Path | None,
    typer.Argument(
        help="Sensor trajectory: TUM, CSV t,x,y,theta|heading, or a bag (default with "
        "--scan-topic: the ENCODERS bag)."
    ),
]
SensorFmtOpt = Annotated[
    RunFormat | None,
    typer.Option(
        "--format",
        "-f",
        help="Format of the encoder log [default: bag with --scan-topic/--sensor-topic or "
        "a .bag/.mcap/bag folder, else csv].",
    ),
]
SensorJsonOutOpt = Annotated[Path | None, typer.Option("--json", help="Write the result here.")]
SensorTimeOffsetOpt = Annotated[
    str,
    typer.Option(help="Sensor clock minus encoder clock (s), or 'auto' (yaw-rate match)."),
]
SensorMaxOffsetOpt = Annotated[float, typer.Option(help="With auto: search +- this (s).")]
SensorIntervalOpt = Annotated[float, typer.Option(help="Interval between sensor poses (s).")]
SensorMaxOutliersOpt = Annotated[
    float, typer.Option(help="Largest fraction of intervals trimmed as outliers.")
]
SensorSensorTopicOpt = Annotated[
    str | None, typer.Option(help="Bag: the sensor's PoseStamped/Odometry topic.")
]
SensorScanTopicOpt = Annotated[
    str | None,
    typer.Option(help="Bag: a LaserScan topic, matched scan to scan (small_gicp GICP)."),
]
SensorTruthOutOpt = Annotated[
    Path | None,
    typer.Option(
        "--truth-out",
        help="Write the robot centre's path (the sensor's, moved by the calibrated mount, "
        "on the encoder clock): ground truth for calibrate lsq / evaluate.",
    ),
]
SensorScanEveryOpt = Annotated[
    int, typer.Option(min=1, help="With --scan-topic: match every N-th scan (fast scanners).")
]


@calibrate_app.command("sensor")
def calibrate_sensor_cmd(
    encoders: SensorEncodersOpt,
    params: NominalParamsOpt,
    output: NewParamsOutputOpt,
    sensor: SensorSensorOpt = None,
    fmt: SensorFmtOpt = None,
    json_out: SensorJsonOutOpt = None,
    time_offset: SensorTimeOffsetOpt = "0",
    max_offset: SensorMaxOffsetOpt = 30.0,
    interval: SensorIntervalOpt = 0.5,
    max_outliers: SensorMaxOutliersOpt = 0.2,
    sensor_topic: SensorSensorTopicOpt = None,
    scan_topic: SensorScanTopicOpt = None,
    truth_out: SensorTruthOutOpt = None,
    scan_every: SensorScanEveryOpt = 1,
    joint_topic: JointTopicOpt = BAG_JOINT_TOPIC,
    joints: JointsOpt = BAG_JOINTS,
) -> None:
    """Wheel radii, track and the sensor's pose on the robot (Censi et al. 2013), with standard
    errors (the Cramér-Rao bound at the estimate)."""
    from odolab.app.groundtruth import SensorRequest, calibrate_sensor_log
    from odolab.cli._output import write_json

    request = SensorRequest(
        encoders, params, output, sensor, fmt.value if fmt is not None else None,
        _time_offset(time_offset), max_offset, interval, max_outliers, sensor_topic, scan_topic,
        truth_out, scan_every, joint_topic, joints,
    )  # fmt: skip
    outcome = calibrate_sensor_log(
        request, lambda: _check_sensor_outputs(output, params, json_out, truth_out)
    )
    write_json(outcome.result.to_dict(), json_out)
    _print_sensor(outcome.result, output)
    if truth_out is not None:
        echo(f"robot path from the sensor -> {truth_out}")


def _check_sensor_outputs(
    output: Path, params: str, json_out: Path | None, truth_out: Path | None
) -> None:
    from odolab.cli._output import check_not_the_input, check_output_path

    check_output_path(output, "parameters file")
    check_not_the_input(output, params)
    if json_out is not None:
        check_output_path(json_out, "JSON result")
    if truth_out is not None:
        check_output_path(truth_out, "robot trajectory")


def _print_sensor(result: SensorCalibration, output: Path) -> None:
    from rich.console import Console

    from odolab.cli._console import fit_table

    console = Console()
    table = fit_table(
        f"odometry + sensor calibration ({result.intervals} intervals, {result.outliers} "
        f"trimmed) -> {output}",
        "std error (CRB)",
        (
            (key, getattr(result.nominal, key, None), value, result.stderr[key])
            for key, value in result.values.items()
        ),
    )
    console.print(table)
    sx, sy, sth = result.noise_sigma
    console.print(
        f"sensor noise per interval: x {sx:.4f} m, y {sy:.4f} m, theta "
        f"{math.degrees(sth):.3f} deg; time offset {result.time_offset:.3f} s"
    )


def _board(text: str, square: float, marker: float, dictionary: str) -> Any:
    from odolab.tracking.charuco import BoardSpec

    try:
        sx, sy = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise OptionError(f"--board is {text!r}; expected COLSxROWS squares, e.g. 5x7") from None
    return BoardSpec(sx, sy, square, marker, dictionary)


TrackVideoOpt = Annotated[Path, typer.Argument(help="Video of the floor and the robot.")]
TrackFloorOpt = Annotated[Path, typer.Option(help="FLOOR.csv: id,x,y,yaw,size of floor markers.")]
TrackRobotMarkerOpt = Annotated[int, typer.Option(help="Id of the marker on the robot.")]
TrackMarkerSizeOpt = Annotated[float, typer.Option(help="Robot marker's black square side (m).")]
TrackMarkerHeightOpt = Annotated[float, typer.Option(help="Robot marker's height above floor (m).")]
TrackCameraOpt = Annotated[Path, typer.Option(help="CAMERA.toml (odolab camera calibrate).")]
TrackOutputOpt = Annotated[Path, typer.Option("--output", "-o", help="Track CSV to write.")]
TrackMarkerOffsetOpt = Annotated[
    tuple[float, float], typer.Option(help="DX DY: marker centre in the robot frame (m).")
]
#: the ArUco markers and ChArUco board of ``track``, ``markers`` and ``camera calibrate``
DictionaryOpt = Annotated[str, typer.Option(help="ArUco dictionary.")]
BoardSquareOpt = Annotated[float, typer.Option(help="Board square side (m).")]
BoardMarkerOpt = Annotated[float, typer.Option(help="Board marker side (m).")]
TrackEncodersOpt = Annotated[
    Path | None,
    typer.Option(
        help="Encoder log: put t on its clock (offset found from yaw rates) and decide the "
        "whole turns across gaps in the track."
    ),
]
TrackParamsOpt = Annotated[
    str | None, typer.Option("--params", "-p", help="With --encoders: parameters.")
]
TrackMaxOffsetOpt = Annotated[float, typer.Option(help="With --encoders: search +- (s).")]
TrackTimeOffsetOpt = Annotated[
    str,
    typer.Option(
        help="With --encoders: the video's clock minus the encoders' (s), or 'auto' "
        "(yaw-rate match)."
    ),
]
TrackMaxYawRateOpt = Annotated[
    float,
    typer.Option(
        help="The robot's fastest turn (deg/s): frames without the marker for 180 deg / this "
        "or longer start a new heading segment (its whole turns unknown)."
    ),
]
TrackCornersOpt = Annotated[
    str,
    typer.Option(
        help="Corner refinement: contour (edges fitted as lines: steady under motion "
        "blur), subpix (the grey-level saddle) or apriltag (docs/ground-truth.md).",
    ),
]


@app.command("track")
def track_cmd(
    video: TrackVideoOpt,
    floor: TrackFloorOpt,
    robot_marker: TrackRobotMarkerOpt,
    marker_size: TrackMarkerSizeOpt,
    marker_height: TrackMarkerHeightOpt,
    camera: TrackCameraOpt,
    output: TrackOutputOpt,
    marker_offset: TrackMarkerOffsetOpt = (0.0, 0.0),
    dictionary: DictionaryOpt = "DICT_4X4_50",
    encoders: TrackEncodersOpt = None,
    params: TrackParamsOpt = None,
    fmt: EncodersFormatOpt = RunFormat.CSV,
    max_offset: TrackMaxOffsetOpt = 30.0,
    time_offset: TrackTimeOffsetOpt = "auto",
    max_yaw_rate: TrackMaxYawRateOpt = 180.0,
    corners: TrackCornersOpt = DEFAULT_CORNERS,
) -> None:
    """Robot poses from a video: floor markers define the floor, the robot's marker its pose.
    Writes t,x,y,theta,heading,quality,segment (t from 0 at the first frame, or on the encoder
    clock; heading continuous within a segment: a new one starts after the marker was hidden
    long enough for a half turn, unless --encoders bridges it)."""
    from rich.console import Console

    from odolab.app.groundtruth import TrackRequest, track_log
    from odolab.cli._output import check_output_path

    request = TrackRequest(
        video, floor, robot_marker, marker_size, marker_height, camera, output, marker_offset,
        dictionary, encoders, params, fmt.value, max_offset, _time_offset(time_offset),
        max_yaw_rate, corners,
    )  # fmt: skip
    out = track_log(request, lambda: check_output_path(output, "track CSV"))
    result, offset = out.result, out.offset
    console = Console(stderr=True)
    pos = result.camera_pose.position
    console.print(
        f"{video}: {result.frames - result.skipped} of {result.frames} frames tracked "
        f"({result.skipped} without the robot's marker); floor markers seen "
        f"{dict(sorted(result.floor_seen.items()))}; camera at ({pos[0]:.3f}, {pos[1]:.3f}, "
        f"{pos[2]:.3f}) m, floor reprojection {result.camera_pose.reprojection_rms:.2f} px; "
        f"median quality {statistics.median(result.quality.tolist()) * 1000:.1f} mm"
        + (f"; video clock minus encoder clock {offset:.3f} s" if encoders else "")
        + f" -> {output}",
        markup=False,
        highlight=False,
    )
    for note in out.notes:
        console.print(f"note: {said(note)}", markup=False, highlight=False)


@app.command("markers")
def markers_cmd(
    ids: Annotated[list[int] | None, typer.Argument(help="Marker ids to print.")] = None,
    size: Annotated[float, typer.Option(help="Black square side (m).")] = 0.2,
    output: Annotated[Path, typer.Option("--output", "-o", help="Folder.")] = Path("markers"),
    dictionary: DictionaryOpt = "DICT_4X4_50",
    dpi: Annotated[int, typer.Option(help="PNG resolution (print at this, unscaled).")] = 300,
    board: Annotated[
        str | None, typer.Option(help="Also a ChArUco board COLSxROWS (e.g. 5x7).")
    ] = None,
    square: BoardSquareOpt = 0.04,
    board_marker: BoardMarkerOpt = 0.03,
) -> None:
    """Write the markers to print (PNG at --dpi and PDF at true size), and a ChArUco board."""
    from odolab.tracking.markers import write_marker_files

    if not ids and board is None:
        raise OptionError("no marker ids and no --board; expected something to print")
    files = write_marker_files(list(ids or []), size, output, name=dictionary, dpi=dpi)
    if board is not None:
        import cv2

        from odolab.tracking.charuco import board_image

        spec = _board(board, square, board_marker, dictionary)
        path = output / f"charuco_{spec.squares_x}x{spec.squares_y}.png"
        output.mkdir(parents=True, exist_ok=True)
        if not cv2.imwrite(str(path), board_image(spec, dpi)):
            raise OptionError(f"{path}: cannot write the board image")
        files.append(path)
    for f in files:
        echo(str(f))


@camera_app.command("calibrate")
def camera_calibrate_cmd(
    video: Annotated[Path, typer.Argument(help="Video of a ChArUco board.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="CAMERA.toml to write.")],
    board: Annotated[str, typer.Option(help="Board squares COLSxROWS.")] = "5x7",
    square: BoardSquareOpt = 0.04,
    board_marker: BoardMarkerOpt = 0.03,
    dictionary: DictionaryOpt = "DICT_4X4_50",
    step: Annotated[int, typer.Option(help="Use every STEP-th frame.")] = 5,
) -> None:
    """Camera intrinsics and distortion from a ChArUco board video -> CAMERA.toml."""
    from odolab.cli._output import check_output_path
    from odolab.tracking import save_camera
    from odolab.tracking.charuco import calibrate_camera_video

    spec = _board(board, square, board_marker, dictionary)
    check_output_path(output, "camera file")
    result = calibrate_camera_video(video, spec, step=step)
    save_camera(output, result.camera, provenance=result.provenance())
    c = result.camera
    echo(
        f"{video}: {result.views} views of {result.frames} frames, reprojection rms "
        f"{result.rms:.3f} px; fx {c.fx:.1f} fy {c.fy:.1f} cx {c.cx:.1f} cy {c.cy:.1f} px, "
        f"k1 {c.k1:.4f} k2 {c.k2:.4f} -> {output}"
    )


#: ``odolab sim video``: the robot's true parameters (nominal jaguar-lite: 0.0835, 0.0835, 0.56)
SIM_VIDEO_TRUTH = (0.0850, 0.0820, 0.60)


def _sim_video_legs(long: bool) -> list[tuple[float, float, float]]:
    """The drive of ``odolab sim video``: straight lines, turns in place and arcs of both signs
    (11.6 s; ``long``: 31.4 s with half turns and a reverse leg)."""
    v = 0.3
    half_turn = math.pi / (v / 0.30)
    if long:
        return [
            (v, v, 4.0), (-v, v, half_turn), (v, v, 4.0), (v, -v, half_turn),
            (0.6 * v, v, 5.0), (v, 0.6 * v, 5.0), (-v, -v, 2.0), (-v, v, half_turn / 2),
            (v, v, 2.0), (v, -v, half_turn / 2),
        ]  # fmt: skip
    return [
        (v, v, 2.0), (-v, v, half_turn / 2), (0.6 * v, v, 2.5), (v, 0.6 * v, 2.5),
        (v, -v, half_turn / 2), (-v, -v, 1.5),
    ]  # fmt: skip


VideoFolderOpt = Annotated[Path, typer.Argument(help="Folder to write the video and its files in.")]
VideoClockOffsetOpt = Annotated[
    float, typer.Option(help="The encoder log's clock minus the video's (s).")
]
VideoLongOpt = Annotated[bool, typer.Option("--long", help="A 31 s drive instead of 12 s.")]
VideoSeedOpt = Annotated[int, typer.Option(min=0, help="Random seed (image noise).")]


@sim_app.command("video")
def sim_video_cmd(
    folder: VideoFolderOpt,
    clock_offset: VideoClockOffsetOpt = 2.0,
    long: VideoLongOpt = False,
    seed: VideoSeedOpt = 0,
) -> None:
    """Film the virtual robot: a 1280x720, 30 fps MJPG video (blur, noise, JPEG) of it driving
    among five floor markers, with its marker 10 (25 cm, 0.30 m up); writes run.avi, floor.csv,
    camera.toml, the encoder log run.csv and the true path truth.csv (encoder clock)."""
    from odolab.cli._output import term
    from odolab.core.params import PRESETS
    from odolab.core.trajectory import Trajectory
    from odolab.core.trials import EncoderLog
    from odolab.io import write_trajectory_csv
    from odolab.io.encoder_csv import write_encoder_csv
    from odolab.sim.drives import record_drive
    from odolab.sim.physics import TrueParams
    from odolab.tracking import CameraModel, FloorMarker, save_camera, write_floor_csv
    from odolab.tracking.render import look_at, render_video

    if not math.isfinite(clock_offset) or abs(clock_offset) > 30.0:
        raise OptionError(f"--clock-offset is {clock_offset!r}; expected seconds within +-30")
    if folder.exists() and not folder.is_dir():
        raise OptionError(f"{folder} is a file; expected a folder to write the video in")
    folder.mkdir(parents=True, exist_ok=True)
    camera = CameraModel(900.0, 900.0, 640.0, 360.0, 1280, 720)
    floor = [
        FloorMarker(i, x, y, yaw, 0.2)
        for i, (x, y, yaw) in enumerate(
            [(-2.2, -1.1, 0.0), (2.2, -1.1, 0.5), (2.2, 1.6, 1.0), (-2.2, 1.6, -0.3),
             (0.0, -1.4, 0.0)]
        )
    ]  # fmt: skip
    rl, rr, b = SIM_VIDEO_TRUTH
    drive = record_drive(
        TrueParams(rl, rl, rr, rr, b), PRESETS["jaguar-lite"], _sim_video_legs(long)
    )
    tr = drive.truth
    truth = Trajectory.from_xyh(tr.t, tr.x - 1.1, tr.y - 0.6, tr.heading)
    scene = look_at(camera, (0.0, -3.0, 3.2), (0.0, 0.3, 0.0))
    video = render_video(
        folder / "run.avi", truth, floor, scene, robot_marker=10, marker_size=0.25,
        marker_height=0.3, seed=seed,
    )  # fmt: skip
    write_floor_csv(folder / "floor.csv", floor)
    save_camera(folder / "camera.toml", camera)
    write_encoder_csv(
        folder / "run.csv",
        EncoderLog(drive.t + clock_offset, drive.counts_left, drive.counts_right),
    )
    write_trajectory_csv(
        folder / "truth.csv",
        Trajectory.from_xyh(truth.t + clock_offset, truth.x, truth.y, truth.heading),
    )
    echo(
        f"{tr.t[-1]:.1f} s drive -> {term(video)} (1280x720, 30 fps), floor.csv, camera.toml, "
        f"run.csv (encoder clock {clock_offset:+.3f} s from the video's), truth.csv; true "
        f"radii {rl} / {rr} m, track {b} m (robot marker 10, 0.25 m, 0.30 m up)"
    )
