"""CLI commands for ground truth without a motion-capture lab: ``odolab calibrate sensor``
(odometry and a sensor calibrated together), ``odolab track`` (a marker filmed by a camera),
``odolab camera calibrate`` and ``odolab markers`` (what to print), and ``odolab sim video`` (a
synthetic 720p video of the virtual robot to try them on)."""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app, sim_app
from odolab.cli._output import echo
from odolab.cli.wording import said
from odolab.defaults import DEFAULT_CORNERS
from odolab.errors import OdolabError

if TYPE_CHECKING:
    from odolab.calibration.sensor import SensorCalibration
    from odolab.tracking.tracker import GapBridge
    from odolab.trajectory import Trajectory

__all__: list[str] = []

camera_app = typer.Typer(
    help="Camera intrinsics for marker tracking.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(camera_app, name="camera")


class EncoderFormat(StrEnum):
    csv = "csv"
    optiodom = "optiodom"
    bag = "bag"
    drive = "drive"


class OptionError(OdolabError):
    """A command-line option that does not make sense."""


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


def estimate_time_offset(
    enc_t: Any,
    enc_heading: Any,
    sensor: Trajectory,
    source: str,
    max_offset: float,
    gaps: Sequence[tuple[float, float]] = (),
) -> float:
    """Sensor-minus-encoder clock offset by cross-correlating yaw rates, as ``validate`` does
    for a phone's IMU (:func:`odolab.validation.align.find_clock_offset`); ``gaps``: intervals
    of the sensor's clock where its rate is unknown, left out."""
    from odolab.errors import ImuLogError
    from odolab.validation.align import find_clock_offset
    from odolab.validation.sensorlog import ImuLog

    keep = sensor.t > sensor.t[0]
    keep[0] = True
    keep[1:] &= sensor.t[1:] > sensor.t[:-1]
    imu = ImuLog(sensor.t[keep], sensor.heading[keep], None, source=source)
    try:
        return find_clock_offset(
            enc_t, enc_heading, imu, max_offset=max_offset, gaps=gaps
        ).clock_offset
    except ImuLogError as err:  # worded for a phone's IMU and `validate`'s options: reword
        raise OptionError(_offset_sentence(str(err), source, max_offset)) from err


def _offset_sentence(text: str, source: str, max_offset: float) -> str:
    """``find_clock_offset``'s refusal in the words of ``track`` and ``calibrate sensor`` (no IMU,
    no --flip-imu or --offset there)."""
    import re

    if "sign reversed" in text:
        numbers = re.search(r"\(correlation [^)]*\)", text)
        return (
            f"{source}: its yaw rate matches the encoders' best with the sign reversed "
            f"{numbers.group(0) if numbers else ''}; expected both to turn the same way (check "
            "that the video is not mirrored and that the encoder log's left and right wheels "
            "are not swapped), or give the clock offset with --time-offset"
        ).replace("  ", " ")
    if "any rotation" in text:
        return (
            f"{source}: neither it nor the encoder log shows any rotation to line the clocks up "
            "with; expected a drive with turns, or give the clock offset with --time-offset"
        )
    if "does not overlap" in text:
        return (
            f"{source}: it does not overlap the encoder log in time for any clock offset within "
            f"+-{max_offset:g} s; expected the log of the same drive, a larger --max-offset, "
            "or the clock offset with --time-offset"
        )
    return text


@calibrate_app.command("sensor")
def calibrate_sensor_cmd(
    encoders: Annotated[Path, typer.Argument(help="Encoder log (any format odolab reads).")],
    params: Annotated[
        str, typer.Option("--params", "-p", help="Nominal parameters TOML or preset.")
    ],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    sensor: Annotated[
        Path | None,
        typer.Argument(
            help="Sensor trajectory: TUM, CSV t,x,y,theta|heading, or a bag (default with "
            "--scan-topic: the ENCODERS bag)."
        ),
    ] = None,
    fmt: Annotated[
        EncoderFormat | None,
        typer.Option(
            "--format",
            "-f",
            help="Format of the encoder log [default: bag with --scan-topic/--sensor-topic or "
            "a .bag/.mcap/bag folder, else csv].",
        ),
    ] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the result here.")] = None,
    time_offset: Annotated[
        str,
        typer.Option(help="Sensor clock minus encoder clock (s), or 'auto' (yaw-rate match)."),
    ] = "0",
    max_offset: Annotated[float, typer.Option(help="With auto: search +- this (s).")] = 30.0,
    interval: Annotated[float, typer.Option(help="Interval between sensor poses (s).")] = 0.5,
    max_outliers: Annotated[
        float, typer.Option(help="Largest fraction of intervals trimmed as outliers.")
    ] = 0.2,
    sensor_topic: Annotated[
        str | None, typer.Option(help="Bag: the sensor's PoseStamped/Odometry topic.")
    ] = None,
    scan_topic: Annotated[
        str | None,
        typer.Option(help="Bag: a LaserScan topic, matched scan to scan (small_gicp GICP)."),
    ] = None,
    truth_out: Annotated[
        Path | None,
        typer.Option(
            "--truth-out",
            help="Write the robot centre's path (the sensor's, moved by the calibrated mount, "
            "on the encoder clock): ground truth for calibrate lsq / evaluate.",
        ),
    ] = None,
    scan_every: Annotated[
        int, typer.Option(min=1, help="With --scan-topic: match every N-th scan (fast scanners).")
    ] = 1,
    joint_topic: Annotated[str, typer.Option(help="Bag: JointState topic.")] = "/joint_states",
    joints: Annotated[tuple[str, str], typer.Option(help="Bag: LEFT RIGHT joint names.")] = (
        "left_wheel_joint",
        "right_wheel_joint",
    ),
) -> None:
    """Wheel radii, track and the sensor's pose on the robot (Censi et al. 2013), with standard
    errors (the Cramér-Rao bound at the estimate)."""
    from odolab.calibration.sensor import (
        SensorOptions,
        calibrate_sensor,
        motions_from_trajectory,
        read_sensor_trajectory,
        wheel_angles,
    )
    from odolab.cli._output import check_not_the_input, check_output_path
    from odolab.cli.evaluate import _write_json
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions
    from odolab.params import load_params, save_params

    offset = _time_offset(time_offset)
    if not (math.isfinite(interval) and interval >= 0):
        raise OptionError(f"--interval is {interval!r}; expected a number of seconds >= 0")
    if not (math.isfinite(max_offset) and max_offset > 0):
        raise OptionError(f"--max-offset is {max_offset!r}; expected a positive number of seconds")
    options = SensorOptions(max_outliers=max_outliers)
    nominal = load_params(params)
    check_output_path(output, "parameters file")
    check_not_the_input(output, params)
    if json_out is not None:
        check_output_path(json_out, "JSON result")
    if truth_out is not None:
        check_output_path(truth_out, "robot trajectory")
    ro = ReadOptions(
        modulus=nominal.encoder_modulus,
        joint_topic=joint_topic,
        joint_names=joints,
        ticks_per_rev=nominal.ticks_per_rev,
    )
    if fmt is None:
        # the scans come from the ENCODERS bag when no SENSOR is given
        is_bag = (scan_topic is not None and sensor is None) or encoders.is_dir()
        is_bag = is_bag or encoders.suffix.lower() in (".bag", ".mcap", ".db3")
        fmt = EncoderFormat.bag if is_bag else EncoderFormat.csv
    if scan_topic is not None and sensor_topic is not None:
        raise OptionError("give --scan-topic or --sensor-topic, not both")
    run = read_run(encoders, fmt.value, ro)
    if scan_topic is not None:
        from odolab.calibration.scanmatch import scan_motions
        from odolab.io.scans import read_scans

        source = sensor or encoders
        traj = scan_motions(read_scans(source, scan_topic), every=scan_every).trajectory
    elif sensor is None:
        raise OptionError("no SENSOR file and no --scan-topic; expected the sensor's motion")
    else:
        traj = read_sensor_trajectory(sensor, sensor_topic)
    pl, pr = wheel_angles(run.dticks_left, run.dticks_right, nominal.ticks_per_rev)
    where = f"{sensor or encoders}" + (f" {scan_topic}" if scan_topic else "")
    if offset is None:
        odo = run.odometry(nominal)
        offset = estimate_time_offset(run.t, odo.heading, traj, where, max_offset)
    data = motions_from_trajectory(
        run.t, pl, pr, traj, interval_s=interval, time_offset=offset, source=where
    )
    result = calibrate_sensor(data, nominal, options, time_offset=offset)
    save_params(output, result.params, provenance=result.provenance())
    _write_json(result.to_dict(), json_out)
    _print_sensor(result, output)
    if truth_out is not None:
        from odolab.calibration.sensor import robot_trajectory
        from odolab.io import write_trajectory_csv

        v = result.values
        mount = (v["sensor_x"], v["sensor_y"], v["sensor_yaw"])
        write_trajectory_csv(truth_out, robot_trajectory(traj, mount, offset))
        echo(f"robot path from the sensor -> {truth_out}")


def _print_sensor(result: SensorCalibration, output: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    table = Table(
        title=f"odometry + sensor calibration ({result.intervals} intervals, "
        f"{result.outliers} trimmed) -> {output}"
    )
    for col in ("parameter", "nominal", "calibrated", "std error (CRB)"):
        table.add_column(col, justify="right")
    for key, value in result.values.items():
        nominal = getattr(result.nominal, key, None)
        table.add_row(
            key,
            f"{nominal:.6f}" if nominal is not None else "-",
            f"{value:.6f}",
            f"{result.stderr[key]:.2e}",
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


@app.command("track")
def track_cmd(
    video: Annotated[Path, typer.Argument(help="Video of the floor and the robot.")],
    floor: Annotated[Path, typer.Option(help="FLOOR.csv: id,x,y,yaw,size of floor markers.")],
    robot_marker: Annotated[int, typer.Option(help="Id of the marker on the robot.")],
    marker_size: Annotated[float, typer.Option(help="Robot marker's black square side (m).")],
    marker_height: Annotated[float, typer.Option(help="Robot marker's height above floor (m).")],
    camera: Annotated[Path, typer.Option(help="CAMERA.toml (odolab camera calibrate).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Track CSV to write.")],
    marker_offset: Annotated[
        tuple[float, float], typer.Option(help="DX DY: marker centre in the robot frame (m).")
    ] = (0.0, 0.0),
    dictionary: Annotated[str, typer.Option(help="ArUco dictionary.")] = "DICT_4X4_50",
    encoders: Annotated[
        Path | None,
        typer.Option(
            help="Encoder log: put t on its clock (offset found from yaw rates) and decide the "
            "whole turns across gaps in the track."
        ),
    ] = None,
    params: Annotated[
        str | None, typer.Option("--params", "-p", help="With --encoders: parameters.")
    ] = None,
    fmt: Annotated[
        EncoderFormat, typer.Option("--format", "-f", help="Format of --encoders.")
    ] = EncoderFormat.csv,
    max_offset: Annotated[float, typer.Option(help="With --encoders: search +- (s).")] = 30.0,
    time_offset: Annotated[
        str,
        typer.Option(
            help="With --encoders: the video's clock minus the encoders' (s), or 'auto' "
            "(yaw-rate match)."
        ),
    ] = "auto",
    max_yaw_rate: Annotated[
        float,
        typer.Option(
            help="The robot's fastest turn (deg/s): frames without the marker for 180 deg / this "
            "or longer start a new heading segment (its whole turns unknown)."
        ),
    ] = 180.0,
    corners: Annotated[
        str,
        typer.Option(
            help="Corner refinement: contour (edges fitted as lines: steady under motion "
            "blur), subpix (the grey-level saddle) or apriltag (docs/ground-truth.md).",
        ),
    ] = DEFAULT_CORNERS,
) -> None:
    """Robot poses from a video: floor markers define the floor, the robot's marker its pose.
    Writes t,x,y,theta,heading,quality,segment (t from 0 at the first frame, or on the encoder
    clock; heading continuous within a segment: a new one starts after the marker was hidden
    long enough for a half turn, unless --encoders bridges it)."""
    from rich.console import Console

    from odolab.cli._output import check_output_path
    from odolab.tracking import load_camera, read_floor_csv
    from odolab.tracking.tracker import TrackOptions, bridge_gaps, track_video, write_track_csv

    if not (math.isfinite(max_yaw_rate) and max_yaw_rate > 0):
        raise OptionError(
            f"--max-yaw-rate is {max_yaw_rate!r}; expected the robot's fastest turn in deg/s, "
            "a positive number"
        )
    options = TrackOptions(
        robot_marker, marker_size, marker_height, marker_offset, dictionary,
        max_yaw_rate=math.radians(max_yaw_rate), corners=corners,
    )  # fmt: skip
    if encoders is not None and params is None:
        raise OptionError("--encoders needs --params (the robot's nominal parameters)")
    if not (math.isfinite(max_offset) and max_offset > 0):
        raise OptionError(f"--max-offset is {max_offset!r}; expected a positive number of seconds")
    given_offset = _time_offset(time_offset)
    if given_offset is not None and encoders is None:
        raise OptionError("--time-offset needs --encoders (the log whose clock it is)")
    cam = load_camera(camera)
    markers = read_floor_csv(floor)
    from odolab.tracking.markers import get_dictionary

    get_dictionary(dictionary)
    check_output_path(output, "track CSV")
    result = track_video(video, markers, cam, options)
    offset = 0.0
    console = Console(stderr=True)
    notes: list[str] = []
    bridges: list[GapBridge] = []
    if encoders is not None and params is not None:
        from odolab.io.registry import read_run
        from odolab.io.run import ReadOptions
        from odolab.params import load_params
        from odolab.trajectory import Trajectory

        nominal = load_params(params)
        run = read_run(
            encoders,
            fmt.value,
            ReadOptions(modulus=nominal.encoder_modulus, ticks_per_rev=nominal.ticks_per_rev),
        )
        odo = run.odometry(nominal)
        if given_offset is None:
            # the yaw rate across a gap is unknown: left out of the search (taken as zero
            # there, it moved the offset by up to a frame, more with the better corners)
            seen = Trajectory.from_xyh(result.t, result.x, result.y, result.heading_without_gaps())
            unknown = [(g.t_before, g.t_after) for g in result.gaps]
            offset = estimate_time_offset(run.t, odo.heading, seen, str(video), max_offset, unknown)
        else:
            offset = given_offset
        result, bridges = bridge_gaps(result, run.t, odo.heading, offset)
        for br in bridges:
            g = br.gap
            where = f"{g.seconds:.2f} s without the marker at {g.t_before - offset:.2f} s"
            if br.bridged:
                notes.append(
                    f"{where}: bridged with the encoders, turned {math.degrees(br.change):+.1f} "
                    f"deg (encoders {math.degrees(br.reference):+.1f} deg)"
                )
    for g in result.gaps:  # the gaps left: no encoders, outside their log, or no candidate near
        bridge = next((br for br in bridges if br.gap == g), None)
        why = (
            "give --encoders to bridge it"
            if encoders is None
            else "the encoder log does not cover it"
            if bridge is None
            else f"the encoders' turn {math.degrees(bridge.reference):+.1f} deg is far from every "
            "whole-turn candidate"
        )
        notes.append(
            f"{g.seconds:.2f} s without the marker at {g.t_before - offset:.2f} s: the robot may "
            f"have turned half a turn or more (--max-yaw-rate {max_yaw_rate:g} deg/s); segment "
            f"{int(result.segments[g.index])} starts there, its heading's whole turns unknown "
            f"({why})"
        )
    write_track_csv(output, result, offset)
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
    for note in notes:
        console.print(f"note: {said(note)}", markup=False, highlight=False)


@app.command("markers")
def markers_cmd(
    ids: Annotated[list[int] | None, typer.Argument(help="Marker ids to print.")] = None,
    size: Annotated[float, typer.Option(help="Black square side (m).")] = 0.2,
    output: Annotated[Path, typer.Option("--output", "-o", help="Folder.")] = Path("markers"),
    dictionary: Annotated[str, typer.Option(help="ArUco dictionary.")] = "DICT_4X4_50",
    dpi: Annotated[int, typer.Option(help="PNG resolution (print at this, unscaled).")] = 300,
    board: Annotated[
        str | None, typer.Option(help="Also a ChArUco board COLSxROWS (e.g. 5x7).")
    ] = None,
    square: Annotated[float, typer.Option(help="Board square side (m).")] = 0.04,
    board_marker: Annotated[float, typer.Option(help="Board marker side (m).")] = 0.03,
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
    square: Annotated[float, typer.Option(help="Board square side (m).")] = 0.04,
    board_marker: Annotated[float, typer.Option(help="Board marker side (m).")] = 0.03,
    dictionary: Annotated[str, typer.Option(help="ArUco dictionary.")] = "DICT_4X4_50",
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


@sim_app.command("video")
def sim_video_cmd(
    folder: Annotated[Path, typer.Argument(help="Folder to write the video and its files in.")],
    clock_offset: Annotated[
        float, typer.Option(help="The encoder log's clock minus the video's (s).")
    ] = 2.0,
    long: Annotated[bool, typer.Option("--long", help="A 31 s drive instead of 12 s.")] = False,
    seed: Annotated[int, typer.Option(min=0, help="Random seed (image noise).")] = 0,
) -> None:
    """Film the virtual robot: a 1280x720, 30 fps MJPG video (blur, noise, JPEG) of it driving
    among five floor markers, with its marker 10 (25 cm, 0.30 m up); writes run.avi, floor.csv,
    camera.toml, the encoder log run.csv and the true path truth.csv (encoder clock)."""
    from odolab.cli._output import term
    from odolab.io import write_trajectory_csv
    from odolab.io.encoder_csv import write_encoder_csv
    from odolab.params import PRESETS
    from odolab.sim.drives import record_drive
    from odolab.sim.physics import TrueParams
    from odolab.tracking import CameraModel, FloorMarker, save_camera, write_floor_csv
    from odolab.tracking.render import look_at, render_video
    from odolab.trajectory import Trajectory
    from odolab.trials import EncoderLog

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
