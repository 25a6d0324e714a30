"""Many runs in the terminal: expanding folders and globs, the fleet summary, failures."""

from __future__ import annotations

import glob
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.cli._output import markup_text, term
from odolab.cli.wording import said
from odolab.core.errors import OdolabError

if TYPE_CHECKING:
    from rich.console import JustifyMethod
    from rich.table import Table

    from odolab.core.params import RobotParams
    from odolab.metrics.cluster import MapReport, Outcome, R
    from odolab.metrics.runs import RunEvaluation

__all__ = ["expand_logs", "expand_runs", "odometry_many", "print_fleet", "report_failures"]

_GLOB = set("*?[")


def expand_runs(paths: Sequence[Path], fmt: str) -> list[Path]:
    """Every run under ``paths``: files, folders, and glob patterns (quoted, ``**`` allowed).

    CSV runs are searched for recursively in folders (``<robot>/<date>/run.csv`` layouts);
    other formats find their runs as their reader does.
    """
    from odolab.io.registry import find_runs

    out: list[Path] = []
    seen: set[Path] = set()

    def add(found: list[Path]) -> None:
        for q in found:
            if q not in seen:
                seen.add(q)
                out.append(q)

    for p in paths:
        text = str(p)
        if not p.exists() and _GLOB & set(text):
            matches = sorted(Path(m) for m in glob.glob(text, recursive=True))  # noqa: PTH207
            if not matches:
                raise OdolabError(f"{text}: no file matches this pattern; expected runs")
            add(find_runs(matches, fmt) if fmt != "csv" else _csv_files(matches))
        elif fmt == "csv" and p.is_dir():
            found = _csv_files(sorted(p.rglob("*.csv")))
            if not found:
                raise OdolabError(f"{p}: no encoder CSV logs (*.csv) in this folder or below")
            add(found)
        else:
            add(find_runs([p], fmt))
    return out


def _csv_files(paths: Sequence[Path]) -> list[Path]:
    return [q for q in paths if q.is_file() and not q.stem.endswith("_gt")]


def _f(value: object, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.{digits}f}"


def _name_column(
    table: Table, header: str, names: Sequence[object], justify: JustifyMethod = "right"
) -> None:
    """A column of names (run, robot, date) never cut: as wide as its longest name."""
    width = max([len(header), *(len(markup_text(n)) for n in names)])
    table.add_column(header, justify=justify, no_wrap=True, min_width=width)


def print_fleet(outcomes: Sequence[Outcome[RunEvaluation]], *, worst: int = 5) -> None:
    """The fleet summary: per robot, per robot and day, and the worst runs."""
    from rich.console import Console
    from rich.table import Table

    from odolab.fleet.table import fleet_rows, summarize

    s = summarize(fleet_rows(outcomes), worst=worst)
    console = Console()
    t = Table(title=f"fleet: {len(outcomes)} runs, per robot (drift in % of distance)")
    # names whole on a narrow terminal (the numbers' headers wrap instead)
    _name_column(t, "robot", [r["robot"] for r in s.per_robot])
    for col in ("runs", "failed", "km", "drift % mean", "drift % max", "deg/m", "end %"):
        t.add_column(col, justify="right")
    for r in s.per_robot:
        t.add_row(
            markup_text(r["robot"]),
            str(r["runs"]),
            str(r["failed"] or 0),
            _f((r["metres"] or 0.0) / 1000.0),
            _f(r["drift_pct_mean"], 2),
            _f(r["drift_pct_max"], 2),
            _f(r["deg_per_m_mean"], 3),
            _f(r["endpoint_pct_mean"], 2),
        )
    console.print(t)
    d = Table(title="per robot and day: drift % mean (runs)")
    dates = sorted({str(r["date"]) for r in s.per_day})
    robots = sorted({str(r["robot"]) for r in s.per_day})
    cell = {(str(r["robot"]), str(r["date"])): r for r in s.per_day}
    _name_column(d, "robot", robots, justify="left")
    for day in dates:
        d.add_column(markup_text(day) or "(no date)", justify="right")
    for robot in robots:
        row = [markup_text(robot)]
        for day in dates:
            c = cell.get((robot, day))
            row.append(f"{_f(c['drift_pct_mean'], 2)} ({c['runs']})" if c else "")
        d.add_row(*row)
    console.print(d)
    w = Table(title=f"worst {len(s.worst)} runs by drift")
    for col in ("run", "robot", "date"):
        _name_column(w, col, [r[col] for r in s.worst])
    for col in ("drift %", "end err m", "length m"):
        w.add_column(col, justify="right")
    for r in s.worst:
        w.add_row(
            markup_text(r["run"]),
            markup_text(r["robot"]),
            markup_text(r["date"]),
            _f(r["drift_pct"], 2),
            _f(r["endpoint_error_m"], 3),
            _f(r["length_m"], 1),
        )
    console.print(w)


def report_failures(
    outcomes: Sequence[Outcome[R]], report: MapReport, results: Path | None
) -> None:
    """Print each failed run with its error, the lost workers; raise when any run failed."""
    from rich.console import Console

    console = Console(stderr=True)
    loss = report.loss_text()
    if loss:
        console.print(f"note: {term(loss)}", markup=False)
    failed = [o for o in outcomes if not o.ok]
    if not failed:
        return
    shown = failed[:20]
    for o in shown:
        console.print(f"failed: {term(said(o.error))}", markup=False, soft_wrap=True)
    if len(failed) > len(shown):
        console.print(f"... and {len(failed) - len(shown)} more failed runs", markup=False)
    kept = f"; the other results are in {results}" if results is not None else ""
    raise OdolabError(f"{len(failed)} of {len(outcomes)} runs failed (listed above){kept}")


_LOG_SUFFIXES = (".csv", ".parquet", ".pq", ".arrow", ".feather", ".ipc")


def expand_logs(paths: Sequence[Path]) -> list[Path]:
    """Encoder logs: files, folders (recursively; not ``*_gt.*``), quoted glob patterns."""
    out: list[Path] = []
    seen: set[Path] = set()
    for p in paths:
        text = str(p)
        if p.is_dir():
            found = sorted(q for q in p.rglob("*") if q.suffix.lower() in _LOG_SUFFIXES)
        elif not p.exists() and _GLOB & set(text):
            found = sorted(Path(m) for m in glob.glob(text, recursive=True))  # noqa: PTH207
            if not found:
                raise OdolabError(f"{text}: no file matches this pattern; expected encoder logs")
        elif p.is_file():
            found = [p]
        else:
            raise OdolabError(f"{p}: no such encoder log, folder or pattern")
        for q in found:
            if q.is_file() and not q.stem.endswith("_gt") and q not in seen:
                seen.add(q)
                out.append(q)
    if not out:
        raise OdolabError(
            f"no encoder logs ({', '.join(_LOG_SUFFIXES)}) under {', '.join(map(str, paths))}"
        )
    return out


def odometry_many(
    logs: Sequence[Path],
    params: RobotParams,
    output: Path,
    *,
    method: str,
    start: tuple[float, float, float] | None,
    max_dticks: int | None,
    chunk_rows: int,
    workers: int | None,
    scheduler: str | None,
    covariance: bool = False,
) -> None:
    """``odolab odometry`` over many logs on Dask; one trajectory file per log under ``output``."""
    import os

    from rich.console import Console

    from odolab.cli._progress import progress_bar
    from odolab.io.chunked import OdometryJob, run_odometry_job
    from odolab.metrics.cluster import Cluster, MapReport, map_outcomes

    cluster = Cluster(scheduler=scheduler, workers=workers)
    files = expand_logs(logs)
    if output.suffix and not output.is_dir():
        raise OdolabError(
            f"--output {output} looks like a file; with many logs it must be a folder"
        )
    root = Path(os.path.commonpath([str(f.resolve().parent) for f in files]))
    jobs = [
        OdometryJob(
            f,
            output / f.resolve().relative_to(root),
            params,
            method,
            start,
            max_dticks,
            chunk_rows,
            covariance,
        )
        for f in files
    ]
    rep = MapReport(cluster.describe())
    with progress_bar("odometry", unit="logs") as report:
        outcomes = map_outcomes(
            run_odometry_job,
            jobs,
            cluster=cluster,
            progress=report,
            label=lambda j: str(j.log),
            report=rep,
        )
    rows = sum(o.result.rows for o in outcomes if o.result is not None)
    ok = sum(1 for o in outcomes if o.ok)
    Console().print(
        f"{ok} of {len(outcomes)} logs -> {term(str(output))} ({rows:,} poses; "
        f"{said(rep.where)}, {rep.seconds:.1f} s)",
        markup=False,
    )
    report_failures(outcomes, rep, None)
