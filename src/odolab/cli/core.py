"""CLI commands: ``odolab odometry`` and ``odolab params show``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app, params_app
from odolab.cli._output import echo
from odolab.defaults import DEFAULT_ROBOT

__all__: list[str] = []


#: Logs larger than this are integrated in chunks unless --chunk-rows says otherwise.
AUTO_CHUNK_BYTES = 64 * 1024 * 1024
AUTO_CHUNK_ROWS = 3_000_000  #: the same for Parquet and IPC logs, by their row count
DEFAULT_CHUNK_ROWS = 1_000_000


def auto_chunk_rows(*paths: Path) -> int:
    """Rows per chunk when the user gave none: :data:`DEFAULT_CHUNK_ROWS` when a file is big
    (CSV over :data:`AUTO_CHUNK_BYTES`, Parquet/IPC over :data:`AUTO_CHUNK_ROWS` rows), else 0
    (read whole)."""
    from odolab.io.tabular import row_count

    for path in paths:
        if not path.is_file():
            continue
        rows = row_count(path)
        if (rows or 0) > AUTO_CHUNK_ROWS or (
            rows is None and path.stat().st_size > AUTO_CHUNK_BYTES
        ):
            return DEFAULT_CHUNK_ROWS
    return 0


class MethodChoice(StrEnum):
    midpoint = "midpoint"
    arc = "arc"


class FormatChoice(StrEnum):
    csv = "csv"
    tum = "tum"


@app.command("odometry")
def odometry_cmd(
    logs: Annotated[
        list[Path],
        typer.Argument(
            help="Encoder log: t,left_ticks,right_ticks (CSV, .parquet or .arrow/.feather); or "
            "many logs, folders, quoted globs (then --output is a folder).",
            metavar="LOG...",
        ),
    ],
    params: Annotated[
        str, typer.Option("--params", "-p", help="Parameters TOML file or preset name.")
    ] = DEFAULT_ROBOT,
    output: Annotated[
        Path,
        typer.Option(
            "--output", "-o", help="Trajectory file to write (.csv, .parquet, .arrow/.feather)."
        ),
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
    chunk_rows: Annotated[
        int | None,
        typer.Option(
            help="Rows per chunk: memory is bounded by it (0: the whole log in memory at once; "
            "default: chunks of 1,000,000 rows for logs over 64 MiB)."
        ),
    ] = None,
    workers: Annotated[
        int, typer.Option(help="Many logs: local Dask worker processes (1: in this process).")
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Many logs: Dask scheduler tcp://HOST:PORT (default: a local cluster)."),
    ] = None,
    covariance: Annotated[
        bool,
        typer.Option(
            "--covariance",
            help="Add each pose's covariance cov_xx,cov_xy,cov_xh,cov_yy,cov_yh,cov_hh "
            "(m^2, m rad, rad^2), propagated from the parameters' \\[noise] table.",
        ),
    ] = False,
) -> None:
    """Integrate an encoder log into a trajectory (one pose per input row), chunk by chunk.

    With many logs (or a folder, or a quoted glob), each is integrated on Dask and written to
    OUTPUT/<its path below the logs' common folder>, in its own format."""
    from odolab.errors import OdolabError
    from odolab.io import read_encoder_csv, write_trajectory
    from odolab.odometry import integrate
    from odolab.params import load_params

    if chunk_rows is not None and chunk_rows < 0:
        raise OdolabError(f"--chunk-rows is {chunk_rows}; expected a number of rows >= 1 (or 0)")
    if covariance and fmt is not FormatChoice.csv:
        raise OdolabError(
            f"--covariance with --format {fmt.value}: TUM has no covariance columns; expected "
            "--format csv (a .csv, .parquet or .arrow output)"
        )
    robot = load_params(params)
    if covariance and robot.noise is None:
        from odolab.errors import ParamsError

        raise ParamsError(
            f"--covariance: the parameters {params} have no [noise] table; expected one with "
            "k_left and k_right (m), as `odolab calibrate noise RUNS -o P.toml` writes it"
        )
    if (
        len(logs) != 1
        or logs[0].is_dir()
        or (not logs[0].exists() and set("*?[") & set(str(logs[0])))
    ):
        from odolab.cli._fleet import odometry_many

        odometry_many(
            logs,
            robot,
            output,
            method=method.value,
            start=start,
            max_dticks=max_dticks,
            chunk_rows=chunk_rows or DEFAULT_CHUNK_ROWS,
            workers=workers,
            scheduler=scheduler,
            covariance=covariance,
        )
        return
    log = logs[0]
    if chunk_rows is None:
        chunk_rows = auto_chunk_rows(log)
    if chunk_rows > 0 and fmt is FormatChoice.csv:
        from odolab.cli._progress import progress_bar
        from odolab.io.chunked import integrate_file

        with progress_bar("odometry", unit="rows") as report:
            res = integrate_file(
                log,
                output,
                robot,
                method.value,
                start=start,
                max_dticks=max_dticks,
                chunk_rows=chunk_rows,
                progress=report,
                covariance=covariance,
            )
        end = res.final
        echo(
            f"{res.rows} poses -> {output}; final x={end.x:.4f} m y={end.y:.4f} m "
            f"heading={end.heading:.4f} rad"
        )
        return
    from odolab.odometry import warm_up

    warm_up(robot, method.value, covariance=covariance)  # the kernels load while the log is read
    enc = read_encoder_csv(log, modulus=robot.encoder_modulus)
    cov = None
    if covariance:
        from odolab.odometry import integrate_with_covariance

        traj, cov = integrate_with_covariance(
            enc.t, enc.left_ticks, enc.right_ticks, robot, method.value, start=start,
            max_dticks=max_dticks, source=str(log),
        )  # fmt: skip
    else:
        traj = integrate(
            enc.t, enc.left_ticks, enc.right_ticks, robot, method.value, start=start,
            max_dticks=max_dticks, source=str(log),
        )  # fmt: skip
    del enc  # the input's memory is free before the output is written
    if cov is None:
        write_trajectory(output, traj, fmt.value)
    else:
        from odolab.io.chunked import OdometryChunk
        from odolab.io.tabular import write_columns

        write_columns(output, OdometryChunk(traj, cov).columns(), "trajectory table")
    end = traj.final
    echo(
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
    from odolab.text import safe_terminal

    text = tomli_w.dumps({"robot": load_params(source).to_dict()}).rstrip()
    # still TOML: a control character in a name is written as its \u escape, not obeyed
    typer.echo("\n".join(safe_terminal(line, unicode_escapes=True) for line in text.split("\n")))


@params_app.command("list")
def params_list() -> None:
    """List the built-in presets."""
    from odolab.params import PRESETS

    for name, p in sorted(PRESETS.items()):
        echo(
            f"{name}: wheel radius L/R {p.left_wheel_radius}/{p.right_wheel_radius} m, "
            f"track {p.track_width} m, {p.ticks_per_rev:g} ticks/rev, modulus {p.encoder_modulus}"
        )
