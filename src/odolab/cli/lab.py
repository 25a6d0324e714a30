"""CLI commands: the lab's end-to-end job (``odolab demo``) and its steps: ``analyze``,
``report``, ``calibrate ratios``, ``calibrate umbmark``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app
from odolab.cli._output import echo, write_calibration_json
from odolab.cli.options import CalibrationJsonOpt, NewParamsOutputOpt

if TYPE_CHECKING:
    from rich.console import Console

    from odolab.app.selection import SelectionRequest

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


def _selection(
    campaign: list[str] | None, exclude: list[str] | None, robot: str | None = None
) -> SelectionRequest:
    from odolab.app.selection import SelectionRequest

    return SelectionRequest(tuple(campaign or ()), tuple(exclude or ()), robot)


SelectRobotOpt = Annotated[
    str | None,
    typer.Option(
        "--robot",
        help="Only this robot's trials (default: every robot's; with several, Table I pools "
        "them and the report calibrates none, and says so).",
    ),
]


def _say(con: Console, text: str) -> None:
    """A sentence of the application layer (names in it are user text: no markup; its settings
    named by their flags)."""
    from odolab.cli.wording import said
    from odolab.core.text import safe_terminal

    con.print(safe_terminal(said(text)), markup=False)


def _console() -> Console:
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
    robot: SelectRobotOpt = None,
) -> None:
    """Fit systematic and random error of every motion and terrain; print Table I."""
    from odolab.app.analysis import analyze
    from odolab.app.selection import open_notebook
    from odolab.cli._console import print_table
    from odolab.cli._output import markup_text as mt
    from odolab.core.writing import strict_json
    from odolab.report import table1_rich

    con = _console()
    with open_notebook(db) as nb:
        result = analyze(nb, _selection(campaign, exclude_campaign, robot))
    _say(con, result.selection.describe())
    analysis = result.analysis
    print_table(con, table1_rich(result.table1))
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

        write_output_text(json_out, strict_json(result.to_dict()), "analysis JSON")
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
    robot: SelectRobotOpt = None,
    figures: Annotated[
        bool,
        typer.Option(
            "--figures/--no-figures",
            help="Draw the figures (most of the time a report takes); --no-figures writes the "
            "page's tables and results.json alone.",
        ),
    ] = True,
) -> None:
    """Write the lab report (HTML with figures, PNGs, results.json) and print Table I."""
    from odolab.app.report import ReportRequest, write_notebook_report
    from odolab.app.selection import open_notebook
    from odolab.cli._console import print_table
    from odolab.cli._output import markup_text
    from odolab.core.params import load_params
    from odolab.report import table1_rich

    con = _console()
    request = ReportRequest(
        _selection(campaign, exclude_campaign, robot),
        load_params(params) if params else None,
        f"--params {params}" if params else None,
        tuple(ground_truth or ()),
        figures,
    )
    with open_notebook(db) as nb:
        outcome = write_notebook_report(nb, out, request)
    content = outcome.content
    _say(con, content.analysis.selection.describe())
    for note in content.notes:
        _say(con, note)
    if content.base is not None and content.calibrations:
        _say(con, f"calibrations start from {content.base.reason}")
    print_table(con, table1_rich(content.analysis.table1))
    for s in content.analysis.analysis.skipped:
        con.print(f"[yellow]not enough data:[/] {markup_text(s)}")
    beside = (
        "figures and results.json beside it"
        if figures
        else "results.json beside it; figures left out"
    )
    con.print(f"report: {markup_text(outcome.path)}  ({beside})")


RobotOpt = Annotated[
    str | None,
    typer.Option(
        "--robot",
        help="With --db: the robot to calibrate (default: the one robot of the selected trials).",
    ),
]
ParamsOpt = Annotated[
    str | None,
    typer.Option(
        "--params",
        "-p",
        help="Parameters TOML or preset to correct (with --db, default: the version the trials "
        "were driven with).",
    ),
]


def _from_notebook(
    db: Path,
    method: str,
    params: str | None,
    *,
    robot: str | None,
    terrain: str | None = None,
    side: float | None = None,
    campaign: list[str] | None,
    exclude: list[str] | None,
) -> Any:
    """Calibrate from the notebook's trials (:func:`odolab.app.calibration.calibrate`),
    recorded as a new parameter version; says what it used and where it started."""
    from odolab.app.calibration import CalibrationRequest, calibrate
    from odolab.app.selection import open_notebook
    from odolab.core.params import load_params

    request = CalibrationRequest(
        method,
        _selection(campaign, exclude),
        robot=robot,
        terrain=terrain,
        params=load_params(params) if params else None,
        params_source=f"--params {params}" if params else None,
        side=side,
    )
    with open_notebook(db) as nb:
        outcome = calibrate(nb, request)
    con = _console()
    _say(con, outcome.selection.describe())
    _say(con, f"starting from {outcome.base.reason}")
    from odolab.calibration.ratios import describe_noise

    noise = describe_noise(outcome.result)  # each constant, its interval, or why unknown
    if noise:
        _say(con, noise)
    return outcome


RatiosDistanceRatioOpt = Annotated[
    float | None,
    typer.Option(
        help="actual/predicted distance: the x fit's ratio through the origin (Table I's "
        "ratio, not the slope of the line with an intercept)."
    ),
]
RatiosRotationRatioOpt = Annotated[
    float | None,
    typer.Option(
        help="actual/predicted rotation: the rotation fit's ratio through the origin "
        "(Table I's ratio, not the slope of the line with an intercept)."
    ),
]
RatiosDbOpt = Annotated[
    Path | None,
    typer.Option("--db", help="Take the ratios from this notebook's fits.", envvar="ODOLAB_DB"),
]
RatiosTerrainOpt = Annotated[str | None, typer.Option(help="Terrain whose fits to use.")]


@calibrate_app.command("ratios")
def calibrate_ratios_cmd(
    output: NewParamsOutputOpt,
    params: ParamsOpt = None,
    distance_ratio: RatiosDistanceRatioOpt = None,
    rotation_ratio: RatiosRotationRatioOpt = None,
    db: RatiosDbOpt = None,
    terrain: RatiosTerrainOpt = None,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
    robot: RobotOpt = None,
    json_out: CalibrationJsonOpt = None,
) -> None:
    """New wheel radius = old x distance ratio; new track = old x distance/rotation ratio."""
    from odolab.calibration import ratios
    from odolab.cli._output import check_not_the_input
    from odolab.core.errors import OdolabError
    from odolab.core.params import load_params

    check_not_the_input(output, params)

    if distance_ratio is not None and rotation_ratio is not None:
        if params is None:
            raise OdolabError(
                "--distance-ratio and --rotation-ratio need --params (the parameters to correct)"
            )
        base = load_params(params)
        result = ratios(base, distance_ratio, rotation_ratio)
        path = result.save(output)
        if db is not None:
            _record_version(db, result, base, trials=[])
        doc = result.to_dict()
    elif distance_ratio is None and rotation_ratio is None:
        if db is None:
            raise OdolabError(
                "calibrate ratios needs --distance-ratio and --rotation-ratio, or --db NOTEBOOK "
                "to take them from the fits"
            )
        outcome = _from_notebook(
            db, "ratios", params, robot=robot, terrain=terrain, campaign=campaign,
            exclude=exclude_campaign,
        )  # fmt: skip
        result = outcome.result
        path = result.save(output)
        _recorded(db, outcome)
        doc = outcome.to_dict()
    else:
        raise OdolabError("give both --distance-ratio and --rotation-ratio, or neither")
    p = result.params
    fits_terrain = result.provenance.get("terrain")
    if fits_terrain and terrain is None:  # chosen for the user: say so
        echo(
            f"terrain: {fits_terrain} (not given, so chosen: the first, alphabetically, with both "
            "a rotation and an x fit; --terrain picks another)"
        )
    echo(
        f"ratios: distance {result.provenance['distance_ratio']:.4g}, rotation "
        f"{result.provenance['rotation_ratio']:.4g} -> wheel radius {p.left_wheel_radius:.5g} m, "
        f"track width {p.track_width:.5g} m; written to {path}"
    )
    write_calibration_json(doc, json_out)


UmbmarkErrorsOpt = Annotated[
    Path | None,
    typer.Option(help="CSV with header direction,x,y: return errors (measured - odometry)."),
]
UmbmarkSideOpt = Annotated[float | None, typer.Option(help="Square side (m), with --errors.")]
UmbmarkDbOpt = Annotated[
    Path | None,
    typer.Option("--db", help="Use this notebook's squares.", envvar="ODOLAB_DB"),
]


@calibrate_app.command("umbmark")
def calibrate_umbmark_cmd(
    output: NewParamsOutputOpt,
    params: ParamsOpt = None,
    errors: UmbmarkErrorsOpt = None,
    side: UmbmarkSideOpt = None,
    db: UmbmarkDbOpt = None,
    campaign: CampaignOpt = None,
    exclude_campaign: ExcludeOpt = None,
    robot: RobotOpt = None,
    json_out: CalibrationJsonOpt = None,
) -> None:
    """UMBmark (Borenstein & Feng): E_d, E_b, corrected radii and track, E_max,syst.

    With --db and square trials that carry encoder logs, UMBmark is iterated (re-integrate the
    logs with the corrected parameters, correct again) until the parameters stop changing; with
    --errors (or squares without logs) it is the single linearized step.
    """
    from odolab.calibration import umbmark
    from odolab.cli._output import check_not_the_input
    from odolab.core.errors import OdolabError
    from odolab.core.params import load_params

    check_not_the_input(output, params)

    if errors is not None:
        if side is None:
            raise OdolabError("--errors needs --side (the square's side in m)")
        if params is None:
            raise OdolabError("--errors needs --params (the parameters the runs were driven with)")
        cw, ccw = _read_umbmark_csv(errors)
        result = umbmark(cw, ccw, side, load_params(params))
        path = result.calibration.save(output)
        doc = result.calibration.to_dict()
    elif db is not None:
        outcome = _from_notebook(
            db, "umbmark", params, robot=robot, side=side, campaign=campaign,
            exclude=exclude_campaign,
        )  # fmt: skip
        assert outcome.umbmark is not None
        result = outcome.umbmark
        path = result.calibration.save(output)
        _recorded(db, outcome)
        echo(outcome.how)
        doc = outcome.to_dict()
    else:
        raise OdolabError("calibrate umbmark needs --errors CSV --side L, or --db NOTEBOOK")
    p = result.params
    echo(
        f"UMBmark: E_d = {result.e_d:.5f}, E_b = {result.e_b:.5f}, E_max,syst = "
        f"{result.e_max_syst:.4g} m -> left/right radius {p.left_wheel_radius:.5g}/"
        f"{p.right_wheel_radius:.5g} m, track width {p.track_width:.5g} m; written to {path}"
    )
    intervals = result.intervals_sentence()
    if intervals is not None:
        echo(intervals)
    write_calibration_json(doc, json_out)


def _recorded(db: Path, outcome: Any) -> None:
    from odolab.core.text import safe_terminal

    echo(f"recorded in {db} as {safe_terminal(outcome.robot)} parameters version {outcome.version}")


def _record_version(db: Path, result: Any, base: Any, *, trials: list[Any]) -> None:
    """Add ratios typed by hand as a new parameter version of the robot in the notebook."""
    from odolab.app.selection import open_notebook
    from odolab.calibration.record import record_calibration
    from odolab.core.text import safe_terminal

    with open_notebook(db) as nb:
        version = record_calibration(nb, result, base, trials=trials)
    echo(f"recorded in {db} as {safe_terminal(base.name)} parameters version {version}")


def _read_umbmark_csv(path: Path) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    from odolab.calibration.umbmark import read_umbmark_errors_csv

    return read_umbmark_errors_csv(path)
