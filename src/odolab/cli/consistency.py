"""CLI: ``odolab calibrate noise`` and the ``--nees`` part of ``odolab evaluate``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import calibrate_app
from odolab.cli._output import echo
from odolab.cli.core import MethodChoice
from odolab.cli.evaluate import RunFormat
from odolab.cli.wording import said

if TYPE_CHECKING:
    from odolab.io.run import OdometryRun
    from odolab.params import RobotParams

__all__ = ["print_nees"]


def _runs(paths: list[Path], fmt: str, robot: RobotParams | None) -> list[OdometryRun]:
    from odolab.io.registry import find_runs, read_run
    from odolab.io.run import ReadOptions

    ro = ReadOptions(ticks_per_rev=robot.ticks_per_rev) if robot else ReadOptions()
    return [read_run(p, fmt, ro) for p in find_runs(paths, fmt)]


def print_nees(
    paths: list[Path],
    fmt: str,
    robot: RobotParams | None,
    method: str,
    segment: float,
    *,
    fit_gt_yaw_offset: bool | None = None,
) -> dict[str, Any]:
    """NEES of every run (pieces of ``segment`` s) against its ground truth; prints a table and
    the verdict, returns the JSON-ready numbers. ``fit_gt_yaw_offset``: as
    :func:`odolab.metrics.consistency.run_nees` (None: fit unless the ground truth starts in
    the odometry's frame)."""
    from rich.table import Table

    from odolab.cli._output import markup_text
    from odolab.errors import ParamsError
    from odolab.metrics.consistency import first_order_note, nees_of_runs, nees_summary
    from odolab.models import CovarianceModel, own_covariance
    from odolab.params import covariance_source

    runs = _runs(paths, fmt, robot)
    sources = set()
    slip_models: list[CovarianceModel] = []
    chosen: dict[int, RobotParams] = {}
    for run in runs:
        p = robot or run.params
        source = covariance_source(p) if p is not None else None
        if p is None or source is None:
            raise ParamsError(
                f"{run.source}: NEES needs the parameters' [noise] (k_left, k_right) or a slip "
                "model; give --params with a [noise] table (e.g. from `odolab calibrate noise`)"
            )
        sources.add(source)
        own = own_covariance(p.model)
        if own is not None and own not in slip_models:
            slip_models.append(own)
        chosen[id(run)] = p
    results, skipped, skip_note = nees_of_runs(
        runs,
        lambda run: chosen[id(run)],
        method,
        segment_s=segment,
        fit_gt_yaw_offset=fit_gt_yaw_offset,
    )
    summary = nees_summary(results)
    table = Table(title=f"NEES of odometry vs ground truth, pieces of {segment:g} s (dof 3)")
    for col in ("run", "pieces", "mean NEES", "gt yaw offset (rad)"):
        table.add_column(col, justify="right")
    for r in results:
        mean = f"{float(r.nees.mean()):.3g}" if r.nees.size else "-"
        offset = (
            f"{r.gt_yaw_offset:.4f} +- {r.gt_yaw_offset_se:.2g} (fitted)"
            if r.dof_removed and r.gt_yaw_offset_se is not None
            else f"{r.gt_yaw_offset:.4f} (not fitted)"
        )
        table.add_row(markup_text(r.name), str(r.nees.size), mean, offset)
    from odolab.cli._console import console as make_console
    from odolab.cli._console import print_table

    console = make_console()
    print_table(console, table)
    lo, hi = summary.mean_bounds95
    fitted = sum(r.dof_removed for r in results)
    dof = f" (expected {summary.dof / summary.n:.4g}: {fitted} fitted offsets)" if fitted else ""
    console.print(
        f"mean NEES {summary.mean:.3g} over {summary.n} pieces{dof}; 95 % bounds "
        f"[{lo:.3g}, {hi:.3g}]; "
        f"{100 * summary.fraction_inside:.1f} % of pieces inside their own 95 % bounds: "
        f"covariance {summary.verdict}",
        markup=False,
        highlight=False,
    )

    for model in slip_models:
        console.print(
            "note: covariance: " + model.describe_covariance(), markup=False, highlight=False
        )
    if skip_note:
        console.print(f"note: {said(skip_note)}", markup=False, highlight=False)
    beyond, note = first_order_note(results)
    if note:
        console.print(f"note: {said(note)}", markup=False, highlight=False)
    head = {
        **summary.to_dict(),
        "pieces_past_first_order": beyond,
        "runs_skipped": len(skipped),
        "skipped": skipped,
        "skipped_note": skip_note,
    }
    return {"summary": head, "runs": [r.to_dict() for r in results]}


@calibrate_app.command("noise")
def calibrate_noise_cmd(
    runs: Annotated[list[Path], typer.Argument(help="Runs (files or folders) with ground truth.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    fmt: Annotated[RunFormat, typer.Option("--format", "-f", help="Run format.")] = (
        RunFormat.optiodom
    ),
    params: Annotated[
        str | None, typer.Option("--params", "-p", help="Parameters (default: the runs' own).")
    ] = None,
    method: Annotated[MethodChoice, typer.Option(help="Pose step rule.")] = MethodChoice.midpoint,
    segment: Annotated[float, typer.Option(help="Piece length (s) of the NEES.")] = 10.0,
    gt_yaw_offset: Annotated[
        bool | None,
        typer.Option(
            "--gt-yaw-offset/--no-gt-yaw-offset",
            help="Fit the ground truth's yaw mounting offset per run (default: unless the "
            "ground truth starts in the odometry's frame).",
        ),
    ] = None,
) -> None:
    """Fit the \\[noise] table to runs with ground truth: k_left, k_right, k_scrub by maximum
    likelihood over the runs' pieces; judge it on held-out runs."""
    from odolab.cli._output import check_not_the_input
    from odolab.errors import OdolabError
    from odolab.metrics.consistency import fit_noise
    from odolab.params import load_params, save_params

    check_not_the_input(output, params)
    robot = load_params(params) if params else None
    found = _runs(runs, fmt.value, robot)
    base = robot or found[0].params
    if base is None:
        raise OdolabError("the runs carry no parameters; give --params")
    fit = fit_noise(found, base, method.value, segment_s=segment, fit_gt_yaw_offset=gt_yaw_offset)
    noise = fit.noise
    new = base.with_(noise=noise)
    save_params(
        output,
        new,
        provenance={
            "method": "noise from ground truth",
            "runs": len(found),
            "segment_s": segment,
            "rule": (
                "k_left, k_right, k_scrub by maximum likelihood of the pieces' errors (each "
                "piece's covariance is linear in them); a constant no piece identifies stays "
                "unknown"
            ),
            "noise_fit": fit.provenance(),
        },
    )
    parts = []
    for key, unit in (("k_left", "m"), ("k_right", "m"), ("k_scrub", "rad")):
        if key in fit.unknown:
            parts.append(f"{key} unknown ({fit.unknown[key]}; written 0)")
        else:
            lo, hi = fit.ci95[key]
            parts.append(f"{key} = {getattr(noise, key):.3g} {unit} [{lo:.3g}, {hi:.3g}]")
    echo(
        f"[noise] {'; '.join(parts)} from {fit.n_pieces} pieces of {len(fit.runs)} runs "
        f"({fit.n_turning} turning) -> {output}; check it on held-out runs: odolab evaluate RUNS "
        f"--format {fmt.value} --params {output} --nees"
    )
