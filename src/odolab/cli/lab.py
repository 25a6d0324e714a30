"""CLI commands: the lab's end-to-end job (``odolab demo``) and its steps: ``analyze``,
``report``, ``calibrate ratios``, ``calibrate umbmark``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app
from odolab.cli._output import echo

__all__: list[str] = []


DbOpt = Annotated[
    Path,
    typer.Option("--db", help="Lab notebook (SQLite) with the trials.", envvar="ODOLAB_DB"),
]
_DB = Path("odolab.db")
CampaignOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--campaign",
        help="Use only this campaign (repeat for several). Default: every campaign except "
        "validation campaigns.",
    ),
]
ExcludeOpt = Annotated[
    list[str] | None,
    typer.Option("--exclude-campaign", help="Leave this campaign out (repeat for several)."),
]


def _load_trials(db: Path, *, with_logs: bool = True) -> tuple[list[Any], set[str]]:
    """Trials of the lab notebook at ``db``, and the names of its validation campaigns."""
    from odolab.analysis.selection import VALIDATION_TAG
    from odolab.errors import OdolabError
    from odolab.store import Notebook

    if not db.exists():
        raise OdolabError(
            f"{db}: no such lab notebook; give --db FILE (or set ODOLAB_DB), or create one with "
            f"`odolab notebook init --db {db}`"
        )
    with Notebook(db) as nb:
        trials = list(nb.load_trials(with_logs=with_logs))
        validation = {
            c.name for c in nb.campaigns() if c.notes.strip().lower().startswith(VALIDATION_TAG)
        }
    return trials, validation


def _select(
    db: Path,
    campaign: list[str] | None,
    exclude: list[str] | None,
    con: Any,
    *,
    with_logs: bool = True,
) -> list[Any]:
    """The trials ``--campaign``/``--exclude-campaign`` select; says which on ``con``."""
    from odolab.analysis.selection import select_trials
    from odolab.text import safe_terminal

    trials, validation = _load_trials(db, with_logs=with_logs)
    sel = select_trials(
        trials, campaigns=campaign or (), exclude=exclude or (), validation_campaigns=validation
    )
    con.print(safe_terminal(sel.describe()), markup=False)  # campaign names are user text
    return sel.trials


def _console() -> Any:
    from odolab.cli._console import console

    return console()


@app.command("analyze")
def analyze_cmd(
    db: DbOpt = _DB,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the whole analysis as JSON here.")
    ] = None,
) -> None:
    """Fit systematic and random error of every motion and terrain; print Table I."""
    import json

    from odolab.analysis import analyze_trials, table1
    from odolab.cli._console import print_table
    from odolab.cli._output import markup_text as mt
    from odolab.report import table1_rich

    con = _console()
    trials = _select(db, campaign, exclude_campaign, con, with_logs=False)
    analysis = analyze_trials(trials)
    print_table(con, table1_rich(table1(analysis)))
    for t in analysis.terrain_tests:
        con.print(mt(t.verdict()))
    for m in analysis.motions:
        if m.growth is not None:
            con.print(mt(f"growth of sigma, {m.motion} on {m.terrain}: {m.growth.verdict()}"))
    for kind, w in analysis.noise_by_kind.items():
        con.print(
            f"wheel noise from {kind} trials: k_r = {w.k_right:.3g} m "
            f"[{w.k_right_ci95[0]:.3g}, {w.k_right_ci95[1]:.3g}], k_l = {w.k_left:.3g} m "
            f"[{w.k_left_ci95[0]:.3g}, {w.k_left_ci95[1]:.3g}]"
            + ("" if w.identifiable else " (only k_r + k_l is identifiable)")
        )
    if analysis.noise_note:
        con.print(f"[yellow]note:[/] {mt(analysis.noise_note)}")
    for o in analysis.outliers:
        con.print(f"[yellow]outlier[/] {mt(o.trial_id)}: {mt(o.reason)}")
    for s in analysis.skipped:
        con.print(f"[yellow]not enough data:[/] {mt(s)}")
    if json_out is not None:
        from odolab.cli._output import write_output_text

        write_output_text(json_out, json.dumps(analysis.to_dict(), indent=2), "analysis JSON")
        con.print(f"analysis written to {mt(json_out)}")


@app.command("report")
def report_cmd(
    db: DbOpt = _DB,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for the report.")] = Path(
        "odolab-report"
    ),
    params: Annotated[
        str | None,
        typer.Option("--params", "-p", help="Parameters to calibrate (default: the trials')."),
    ] = None,
    ground_truth: Annotated[
        list[Path] | None,
        typer.Option(
            "--ground-truth",
            help="A tracked path (odolab track) or a calibrate sensor --json result: a "
            "ground-truth section (repeatable; docs/ground-truth.md).",
        ),
    ] = None,
) -> None:
    """Write the lab report (HTML with figures, PNGs, results.json) and print Table I."""
    from odolab.analysis import analyze_trials, table1
    from odolab.calibration import (
        ratios_from_analysis,
        umbmark,
        umbmark_errors_from_trials,
        umbmark_iterated,
    )
    from odolab.cli._console import print_table
    from odolab.cli._output import markup_text
    from odolab.errors import CalibrationError
    from odolab.params import load_params
    from odolab.report import table1_rich, write_report

    con = _console()
    from odolab.report.ground_truth import ground_truth_summary

    # read (and check) the ground-truth files before the analysis
    truths = [ground_truth_summary(g) for g in ground_truth or []]
    trials = _select(db, campaign, exclude_campaign, con)
    analysis = analyze_trials(trials)
    base = load_params(params) if params else analysis.params
    calibrations: dict[str, Any] = {}
    try:
        calibrations["ratios"] = ratios_from_analysis(analysis, base)
    except CalibrationError as err:
        con.print(f"[yellow]no ratios calibration:[/] {markup_text(err)}")
    if analysis.square_trials and base is not None:
        try:
            if all(t.encoder_log is not None for t in analysis.square_trials):
                # as the demo: iterate on the encoder logs, from the ratios result if any
                start = calibrations["ratios"].params if "ratios" in calibrations else base
                umb = umbmark_iterated(analysis.square_trials, start)
            else:
                cw, ccw, side = umbmark_errors_from_trials(analysis.square_trials)
                umb = umbmark(cw, ccw, side, base)
            calibrations["umbmark"] = umb
        except CalibrationError as err:
            con.print(f"[yellow]no UMBmark calibration:[/] {markup_text(err)}")
    from odolab.analysis.reference import LAB_REPORT_TABLE1

    # a Jaguar's report is set beside the Jaguar lab report's Table I
    jaguar = base is not None and base.name.startswith("jaguar")
    path = write_report(
        out,
        analysis,
        calibrations,
        reference=LAB_REPORT_TABLE1 if jaguar else None,
        extra={"ground_truth": truths} if truths else None,
    )
    print_table(con, table1_rich(table1(analysis)))
    for s in analysis.skipped:
        con.print(f"[yellow]not enough data:[/] {markup_text(s)}")
    con.print(f"report: {markup_text(path)}  (figures and results.json beside it)")


@calibrate_app.command("ratios")
def calibrate_ratios_cmd(
    params: Annotated[str, typer.Option("--params", "-p", help="Parameters TOML or preset.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    distance_ratio: Annotated[
        float | None, typer.Option(help="actual/predicted distance (x fit slope).")
    ] = None,
    rotation_ratio: Annotated[
        float | None, typer.Option(help="actual/predicted rotation (rotation fit slope).")
    ] = None,
    db: Annotated[
        Path | None,
        typer.Option("--db", help="Take the ratios from this notebook's fits.", envvar="ODOLAB_DB"),
    ] = None,
    terrain: Annotated[str | None, typer.Option(help="Terrain whose fits to use.")] = None,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
) -> None:
    """New wheel radius = old x distance ratio; new track = old x distance/rotation ratio."""
    from odolab.calibration import ratios, ratios_from_analysis
    from odolab.errors import OdolabError
    from odolab.params import load_params

    base = load_params(params)
    used: list[Any] = []
    if distance_ratio is not None and rotation_ratio is not None:
        result = ratios(base, distance_ratio, rotation_ratio)
    elif distance_ratio is None and rotation_ratio is None:
        if db is None:
            raise OdolabError(
                "calibrate ratios needs --distance-ratio and --rotation-ratio, or --db NOTEBOOK "
                "to take them from the fits"
            )
        from odolab.analysis import analyze_trials

        used = _select(db, campaign, exclude_campaign, _console(), with_logs=False)
        result = ratios_from_analysis(analyze_trials(used), base, terrain=terrain)
    else:
        raise OdolabError("give both --distance-ratio and --rotation-ratio, or neither")
    path = result.save(output)
    if db is not None:
        _record_version(db, result, base, trials=used)
    p = result.params
    echo(
        f"ratios: distance {result.provenance['distance_ratio']:.4g}, rotation "
        f"{result.provenance['rotation_ratio']:.4g} -> wheel radius {p.left_wheel_radius:.5g} m, "
        f"track width {p.track_width:.5g} m; written to {path}"
    )


@calibrate_app.command("umbmark")
def calibrate_umbmark_cmd(
    params: Annotated[str, typer.Option("--params", "-p", help="Parameters TOML or preset.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    errors: Annotated[
        Path | None,
        typer.Option(help="CSV with header direction,x,y: return errors (measured - odometry)."),
    ] = None,
    side: Annotated[float | None, typer.Option(help="Square side (m), with --errors.")] = None,
    db: Annotated[
        Path | None,
        typer.Option("--db", help="Use this notebook's squares.", envvar="ODOLAB_DB"),
    ] = None,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
) -> None:
    """UMBmark (Borenstein & Feng): E_d, E_b, corrected radii and track, E_max,syst.

    With --db and square trials that carry encoder logs, UMBmark is iterated (re-integrate the
    logs with the corrected parameters, correct again) until the parameters stop changing; with
    --errors (or squares without logs) it is the single linearized step.
    """
    from odolab.calibration import umbmark, umbmark_errors_from_trials, umbmark_iterated
    from odolab.errors import OdolabError
    from odolab.params import load_params
    from odolab.trials import MotionKind, TrialStatus

    base = load_params(params)
    how = ""
    squares: list[Any] = []
    if errors is not None:
        if side is None:
            raise OdolabError("--errors needs --side (the square's side in m)")
        cw, ccw = _read_umbmark_csv(errors)
        result = umbmark(cw, ccw, side, base)
    elif db is not None:
        trials = _select(db, campaign, exclude_campaign, _console())
        squares = [
            t
            for t in trials
            if t.command.kind is MotionKind.SQUARE and t.status is TrialStatus.MEASURED
        ]
        no_log = [t for t in squares if t.encoder_log is None]
        if squares and not no_log:
            result = umbmark_iterated(squares, base)
            if side is not None and abs(side - result.side) > 1e-6:
                raise OdolabError(
                    f"--side {side:g} m disagrees with the notebook's squares ({result.side:g} m)"
                )
            how = (
                f"UMBmark iterated on the encoder logs of {len(squares)} square trials: "
                f"converged in {result.calibration.provenance['n_iterations']} steps; "
                f"E_max,syst {result.e_max_syst:.4g} m -> {result.e_max_syst_after:.4g} m "
                "with the new parameters (same runs)"
            )
        else:
            cw_a, ccw_a, sq_side = umbmark_errors_from_trials(trials)
            result = umbmark(cw_a, ccw_a, side or sq_side, base)
            how = (
                f"UMBmark single linearized step: {len(no_log)} of {len(squares)} square trials "
                "have no encoder log to iterate on"
            )
    else:
        raise OdolabError("calibrate umbmark needs --errors CSV --side L, or --db NOTEBOOK")
    path = result.calibration.save(output)
    if db is not None and errors is None:
        _record_version(db, result.calibration, base, trials=squares)
    if how:
        echo(how)
    p = result.params
    echo(
        f"UMBmark: E_d = {result.e_d:.5f}, E_b = {result.e_b:.5f}, E_max,syst = "
        f"{result.e_max_syst:.4g} m -> left/right radius {p.left_wheel_radius:.5g}/"
        f"{p.right_wheel_radius:.5g} m, track width {p.track_width:.5g} m; written to {path}"
    )


def _record_version(db: Path, result: Any, base: Any, *, trials: list[Any]) -> None:
    """Add the calibration as a new parameter version of the robot in the notebook."""
    from odolab.calibration.record import record_calibration
    from odolab.store import Notebook
    from odolab.text import safe_terminal

    with Notebook(db) as nb:
        version = record_calibration(nb, result, base, trials=trials)
    echo(f"recorded in {db} as {safe_terminal(base.name)} parameters version {version}")


def _read_umbmark_csv(path: Path) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    from odolab.calibration.umbmark import read_umbmark_errors_csv

    return read_umbmark_errors_csv(path)
