"""CLI: ``odolab calibrate imu`` (the rotation part of the model from the robot's own gyro)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from odolab.cli._apps import calibrate_app
from odolab.cli._output import echo, write_calibration_json
from odolab.cli.options import CalibrationJsonOpt, NewParamsOutputOpt

if TYPE_CHECKING:
    from odolab.app.imu import ImuOutcome

__all__: list[str] = []


ImuRunsOpt = Annotated[
    list[Path],
    typer.Argument(
        help="Encoder logs with a gyro (NAME.csv with NAME_imu.csv: t,wz), robot run "
        "folders (encoders.csv with imu.csv), or a DRIVE window table."
    ),
]
ImuParamsOpt = Annotated[
    str | None,
    typer.Option(
        "--params",
        "-p",
        help="Parameters in use: TOML or preset (default: a run folder's own, else "
        "jaguar-lite). Their mean wheel radius is kept.",
    ),
]
ImuImuOpt = Annotated[
    Path | None,
    typer.Option(
        "--imu", help="The gyro log of the one run: t,wz CSV or a SensorLog CSV (a phone)."
    ),
]
ImuImuTopicOpt = Annotated[
    str, typer.Option(help="A bag's sensor_msgs/Imu topic (with its joint states).")
]
ImuOffsetOpt = Annotated[float, typer.Option(help="Nominal clock offset, gyro minus encoders (s).")]
ImuMaxOffsetOpt = Annotated[
    float | None,
    typer.Option(
        help="Search the offset within --offset +- S (0 fixes it; default 30 s, or 0.2 s for "
        "a gyro on the encoders' clock: NAME_imu.csv, imu.csv, DRIVE)."
    ),
]
ImuTurnedOpt = Annotated[
    list[float] | None,
    typer.Option(
        "--turned",
        help="What the robot truly turned over a run (rad, counter-clockwise; a count of "
        "turns x 2 pi, a compass): fixes the gyro's scale. One per run, in order.",
    ),
]
ImuGtReferenceOpt = Annotated[
    bool,
    typer.Option(
        "--gt-reference",
        help="Use the ground truth beside each log (NAME_gt.csv) as the reference turn.",
    ),
]
ImuReferenceSdOpt = Annotated[
    float, typer.Option(help="Standard uncertainty of a reference turn (rad).")
]
ImuScaleCiOpt = Annotated[
    float,
    typer.Option(help="Without a reference: the gyro scale's assumed 95 % uncertainty."),
]
ImuWindowOpt = Annotated[float, typer.Option(help="Window length (s).")]
ImuBiasOpt = Annotated[
    float | None,
    typer.Option(
        help="The gyro's bias when known (rad/s; default: fitted): for runs that turn one "
        "way without standing still."
    ),
]
ImuBiasSdOpt = Annotated[
    float, typer.Option(help="Standard uncertainty of a known --bias (rad/s).")
]
ImuGyroRangeOpt = Annotated[
    float | None, typer.Option(help="The gyro's full scale (rad/s), to spot saturation.")
]
ImuDbOpt = Annotated[
    Path | None,
    typer.Option("--db", help="Record the result as a new parameter version in this notebook."),
]


@calibrate_app.command("imu")
def calibrate_imu_cmd(
    runs: ImuRunsOpt,
    output: NewParamsOutputOpt,
    params: ImuParamsOpt = None,
    imu: ImuImuOpt = None,
    imu_topic: ImuImuTopicOpt = "/imu/data",
    offset: ImuOffsetOpt = 0.0,
    max_offset: ImuMaxOffsetOpt = None,
    turned: ImuTurnedOpt = None,
    gt_reference: ImuGtReferenceOpt = False,
    reference_sd: ImuReferenceSdOpt = 0.01745,
    scale_ci: ImuScaleCiOpt = 0.01,
    window: ImuWindowOpt = 0.5,
    bias: ImuBiasOpt = None,
    bias_sd: ImuBiasSdOpt = 0.005,
    gyro_range: ImuGyroRangeOpt = None,
    db: ImuDbOpt = None,
    json_out: CalibrationJsonOpt = None,
) -> None:
    """The effective track and the radius ratio from a gyro, with 95 % intervals; the gyro's
    bias, scale (with a reference turn) and clock offset (docs/imu.md)."""
    from odolab.app.imu import ImuRequest, calibrate_gyro
    from odolab.calibration.imu import ImuOptions
    from odolab.cli._output import check_not_the_input

    check_not_the_input(output, params)
    req = ImuRequest(
        runs=runs,
        params=params,
        imu=imu,
        turned=tuple(turned or ()),
        reference_sd=reference_sd,
        gt_reference=gt_reference,
        options=ImuOptions(
            window_s=window,
            offset=offset,
            max_offset=max_offset,
            scale_ci95=scale_ci,
            gyro_range=gyro_range,
            bias=bias,
            bias_sd=bias_sd,
        ),
        db=db,
        imu_topic=imu_topic,
    )
    outcome = calibrate_gyro(req)
    _print_outcome(outcome, output, db, json_out)


def _print_outcome(
    outcome: ImuOutcome, output: Path, db: Path | None, json_out: Path | None
) -> None:
    """Where the parameters came from, the calibration's lines, and where it was written and
    recorded."""
    from odolab.core.text import safe_terminal

    cal = outcome.calibration
    echo(outcome.params_from)
    for line in cal.lines():
        echo(safe_terminal(line))
    path = cal.save(output)
    echo(f"written to {path}")
    if outcome.version is not None:
        echo(
            f"recorded in {db} as {safe_terminal(cal.old_params.name)} parameters version "
            f"{outcome.version}"
            + (
                f" (source trials: {', '.join(outcome.source_trials)})"
                if outcome.source_trials
                else ""
            )
        )
    write_calibration_json(outcome.to_dict(), json_out)
