"""CLI commands: the lab notebook (``odolab trials ...`` and ``odolab notebook ...``)."""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from odolab.cli._apps import app, trials_app
from odolab.cli._output import echo, term
from odolab.cli.options import DEFAULT_DB, NotebookDbOpt
from odolab.core.defaults import DEFAULT_ROBOT, TrialStatus
from odolab.core.motion import MotionKind

if TYPE_CHECKING:
    from odolab.core.params import RobotParams
    from odolab.core.trials import Measurement, Trial
    from odolab.store import Notebook

__all__: list[str] = []

notebook_app = typer.Typer(
    help="The lab notebook file: create it, see what it holds.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(notebook_app, name="notebook")

#: options several notebook commands share
NotesOpt = Annotated[str, typer.Option(help="Free text.")]
TrialIdArg = Annotated[str, typer.Argument(help="Trial id.")]


class CampaignKind(StrEnum):
    rotation = "rotation"
    translation = "translation"
    square = "square"
    free = "free"


def _open(db: Path, *, create: bool = False, check: bool = True) -> Notebook:
    """Open the notebook; only commands that add things may create a new file. ``check``:
    refuse a damaged one (``notebook info`` reports the integrity check instead)."""
    from odolab.core.errors import StoreError
    from odolab.store import Notebook

    if not create and not db.exists():
        raise StoreError(f"{db}: no such notebook; create it with `odolab notebook init --db {db}`")
    return Notebook(db, check=check)


def _fmt(value: float | None, spec: str = ".3f") -> str:
    return (
        ""
        if value is None or (isinstance(value, float) and math.isnan(value))
        else format(value, spec)
    )


def _describe_measurement(t: Trial) -> str:
    from odolab.store.measure import describe_measurement

    return describe_measurement(t)


def _describe_prediction(t: Trial) -> str:
    p = t.predicted
    if t.command.kind.turns_in_place:
        return f"heading {p.heading:.3f} rad ({p.heading / math.pi:.2f} pi)"
    return f"x {p.x:.3f} y {p.y:.3f} m, heading {p.heading:.3f} rad"


# -- notebook ------------------------------------------------------------------------------------


@notebook_app.command("init")
def notebook_init(db: NotebookDbOpt = DEFAULT_DB) -> None:
    """Create a notebook (or migrate an older one) and say what it holds."""
    with _open(db, create=True) as nb:
        info = nb.info()
    how = (
        "created"
        if info.migrated_from == 0
        else (
            f"migrated from schema {info.migrated_from}"
            if info.migrated_from < info.schema_version
            else "already up to date"
        )
    )
    echo(f"{db}: notebook schema {info.schema_version} ({how}), {info.trials} trials")


@notebook_app.command("info")
def notebook_info(db: NotebookDbOpt = DEFAULT_DB) -> None:
    """Counts of robots, parameter versions, campaigns and trials."""
    with _open(db, check=False) as nb:  # it says what the integrity check says
        info = nb.info()
        check = nb.integrity_check()
        campaigns = nb.campaigns()
    echo(f"notebook {info.path} (schema {info.schema_version}, integrity {check})")
    echo(f"  robots {info.robots}, parameter versions {info.params_versions}")
    status = ", ".join(f"{k} {v}" for k, v in sorted(info.by_status.items())) or "none"
    echo(f"  trials {info.trials} ({status}), encoder logs {info.encoder_logs}")
    for c in campaigns:
        echo(term(f"  campaign {c.name}: {c.kind} on {c.terrain}, {c.date or ''} {c.operator}"))


@notebook_app.command("rescue")
def notebook_rescue(
    new: Annotated[Path, typer.Argument(help="The new notebook file to write (must not exist).")],
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Copy every record a damaged notebook still holds into a new notebook (the damaged file
    is only read)."""
    from odolab.store.rescue import rescue_notebook

    report = rescue_notebook(db, new)
    stretches = sum(report.unreadable_stretches.values())
    broken = sum(report.broken_rows.values())
    kept = ", ".join(f"{n} {t.replace('_', ' ')}" for t, n in report.kept.items())
    echo(f"{new}: rescued {report.trials} trials from {db} ({kept})")
    echo(
        f"  {stretches} unreadable stretch{'es' if stretches != 1 else ''} skipped, "
        f"{broken} broken row{'s' if broken != 1 else ''} left out"
        + (
            f", {len(report.dropped_trials)} invalid trials dropped"
            if report.dropped_trials
            else ""
        )
    )
    if report.dropped_trials:
        echo(term(f"  dropped: {', '.join(report.dropped_trials[:20])}"))


# -- campaigns and parameter versions ------------------------------------------------------------


@trials_app.command("campaign-add")
def campaign_add(
    name: Annotated[str, typer.Argument(help="Campaign name, e.g. rot-lab-2024-05.")],
    kind: Annotated[CampaignKind, typer.Option(help="What its trials command.")],
    terrain: Annotated[str, typer.Option(help="Where: lab, concrete, grass ...")],
    date: Annotated[str | None, typer.Option(help="YYYY-MM-DD (default today).")] = None,
    operator: Annotated[str, typer.Option(help="Who ran it.")] = "",
    notes: NotesOpt = "",
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Add a campaign: a series of trials of one kind on one terrain."""
    with _open(db, create=True) as nb:
        nb.add_campaign(name, kind.value, terrain, date=date, operator=operator, notes=notes)
    echo(f"campaign {term(name)} ({kind.value} on {term(terrain)}) added to {db}")


@trials_app.command("campaigns")
def campaigns_cmd(db: NotebookDbOpt = DEFAULT_DB) -> None:
    """List the campaigns."""
    with _open(db) as nb:
        for c in nb.campaigns():
            cells = (c.name, c.kind, c.terrain, c.date or "", c.operator, c.notes)
            typer.echo("\t".join(term(x) for x in cells))


@trials_app.command("params-add")
def params_add(
    source: Annotated[str, typer.Argument(help="Parameters TOML file or preset name.")],
    method: Annotated[str, typer.Option(help="How they were obtained (preset, ratios ...).")],
    source_trial: Annotated[
        list[str] | None, typer.Option("--source-trial", help="A trial they come from (repeat).")
    ] = None,
    notes: NotesOpt = "",
    robot: Annotated[
        str | None,
        typer.Option(
            help="Robot whose new version they are (default: the name in the file, which a "
            "calibration suffixes, e.g. jaguar-lite-ratios)."
        ),
    ] = None,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Add a new version of a robot's parameters (nothing is ever overwritten)."""
    from odolab.core.params import load_params

    params = load_params(source)
    if robot is not None:
        params = params.with_(name=robot)
    with _open(db, create=True) as nb:
        v = nb.add_params_version(
            params, method=method, source_trials=source_trial or (), notes=notes
        )
    echo(f"{term(params.name)} parameters version {v} ({method}) added to {db}")


@trials_app.command("params-versions")
def params_versions_cmd(
    robot: Annotated[str, typer.Argument(help="Robot name, e.g. jaguar-lite.")],
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """List every version of a robot's parameters, with provenance."""
    with _open(db) as nb:
        versions = nb.params_versions(robot)
    if not versions:
        from odolab.core.errors import StoreError

        raise StoreError(f"no parameters of robot {robot!r} in {db}")
    for v in versions:
        p = v.params
        src = f" from {', '.join(v.source_trials)}" if v.source_trials else ""
        echo(
            term(
                f"v{v.version}  {v.created}  {v.method}{src}: wheel radius L/R "
                f"{p.left_wheel_radius:g}/{p.right_wheel_radius:g} m, track {p.track_width:g} m, "
                f"{p.ticks_per_rev:g} ticks/rev{_model_words(p)}"
                f"{'  - ' + v.notes if v.notes else ''}"
            )
        )


def _model_words(p: RobotParams) -> str:
    """``; model icr (y_icr_left 0.34, ... m); noise k_left ..`` for a set that has them."""
    return "".join(f"; {label} {text}" for label, text in p.model_words())


# -- trials --------------------------------------------------------------------------------------

#: the filters ``trials list`` and ``trials export`` share
CampaignFilter = Annotated[str | None, typer.Option(help="Only this campaign.")]
TerrainFilter = Annotated[str | None, typer.Option(help="Only this terrain.")]
KindFilter = Annotated[MotionKind | None, typer.Option(help="Only this kind.")]
StatusFilter = Annotated[TrialStatus | None, typer.Option(help="Only this status.")]


@trials_app.command("list")
def list_cmd(
    campaign: CampaignFilter = None,
    terrain: TerrainFilter = None,
    kind: KindFilter = None,
    status: StatusFilter = None,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """The trials as a table."""
    from rich.table import Table

    with _open(db) as nb:
        trials = nb.load_trials(
            campaign,
            terrain,
            kind.value if kind else None,
            status.value if status else None,
            with_logs=False,
        )
    from odolab.cli._output import markup_text
    from odolab.core.numfmt import count

    table = Table(title=f"{count(len(trials), 'trial')} in {markup_text(db)}")
    for col in ("trial", "campaign", "terrain", "command", "predicted", "measured", "status"):
        table.add_column(col)
    from rich.markup import escape

    for t in trials:
        st = t.status.value + (f": {t.exclusion_reason}" if t.exclusion_reason else "")
        table.add_row(
            escape(term(t.trial_id)),
            escape(term(t.campaign)),
            escape(term(t.terrain)),
            t.command.describe(),
            _describe_prediction(t),
            escape(term(_describe_measurement(t))),
            escape(term(st)),
        )
    from odolab.cli._console import console, print_table

    print_table(console(), table)


@trials_app.command("show")
def show_cmd(trial_id: TrialIdArg, db: NotebookDbOpt = DEFAULT_DB) -> None:
    """Everything recorded about one trial."""
    with _open(db) as nb:
        t = nb.get_trial(trial_id)
        robot, version = nb.trial_params_version(trial_id)
    echo(term(f"trial {t.trial_id}: {t.command.describe()} ({t.campaign}, {t.terrain})"))
    echo(
        f"  status: {t.status.value}"
        + (f" ({term(t.exclusion_reason)})" if t.exclusion_reason else "")
    )
    p = t.predicted
    echo(
        f"  predicted: x {p.x:.4f} m, y {p.y:.4f} m, theta {p.theta:.4f} rad, "
        f"heading {p.heading:.4f} rad at t {p.t:g} s; parameters {term(robot)} v{version}"
    )
    m = t.measured
    if m is not None:
        parts = []
        if m.rotation is not None:
            parts.append(f"rotation {m.rotation:.4f} rad ± {_fmt(m.sigma_rotation, '.3f')}")
        if m.x is not None:
            parts.append(f"x {m.x:.4f} y {_fmt(m.y, '.4f')} m ± {_fmt(m.sigma_xy, '.4f')}")
        echo(term(f"  measured ({m.instrument}): {', '.join(parts)}; raw {dict(m.raw)}"))
    if t.true is not None:
        echo(f"  true: x {t.true.x:.4f} y {t.true.y:.4f} m, heading {t.true.heading:.4f}")
    if t.encoder_log is not None:
        echo(f"  encoder log: {len(t.encoder_log)} samples, modulus {t.encoder_log.modulus}")
    if t.notes:
        echo(f"  notes: {term(t.notes)}")


def _measurement(
    t: Trial,
    initial: float | None,
    final: float | None,
    turns: int | None,
    x: float | None,
    y: float | None,
    sigma: float | None,
) -> Measurement:
    """Build the measurement of ``t``; ask for what is missing when there is a terminal."""
    from odolab.core.errors import StoreError
    from odolab.core.measurement import check_compass_reading

    def ask_compass(text: str) -> float:
        while True:
            value: float = typer.prompt(text, type=float)
            try:
                return check_compass_reading(value, text.split(" (")[0])
            except StoreError as err:
                echo(f"refused: {err}", err=True)

    def ask_turns() -> int:
        while True:
            value: int = typer.prompt("whole turns counted", type=int)
            if value >= 0:
                return value
            echo("refused: turns must be 0 or more", err=True)

    from odolab.store.measure import (
        Readings,
        build_measurement,
        check_reading_names,
        measurement_for_trial,
    )

    rotation = t.command.kind.turns_in_place
    # do not drop what was typed and then ask for something else
    check_reading_names(t, Readings(initial, final, turns, x, y))
    given = (initial, final, turns) if rotation else (x, y)
    if not any(v is None for v in given):
        return measurement_for_trial(t, Readings(initial, final, turns, x, y, sigma))
    while True:
        if rotation:
            if initial is None:
                initial = ask_compass("compass initial reading (deg, clockwise from north)")
            if final is None:
                final = ask_compass("compass final reading (deg)")
            if turns is None:
                turns = ask_turns()
        else:
            if x is None:
                x = typer.prompt("x by meterstick (m, forward)", type=float)
            if y is None:
                y = typer.prompt("y by meterstick (m, to the left)", type=float)
        try:
            return build_measurement(t, Readings(initial, final, turns, x, y, sigma))
        except StoreError as err:
            echo(f"refused: {err}. Please enter the readings again.", err=True)
            initial = final = turns = None
            x = y = None


def _newest_awaiting(nb: Notebook, db: Path) -> str:
    """The id of the newest trial awaiting measurement (refused when there is none)."""
    from odolab.core.errors import StoreError

    waiting = nb.load_trials(status="awaiting", with_logs=False)
    if not waiting:
        raise StoreError(f"{db}: no trial is awaiting measurement; give the trial id")
    return waiting[-1].trial_id


#: the readings ``trials measure`` and ``trials add`` take
InitialOpt = Annotated[float | None, typer.Option(help="Compass before (deg).")]
FinalOpt = Annotated[float | None, typer.Option(help="Compass after (deg).")]
TurnsOpt = Annotated[int | None, typer.Option(help="Whole turns counted.")]
XOpt = Annotated[float | None, typer.Option(help="x by meterstick (m).")]
YOpt = Annotated[float | None, typer.Option(help="y by meterstick (m).")]


@trials_app.command("measure")
def measure_cmd(
    trial_id: Annotated[
        str | None,
        typer.Argument(help="Trial id (default: the newest trial awaiting measurement)."),
    ] = None,
    initial: InitialOpt = None,
    final: FinalOpt = None,
    turns: TurnsOpt = None,
    x: XOpt = None,
    y: YOpt = None,
    sigma: Annotated[
        float | None,
        typer.Option(help="Uncertainty: of one compass reading (rad) or of x and y (m)."),
    ] = None,
    replace: Annotated[bool, typer.Option(help="Overwrite an earlier measurement.")] = False,
    virtual: Annotated[
        bool,
        typer.Option(
            "--virtual",
            help="Take what the virtual instruments show (a run on a virtual board only: "
            "sim://, odolab robot sim-server).",
        ),
    ] = False,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Enter what was measured: compass readings and turns, or x and y (asks what is missing)."""
    from odolab.core.errors import StoreError

    with _open(db) as nb:
        trial_id = trial_id if trial_id is not None else _newest_awaiting(nb, db)
        t = nb.get_trial(trial_id)
        from odolab.store.measure import (
            describe_readings,
            refuse_if_measured,
            virtual_measurement,
            virtual_readings,
        )

        refuse_if_measured(t, replace)  # before asking for the readings, not after they were typed
        echo(
            term(f"trial {t.trial_id}: {t.command.describe()}; predicted {_describe_prediction(t)}")
        )
        readings = virtual_readings(t)
        if virtual:
            if any(v is not None for v in (initial, final, turns, x, y)):
                raise StoreError(
                    f"trial {t.trial_id}: --virtual takes the readings from the virtual "
                    "instruments; expected no --initial, --final, --turns, --x or --y with it"
                )
            m = virtual_measurement(t, sigma)
            assert readings is not None  # virtual_measurement refuses a run without them
            echo(term(f"the virtual instruments show: {describe_readings(readings)}"))
        else:
            if readings is not None:  # what a student on the virtual board would read off
                echo(term(f"the virtual instruments show: {describe_readings(readings)}"))
            m = _measurement(t, initial, final, turns, x, y, sigma)
        nb.set_measurement(trial_id, m, replace=replace)
        saved = nb.get_trial(trial_id)
    echo(term(f"trial {trial_id} measured: {_describe_measurement(saved)}"))


@trials_app.command("add")
def add_cmd(
    trial_id: Annotated[str, typer.Option("--id", help="New trial id.")],
    campaign: Annotated[str, typer.Option(help="Campaign (must exist unless --create-campaign).")],
    kind: Annotated[MotionKind, typer.Option(help="What was commanded.")],
    predicted_heading: Annotated[
        float, typer.Option(help="Odometry's final heading, unwrapped (rad).")
    ] = 0.0,
    predicted_x: Annotated[float, typer.Option(help="Odometry's final x (m).")] = 0.0,
    predicted_y: Annotated[float, typer.Option(help="Odometry's final y (m).")] = 0.0,
    terrain: Annotated[str | None, typer.Option(help="Default: the campaign's.")] = None,
    angle: Annotated[float | None, typer.Option(help="Commanded angle (rad).")] = None,
    angle_pi: Annotated[
        float | None, typer.Option(help="Commanded angle in multiples of pi (e.g. 20).")
    ] = None,
    distance: Annotated[float | None, typer.Option(help="Commanded distance (m).")] = None,
    robot: Annotated[
        str, typer.Option(help="Robot (preset name or one in the notebook).")
    ] = DEFAULT_ROBOT,
    params_version: Annotated[
        int | None, typer.Option(help="Parameter version used (default: the latest).")
    ] = None,
    initial: InitialOpt = None,
    final: FinalOpt = None,
    turns: TurnsOpt = None,
    x: XOpt = None,
    y: YOpt = None,
    notes: NotesOpt = "",
    create_campaign: Annotated[bool, typer.Option(help="Create an unknown campaign.")] = False,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Record a trial typed by hand (and its measurement, when given), for scripts."""
    from odolab.app.trials import AddRequest, add_trial

    request = AddRequest(
        trial_id, campaign, kind.value, predicted_heading, predicted_x, predicted_y, terrain,
        angle, angle_pi, distance, robot, params_version, (initial, final, turns, x, y), notes,
        create_campaign,
    )  # fmt: skip
    added = add_trial(
        db, request, lambda trial: _measurement(trial, initial, final, turns, x, y, None)
    )
    echo(
        f"trial {term(trial_id)} ({added.trial.command.describe()}) recorded in {db}: "
        f"{added.trial.status.value}{added.chosen}"
    )


@trials_app.command("exclude")
def exclude_cmd(
    trial_id: TrialIdArg,
    reason: Annotated[str, typer.Option(help="Why it is left out of the analysis.")],
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Leave a trial out of the analysis (it is kept, with the reason)."""
    with _open(db) as nb:
        nb.exclude_trial(trial_id, reason)
    echo(term(f"trial {trial_id} excluded: {reason}"))


@trials_app.command("include")
def include_cmd(trial_id: TrialIdArg, db: NotebookDbOpt = DEFAULT_DB) -> None:
    """Undo an exclusion."""
    with _open(db) as nb:
        nb.include_trial(trial_id)
    echo(f"trial {term(trial_id)} included again")


@trials_app.command("import")
def import_cmd(
    file: Annotated[Path, typer.Argument(help="A .csv (see docs/notebook.md) or .json file.")],
    create_campaigns: Annotated[
        bool, typer.Option(help="CSV: create campaigns the notebook does not know.")
    ] = False,
    batch_size: Annotated[int, typer.Option(help="Trials per transaction.")] = 1000,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Import trials; the whole file is checked before anything is written."""
    with _open(db, create=True) as nb:
        if file.suffix.lower() == ".json":
            n = nb.import_json(file, batch_size=batch_size)
        else:
            n = nb.import_csv(file, create_campaigns=create_campaigns, batch_size=batch_size)
    echo(f"{n} trials imported from {file} into {db}")


@trials_app.command("export")
def export_cmd(
    file: Annotated[Path, typer.Argument(help="A .csv or .json file to write.")],
    campaign: CampaignFilter = None,
    terrain: TerrainFilter = None,
    kind: KindFilter = None,
    status: StatusFilter = None,
    db: NotebookDbOpt = DEFAULT_DB,
) -> None:
    """Export trials as CSV (a spreadsheet, no encoder logs) or JSON (everything)."""
    from odolab.app.exports import ExportRequest, export_trials, format_of
    from odolab.cli._output import check_output_path

    check_output_path(file, "trials export")
    k = kind.value if kind else None
    s = status.value if status else None
    with _open(db) as nb:  # the web's /data/export makes the same request
        n = export_trials(nb, file, ExportRequest(format_of(file), campaign, terrain, k, s))
    echo(f"{n} trials exported from {db} to {file}")
