"""CLI commands: ``odolab evaluate`` (APE/RPE/drift) and ``odolab calibrate lsq``."""

from __future__ import annotations

import json
from collections.abc import Callable
from contextlib import AbstractContextManager
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app, calibrate_app
from odolab.cli._output import markup_text

if TYPE_CHECKING:
    from odolab.io.run import ReadOptions
    from odolab.params import RobotParams

__all__: list[str] = []


class RunFormat(StrEnum):
    csv = "csv"
    optiodom = "optiodom"
    bag = "bag"


class DeltaUnitChoice(StrEnum):
    frames = "frames"
    m = "m"


class AlignChoice(StrEnum):
    none = "none"
    origin = "origin"
    se2 = "se2"


class SyncChoice(StrEnum):
    nearest = "nearest"
    interpolate = "interpolate"


class ModelChoice(StrEnum):
    diff = "diff"
    extended = "extended"
    icr = "icr"


FormatOpt = Annotated[
    RunFormat | None,
    typer.Option("--format", "-f", help="Paths are runs of this format (else: GT EST files)."),
]
ParamsOpt = Annotated[
    str | None,
    typer.Option("--params", "-p", help="Parameters TOML or preset (default: the log's)."),
]
WorkersOpt = Annotated[
    int, typer.Option(help="Local Dask worker processes for many runs (1: in this process).")
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option(help="Dask scheduler address tcp://HOST:PORT (default: a local cluster)."),
]
JointTopicOpt = Annotated[str, typer.Option(help="Bags: JointState topic.")]
JointsOpt = Annotated[
    tuple[str, str], typer.Option(help="Bags: LEFT RIGHT joint names in the JointState.")
]
GtTopicOpt = Annotated[str, typer.Option(help="Bags: ground truth (PoseStamped/Odometry) topic.")]


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
    )


def _write_json(doc: Any, path: Path | None) -> None:
    if path is None:
        return
    from odolab.cli._output import write_output_text

    write_output_text(path, json.dumps(doc, indent=2, allow_nan=True) + "\n", "JSON result")


@app.command("evaluate")
def evaluate_cmd(
    paths: Annotated[
        list[Path],
        typer.Argument(help="GT EST trajectory files (CSV/TUM), or runs with --format."),
    ],
    fmt: FormatOpt = None,
    params: ParamsOpt = None,
    delta: Annotated[
        float | None, typer.Option(help="RPE step (default 1 frame; runs 1 m).")
    ] = None,
    delta_unit: Annotated[
        DeltaUnitChoice | None, typer.Option("--delta-unit", help="Unit of --delta.")
    ] = None,
    all_pairs: Annotated[bool, typer.Option(help="RPE over all pairs, not consecutive.")] = False,
    pairs_from_reference: Annotated[
        bool | None, typer.Option(help="Choose RPE pairs on the reference (evo: on the estimate).")
    ] = None,
    align: Annotated[
        AlignChoice | None, typer.Option(help="Alignment (default none; runs origin).")
    ] = None,
    sync: Annotated[
        SyncChoice | None, typer.Option(help="Association (default nearest; runs interpolate).")
    ] = None,
    max_diff: Annotated[
        float | None, typer.Option(help="Largest stamp difference to associate (s).")
    ] = None,
    drift_segment: Annotated[float, typer.Option(help="Path length per drift segment (m).")] = 1.0,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the numbers here.")] = None,
    workers: WorkersOpt = 2,
    scheduler: SchedulerOpt = None,
    results: Annotated[
        Path | None,
        typer.Option(help="Runs: the fleet table, one row per run (.parquet, .arrow or .csv)."),
    ] = None,
    joint_topic: JointTopicOpt = "/joint_states",
    joints: JointsOpt = ("left_wheel_joint", "right_wheel_joint"),
    gt_topic: GtTopicOpt = "/ground_truth",
    nees: Annotated[
        bool, typer.Option("--nees", help="Runs: NEES of the propagated covariance (\\[noise]).")
    ] = False,
    nees_segment: Annotated[float, typer.Option(help="Piece length (s) of the NEES.")] = 10.0,
    gt_yaw_offset: Annotated[
        bool | None,
        typer.Option(
            "--gt-yaw-offset/--no-gt-yaw-offset",
            help="--nees: fit the ground truth's yaw mounting offset per run (default: unless "
            "the ground truth starts in the odometry's frame).",
        ),
    ] = None,
    chunk_rows: Annotated[
        int | None,
        typer.Option(
            help="GT EST: rows per chunk, memory bounded by it (0: both files in memory at "
            "once; default: chunks of 1,000,000 rows when a file is over 64 MiB of CSV or "
            "3 M rows)."
        ),
    ] = None,
) -> None:
    """APE, RPE (evo's definitions) and drift per distance: of EST against GT, or of runs.

    Runs (--format) may be files, folders (searched recursively for CSV runs), quoted glob
    patterns, thousands of them: they are evaluated on Dask (a local cluster, or --scheduler).
    A run that fails is reported with its error; the others still get their results."""
    from dataclasses import replace

    from odolab.errors import OdolabError
    from odolab.metrics import (
        RUN_OPTIONS,
        Alignment,
        DeltaUnit,
        EvaluationOptions,
        SyncMethod,
    )
    from odolab.params import load_params

    base = RUN_OPTIONS if fmt is not None else EvaluationOptions()
    changes: dict[str, Any] = {"all_pairs": all_pairs, "drift_delta_m": drift_segment}
    if delta_unit is not None:
        changes["delta_unit"] = DeltaUnit(delta_unit.value)
        changes["delta"] = 1.0
    if delta is not None:
        changes["delta"] = delta
    if align is not None:
        changes["alignment"] = Alignment(align.value)
    if sync is not None:
        changes["sync"] = SyncMethod(sync.value)
    if max_diff is not None:
        changes["max_diff"] = max_diff
    if pairs_from_reference is not None:
        changes["pairs_from_reference"] = pairs_from_reference
    options = replace(base, **changes)
    robot = load_params(params) if params else None
    if nees:  # checked before any file is read: a typo costs nothing
        import math

        if not (math.isfinite(nees_segment) and nees_segment > 0):
            raise OdolabError(
                f"--nees-segment is {nees_segment}; expected a positive number of seconds"
            )
        if robot is not None and robot.noise is None:
            raise OdolabError(
                f"--nees: the parameters {params} have no [noise] table (k_left, k_right); "
                "give --params with one (e.g. from `odolab calibrate noise`)"
            )
    if fmt is None:
        from odolab.io import read_trajectory
        from odolab.metrics import evaluate

        if nees:
            raise OdolabError(
                "--nees needs runs with encoder increments (--format), not two trajectories"
            )
        if len(paths) != 2:
            from odolab.numfmt import count

            raise OdolabError(
                f"evaluate takes GT EST (two trajectory files), got {count(len(paths), 'path')}; "
                "use --format for runs"
            )
        if chunk_rows is not None and chunk_rows < 0:
            raise OdolabError(
                f"--chunk-rows is {chunk_rows}; expected a number of rows >= 1 (or 0)"
            )
        from odolab.cli.core import auto_chunk_rows

        rows = auto_chunk_rows(*paths) if chunk_rows is None else chunk_rows
        names = (str(paths[0]), str(paths[1]))
        if rows > 0:
            from odolab.cli._progress import progress_bar
            from odolab.metrics.chunked import evaluate_files

            with progress_bar("evaluate", unit="rows") as report:
                ev = evaluate_files(
                    paths[0], paths[1], options, chunk_rows=rows, names=names, progress=report
                )
        else:
            ev = evaluate(
                read_trajectory(paths[0]), read_trajectory(paths[1]), options, names=names
            )
        _write_json(ev.to_dict(), json_out)
        _print_table([(paths[1].name, ev)])
        return
    if chunk_rows is not None:
        raise OdolabError(
            "--chunk-rows reads two trajectory files (GT EST) in chunks; runs (--format) are "
            "read whole, one per task"
        )
    from odolab.cli._fleet import expand_runs, print_fleet, report_failures
    from odolab.metrics.cluster import Cluster, MapReport
    from odolab.metrics.runs import evaluate_runs

    cluster = Cluster(scheduler=scheduler, workers=workers)
    runs = expand_runs(paths, fmt.value)
    ro = _read_options(robot, joint_topic, joints, gt_topic)
    rep = MapReport(cluster.describe())
    with _progress_bar("evaluate") as report:
        outcomes = evaluate_runs(
            runs,
            fmt.value,
            params=robot,
            options=options,
            read_options=ro,
            cluster=cluster,
            progress=report,
            report=rep,
        )
    done = [o.result for o in outcomes if o.result is not None]
    doc: dict[str, Any] = {"runs": [r.to_dict() for r in done]}
    if results is not None:
        from odolab.fleet.table import fleet_rows, write_fleet_table

        write_fleet_table(fleet_rows(outcomes), results)
    if len(outcomes) > 20:
        print_fleet(outcomes)
    elif done:  # (every run failed: no empty table; report_failures lists them)
        _print_table(list(zip(run_labels(done), [r.evaluation for r in done], strict=True)))
    if nees:
        from odolab.cli.consistency import print_nees

        doc["nees"] = print_nees(
            paths, fmt.value, robot, "midpoint", nees_segment, fit_gt_yaw_offset=gt_yaw_offset
        )
    _write_json(doc, json_out)
    report_failures(outcomes, rep, results)


def run_labels(runs: list[Any]) -> list[str]:
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
    several folders (the means the docs quote)."""
    import numpy as np

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
                    [float(np.mean([values[i][k] for i in idx])) for k in range(len(values[0]))],
                )
            )
    if len(groups) > 1 and len(names) > 1:
        out.append(
            (
                f"mean, all ({len(names)} runs)",
                [float(np.mean([v[k] for v in values])) for k in range(len(values[0]))],
            )
        )
    return out


def _print_table(rows: list[tuple[str, Any]]) -> None:
    import math

    from rich.table import Table

    from odolab.cli._console import console, print_table

    table = Table(title="trajectory error (translation m, rotation deg)")
    for col in ("run", "APE rmse", "RPE rmse", "RPE rot rmse", "end err", "drift %", "deg/m"):
        table.add_column(col, justify="right")
    decimals = (4, 4, 3, 4, 2, 3)
    values = [
        [
            ev.ape.rmse,
            ev.rpe.rmse,
            math.degrees(ev.rpe_rot.rmse),
            ev.drift.endpoint_error,
            ev.drift.translation_pct,
            ev.drift.rotation_deg_per_m,
        ]
        for _, ev in rows
    ]
    names = [name for name, _ in rows]
    for i, (name, vals) in enumerate(zip(names, values, strict=True)):
        table.add_row(
            markup_text(name),
            *(f"{v:.{d}f}" for v, d in zip(vals, decimals, strict=True)),
            end_section=i == len(rows) - 1,
        )
    for label, vals in _mean_rows(names, values) if values else []:
        table.add_row(
            markup_text(label), *(f"{v:.{d}f}" for v, d in zip(vals, decimals, strict=True))
        )
    print_table(console(), table)


@calibrate_app.command("lsq")
def calibrate_lsq_cmd(
    runs: Annotated[list[Path], typer.Argument(help="Runs (files or folders) with ground truth.")],
    output: Annotated[Path, typer.Option("--output", "-o", help="New parameters TOML.")],
    fmt: Annotated[RunFormat, typer.Option("--format", "-f", help="Run format.")] = (
        RunFormat.optiodom
    ),
    params: ParamsOpt = None,
    validate: Annotated[
        list[Path] | None,
        typer.Option("--validate", help="Held-out runs to compare nominal vs calibrated."),
    ] = None,
    segment: Annotated[float, typer.Option(help="Segment length (s) of the residuals.")] = 2.0,
    no_gt_yaw_offset: Annotated[
        bool,
        typer.Option(
            "--no-gt-yaw-offset", help="Do not estimate the ground truth's yaw mounting offset."
        ),
    ] = False,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the report here.")] = None,
    workers: WorkersOpt = 2,
    scheduler: SchedulerOpt = None,
    joint_topic: JointTopicOpt = "/joint_states",
    joints: JointsOpt = ("left_wheel_joint", "right_wheel_joint"),
    gt_topic: GtTopicOpt = "/ground_truth",
    model: Annotated[
        ModelChoice,
        typer.Option(help="Kinematic model to fit (docs/models.md): diff, extended or icr."),
    ] = ModelChoice.diff,
    ground_truth: Annotated[
        Path | None,
        typer.Option(
            "--ground-truth",
            help="The ground truth of the one run given (trajectory CSV or TUM, e.g. from "
            "`odolab track` or `calibrate sensor --truth-out`), replacing the run's own.",
        ),
    ] = None,
) -> None:
    """Least-squares kinematic model (radii and track width, or ICRs) from runs with ground truth."""
    from dataclasses import replace

    from odolab.calibration.lsq import LsqOptions, calibrate_lsq_files
    from odolab.cli._fleet import expand_runs
    from odolab.errors import OdolabError
    from odolab.metrics.cluster import Cluster
    from odolab.params import load_params, save_params

    cluster = Cluster(scheduler=scheduler, workers=workers)
    if ground_truth is not None:  # checked before any run is read
        if len(runs) != 1 or validate:
            raise OdolabError(
                f"--ground-truth is one run's ground truth; expected exactly one run and no "
                f"--validate, got {len(runs)} run(s)" + (" and --validate" if validate else "")
            )
        if not ground_truth.is_file():
            raise OdolabError(f"--ground-truth {ground_truth}: no such file")
    if any(not p.exists() for p in [*runs, *(validate or [])]):  # glob patterns
        runs = expand_runs(runs, fmt.value)
        validate = expand_runs(validate, fmt.value) if validate else validate
    robot = load_params(params) if params else None
    ro = _read_options(robot, joint_topic, joints, gt_topic)
    if ground_truth is not None:
        ro = replace(ro, ground_truth=str(ground_truth))
    with _progress_bar("calibrate") as report:
        result = calibrate_lsq_files(
            runs,
            fmt.value,
            nominal=robot,
            validate=validate or [],
            options=LsqOptions(
                segment_s=segment, fit_gt_yaw_offset=not no_gt_yaw_offset, model=model.value
            ),
            read_options=ro,
            workers=workers,
            progress=report,
            cluster=cluster,
        )
    save_params(output, result.params, provenance=result.provenance)
    _write_json(result.to_dict(), json_out)
    _print_calibration(result, output)


def _print_calibration(result: Any, output: Path) -> None:
    import math

    from rich.table import Table

    from odolab.cli._console import console as make_console
    from odolab.cli._console import print_table

    console = make_console()
    table = Table(
        title=f"least-squares calibration ({len(result.runs)} runs, "
        f"{result.segments} segments) -> {output}"
    )
    for col in ("parameter", "nominal", "calibrated", "std error"):
        table.add_column(col, justify="right")
    nominal, fitted = result.nominal_values, result.values
    for key, err in result.stderr.items():
        table.add_row(key, f"{nominal[key]:.6f}", f"{fitted[key]:.6f}", f"{err:.2e}")
    print_table(console, table)
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
            f"{x[0]:.4f} -> {x[1]:.4f}",
            f"{x[2]:.2f} -> {x[3]:.2f}",
            f"{x[4]:.3f} -> {x[5]:.3f}",
            end_section=i == len(rows) - 1,
        )
    print_table(console, val)
    if math.isfinite(result.rms_after):
        console.print(f"residual rms {result.rms_before:.5f} -> {result.rms_after:.5f} m")
