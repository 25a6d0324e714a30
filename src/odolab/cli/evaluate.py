"""CLI commands: ``odolab evaluate`` (APE/RPE/drift) and ``odolab calibrate lsq``."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app
from odolab.cli._output import echo, markup_text, write_json
from odolab.cli._several import several_values_command
from odolab.cli.options import (
    BAG_GT_TOPIC,
    BAG_JOINT_TOPIC,
    BAG_JOINTS,
    GtTopicOpt,
    JointsOpt,
    JointTopicOpt,
    NewParamsOutputOpt,
    RunFormat,
    SchedulerOpt,
    WorkersOpt,
)
from odolab.cli.wording import said
from odolab.core.defaults import Alignment, DeltaUnit, SyncMethod

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from rich.console import Console

    from odolab.app.evaluate import EvaluationRequest, RunSetEvaluation
    from odolab.calibration.lsq import LsqCalibration
    from odolab.core.params import RobotParams
    from odolab.io.run import ReadOptions
    from odolab.metrics.runs import RunEvaluation
    from odolab.metrics.truthnoise import TruthNoise

__all__: list[str] = []


RUN_FORMAT_HELP = (
    "Run format (default: detected from the files found: a bag, OptiOdom runs beside their "
    "<id>_metadata.csv, else odolab's encoder log CSV; the output says which)."
)
#: ``calibrate lsq``, ``calibrate compare``: --format, detected when not given
RunFormatOpt = Annotated[RunFormat | None, typer.Option("--format", "-f", help=RUN_FORMAT_HELP)]


def run_format(fmt: RunFormat | None, paths: list[Path]) -> RunFormat:
    """``fmt``, else the format detected at ``paths`` (said on the output, with why)."""
    if fmt is not None:
        return fmt
    from odolab.io.registry import detect_format

    found, why = detect_format(paths)
    echo(f"format: {found.value}, detected: {why} (--format chooses another)")
    return RunFormat(found.value)


class ModelChoice(StrEnum):
    diff = "diff"
    extended = "extended"
    icr = "icr"
    slip = "slip"


FormatOpt = Annotated[
    RunFormat | None,
    typer.Option("--format", "-f", help="Paths are runs of this format (else: GT EST files)."),
]
ParamsOpt = Annotated[
    str | None,
    typer.Option("--params", "-p", help="Parameters TOML or preset (default: the runs' own)."),
]


def _progress_bar(label: str) -> AbstractContextManager[Callable[[int, int, str], None]]:
    """The progress bar of commands over many runs (done/total)."""
    from odolab.cli._progress import progress_bar

    return progress_bar(label, of_total=True)


def _read_options(
    params: RobotParams | None, joint_topic: str, joints: tuple[str, str], gt_topic: str
) -> ReadOptions:
    import math

    from odolab.io.run import ReadOptions

    return ReadOptions(
        joint_topic=joint_topic,
        joint_names=joints,
        ground_truth_topic=gt_topic,
        ticks_per_rev=params.ticks_per_rev if params else 2.0 * math.pi,
        modulus=params.encoder_modulus if params else None,
        params=params,
    )


EvalPathsOpt = Annotated[
    list[Path],
    typer.Argument(help="GT EST trajectory files (CSV/TUM), or runs with --format."),
]
EvalDeltaOpt = Annotated[float | None, typer.Option(help="RPE step (default 1 frame; runs 1 m).")]
EvalDeltaUnitOpt = Annotated[
    DeltaUnit | None,
    typer.Option(
        "--delta-unit",
        help="Unit of --delta: frames, m, or the angle turned in deg or rad (evo's d, r: "
        "for runs that turn in place). A unit alone: 1 frame, 1 m, 90 deg, pi/2 rad.",
    ),
]
EvalAllPairsOpt = Annotated[bool, typer.Option(help="RPE over all pairs, not consecutive.")]
EvalPairsFromReferenceOpt = Annotated[
    bool | None, typer.Option(help="Choose RPE pairs on the reference (evo: on the estimate).")
]
EvalAlignOpt = Annotated[
    Alignment | None, typer.Option(help="Alignment (default none; runs origin).")
]
EvalSyncOpt = Annotated[
    SyncMethod | None, typer.Option(help="Association (default nearest; runs interpolate).")
]
EvalMaxDiffOpt = Annotated[
    float | None, typer.Option(help="Largest stamp difference to associate (s).")
]
EvalDriftSegmentOpt = Annotated[float, typer.Option(help="Path length per drift segment (m).")]
EvalDriftTurnOpt = Annotated[
    float, typer.Option(help="Angle turned per piece of the drift per angle turned (deg).")
]
EvalJsonOutOpt = Annotated[Path | None, typer.Option("--json", help="Write the numbers here.")]
EvalResultsOpt = Annotated[
    Path | None,
    typer.Option(help="Runs: the fleet table, one row per run (.parquet, .arrow or .csv)."),
]
EvalNeesOpt = Annotated[
    bool, typer.Option("--nees", help="Runs: NEES of the propagated covariance (\\[noise]).")
]
NeesSegmentOpt = Annotated[float, typer.Option(help="Piece length (s) of the NEES.")]
#: ``evaluate --nees`` and ``calibrate noise``: the NEES pieces' ground-truth yaw offset
GtYawOffsetOpt = Annotated[
    bool | None,
    typer.Option(
        "--gt-yaw-offset/--no-gt-yaw-offset",
        help="NEES: fit the ground truth's yaw mounting offset per run (default: unless "
        "the ground truth starts in the odometry's frame).",
    ),
]
EvalChunkRowsOpt = Annotated[
    int | None,
    typer.Option(
        help="GT EST: rows per chunk, memory bounded by it (0: both files in memory at "
        "once; default: chunks of 1,000,000 rows when a file is over 64 MiB of CSV or "
        "3 M rows)."
    ),
]


@app.command("evaluate")
def evaluate_cmd(
    paths: EvalPathsOpt,
    fmt: FormatOpt = None,
    params: ParamsOpt = None,
    delta: EvalDeltaOpt = None,
    delta_unit: EvalDeltaUnitOpt = None,
    all_pairs: EvalAllPairsOpt = False,
    pairs_from_reference: EvalPairsFromReferenceOpt = None,
    align: EvalAlignOpt = None,
    sync: EvalSyncOpt = None,
    max_diff: EvalMaxDiffOpt = None,
    drift_segment: EvalDriftSegmentOpt = 1.0,
    drift_turn: EvalDriftTurnOpt = 90.0,
    json_out: EvalJsonOutOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    results: EvalResultsOpt = None,
    joint_topic: JointTopicOpt = BAG_JOINT_TOPIC,
    joints: JointsOpt = BAG_JOINTS,
    gt_topic: GtTopicOpt = BAG_GT_TOPIC,
    nees: EvalNeesOpt = False,
    nees_segment: NeesSegmentOpt = 10.0,
    gt_yaw_offset: GtYawOffsetOpt = None,
    chunk_rows: EvalChunkRowsOpt = None,
    truth_sigma: TruthSigmaOpt = None,
) -> None:
    """APE, RPE (evo's definitions) and drift per distance: of EST against GT, or of runs.

    Planar: x, y and heading (evo's 3-D numbers differ where a trajectory leaves the plane).
    Runs (--format) may be files, folders (searched recursively for CSV runs), quoted glob
    patterns, thousands of them: they are evaluated on Dask (a local cluster, or --scheduler).
    A run that fails is reported with its error; the others still get their results."""
    from odolab.app.evaluate import EvaluationRequest, evaluate_run_set, load_request_params

    def value(choice: StrEnum | None) -> str | None:
        return choice.value if choice is not None else None

    request = EvaluationRequest(
        tuple(paths), value(fmt), params, delta, value(delta_unit), all_pairs,
        pairs_from_reference, value(align), value(sync), max_diff, drift_segment, drift_turn,
        chunk_rows, nees, nees_segment,
    )  # fmt: skip
    robot = load_request_params(request)  # every option checked before any file is read
    truth = _nees_truth(truth_sigma, nees)
    if fmt is None:
        _evaluate_pair(request, paths, json_out)
        return
    from odolab.cli._fleet import expand_runs
    from odolab.metrics.cluster import Cluster

    cluster = Cluster(scheduler=scheduler, workers=workers)  # (its address checked first)
    runs = expand_runs(paths, fmt.value)
    with _progress_bar("evaluate") as report:
        done = evaluate_run_set(
            request,
            runs,
            read_options=_read_options(robot, joint_topic, joints, gt_topic),
            cluster=cluster,
            progress=report,
        )
    nees_of = (fmt.value, robot, gt_yaw_offset, truth) if nees else None
    _print_run_set(done, paths, results, json_out, nees_of, nees_segment)


def _nees_truth(truth_sigma: str | None, nees: bool) -> TruthNoise | None:
    """``--truth-sigma``: the ground truth's noise for ``--nees`` (None: estimated)."""
    from odolab.core.errors import OdolabError
    from odolab.metrics.truthnoise import parse_truth_sigma

    if truth_sigma is None:
        return None
    if not nees:
        raise OdolabError(
            "--truth-sigma is the ground truth's noise in each NEES piece's covariance; "
            "expected --nees too"
        )
    return parse_truth_sigma(truth_sigma)


def _evaluate_pair(request: EvaluationRequest, paths: list[Path], json_out: Path | None) -> None:
    """GT EST: evaluated (chunk by chunk with a progress bar when large), written and shown."""
    from odolab.app.evaluate import PLANAR_NOTE, chunk_rows_for, evaluate_trajectories

    if chunk_rows_for(request) > 0:
        from odolab.cli._progress import progress_bar

        with progress_bar("evaluate", unit="rows") as report:
            one = evaluate_trajectories(request, progress=report)
    else:
        one = evaluate_trajectories(request)
    write_json(one.to_dict(), json_out)
    _print_table([(paths[1].name, one.evaluation)])
    _print_notes([PLANAR_NOTE, *one.evaluation.notes])


def _print_run_set(
    done: RunSetEvaluation,
    paths: list[Path],
    results: Path | None,
    json_out: Path | None,
    nees_of: tuple[str, RobotParams | None, bool | None, TruthNoise | None] | None,
    nees_segment: float,
) -> None:
    """Runs: the fleet table (``results``), the table or the fleet summary, the notes, the
    NEES (``nees_of``: format, parameters, fit the yaw offset), the JSON and the failures."""
    from odolab.cli._fleet import print_fleet, report_failures

    doc = done.to_dict()
    if results is not None:
        from odolab.fleet.table import fleet_rows, write_fleet_table

        write_fleet_table(fleet_rows(done.outcomes), results)
    if len(done.outcomes) > 20:
        print_fleet(done.outcomes)
    elif done.done:  # (every run failed: no empty table; report_failures lists them)
        evs = [r.evaluation for r in done.done]
        _print_table(list(zip(run_labels(done.done), evs, strict=True)))
    _print_notes(done.notes)
    if nees_of is not None:
        from odolab.cli._nees import print_nees

        fmt, robot, gt_yaw_offset, truth = nees_of
        doc["nees"] = print_nees(
            paths, fmt, robot, "midpoint", nees_segment, fit_gt_yaw_offset=gt_yaw_offset,
            truth_sigma=truth,
        )  # fmt: skip
    write_json(doc, json_out)
    report_failures(done.outcomes, done.report, results)


def _print_notes(notes: list[str]) -> None:
    """``note: ...`` lines under a table (the planar note, why a value is n/a)."""
    from odolab.cli._console import console

    _print_said(console(), "note", notes)


def _print_said(con: Console, kind: str, lines: Iterable[str]) -> None:
    """``KIND: ...`` lines, each in the CLI's words, as they are: no markup, never wrapped."""
    for line in lines:
        con.print(f"{kind}: {said(line)}", markup=False, soft_wrap=True)


def run_labels(runs: Sequence[RunEvaluation]) -> list[str]:
    """Names for a table of runs (objects with ``name`` and ``source``): the runs' names, or,
    where two share one (``run-001`` of every robot and day), their paths below the folder
    all of them are in, without the extension (``robot-01/2026-03-02/run-001``)."""
    import os

    names = [str(r.name) for r in runs]
    if len(set(names)) == len(names):
        return names
    sources = [Path(str(r.source)) for r in runs]
    try:
        root = Path(os.path.commonpath([s.parent for s in sources]))
        labels = [s.relative_to(root).with_suffix("").as_posix() for s in sources]
    except ValueError:  # no common folder (relative and absolute paths mixed)
        return names
    return labels if len(set(labels)) == len(labels) else names


def _group_of(name: str) -> str:
    """The folder a run was found in (``circular/2506.../run-01`` -> ``circular``)."""
    return name.split("/", 1)[0] if "/" in name else ""


def _mean_rows(names: list[str], values: list[list[float]]) -> list[tuple[str, list[float]]]:
    """One mean row per folder with two or more runs, and one over all runs when there are
    several folders (the means the docs quote). A mean is over the runs where the value is
    defined (NaN: undefined, e.g. drift per metre of a run that turns in place)."""
    import math

    import numpy as np

    def mean(xs: list[float]) -> float:  # over the runs where the value is defined
        ok = [x for x in xs if not math.isnan(x)]
        return float(np.mean(ok)) if ok else math.nan

    groups: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        groups.setdefault(_group_of(n), []).append(i)
    out: list[tuple[str, list[float]]] = []
    for g, idx in groups.items():
        if len(idx) > 1:
            label = f"mean, {g} ({len(idx)} runs)" if g else f"mean ({len(idx)} runs)"
            out.append(
                (
                    label,
                    [mean([values[i][k] for i in idx]) for k in range(len(values[0]))],
                )
            )
    if len(groups) > 1 and len(names) > 1:
        out.append(
            (
                f"mean, all ({len(names)} runs)",
                [mean([v[k] for v in values]) for k in range(len(values[0]))],
            )
        )
    return out


def _cell(value: float, decimals: int) -> str:
    """A number for a table; an undefined one (NaN) is ``n/a`` (the notes say why)."""
    import math

    return "n/a" if math.isnan(value) else f"{value:.{decimals}f}"


def _print_table(rows: list[tuple[str, Any]]) -> None:
    import math

    from rich.table import Table

    from odolab.cli._console import console, print_table

    table = Table(title="trajectory error, planar (translation m, rotation deg)")
    for col in (
        "run", "APE rmse", "RPE rmse", "RPE rot rmse", "end err", "drift %", "deg/m",
        "rot % of turn",
    ):  # fmt: skip
        table.add_column(col, justify="right")
    decimals = (4, 4, 3, 4, 2, 3, 2)
    values = [
        [
            ev.ape.rmse,
            ev.rpe.rmse,
            math.degrees(ev.rpe_rot.rmse),
            ev.drift.endpoint_error,
            ev.drift.translation_pct,
            ev.drift.rotation_deg_per_m,
            ev.drift.rotation_pct_of_turn,
        ]
        for _, ev in rows
    ]
    names = [name for name, _ in rows]
    for i, (name, vals) in enumerate(zip(names, values, strict=True)):
        table.add_row(
            markup_text(name),
            *(_cell(v, d) for v, d in zip(vals, decimals, strict=True)),
            end_section=i == len(rows) - 1,
        )
    for label, vals in _mean_rows(names, values) if values else []:
        table.add_row(
            markup_text(label), *(_cell(v, d) for v, d in zip(vals, decimals, strict=True))
        )
    print_table(console(), table)


#: ``calibrate lsq``, ``calibrate noise``, ``calibrate compare``: the runs a fit is made on
RunsWithTruthArg = Annotated[
    list[Path], typer.Argument(help="Training runs (files or folders) with ground truth.")
]
# ``--validate D E F`` (a shell glob) holds out D, E and F; click alone would fit E and F
LsqValidateOpt = Annotated[
    list[Path] | None,
    typer.Option(
        "--validate",
        help="Held-out runs (files, folders, quoted globs) to compare nominal vs calibrated: "
        "every path after --validate up to the next option (a shell glob works).",
    ),
]
SegmentOpt = Annotated[float, typer.Option(help="Segment length (s) of the residuals.")]
LsqNoGtYawOffsetOpt = Annotated[
    bool,
    typer.Option(
        "--no-gt-yaw-offset", help="Do not estimate the ground truth's yaw mounting offset."
    ),
]
ReportJsonOpt = Annotated[Path | None, typer.Option("--json", help="Write the report here.")]
LsqModelOpt = Annotated[
    ModelChoice,
    typer.Option(help="Model to fit (docs/models.md): diff, extended, icr or slip."),
]
LsqGroundTruthOpt = Annotated[
    Path | None,
    typer.Option(
        "--ground-truth",
        help="The ground truth of the one run given (trajectory CSV or TUM, e.g. from "
        "`odolab track` or `calibrate sensor --truth-out`), replacing the run's own.",
    ),
]
TruthSigmaOpt = Annotated[
    str | None,
    typer.Option(
        "--truth-sigma",
        help="The ground truth's noise XY,YAW (m, rad) for the slip fit, compare's held-out "
        "segments and --nees, e.g. 0.05,0.1 (default: estimated from the truth's own updates; 0,0: "
        "none; docs/models.md).",
    ),
]
LossOpt = Annotated[
    str,
    typer.Option(
        help="Loss of the kinematic fits: linear (least squares), or huber, soft_l1, cauchy, "
        "arctan (robust to ground-truth glitches; docs/models.md).",
    ),
]


@calibrate_app.command("lsq", cls=several_values_command("--validate"))
def calibrate_lsq_cmd(
    runs: RunsWithTruthArg,
    output: NewParamsOutputOpt,
    fmt: RunFormatOpt = None,
    params: ParamsOpt = None,
    validate: LsqValidateOpt = None,
    segment: SegmentOpt = 2.0,
    no_gt_yaw_offset: LsqNoGtYawOffsetOpt = False,
    json_out: ReportJsonOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    joint_topic: JointTopicOpt = BAG_JOINT_TOPIC,
    joints: JointsOpt = BAG_JOINTS,
    gt_topic: GtTopicOpt = BAG_GT_TOPIC,
    model: LsqModelOpt = ModelChoice.diff,
    ground_truth: LsqGroundTruthOpt = None,
    truth_sigma: TruthSigmaOpt = None,
    loss: LossOpt = "linear",
) -> None:
    """Least-squares kinematic model (radii and track width, or ICRs) from runs with ground truth.

    The output lists the runs fitted and the runs held out (--validate)."""
    from odolab.app.evaluate import LsqRequest, calibrate_lsq_runs
    from odolab.cli._fleet import expand_runs
    from odolab.cli._output import check_not_the_input
    from odolab.core.params import load_params, save_params
    from odolab.metrics.cluster import Cluster

    check_not_the_input(output, params)
    cluster = Cluster(scheduler=scheduler, workers=workers)  # (its address checked first)
    held = list(validate or [])
    fmt = run_format(fmt, [*runs, *held])
    if any(not p.exists() for p in [*runs, *held]):  # glob patterns
        runs = expand_runs(runs, fmt.value)
        held = expand_runs(held, fmt.value) if held else held
    request = LsqRequest(
        runs=tuple(runs),
        fmt=fmt.value,
        params=params,
        held_out=tuple(held),
        segment_s=segment,
        fit_gt_yaw_offset=not no_gt_yaw_offset,
        model=model.value,
        ground_truth=ground_truth,
        truth_sigma=truth_sigma,
        loss=loss,
    )
    robot = load_params(params) if params else None
    with _progress_bar("calibrate") as report:
        result = calibrate_lsq_runs(
            request,
            read_options=_read_options(robot, joint_topic, joints, gt_topic),
            cluster=cluster,
            workers=workers,
            progress=report,
        )
    save_params(output, result.calibration.params, provenance=result.calibration.provenance)
    write_json(result.to_dict(), json_out)
    _print_calibration(result.calibration, output)
    _print_run_sets(result.fitted, result.held_out, result.params_source)
    _print_notes(result.computed)


def _run_list(paths: list[Path]) -> str:
    """The runs, each by its path; a window table's windows (``T.csv#window-N``) as one entry
    with their numbers in ranges (``T.csv#window-0-2,6``): every run is named, in a line, not a
    wall."""
    out: list[str] = []
    groups: dict[str, list[int]] = {}
    for p in paths:
        head, sep, tail = str(p).rpartition("#window-")
        if sep and tail.isdigit():
            if head not in groups:
                groups[head] = []
                out.append(head)
            groups[head].append(int(tail))
        else:
            out.append(str(p))
    for i, item in enumerate(out):
        if item in groups:
            ns = sorted(groups[item])
            spans: list[str] = []
            start = prev = ns[0]
            for n in [*ns[1:], None]:
                if n is not None and n == prev + 1:
                    prev = n
                    continue
                spans.append(f"{start}" if start == prev else f"{start}-{prev}")
                if n is not None:
                    start = prev = n
            out[i] = f"{item}#window-{','.join(spans)} ({len(ns)} windows)"
    return ", ".join(out)


def _print_run_sets(fitted: list[Path], held: list[Path], source: str) -> None:
    """Which run files were fitted and which held out (a shell glob cannot hide one)."""
    from odolab.core.numfmt import count

    lines = [f"fitted: {count(len(fitted), 'run')}: " + _run_list(fitted)]
    if held:
        lines.append(f"held out: {count(len(held), 'run')}: " + _run_list(held))
    else:
        lines.append("held out: none (--validate)")
    lines.append(source)
    from odolab.cli._console import console

    con = console()
    for line in lines:
        con.print(line, markup=False, soft_wrap=True)


def _print_calibration(result: LsqCalibration, output: Path) -> None:
    import math

    from rich.table import Table

    from odolab.cli._console import console as make_console
    from odolab.cli._console import fit_table, print_table

    console = make_console()
    nominal, fitted = result.nominal_values, result.values
    table = fit_table(
        f"least-squares calibration ({len(result.runs)} runs, {result.segments} segments) -> "
        f"{output}",
        "std error",
        ((key, nominal[key], fitted[key], err) for key, err in result.stderr.items()),
    )
    print_table(console, table)
    _print_said(console, "warning", result.warnings)
    _print_said(console, "note", result.notes)
    if not result.validation:
        return
    val = Table(title="held-out runs: nominal -> calibrated")
    for col in ("run", "end err (m)", "drift %", "deg/m"):
        val.add_column(col, justify="right")
    names: list[str] = []
    values: list[list[float]] = []
    labels = run_labels([v.nominal for v in result.validation])
    for v, label in zip(result.validation, labels, strict=True):
        n, c = v.nominal.evaluation.drift, v.calibrated.evaluation.drift
        names.append(label)
        values.append(
            [
                n.endpoint_error,
                c.endpoint_error,
                n.translation_pct,
                c.translation_pct,
                n.rotation_deg_per_m,
                c.rotation_deg_per_m,
            ]
        )
    rows = [(name, vals) for name, vals in zip(names, values, strict=True)]
    means = _mean_rows(names, values) if values else []
    for i, (name, x) in enumerate([*rows, *means]):
        val.add_row(
            markup_text(name),
            f"{_cell(x[0], 4)} -> {_cell(x[1], 4)}",
            f"{_cell(x[2], 2)} -> {_cell(x[3], 2)}",
            f"{_cell(x[4], 3)} -> {_cell(x[5], 3)}",
            end_section=i == len(rows) - 1,
        )
    print_table(console, val)
    if math.isfinite(result.rms_after):
        console.print(f"residual rms {result.rms_before:.5f} -> {result.rms_after:.5f} m")
    _print_said(console, "note", [*getattr(result, "notes", []), *getattr(result, "warnings", [])])
