"""CLI commands: ``odolab odometry`` and ``odolab params show``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from odolab.app.odometry import DEFAULT_CHUNK_ROWS
from odolab.cli._apps import app, params_app
from odolab.cli._output import echo
from odolab.cli.options import SchedulerOpt, WorkersOpt
from odolab.core.defaults import DEFAULT_ROBOT, LogFormat

__all__: list[str] = []


def auto_chunk_rows(*paths: Path) -> int:
    """Rows per chunk when the user gave none (:func:`odolab.app.odometry.auto_chunk_rows`)."""
    from odolab.app.odometry import auto_chunk_rows as rule

    return rule(*paths)


class MethodChoice(StrEnum):
    midpoint = "midpoint"
    arc = "arc"


#: --method of every command that integrates encoder logs
MethodOpt = Annotated[MethodChoice, typer.Option(help="Pose step rule.")]


class FormatChoice(StrEnum):
    csv = "csv"
    tum = "tum"


#: --format: the log formats of the registry (odolab.io.registry.READERS), and ``tum``, the older
#: spelling of --to tum (an encoder log written as TUM)
LogFormatChoice = StrEnum(  # type: ignore[misc]
    "LogFormatChoice", {**{f.value: f.value for f in LogFormat}, "tum": "tum"}
)


OdoLogsOpt = Annotated[
    list[Path],
    typer.Argument(
        help="Encoder log: t,left_ticks,right_ticks (CSV, .parquet or .arrow/.feather); or "
        "many logs, folders, quoted globs (then --output is a folder); or one recorded run "
        "in another --format.",
        metavar="LOG...",
    ),
]
OdoParamsOpt = Annotated[
    str | None,
    typer.Option(
        "--params",
        "-p",
        help="Parameters TOML file or preset name (default: the log's run.json or a run's "
        f"metadata, else {DEFAULT_ROBOT}, and the output says which).",
    ),
]
OdoOutputOpt = Annotated[
    Path,
    typer.Option(
        "--output", "-o", help="Trajectory file to write (.csv, .parquet, .arrow/.feather)."
    ),
]
OdoFmtOpt = Annotated[
    LogFormatChoice,
    typer.Option(
        "--format",
        "-f",
        help="Log format (csv: an encoder log; optiodom, bag: one recorded run, with its "
        "nominal parameters when it has any). tum: the older spelling of --to tum.",
    ),
]
OdoToOpt = Annotated[FormatChoice | None, typer.Option("--to", help="Output format (default csv).")]
OdoStartOpt = Annotated[
    tuple[float, float, float] | None,
    typer.Option(help="Start pose X Y HEADING (m, m, rad); default the origin."),
]
OdoMaxDticksOpt = Annotated[
    int | None,
    typer.Option(help="Largest plausible counter change per cycle (default modulus/4)."),
]
OdoChunkRowsOpt = Annotated[
    int | None,
    typer.Option(
        help="Rows per chunk: memory is bounded by it (0: the whole log in memory at once; "
        "default: chunks of 1,000,000 rows for logs over 64 MiB)."
    ),
]
OdoCovarianceOpt = Annotated[
    bool,
    typer.Option(
        "--covariance",
        help="Add each pose's covariance cov_xx,cov_xy,cov_xh,cov_yy,cov_yh,cov_hh "
        "(m^2, m rad, rad^2), propagated from the parameters' \\[noise] table.",
    ),
]


@app.command("odometry")
def odometry_cmd(
    logs: OdoLogsOpt,
    params: OdoParamsOpt = None,
    output: OdoOutputOpt = Path("trajectory.csv"),
    method: MethodOpt = MethodChoice.midpoint,
    fmt: OdoFmtOpt = LogFormatChoice.csv,  # type: ignore[attr-defined]
    to: OdoToOpt = None,
    start: OdoStartOpt = None,
    max_dticks: OdoMaxDticksOpt = None,
    chunk_rows: OdoChunkRowsOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    covariance: OdoCovarianceOpt = False,
) -> None:
    """Integrate an encoder log into a trajectory (one pose per input row), chunk by chunk.

    With many logs (or a folder, or a quoted glob), each is integrated on Dask and written to
    OUTPUT/<its path below the logs' common folder>, in its own format."""
    from odolab.app.odometry import (
        OdometryRequest,
        check_request,
        choose_params,
        integrate_log,
        many_logs,
        resolve_formats,
    )

    log_format, out_fmt = resolve_formats(fmt.value, to.value if to else None)
    many = many_logs(logs, log_format)
    choice = choose_params(logs, params, log_format)
    check_request(
        choice, fmt=out_fmt, covariance=covariance, chunk_rows=chunk_rows,
        log_format=log_format, max_dticks=max_dticks,
    )  # fmt: skip
    echo(choice.describe())
    if many:
        from odolab.cli._fleet import odometry_many

        odometry_many(
            logs, choice.params, output, method=method.value, start=start,
            max_dticks=max_dticks, chunk_rows=chunk_rows or DEFAULT_CHUNK_ROWS, workers=workers,
            scheduler=scheduler, covariance=covariance,
        )  # fmt: skip
        return
    req = OdometryRequest(
        logs[0], output, choice, method.value, out_fmt, start, max_dticks, chunk_rows,
        covariance, log_format,
    )  # fmt: skip
    if req.chunks() > 0:
        from odolab.cli._progress import progress_bar

        with progress_bar("odometry", unit="rows") as report:
            outcome = integrate_log(req, progress=report)
    else:
        outcome = integrate_log(req)
    echo(outcome.describe())
    for note in outcome.notes:
        echo(f"note: {note}")


@params_app.command("show")
def params_show(
    source: Annotated[str, typer.Argument(help="Preset name or parameters TOML file.")],
) -> None:
    """Print a parameter set as TOML."""
    import tomli_w

    from odolab.core.params import load_params
    from odolab.core.text import safe_terminal

    text = tomli_w.dumps({"robot": load_params(source).to_dict()}).rstrip()
    # still TOML: a control character in a name is written as its \u escape, not obeyed
    typer.echo("\n".join(safe_terminal(line, unicode_escapes=True) for line in text.split("\n")))


@params_app.command("list")
def params_list() -> None:
    """List the built-in presets."""
    from odolab.core.params import PRESETS

    for name, p in sorted(PRESETS.items()):
        echo(
            f"{name}: wheel radius L/R {p.left_wheel_radius}/{p.right_wheel_radius} m, "
            f"track {p.track_width} m, {p.ticks_per_rev:g} ticks/rev, modulus {p.encoder_modulus}"
        )
