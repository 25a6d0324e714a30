"""CLI command: ``odolab validate``: old vs new parameters vs a phone IMU log (Fig. 21)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app
from odolab.cli._output import echo
from odolab.cli.core import MethodChoice
from odolab.defaults import DEFAULT_ROBOT

__all__: list[str] = []


@app.command("validate")
def validate_cmd(
    encoder_log: Annotated[
        Path,
        typer.Argument(
            help="Encoder log CSV (t,left_ticks,right_ticks), or with --db the id of a trial "
            "in that notebook (its stored encoder log)."
        ),
    ],
    imu_log: Annotated[
        Path, typer.Argument(help="Phone IMU log in the SensorLog app's CSV format.")
    ],
    new: Annotated[
        str, typer.Option("--new", help="New (calibrated) parameters: TOML file or preset name.")
    ],
    old: Annotated[
        str | None,
        typer.Option(
            "--old",
            help="Old parameters: TOML file or preset name (default: the trial's with --db, "
            "else jaguar-lite).",
        ),
    ] = None,
    db: Annotated[
        Path | None,
        typer.Option("--db", help="Lab notebook: ENCODER_LOG is then a trial id in it."),
    ] = None,
    offset: Annotated[
        float,
        typer.Option(help="Nominal clock offset, phone clock minus robot clock (s)."),
    ] = 0.0,
    max_offset: Annotated[
        float,
        typer.Option(
            help="Search the clock offset within --offset +- this (s); 0 fixes it, inf = any."
        ),
    ] = 30.0,
    smooth: Annotated[
        float,
        typer.Option(
            help="Low-pass both yaw rates (Gaussian sigma, s) before cross-correlating them. "
            "More smoothing raises the correlation of noisy rates but blurs the timing."
        ),
    ] = 0.1,
    wallclock: Annotated[
        bool,
        typer.Option(
            "--wallclock",
            help="Use the phone's loggingTime (POSIX s) instead of its since-reboot clock.",
        ),
    ] = False,
    flip_imu: Annotated[
        bool, typer.Option("--flip-imu", help="Negate the IMU's heading (phone face down).")
    ] = False,
    method: Annotated[MethodChoice, typer.Option(help="Pose step rule.")] = MethodChoice.midpoint,
    plot: Annotated[
        Path | None, typer.Option(help="Write the figure (headings and errors) to this PNG.")
    ] = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write the result (with time series) as JSON.")
    ] = None,
) -> None:
    """Compare the heading of the old and the new parameters with a phone IMU's."""
    from odolab.io import read_encoder_csv
    from odolab.params import load_params
    from odolab.validation import read_sensorlog, validate, validation_figure
    from odolab.writing import strict_json

    new_params = load_params(new)
    if db is not None:
        from odolab.errors import ImuLogError
        from odolab.store import Notebook

        with Notebook(db) as nb:
            trial = nb.get_trial(str(encoder_log))
        if trial.encoder_log is None:
            raise ImuLogError(f"{db}: trial {trial.trial_id} has no encoder log to validate")
        enc = trial.encoder_log
        old_params = load_params(old) if old is not None else trial.params
        source = f"{db}: trial {trial.trial_id}"
    else:
        old_params = load_params(old or DEFAULT_ROBOT)
        enc = read_encoder_csv(encoder_log, modulus=old_params.encoder_modulus)
        source = str(encoder_log)
    imu = read_sensorlog(imu_log)
    if wallclock:
        imu = imu.on_wallclock()
    if flip_imu:
        imu = imu.flipped()
    result = validate(
        enc,
        imu,
        old_params,
        new_params,
        offset=offset,
        max_offset=max_offset,
        smooth=smooth,
        method=method.value,
        encoder_source=source,
    )
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from odolab.cli._output import check_output_path

        check_output_path(plot, "figure")
        from odolab.cli._output import OutputError
        from odolab.writing import replacing_path

        fig = validation_figure(result)
        with replacing_path(plot, what="figure", error=OutputError) as tmp:
            fig.savefig(tmp, dpi=120, format=plot.suffix.lstrip(".").lower() or "png")
        plt.close(fig)
    if json_out is not None:
        from odolab.cli._output import write_output_text

        write_output_text(json_out, strict_json(result.to_dict()) + "\n", "JSON result")
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
    if plot is not None:
        echo(f"figure -> {plot}")
    if json_out is not None:
        echo(f"result -> {json_out}")
