"""The fleet table: one row per run (robot, date, length, APE/RPE, drift, end-point error).

Robot and date come from the run's path: ``.../<robot>/<YYYY-MM-DD>/<run>.<ext>`` (the layout
:func:`odolab.fleet.simulate_fleet` writes and a fleet's log store typically has); a path without
a date folder gives the run's folder name as robot and an empty date. A run that failed keeps its
row, with its error and no numbers.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.metrics.cluster import Outcome
from odolab.metrics.runs import RunEvaluation

if TYPE_CHECKING:
    import polars as pl

__all__ = [
    "COLUMNS",
    "FleetSummary",
    "fleet_rows",
    "read_fleet_table",
    "robot_and_date",
    "summarize",
    "write_fleet_table",
]

_DATE = re.compile(r"^\d{4}-\d{2}-\d{2}$")
_SESSION = re.compile(r"^\d{12}$")  # OptiOdom: DDMMYYYYHHMM

#: Columns of the fleet table, in order (lengths m, angles deg, drift % of distance).
COLUMNS = (
    "run",
    "source",
    "robot",
    "date",
    "error",
    "samples",
    "duration_s",
    "length_m",
    "ape_rmse_m",
    "ape_mean_m",
    "ape_median_m",
    "ape_max_m",
    "ape_rot_rmse_deg",
    "rpe_rmse_m",
    "rpe_mean_m",
    "rpe_max_m",
    "rpe_rot_rmse_deg",
    "drift_pct",
    "drift_deg_per_m",
    "endpoint_error_m",
    "endpoint_pct",
)
_TEXT = ("run", "source", "robot", "date", "error")

#: One cell of the table: text (``_TEXT``, an error may be None), the sample count, or a number.
Cell = str | int | float | None


def _session_date(name: str) -> str | None:
    """An OptiOdom session folder's date: its id is the date-time ``DDMMYYYYHHMM``
    (``231220200121``: 23 Dec 2020, 01:21) -> ``2020-12-23``; None for any other name."""
    if not _SESSION.match(name):
        return None
    import datetime

    try:
        when = datetime.datetime.strptime(name, "%d%m%Y%H%M")
    except ValueError:
        return None
    return when.date().isoformat()


def robot_and_date(path: str | Path) -> tuple[str, str]:
    """``(robot, date)`` from ``.../<robot>/<YYYY-MM-DD>/<run>`` or OptiOdom's
    ``.../<kind>/<DDMMYYYYHHMM>/<run>``; else (folder name, '')."""
    p = Path(path)
    parents = [q.name for q in p.parents]
    for k, name in enumerate(parents):
        day = name if _DATE.match(name) else _session_date(name)
        if day is not None:
            robot = parents[k + 1] if k + 1 < len(parents) else ""
            return robot, day
    return (parents[0] if parents else ""), ""


def _row(o: Outcome[RunEvaluation]) -> dict[str, Cell]:
    robot, date = robot_and_date(o.label)
    row: dict[str, Cell] = dict.fromkeys(COLUMNS, math.nan)
    row.update(run=Path(o.label).stem, source=o.label, robot=robot, date=date, error=o.error)
    row["samples"] = 0
    r = o.result
    if r is None:
        return row
    ev = r.evaluation
    d = ev.drift
    row.update(
        samples=ev.pairs,
        duration_s=r.duration_s,
        length_m=d.path_length,
        ape_rmse_m=ev.ape.rmse,
        ape_mean_m=ev.ape.mean,
        ape_median_m=ev.ape.median,
        ape_max_m=ev.ape.max,
        ape_rot_rmse_deg=math.degrees(ev.ape_rot.rmse),
        rpe_rmse_m=ev.rpe.rmse,
        rpe_mean_m=ev.rpe.mean,
        rpe_max_m=ev.rpe.max,
        rpe_rot_rmse_deg=math.degrees(ev.rpe_rot.rmse),
        drift_pct=d.translation_pct,
        drift_deg_per_m=d.rotation_deg_per_m,
        endpoint_error_m=d.endpoint_error,
        endpoint_pct=d.endpoint_pct,
    )
    return row


def fleet_rows(outcomes: Sequence[Outcome[RunEvaluation]]) -> dict[str, list[Cell]]:
    """The fleet table as columns (``COLUMNS``), one row per outcome, in order."""
    rows = [_row(o) for o in outcomes]
    return {c: [r[c] for r in rows] for c in COLUMNS}


def _frame(columns: dict[str, list[Cell]]) -> pl.DataFrame:
    import polars as pl

    schema = {c: (pl.String if c in _TEXT else pl.Int64 if c == "samples" else pl.Float64)
              for c in COLUMNS}  # fmt: skip
    return pl.DataFrame(columns, schema=schema)


def write_fleet_table(columns: dict[str, list[Cell]], path: str | Path) -> Path:
    """Write the table: Parquet, Arrow IPC or CSV by the file's extension.

    The file is written beside ``path`` and then renamed over it (:mod:`odolab.core.writing`). In a
    CSV, a text cell a spreadsheet would run as a formula (a run or robot named ``=cmd()``, an
    error message starting with ``-``) gets a leading ``'`` (:func:`odolab.core.text.inert_csv_cell`);
    :func:`read_fleet_table` takes it off again.
    """
    from odolab.core.text import inert_csv_cell
    from odolab.io.tabular import table_format, write_frame

    p = Path(path)
    if table_format(p) == "csv":
        columns = dict(columns)
        for c in _TEXT:
            columns[c] = [None if v is None else inert_csv_cell(str(v)) for v in columns[c]]
    return write_frame(p, _frame(columns), "fleet table")  # through a temporary file


def read_fleet_table(path: str | Path) -> dict[str, list[Cell]]:
    """Read a fleet table written by :func:`write_fleet_table` (any of its formats).

    Raises:
        LogFormatError: the file is missing, unreadable, or lacks a fleet table column.
    """
    import polars as pl

    from odolab.core.errors import LogFormatError
    from odolab.io.tabular import table_format

    p = Path(path)
    if not p.is_file():
        raise LogFormatError(f"{p}: no such fleet table")
    fmt = table_format(p)
    try:
        if fmt == "parquet":
            frame = pl.read_parquet(p)
        elif fmt == "ipc":
            frame = pl.read_ipc(p)
        else:
            frame = pl.read_csv(p, schema_overrides={"date": pl.String, "error": pl.String})
    except (OSError, pl.exceptions.PolarsError) as err:
        raise LogFormatError(f"{p}: not a readable fleet table ({err})") from err
    missing = [c for c in COLUMNS if c not in frame.columns]
    if missing:
        raise LogFormatError(
            f"{p}: missing column {missing[0]!r}; expected a fleet table from odolab evaluate"
        )
    table = {c: frame[c].to_list() for c in COLUMNS}
    if fmt == "csv":  # text cells were written inert ("'=x" for "=x")
        from odolab.core.text import read_csv_cell

        for c in _TEXT:
            table[c] = [v if not isinstance(v, str) else read_csv_cell(v) for v in table[c]]
    return table


@dataclass(frozen=True)
class FleetSummary:
    """Per robot, per robot and day, and the worst runs (each a list of row dicts)."""

    per_robot: list[dict[str, Any]]  # polars' row dicts
    per_day: list[dict[str, object]]  # polars' row dicts
    worst: list[dict[str, object]]  # polars' row dicts
    failed: list[dict[str, object]]  # polars' row dicts


def summarize(columns: dict[str, list[Cell]], *, worst: int = 5) -> FleetSummary:
    """Per robot and per (robot, day): runs, failures, metres, mean/max drift, mean end error.

    ``worst``: the runs with the largest drift (% of distance), worst first.
    """
    import polars as pl

    frame = _frame(columns)
    ok = frame.filter(pl.col("error").is_null())
    aggs = [
        pl.len().alias("runs"),
        pl.col("length_m").sum().alias("metres"),
        pl.col("drift_pct").mean().alias("drift_pct_mean"),
        pl.col("drift_pct").max().alias("drift_pct_max"),
        pl.col("drift_deg_per_m").mean().alias("deg_per_m_mean"),
        pl.col("endpoint_pct").mean().alias("endpoint_pct_mean"),
        pl.col("ape_rmse_m").mean().alias("ape_rmse_mean_m"),
    ]
    failures = frame.group_by("robot").agg(pl.col("error").is_not_null().sum().alias("failed"))
    per_robot = (
        ok.group_by("robot")
        .agg(aggs)
        .join(failures, on="robot", how="full", coalesce=True)
        .with_columns(pl.col("runs").fill_null(0))
        .sort("robot")
    )
    per_day = ok.group_by(["robot", "date"]).agg(aggs).sort(["robot", "date"])
    worst_runs = (
        ok.filter(pl.col("drift_pct").is_not_nan())
        .sort("drift_pct", descending=True)
        .head(worst)
        .select(["run", "robot", "date", "drift_pct", "endpoint_error_m", "length_m", "source"])
    )
    failed = frame.filter(pl.col("error").is_not_null()).select(["source", "robot", "error"])
    return FleetSummary(
        per_robot.to_dicts(), per_day.to_dicts(), worst_runs.to_dicts(), failed.to_dicts()
    )
