"""CLI commands ``odolab calibrate compare`` (which kinematic model does my robot need?) and
``odolab sim questions`` (the lab's open questions on the virtual robot)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import calibrate_app, sim_app
from odolab.cli._several import several_values_command
from odolab.cli.evaluate import (
    LossOpt,
    ParamsOpt,
    ReportJsonOpt,
    RunFormatOpt,
    RunsWithTruthArg,
    SegmentOpt,
    TruthSigmaOpt,
    _print_notes,
    _progress_bar,
    _read_options,
    run_format,
)
from odolab.cli.options import (
    BAG_GT_TOPIC,
    BAG_JOINT_TOPIC,
    BAG_JOINTS,
    GtTopicOpt,
    JointsOpt,
    JointTopicOpt,
    NominalParamsOpt,
    RandomSeedOpt,
    VirtualTruthOpt,
    WorkersOpt,
)

if TYPE_CHECKING:
    from rich.console import Console

    from odolab.calibration.compare import ModelComparison

__all__: list[str] = []


CompareValidateOpt = Annotated[
    list[Path] | None,
    typer.Option(
        "--validate",
        help="Held-out runs (default: cross-validation over the training runs); every "
        "value up to the next option (a shell glob's files).",
    ),
]
CompareModelsOpt = Annotated[
    str,
    typer.Option(
        help="Comma-separated models to compare: diff, extended, icr, slip (the slip model, "
        "learned from data, is scored only when named)."
    ),
]
CompareLearningCurveOpt = Annotated[
    str,
    typer.Option(
        help="Also a learning curve: comma-separated seconds of the first training run "
        "(an exploration run) to fit each model on, e.g. 10,20,30,60."
    ),
]
CompareSeedOpt = Annotated[int, typer.Option(help="Seed of the bootstrap confidence intervals.")]


@calibrate_app.command("compare", cls=several_values_command("--validate"))
def calibrate_compare_cmd(
    runs: RunsWithTruthArg,
    fmt: RunFormatOpt = None,
    params: ParamsOpt = None,
    validate: CompareValidateOpt = None,
    models: CompareModelsOpt = "diff,extended,icr",
    learning_curve: CompareLearningCurveOpt = "",
    segment: SegmentOpt = 2.0,
    seed: CompareSeedOpt = 0,
    json_out: ReportJsonOpt = None,
    workers: WorkersOpt = None,
    joint_topic: JointTopicOpt = BAG_JOINT_TOPIC,
    joints: JointsOpt = BAG_JOINTS,
    gt_topic: GtTopicOpt = BAG_GT_TOPIC,
    truth_sigma: TruthSigmaOpt = None,
    loss: LossOpt = "linear",
) -> None:
    """Fit every kinematic model on training runs, score it on held-out runs, recommend one."""
    from odolab.app.models import CompareRequest, compare_files
    from odolab.calibration.compare import parse_curve
    from odolab.calibration.lsq import LsqOptions
    from odolab.cli._output import write_json
    from odolab.core.params import load_params
    from odolab.metrics.truthnoise import parse_truth_sigma

    chosen = _models(models)
    curve = parse_curve(learning_curve)  # (one check, in the library)
    robot = load_params(params) if params else None
    ro = _read_options(robot, joint_topic, joints, gt_topic)
    computed: list[str] = []
    with _progress_bar("compare") as report:
        request = CompareRequest(
            models=tuple(chosen), curve=tuple(curve), seed=seed,
            options=LsqOptions(
                segment_s=segment, loss=loss,
                truth_sigma=(
                    parse_truth_sigma(truth_sigma) if truth_sigma is not None else None
                ),
            ),
        )  # fmt: skip
        result = compare_files(
            runs,
            run_format(fmt, [*runs, *(validate or [])]).value,
            request,
            validate=validate or [],
            nominal=robot,
            read_options=ro,
            workers=workers,
            progress=report,
            where=computed,
        )
    write_json(result.to_dict(), json_out)
    _print_comparison(result)
    _print_notes(computed)


def _models(models: str) -> list[str]:
    """``--models``: a comma-separated list of the models ``calibrate lsq`` fits."""
    from odolab.calibration.lsq import FIT_MODELS
    from odolab.core.errors import CalibrationError

    chosen = [m.strip() for m in models.split(",") if m.strip()]
    for m in chosen:
        if m not in FIT_MODELS:
            raise CalibrationError(
                f"--models: unknown model {m!r}; expected a comma-separated list of "
                f"{', '.join(FIT_MODELS)}"
            )
    if not chosen:
        raise CalibrationError("--models: empty; expected e.g. diff,icr")
    return chosen


def _ci(value: float, low: float, high: float, fmt: str) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return format(value, fmt)
    return f"{value:{fmt}} [{low:{fmt}}, {high:{fmt}}]"


def _print_comparison(result: ModelComparison) -> None:
    from rich.markup import escape
    from rich.table import Table

    from odolab.calibration.compare import NOT_WORSE
    from odolab.cli._console import console as make_console
    from odolab.cli._console import print_table
    from odolab.core.numfmt import coefficients_with_se

    console = make_console()  # piped: lines as long as their content, never cut
    how = "cross-validated" if result.cross_validated else "held out"
    table = Table(
        title=f"kinematic models: {len(result.train)} training runs, "
        f"{len(result.held_out)} runs {how}; {result.segments} held-out segments (mean, 95 % CI)"
    )
    columns = ("model", "k", "segment err (m)", "vs best", "verdict", "end err (m)", "RPE (m)")
    for col in (*columns, "drift %", "dBIC"):
        table.add_column(col, justify="right")
    for s in result.scores:
        if s.problem is not None:
            table.add_row(s.model, str(s.n_params), escape(s.problem), *[""] * 6)
            continue
        h = s.held_out
        g, r, d = s.segment_error, s.ratio_to_best, s.delta_bic
        table.add_row(
            s.model,
            str(s.n_params),
            _ci(g.value, g.low, g.high, ".4f") if g else "",
            _ci(r.value, r.low, r.high, ".3f") if r else "",
            s.verdict,
            *[
                _ci(h[k].value, h[k].low, h[k].high, f)
                for k, f in (("endpoint_error", ".4f"), ("rpe_rmse", ".4f"), ("drift_pct", ".2f"))
            ],
            _ci(d.value, d.low, d.high, ".1f") if d else "",
        )
    print_table(console, table)
    for s in result.scores:
        if s.fit is None:
            continue
        values = coefficients_with_se(s.fit.values, s.fit.stderr)
        console.print(f"{s.model}: {values}")
    console.print(
        "decided on the held-out segments (1 m of path or 90 deg of turn each): the simplest "
        f"model whose error ratio to the best has its 95 % CI within 1 + {NOT_WORSE:g}",
        highlight=False,
    )
    if result.truth is not None and result.truth.smoothed_s > 0:
        console.print(f"note: {result.truth.describe()}", markup=False, highlight=False)
    if result.learning_curve:
        _print_curve(console, result.learning_curve)
    if result.decided:
        console.print(f"recommended: [bold]{result.recommended}[/bold] ({escape(result.reason)})")
    else:
        why = escape(result.reason.removeprefix("undecided: "))
        console.print(f"recommended: [bold]undecided[/bold], no model ({why})")


def _print_curve(console: Console, curve: list[dict[str, Any]]) -> None:
    """The learning curve: each model's held-out mean end-point error per training length."""
    from rich.table import Table

    from odolab.cli._console import print_table

    seconds = sorted({float(r["seconds"]) for r in curve})
    curve_table = Table(title="learning curve: held-out mean end-point error (m)")
    curve_table.add_column("model")
    for sec in seconds:
        curve_table.add_column(f"{sec:g} s", justify="right")
    for name in dict.fromkeys(str(r["model"]) for r in curve):
        cells = {float(r["seconds"]): r["endpoint_error"] for r in curve
                 if r["model"] == name}  # fmt: skip
        curve_table.add_row(
            name,
            *["not fitted" if cells.get(x) is None else f"{cells[x]:.4f}" for x in seconds],
        )
    print_table(console, curve_table)


QuestionsExperimentsOpt = Annotated[
    list[str] | None,
    typer.Argument(help="Experiment files or built-in names (default: every built-in)."),
]
QuestionsRepeatsOpt = Annotated[
    int | None, typer.Option(min=2, help="Repeats per condition (default: the file's).")
]
QuestionsJsonOutOpt = Annotated[Path | None, typer.Option("--json", help="Write the answers here.")]


@sim_app.command("questions")
def sim_questions_cmd(
    experiments: QuestionsExperimentsOpt = None,
    truth: VirtualTruthOpt = "jaguar-lab-tracked",
    params: NominalParamsOpt = "jaguar-lite",
    seed: RandomSeedOpt = 0,
    repeats: QuestionsRepeatsOpt = None,
    json_out: QuestionsJsonOutOpt = None,
) -> None:
    """Answer the lab's open questions on the virtual robot: effect sizes with 95 % CIs."""
    from rich.console import Console
    from rich.markup import escape

    from odolab.analysis.questions import builtin_experiments, load_experiment, run_experiment
    from odolab.cli._output import write_json
    from odolab.core.errors import SimError
    from odolab.core.params import load_params
    from odolab.sim.presets import TRUTH_PRESETS

    if truth not in TRUTH_PRESETS:
        raise SimError(
            f"--truth: unknown preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    nominal = load_params(params)
    loaded = [load_experiment(e) for e in (experiments or sorted(builtin_experiments()))]
    console = Console()
    results = []
    with _progress_bar("questions") as report:
        for exp in loaded:

            def step(done: int, total: int, name: str = exp.name) -> None:
                report(done, total, name)

            results.append(
                run_experiment(
                    exp,
                    TRUTH_PRESETS[truth],
                    nominal,
                    seed=seed,
                    repeats=repeats,
                    progress=step,
                )
            )
    for res in results:
        console.print(f"[bold]{escape(res.experiment.question)}[/bold]")
        for c in res.conditions:
            if c.slip:
                console.print(
                    f"  {escape(c.label)}: slip {c.mean:.1f} % [{c.low:.1f}, {c.high:.1f}] "
                    f"({len(c.slip)} runs" + (f", {c.stalled} stalled)" if c.stalled else ")")
                )
            else:
                console.print(f"  {escape(c.label)}: stalled in all {c.stalled} runs")
        for e in res.effects:
            console.print(f"  -> {escape(e.sentence())}")
        if res.trend is not None:
            console.print(f"  -> {escape(res.trend.sentence())}")
    write_json([r.to_dict() for r in results], json_out)
