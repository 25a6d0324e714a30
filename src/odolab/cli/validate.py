"""CLI command: ``odolab validate``: old vs new parameters vs a phone IMU log (Fig. 21)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from odolab.cli._apps import app
from odolab.cli._output import echo, write_json
from odolab.cli.core import MethodChoice, MethodOpt

if TYPE_CHECKING:
    from odolab.validation import ValidationResult

__all__: list[str] = []


EncoderLogOpt = Annotated[
    Path,
    typer.Argument(
        help="Encoder log CSV (t,left_ticks,right_ticks), or with --db the id of a trial "
        "in that notebook (its stored encoder log)."
    ),
]
ImuLogOpt = Annotated[Path, typer.Argument(help="Phone IMU log in the SensorLog app's CSV format.")]
NewOpt = Annotated[
    str, typer.Option("--new", help="New (calibrated) parameters: TOML file or preset name.")
]
OldOpt = Annotated[
    str | None,
    typer.Option(
        "--old",
        help="Old parameters: TOML file or preset name (default: the trial's with --db, "
        "else the ones the log's run.json names, else jaguar-lite).",
    ),
]
DbOpt = Annotated[
    Path | None,
    typer.Option("--db", help="Lab notebook: ENCODER_LOG is then a trial id in it."),
]
OffsetOpt = Annotated[
    float,
    typer.Option(help="Nominal clock offset, phone clock minus robot clock (s)."),
]
MaxOffsetOpt = Annotated[
    float,
    typer.Option(
        help="Search the clock offset within --offset +- this (s); 0 fixes it, inf = any."
    ),
]
SmoothOpt = Annotated[
    float,
    typer.Option(
        help="Low-pass both yaw rates (Gaussian sigma, s) before cross-correlating them. "
        "More smoothing raises the correlation of noisy rates but blurs the timing."
    ),
]
WallclockOpt = Annotated[
    bool,
    typer.Option(
        "--wallclock",
        help="Use the phone's loggingTime (POSIX s) instead of its since-reboot clock.",
    ),
]
FlipImuOpt = Annotated[
    bool, typer.Option("--flip-imu", help="Negate the IMU's heading (phone face down).")
]
PlotOpt = Annotated[
    Path | None, typer.Option(help="Write the figure (headings and errors) to this PNG.")
]
JsonOutOpt = Annotated[
    Path | None, typer.Option("--json", help="Write the result (with time series) as JSON.")
]


@app.command("validate")
def validate_cmd(
    encoder_log: EncoderLogOpt,
    imu_log: ImuLogOpt,
    new: NewOpt,
    old: OldOpt = None,
    db: DbOpt = None,
    offset: OffsetOpt = 0.0,
    max_offset: MaxOffsetOpt = 30.0,
    smooth: SmoothOpt = 0.1,
    wallclock: WallclockOpt = False,
    flip_imu: FlipImuOpt = False,
    method: MethodOpt = MethodChoice.midpoint,
    plot: PlotOpt = None,
    json_out: JsonOutOpt = None,
) -> None:
    """Compare the heading of the old and the new parameters with a phone IMU's."""
    from odolab.app.validate import ValidateRequest, validate_log

    request = ValidateRequest(
        encoder_log, imu_log, new, old, db, offset, max_offset, smooth, wallclock, flip_imu,
        method.value,
    )  # fmt: skip
    result = validate_log(request).result
    _write_outputs(result, plot, json_out)
    _print_result(result)
    if plot is not None:
        echo(f"figure -> {plot}")
    if json_out is not None:
        echo(f"result -> {json_out}")


def _write_outputs(result: ValidationResult, plot: Path | None, json_out: Path | None) -> None:
    """The figure (PNG) and the JSON result, where asked."""
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from odolab.cli._output import check_output_path

        check_output_path(plot, "figure")
        from odolab.cli._output import OutputError
        from odolab.core.writing import replacing_path
        from odolab.validation import validation_figure

        fig = validation_figure(result)
        with replacing_path(plot, what="figure", error=OutputError) as tmp:
            fig.savefig(tmp, dpi=120, format=plot.suffix.lstrip(".").lower() or "png")
        plt.close(fig)
    write_json(result.to_dict(), json_out)


def _print_result(result: ValidationResult) -> None:
    """The clock offset, each parameter set's heading error, their ratio and the warnings."""
    a = result.alignment
    corr = "" if a.correlation != a.correlation else f" (rate correlation {a.correlation:.3f})"
    echo(
        f"clock offset {result.clock_offset:.4f} s (phone - robot){corr}; "
        f"{result.t.size} IMU samples over {a.overlap_end - a.overlap_start:.2f} s; "
        f"IMU rotation {result.imu_heading[-1]:.4f} rad"
    )
    for h in (result.old, result.new):
        echo(
            f"{h.label} ({h.params.name}): RMS heading error {h.rms:.4f} rad, "
            f"final {h.final:+.4f} rad, max |error| {h.max_abs:.4f} rad"
        )
    echo(f"RMS new/old: {result.improvement:.3f}")
    for w in result.warnings:
        echo(f"warning: {w}", err=True)
