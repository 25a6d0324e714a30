"""CLI commands: ``odolab export ros2-controller`` and ``odolab export mcap``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import export_app
from odolab.cli._output import echo
from odolab.cli.core import MethodChoice

__all__: list[str] = []


class RosDistro(StrEnum):
    humble = "humble"
    jazzy = "jazzy"
    kilted = "kilted"
    rolling = "rolling"


class RunFormatChoice(StrEnum):
    csv = "csv"
    optiodom = "optiodom"
    bag = "bag"
    drive = "drive"


@export_app.command("ros2-controller")
def ros2_controller_cmd(
    params: Annotated[str, typer.Argument(help="Calibrated parameters TOML (or a preset).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="YAML file to write.")],
    nominal: Annotated[
        str | None,
        typer.Option(help="Nominal parameters: base values, the calibration as multipliers."),
    ] = None,
    controller_name: Annotated[
        str, typer.Option(help="Controller name (the YAML's top key).")
    ] = "diff_drive_controller",
    speed: Annotated[float, typer.Option(help="Speed (m/s) the covariance is stated at.")] = 0.5,
    rate: Annotated[
        float,
        typer.Option(
            help="The controller's update rate (Hz: the controller_manager's update_rate; also "
            "publish_rate where the distribution has it)."
        ),
    ] = 50.0,
    window: Annotated[
        int,
        typer.Option(help="The controller's velocity_rolling_window_size (cycles)."),
    ] = 10,
    ros_distro: Annotated[
        RosDistro,
        typer.Option(
            "--ros-distro",
            help="ROS 2 distribution: exactly the keys its diff_drive_controller declares "
            "(default: jazzy, the newest LTS).",
        ),
    ] = RosDistro.jazzy,
    horizon: Annotated[
        float, typer.Option(help="Straight path (m) the pose covariance is stated after.")
    ] = 1.0,
    left_wheels: Annotated[
        list[str] | None, typer.Option("--left-wheel", help="Left wheel joint name(s).")
    ] = None,
    right_wheels: Annotated[
        list[str] | None, typer.Option("--right-wheel", help="Right wheel joint name(s).")
    ] = None,
) -> None:
    """Write a ready-to-load ROS 2 diff_drive_controller parameter file."""
    import tomllib

    from odolab.cli._output import write_output_text
    from odolab.cli.wording import CLI
    from odolab.export.ros2_controller import diff_drive_controller_yaml
    from odolab.params import PRESETS, load_params

    robot = load_params(params)
    provenance = None
    if params not in PRESETS or Path(params).exists():
        provenance = tomllib.loads(Path(params).read_text(encoding="utf-8")).get("provenance")
    left = tuple(left_wheels or ["left_wheel_joint"])
    right = tuple(right_wheels or ["right_wheel_joint"])
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


@export_app.command("mcap")
def mcap_cmd(
    sources: Annotated[
        list[Path] | None,
        typer.Argument(help="A robot run folder; a run with --format; or GT EST trajectory files."),
    ] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="MCAP file to write.")] = Path(
        "odolab.mcap"
    ),
    params: Annotated[
        str | None,
        typer.Option("--params", "-p", help="Parameters (with \\[noise] for the covariance)."),
    ] = None,
    fmt: Annotated[
        RunFormatChoice | None,
        typer.Option("--format", "-f", help="SOURCE is a run of this format."),
    ] = None,
    db: Annotated[
        Path | None, typer.Option(help="Lab notebook (with --campaign).", envvar="ODOLAB_DB")
    ] = None,
    campaign: Annotated[str | None, typer.Option(help="Notebook campaign to export.")] = None,
    method: Annotated[MethodChoice, typer.Option(help="Pose step rule.")] = MethodChoice.midpoint,
    start_time: Annotated[
        float, typer.Option(help="Seconds added to every stamp (e.g. the run's Unix time).")
    ] = 0.0,
) -> None:
    """Write a ROS 2 MCAP (/odom with covariance, /joint_states, /ground_truth, /tf)."""
    from odolab.cli._output import check_output_path
    from odolab.errors import OdolabError
    from odolab.export.mcap import (
        check_start_time,
        stream_from_campaign,
        stream_from_run,
        stream_from_run_folder,
        stream_from_trajectories,
        write_mcap,
    )
    from odolab.params import load_params

    check_start_time(start_time)  # every option checked before any input is read
    check_output_path(output, "MCAP file")
    robot = load_params(params) if params else None
    paths = list(sources or [])
    if campaign is not None or db is not None:
        if campaign is None or db is None or paths:
            raise OdolabError("a notebook campaign needs --db and --campaign, and no SOURCE")
        from odolab.cli.trials import _open

        with _open(db) as nb:  # a missing notebook is refused, not created
            stream = stream_from_campaign(nb, campaign, robot, method.value)
    elif fmt is not None:
        from odolab.io.registry import read_run
        from odolab.io.run import ReadOptions

        if len(paths) != 1:
            raise OdolabError(f"--format takes one run, got {len(paths)} paths")
        ro = ReadOptions(ticks_per_rev=robot.ticks_per_rev) if robot else ReadOptions()
        stream = stream_from_run(read_run(paths[0], fmt.value, ro), robot, method.value)
    elif len(paths) == 1 and (paths[0] / "run.json").is_file():
        stream = stream_from_run_folder(paths[0], robot, method.value)
    elif len(paths) == 2:
        from odolab.io import read_trajectory

        stream = stream_from_trajectories(read_trajectory(paths[1]), read_trajectory(paths[0]))
    else:
        raise OdolabError(
            "export mcap takes a robot run folder (with run.json), one run with --format, "
            "GT EST trajectory files, or --db with --campaign"
        )
    counts = write_mcap(output, stream, start_time=start_time)
    echo(f"wrote {output}: " + ", ".join(f"{topic} {n}" for topic, n in counts.items()))
    from odolab.export.mcap import first_order_notes

    for note in first_order_notes(stream):  # the covariance's range (docs/ros2.md)
        echo(f"note: /odom pose covariance: {note}")
    if stream.covariance_source == "slip":
        from odolab.models import own_covariance

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
