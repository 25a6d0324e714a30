"""CLI commands: ``odolab odometry`` and ``odolab params show``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app, params_app
from odolab.defaults import DEFAULT_ROBOT

__all__: list[str] = []


class MethodChoice(StrEnum):
    midpoint = "midpoint"
    arc = "arc"


class FormatChoice(StrEnum):
    csv = "csv"
    tum = "tum"


@app.command("odometry")
def odometry_cmd(
    log: Annotated[Path, typer.Argument(help="Encoder log CSV: t,left_ticks,right_ticks.")],
    params: Annotated[
        str, typer.Option("--params", "-p", help="Parameters TOML file or preset name.")
    ] = DEFAULT_ROBOT,
    output: Annotated[
        Path, typer.Option("--output", "-o", help="Trajectory file to write.")
    ] = Path("trajectory.csv"),
    method: Annotated[MethodChoice, typer.Option(help="Pose step rule.")] = MethodChoice.midpoint,
    fmt: Annotated[
        FormatChoice, typer.Option("--format", help="Output format.")
    ] = FormatChoice.csv,
    start: Annotated[
        tuple[float, float, float] | None,
        typer.Option(help="Start pose X Y HEADING (m, m, rad); default the origin."),
    ] = None,
    max_dticks: Annotated[
        int | None,
        typer.Option(help="Largest plausible counter change per cycle (default modulus/4)."),
    ] = None,
) -> None:
    """Integrate an encoder log into a trajectory (one pose per input row)."""
    from odolab.io import read_encoder_csv, write_trajectory
    from odolab.odometry import integrate
    from odolab.params import load_params

    robot = load_params(params)
    enc = read_encoder_csv(log, modulus=robot.encoder_modulus)
    traj = integrate(
        enc.t,
        enc.left_ticks,
        enc.right_ticks,
        robot,
        method.value,
        start=start,
        max_dticks=max_dticks,
        source=str(log),
    )
    write_trajectory(output, traj, fmt.value)
    end = traj.final
    typer.echo(
        f"{len(traj)} poses -> {output}; final x={end.x:.4f} m y={end.y:.4f} m "
        f"heading={end.heading:.4f} rad"
    )


@params_app.command("show")
def params_show(
    source: Annotated[str, typer.Argument(help="Preset name or parameters TOML file.")],
) -> None:
    """Print a parameter set as TOML."""
    import tomli_w

    from odolab.params import load_params

    typer.echo(tomli_w.dumps({"robot": load_params(source).to_dict()}).rstrip())


@params_app.command("list")
def params_list() -> None:
    """List the built-in presets."""
    from odolab.params import PRESETS

    for name, p in sorted(PRESETS.items()):
        typer.echo(
            f"{name}: wheel radius L/R {p.left_wheel_radius}/{p.right_wheel_radius} m, "
            f"track {p.track_width} m, {p.ticks_per_rev:g} ticks/rev, modulus {p.encoder_modulus}"
        )
