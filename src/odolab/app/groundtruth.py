"""Ground truth without a motion-capture lab: ``odolab calibrate sensor`` calls
:func:`calibrate_sensor_log` (odometry and a sensor calibrated together) and ``odolab track``
calls :func:`track_log` (a marker filmed by a camera).

The rules live here once: the encoder log's format when none is named (a bag with a scan or
sensor topic or a bag file, else CSV), the clock offset between the sensor and the encoders
(given, else found by cross-correlating yaw rates, as ``validate`` does for a phone's IMU), and
which gaps in a video track the encoders bridge.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.defaults import DEFAULT_CORNERS
from odolab.core.errors import OdolabError, opt

if TYPE_CHECKING:
    import numpy as np

    from odolab.calibration.sensor import SensorCalibration
    from odolab.core.trajectory import Trajectory
    from odolab.tracking.photo import PhotoTrack
    from odolab.tracking.tracker import GapBridge, TrackResult

__all__ = [
    "OptionError",
    "PhotoRequest",
    "SensorOutcome",
    "SensorRequest",
    "TrackOutcome",
    "TrackRequest",
    "calibrate_sensor_log",
    "estimate_time_offset",
    "track_log",
    "track_photo_log",
]


class OptionError(OdolabError):
    """A command-line option that does not make sense."""


def _nothing() -> None:
    return None


def estimate_time_offset(
    enc_t: np.ndarray,
    enc_heading: np.ndarray,
    sensor: Trajectory,
    source: str,
    max_offset: float,
    gaps: Sequence[tuple[float, float]] = (),
) -> float:
    """Sensor-minus-encoder clock offset by cross-correlating yaw rates, as ``validate`` does
    for a phone's IMU (:func:`odolab.validation.align.find_clock_offset`); ``gaps``: intervals
    of the sensor's clock where its rate is unknown, left out.

    Raises:
        OptionError: the rates cannot be lined up (no rotation, no overlap, sign reversed).
    """
    from odolab.core.errors import ImuLogError
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
            f"are not swapped), or give the clock offset with {opt('time_offset')}"
        ).replace("  ", " ")
    if "any rotation" in text:
        return (
            f"{source}: neither it nor the encoder log shows any rotation to line the clocks up "
            f"with; expected a drive with turns, or give the clock offset with {opt('time_offset')}"
        )
    if "does not overlap" in text:
        return (
            f"{source}: it does not overlap the encoder log in time for any clock offset within "
            f"+-{max_offset:g} s; expected the log of the same drive, a larger {opt('max_offset')}, "
            f"or the clock offset with {opt('time_offset')}"
        )
    return text


def _check_max_offset(max_offset: float) -> None:
    """The clock-offset search's bound (``track`` and ``calibrate sensor``): seconds, > 0."""
    if not (math.isfinite(max_offset) and max_offset > 0):
        raise OptionError(
            f"{opt('max_offset')} is {max_offset!r}; expected a positive number of seconds"
        )


# -- calibrate sensor -----------------------------------------------------------------------


@dataclass(frozen=True)
class SensorRequest:
    """What ``odolab calibrate sensor`` was asked (``time_offset`` None: found from yaw rates)."""

    encoders: Path
    params: str
    output: Path
    sensor: Path | None = None
    fmt: str | None = None
    time_offset: float | None = 0.0
    max_offset: float = 30.0
    interval: float = 0.5
    max_outliers: float = 0.2
    sensor_topic: str | None = None
    scan_topic: str | None = None
    truth_out: Path | None = None
    scan_every: int = 1
    joint_topic: str = "/joint_states"
    joints: tuple[str, str] = ("left_wheel_joint", "right_wheel_joint")


@dataclass(frozen=True)
class SensorOutcome:
    """The calibration (saved to the request's output) and the clock offset it used."""

    result: SensorCalibration
    time_offset: float


def _encoder_format(req: SensorRequest) -> str:
    """The encoder log's format: the one named, else a bag (scans from the ENCODERS bag when no
    SENSOR is given, a bag folder or file), else CSV."""
    if req.fmt is not None:
        return req.fmt
    is_bag = (req.scan_topic is not None and req.sensor is None) or req.encoders.is_dir()
    is_bag = is_bag or req.encoders.suffix.lower() in (".bag", ".mcap", ".db3")
    return "bag" if is_bag else "csv"


def _sensor_trajectory(req: SensorRequest) -> Trajectory:
    """The sensor's motion: scans matched to each other, or a trajectory file or topic."""
    from odolab.calibration.sensor import read_sensor_trajectory

    if req.scan_topic is not None:
        from odolab.calibration.scanmatch import scan_motions
        from odolab.io.scans import read_scans

        source = req.sensor or req.encoders
        return scan_motions(read_scans(source, req.scan_topic), every=req.scan_every).trajectory
    if req.sensor is None:
        raise OptionError("no SENSOR file and no {{scan_topic}}; expected the sensor's motion")
    return read_sensor_trajectory(req.sensor, req.sensor_topic)


def calibrate_sensor_log(
    req: SensorRequest, check_outputs: Callable[[], None] = _nothing
) -> SensorOutcome:
    """Wheel radii, track and the sensor's pose on the robot (Censi et al. 2013), with standard
    errors; the new parameters saved to ``req.output``, the robot centre's path to
    ``req.truth_out`` where asked. ``check_outputs``: the face's check of its output paths,
    called once the options are known good and before any log is read.

    Raises:
        OptionError: an option out of its range, or both a scan and a sensor topic.
        ParamsError: parameters that cannot be read.
    """
    from odolab.calibration.sensor import (
        SensorOptions,
        calibrate_sensor,
        motions_from_trajectory,
        wheel_angles,
    )
    from odolab.core.params import load_params, save_params
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions

    if not (math.isfinite(req.interval) and req.interval >= 0):
        raise OptionError(
            f"{opt('interval')} is {req.interval!r}; expected a number of seconds >= 0"
        )
    _check_max_offset(req.max_offset)
    options = SensorOptions(max_outliers=req.max_outliers)
    nominal = load_params(req.params)
    check_outputs()
    ro = ReadOptions(
        modulus=nominal.encoder_modulus,
        joint_topic=req.joint_topic,
        joint_names=req.joints,
        ticks_per_rev=nominal.ticks_per_rev,
    )
    fmt = _encoder_format(req)
    if req.scan_topic is not None and req.sensor_topic is not None:
        raise OptionError("give {{scan_topic}} or {{sensor_topic}}, not both")
    run = read_run(req.encoders, fmt, ro)
    traj = _sensor_trajectory(req)
    pl, pr = wheel_angles(run.dticks_left, run.dticks_right, nominal.ticks_per_rev)
    where = f"{req.sensor or req.encoders}" + (f" {req.scan_topic}" if req.scan_topic else "")
    offset = req.time_offset
    if offset is None:
        odo = run.odometry(nominal)
        offset = estimate_time_offset(run.t, odo.heading, traj, where, req.max_offset)
    data = motions_from_trajectory(
        run.t, pl, pr, traj, interval_s=req.interval, time_offset=offset, source=where
    )
    result = calibrate_sensor(data, nominal, options, time_offset=offset)
    save_params(req.output, result.params, provenance=result.provenance())
    if req.truth_out is not None:
        from odolab.calibration.sensor import robot_trajectory
        from odolab.io import write_trajectory_csv

        v = result.values
        mount = (v["sensor_x"], v["sensor_y"], v["sensor_yaw"])
        write_trajectory_csv(req.truth_out, robot_trajectory(traj, mount, offset))
    return SensorOutcome(result, offset)


# -- track ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrackRequest:
    """What ``odolab track`` was asked (``time_offset`` None: found from yaw rates)."""

    video: Path
    floor: Path
    robot_marker: int
    marker_size: float
    marker_height: float
    camera: Path
    output: Path
    marker_offset: tuple[float, float] = (0.0, 0.0)
    dictionary: str = "DICT_4X4_50"
    encoders: Path | None = None
    params: str | None = None
    fmt: str = "csv"
    max_offset: float = 30.0
    time_offset: float | None = None
    max_yaw_rate: float = 180.0  #: deg/s
    corners: str = DEFAULT_CORNERS


@dataclass
class TrackOutcome:
    """The track (written to the request's output), the video-minus-encoder clock offset (0
    without encoders), and one note for each gap bridged or left."""

    result: TrackResult
    offset: float = 0.0
    notes: list[str] = field(default_factory=list)


def _check_track(req: TrackRequest) -> None:
    if not (math.isfinite(req.max_yaw_rate) and req.max_yaw_rate > 0):
        raise OptionError(
            f"{opt('max_yaw_rate')} is {req.max_yaw_rate!r}; expected the robot's fastest turn in "
            "deg/s, a positive number"
        )
    if req.encoders is not None and req.params is None:
        raise OptionError("{{encoders}} needs {{params}} (the robot's nominal parameters)")
    _check_max_offset(req.max_offset)
    if req.time_offset is not None and req.encoders is None:
        raise OptionError("{{time_offset}} needs {{encoders}} (the log whose clock it is)")


def _bridge(
    req: TrackRequest, result: TrackResult, encoders: Path, params: str, notes: list[str]
) -> tuple[TrackResult, float, list[GapBridge]]:
    """The track on the encoder clock, its gaps bridged with the encoders where they can be."""
    from odolab.core.params import load_params
    from odolab.core.trajectory import Trajectory
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions
    from odolab.tracking.tracker import bridge_gaps

    nominal = load_params(params)
    run = read_run(
        encoders,
        req.fmt,
        ReadOptions(modulus=nominal.encoder_modulus, ticks_per_rev=nominal.ticks_per_rev),
    )
    odo = run.odometry(nominal)
    if req.time_offset is None:
        # the yaw rate across a gap is unknown: left out of the search (taken as zero
        # there, it moved the offset by up to a frame, more with the better corners)
        seen = Trajectory.from_xyh(result.t, result.x, result.y, result.heading_without_gaps())
        unknown = [(g.t_before, g.t_after) for g in result.gaps]
        offset = estimate_time_offset(
            run.t, odo.heading, seen, str(req.video), req.max_offset, unknown
        )
    else:
        offset = req.time_offset
    result, bridges = bridge_gaps(result, run.t, odo.heading, offset)
    for br in bridges:
        g = br.gap
        where = f"{g.seconds:.2f} s without the marker at {g.t_before - offset:.2f} s"
        if br.bridged:
            notes.append(
                f"{where}: bridged with the encoders, turned {math.degrees(br.change):+.1f} "
                f"deg (encoders {math.degrees(br.reference):+.1f} deg)"
            )
    return result, offset, bridges


def track_log(req: TrackRequest, check_output: Callable[[], None] = _nothing) -> TrackOutcome:
    """Robot poses from a video: floor markers define the floor, the robot's marker its pose;
    on the encoder clock with its gaps bridged where ``req.encoders`` is given; written to
    ``req.output``. ``check_output``: the face's check of its output path, called once the
    options, the camera, the floor and the dictionary are known good.

    Raises:
        OptionError: an option out of its range or missing its partner.
    """
    from odolab.tracking import load_camera, read_floor_csv
    from odolab.tracking.markers import get_dictionary
    from odolab.tracking.tracker import TrackOptions, track_video, write_track_csv

    _check_track(req)
    options = TrackOptions(
        req.robot_marker, req.marker_size, req.marker_height, req.marker_offset, req.dictionary,
        max_yaw_rate=math.radians(req.max_yaw_rate), corners=req.corners,
    )  # fmt: skip
    cam = load_camera(req.camera)
    markers = read_floor_csv(req.floor)
    get_dictionary(req.dictionary)
    check_output()
    result = track_video(req.video, markers, cam, options)
    out = TrackOutcome(result)
    bridges: list[GapBridge] = []
    if req.encoders is not None and req.params is not None:
        out.result, out.offset, bridges = _bridge(req, result, req.encoders, req.params, out.notes)
    for g in out.result.gaps:  # the gaps left: no encoders, outside their log, or none near
        bridge = next((br for br in bridges if br.gap == g), None)
        why = (
            f"give {opt('encoders')} to bridge it"
            if req.encoders is None
            else "the encoder log does not cover it"
            if bridge is None
            else f"the encoders' turn {math.degrees(bridge.reference):+.1f} deg is far from every "
            "whole-turn candidate"
        )
        out.notes.append(
            f"{g.seconds:.2f} s without the marker at {g.t_before - out.offset:.2f} s: the robot "
            f"may have turned half a turn or more ({opt('max_yaw_rate')} {req.max_yaw_rate:g} deg/s); "
            f"segment {int(out.result.segments[g.index])} starts there, its heading's whole "
            f"turns unknown ({why})"
        )
    write_track_csv(req.output, out.result, out.offset)
    return out


# -- track-photo ----------------------------------------------------------------------------


@dataclass(frozen=True)
class PhotoRequest:
    """What ``odolab track-photo`` was asked: the photo, its floor points, the run's encoder
    log and parameters, the LED's timing, where the path (and an overlay) go."""

    photo: Path
    floor_points: Path
    encoders: Path
    params: str
    output: Path
    led_hz: float = 2.0
    duty: float = 0.5
    overlay: Path | None = None
    fmt: str = "csv"


def track_photo_log(req: PhotoRequest, check_outputs: Callable[[], None] = _nothing) -> PhotoTrack:
    """A timed path from one long-exposure photo of an LED flashing on the robot: the dashes
    found, ordered from the robot's start and placed on the encoder log's clock by matching
    the distance driven; written to ``req.output`` (and the overlay where asked).
    ``check_outputs``: the face's check of its output paths, once the options are good.

    Raises:
        OptionError: an LED frequency or ON fraction out of range.
    """
    from odolab.core.params import load_params
    from odolab.io.registry import read_run
    from odolab.io.run import ReadOptions
    from odolab.tracking.photo import (
        WheelTravel,
        draw_overlay,
        read_floor_points,
        read_photo,
        track_photo,
        write_photo_csv,
    )

    if not (math.isfinite(req.led_hz) and req.led_hz > 0):
        raise OptionError(
            f"{opt('led_hz')} is {req.led_hz!r}; expected the LED's frequency, > 0 Hz"
        )
    if not (math.isfinite(req.duty) and 0.05 <= req.duty <= 0.95):
        raise OptionError(
            f"{opt('duty')} is {req.duty!r}; expected the LED's ON fraction, 0.05 to 0.95"
        )
    check_outputs()
    points = read_floor_points(req.floor_points)
    nominal = load_params(req.params)
    run = read_run(
        req.encoders,
        req.fmt,
        ReadOptions(modulus=nominal.encoder_modulus, ticks_per_rev=nominal.ticks_per_rev),
    )
    odo = run.odometry(nominal)
    per_tick = 2.0 * math.pi / nominal.ticks_per_rev
    travel = WheelTravel.from_increments(
        run.t, run.dticks_left, run.dticks_right,
        nominal.left_wheel_radius * per_tick, nominal.right_wheel_radius * per_tick,
    )  # fmt: skip
    image = read_photo(req.photo)
    track = track_photo(
        image, points, travel, led_hz=req.led_hz, duty=req.duty, source=str(req.photo)
    )
    write_photo_csv(req.output, track)
    if req.overlay is not None:
        draw_overlay(req.overlay, image, track, odo)
    return track
