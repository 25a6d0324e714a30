"""CLI commands for ground truth without a motion-capture lab: ``odolab calibrate sensor``
(odometry and a sensor calibrated together), ``odolab track`` (a marker filmed by a camera),
``odolab camera calibrate`` and ``odolab markers`` (what to print)."""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app
from odolab.errors import OdolabError

if TYPE_CHECKING:
    from odolab.calibration.sensor import SensorCalibration
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
    enc_t: Any, enc_heading: Any, sensor: Trajectory, source: str, max_offset: float
) -> float:
    """Sensor-minus-encoder clock offset by cross-correlating yaw rates, as ``validate`` does
    for a phone's IMU (:func:`odolab.validation.align.find_clock_offset`)."""
    from odolab.validation.align import find_clock_offset
    from odolab.validation.sensorlog import ImuLog

    keep = sensor.t > sensor.t[0]
    keep[0] = True
    keep[1:] &= sensor.t[1:] > sensor.t[:-1]
    imu = ImuLog(sensor.t[keep], sensor.heading[keep], None, source=source)
    return find_clock_offset(enc_t, enc_heading, imu, max_offset=max_offset).clock_offset


@calibrate_app.command("sensor")
def calibrate_sensor_cmd(
    encoders: Annotated[Path, typer.Argument(help="Encoder log (any format odolab reads).")],
    sensor: Annotated[
        Path, typer.Argument(help="Sensor trajectory: TUM, CSV t,x,y,theta|heading, or a bag.")
    ],
    params: Annotated[
        str, typer.Option("--params", "-p", help="Nominal parameters TOML or preset.")
    ],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    fmt: Annotated[
        EncoderFormat, typer.Option("--format", "-f", help="Format of the encoder log.")
    ] = EncoderFormat.csv,
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
    from odolab.cli._output import check_output_path
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
    if json_out is not None:
        check_output_path(json_out, "JSON result")
    ro = ReadOptions(
        modulus=nominal.encoder_modulus,
        joint_topic=joint_topic,
        joint_names=joints,
        ticks_per_rev=nominal.ticks_per_rev,
    )
    run = read_run(encoders, fmt.value, ro)
    traj = read_sensor_trajectory(sensor, sensor_topic)
    pl, pr = wheel_angles(run.dticks_left, run.dticks_right, nominal.ticks_per_rev)
    if offset is None:
        odo = run.odometry(nominal)
        offset = estimate_time_offset(run.t, odo.heading, traj, str(sensor), max_offset)
    data = motions_from_trajectory(
        run.t, pl, pr, traj, interval_s=interval, time_offset=offset, source=str(sensor)
    )
    result = calibrate_sensor(data, nominal, options, time_offset=offset)
    save_params(result.params, output, provenance=result.provenance())
    _write_json(result.to_dict(), json_out)
    _print_sensor(result, output)


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
