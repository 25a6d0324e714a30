"""CLI commands: ``odolab export ros2-controller`` and ``odolab export mcap``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import export_app
from odolab.cli._output import echo
from odolab.cli.core import MethodChoice, MethodOpt
from odolab.cli.options import RunFormat
from odolab.export.ros2_controller import (
    DEFAULT_CONTROLLER,
    DEFAULT_DISTRO,
    DEFAULT_HORIZON,
    DEFAULT_LEFT_WHEELS,
    DEFAULT_RATE,
    DEFAULT_RIGHT_WHEELS,
    DEFAULT_SPEED,
    DEFAULT_WINDOW,
)

__all__: list[str] = []


class RosDistro(StrEnum):
    humble = "humble"
    jazzy = "jazzy"
    kilted = "kilted"
    rolling = "rolling"


#: the library's default distribution, as the option's choice
_DEFAULT_DISTRO = RosDistro(DEFAULT_DISTRO)


Ros2ParamsOpt = Annotated[str, typer.Argument(help="Calibrated parameters TOML (or a preset).")]
Ros2OutputOpt = Annotated[Path, typer.Option("--output", "-o", help="YAML file to write.")]
Ros2NominalOpt = Annotated[
    str | None,
    typer.Option(help="Nominal parameters: base values, the calibration as multipliers."),
]
Ros2ControllerNameOpt = Annotated[str, typer.Option(help="Controller name (the YAML's top key).")]
Ros2SpeedOpt = Annotated[float, typer.Option(help="Speed (m/s) the covariance is stated at.")]
Ros2RateOpt = Annotated[
    float,
    typer.Option(
        help="The controller's update rate (Hz: the controller_manager's update_rate; also "
        "publish_rate where the distribution has it)."
    ),
]
Ros2WindowOpt = Annotated[
    int,
    typer.Option(help="The controller's velocity_rolling_window_size (cycles)."),
]
Ros2RosDistroOpt = Annotated[
    RosDistro,
    typer.Option(
        "--ros-distro",
        help="ROS 2 distribution: exactly the keys its diff_drive_controller declares "
        "(default: jazzy, the newest LTS).",
    ),
]
Ros2HorizonOpt = Annotated[
    float, typer.Option(help="Straight path (m) the pose covariance is stated after.")
]
Ros2LeftWheelsOpt = Annotated[
    list[str] | None, typer.Option("--left-wheel", help="Left wheel joint name(s).")
]
Ros2RightWheelsOpt = Annotated[
    list[str] | None, typer.Option("--right-wheel", help="Right wheel joint name(s).")
]


@export_app.command("ros2-controller")
def ros2_controller_cmd(
    params: Ros2ParamsOpt,
    output: Ros2OutputOpt,
    nominal: Ros2NominalOpt = None,
    controller_name: Ros2ControllerNameOpt = DEFAULT_CONTROLLER,
    speed: Ros2SpeedOpt = DEFAULT_SPEED,
    rate: Ros2RateOpt = DEFAULT_RATE,
    window: Ros2WindowOpt = DEFAULT_WINDOW,
    ros_distro: Ros2RosDistroOpt = _DEFAULT_DISTRO,
    horizon: Ros2HorizonOpt = DEFAULT_HORIZON,
    left_wheels: Ros2LeftWheelsOpt = None,
    right_wheels: Ros2RightWheelsOpt = None,
) -> None:
    """Write a ready-to-load ROS 2 diff_drive_controller parameter file."""
    import tomllib

    from odolab.cli._output import write_output_text
    from odolab.cli.wording import CLI
    from odolab.core.params import PRESETS, load_params
    from odolab.export.ros2_controller import diff_drive_controller_yaml

    robot = load_params(params)
    provenance = None
    if params not in PRESETS or Path(params).exists():
        provenance = tomllib.loads(Path(params).read_text(encoding="utf-8")).get("provenance")
    left = tuple(left_wheels) if left_wheels else DEFAULT_LEFT_WHEELS
    right = tuple(right_wheels) if right_wheels else DEFAULT_RIGHT_WHEELS
    text = diff_drive_controller_yaml(
        robot,
        nominal=load_params(nominal) if nominal else None,
        controller=controller_name,
        speed=speed,
        rate=rate,
        horizon=horizon,
        window=window,
        distro=ros_distro.value,
        left_wheel_names=left,
        right_wheel_names=right,
        provenance=provenance,
        words=CLI,
    )
    write_output_text(output, text, "controller parameters")
    echo(f"wrote {output} (diff_drive_controller of ROS 2 {ros_distro.value})")
    # what the calibration could not determine is said here too, not only in a YAML comment
    for line in (provenance or {}).get("warnings", []) or []:
        echo(f"warning: {params}: {line}")


McapSourcesOpt = Annotated[
    list[Path] | None,
    typer.Argument(help="A robot run folder; a run with --format; or GT EST trajectory files."),
]
McapOutputOpt = Annotated[Path, typer.Option("--output", "-o", help="MCAP file to write.")]
McapParamsOpt = Annotated[
    str | None,
    typer.Option("--params", "-p", help="Parameters (with \\[noise] for the covariance)."),
]
McapFmtOpt = Annotated[
    RunFormat | None,
    typer.Option("--format", "-f", help="SOURCE is a run of this format."),
]
McapDbOpt = Annotated[
    Path | None, typer.Option(help="Lab notebook (with --campaign).", envvar="ODOLAB_DB")
]
McapCampaignOpt = Annotated[str | None, typer.Option(help="Notebook campaign to export.")]
McapStartTimeOpt = Annotated[
    float, typer.Option(help="Seconds added to every stamp (e.g. the run's Unix time).")
]


@export_app.command("mcap")
def mcap_cmd(
    sources: McapSourcesOpt = None,
    output: McapOutputOpt = Path("odolab.mcap"),
    params: McapParamsOpt = None,
    fmt: McapFmtOpt = None,
    db: McapDbOpt = None,
    campaign: McapCampaignOpt = None,
    method: MethodOpt = MethodChoice.midpoint,
    start_time: McapStartTimeOpt = 0.0,
) -> None:
    """Write a ROS 2 MCAP (/odom with covariance, /joint_states, /ground_truth, /tf)."""
    from odolab.app.exports import mcap_stream
    from odolab.cli._output import check_output_path
    from odolab.cli.trials import _open
    from odolab.core.params import load_params
    from odolab.export.mcap import check_start_time, write_mcap

    check_start_time(start_time)  # every option checked before any input is read
    check_output_path(output, "MCAP file")
    robot = load_params(params) if params else None
    paths = list(sources or [])
    stream = mcap_stream(
        paths, robot, method.value, fmt=fmt.value if fmt is not None else None, db=db,
        campaign=campaign, open_notebook=_open,  # a missing notebook is refused, not created
    )  # fmt: skip
    counts = write_mcap(output, stream, start_time=start_time)
    echo(f"wrote {output}: " + ", ".join(f"{topic} {n}" for topic, n in counts.items()))
    from odolab.export.mcap import first_order_notes

    for note in first_order_notes(stream):  # the covariance's range (docs/ros2.md)
        echo(f"note: /odom pose covariance: {note}")
    if stream.covariance_source == "slip":
        from odolab.core.models import own_covariance

        model = own_covariance(robot.model) if robot is not None else None
        echo(
            "note: /odom covariance: "
            + (
                model.describe_covariance()
                if model is not None
                else "the slip model's predictive variance (docs/models.md)"
            )
        )
    elif stream.covariance is None and len(paths) != 2:
        echo("note: /odom has no covariance (written as zeros): the parameters have neither a "
             "[noise] table nor a slip model")  # fmt: skip
