"""Copy what can still be read of a damaged notebook into a new one (``odolab notebook rescue``).

A damaged page of a SQLite file makes every query that reads it fail, so a plain export stops at
the first bad page. The rescue reads each table by rowid instead: when a stretch of rows cannot be
read, it looks for the first rowid after it that can (doubling steps, then a binary search) and
goes on from there. Every row read is inserted into a new notebook with the schema's constraints
on (a row that breaks one is dropped); every parameter version must build a valid parameter set
and every trial must load and pass :func:`odolab.core.trials.validate_trial` (or it is dropped, with
its encoder log and history). What is rescued is what SQLite could read: a value changed inside a
readable page (a flipped bit in a number) cannot be told from the truth.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from odolab.core.errors import OdolabError, StoreError
from odolab.core.trials import validate_trial
from odolab.store.health import NotebookFileError, check_notebook_file
from odolab.store.notebook import Notebook
from odolab.store.records import params_from_columns
from odolab.store.schema import SCHEMA_VERSION

__all__ = ["RescueReport", "rescue_notebook"]

#: The tables in the order their rows can be inserted (parents first).
TABLES = ("robots", "params_versions", "campaigns", "trials", "encoder_logs",
          "measurement_history")  # fmt: skip
_MAX_ROWID = 2**63 - 1


@dataclass
class RescueReport:
    """Rows kept per table, rows dropped (unreadable stretches, broken rows), dropped trials."""

    kept: dict[str, int] = field(default_factory=dict)
    unreadable_stretches: dict[str, int] = field(default_factory=dict)
    broken_rows: dict[str, int] = field(default_factory=dict)
    dropped_trials: list[str] = field(default_factory=list)

    @property
    def trials(self) -> int:
        return self.kept.get("trials", 0)


def _seek_ok(conn: sqlite3.Connection, table: str, at: int) -> int | bool | None:
    """The first rowid >= ``at`` (None: there is none), or False when the seek meets damage."""
    try:
        row = conn.execute(
            f"SELECT rowid FROM {table} WHERE rowid >= ? ORDER BY rowid LIMIT 1", (at,)
        ).fetchone()
    except sqlite3.DatabaseError:
        return False
    return None if row is None else int(row[0])


def _skip(conn: sqlite3.Connection, table: str, bad: int) -> int | None:
    """The first readable rowid after the damage met at ``bad`` (None: nothing after it)."""
    step, lo, hi = 1, bad, None
    while hi is None:  # doubling steps until a seek succeeds
        probe = min(bad + step, _MAX_ROWID)
        found = _seek_ok(conn, table, probe)
        if found is None:
            return None
        if found is False:
            if probe >= _MAX_ROWID:
                return None
            lo, step = probe, step * 2
        else:
            hi = probe
    while hi - lo > 1:  # the smallest seek that succeeds: no readable row is skipped
        mid = (lo + hi) // 2
        if _seek_ok(conn, table, mid) is False:
            lo = mid
        else:
            hi = mid
    first = _seek_ok(conn, table, hi)
    return None if first is None or first is False else int(first)


def _readable_rows(
    conn: sqlite3.Connection, table: str, columns: list[str], report: RescueReport
) -> Iterator[tuple[object, ...]]:
    """``(rowid, *columns)`` of every row of ``table`` SQLite can read, in rowid order."""
    cols = ", ".join(["rowid", *columns])
    start: int | None = -_MAX_ROWID - 1
    while start is not None:
        last = start - 1
        try:
            cur = conn.execute(
                f"SELECT {cols} FROM {table} WHERE rowid >= ? ORDER BY rowid", (start,)
            )
            for row in cur:
                last = int(row[0])
                yield tuple(row)
            return
        except sqlite3.DatabaseError:
            report.unreadable_stretches[table] = report.unreadable_stretches.get(table, 0) + 1
            start = _skip(conn, table, last + 1)


def _columns(conn: sqlite3.Connection, table: str) -> list[str]:
    """The columns of ``table``, without an ``INTEGER PRIMARY KEY`` (it is the rowid)."""
    info = list(conn.execute(f"PRAGMA table_info({table})"))
    keys = [r for r in info if int(r[5]) > 0]
    alias = keys[0][1] if len(keys) == 1 and str(keys[0][2]).upper() == "INTEGER" else None
    return [str(r[1]) for r in info if r[1] != alias]


def rescue_notebook(damaged: str | Path, new: str | Path) -> RescueReport:
    """Copy every readable, valid record of the notebook ``damaged`` into the new notebook
    ``new`` (which must not exist); ``damaged`` is only read.

    Raises:
        NotebookFileError: the source is missing or cannot be opened.
        StoreError: the destination exists, the schema is not the current one, or the table list is
            damaged.
    """
    src, dst = Path(damaged), Path(new)
    if not check_notebook_file(src):
        raise NotebookFileError(f"{src}: no such notebook to rescue")
    if dst.exists():
        raise StoreError(
            f"{dst}: already exists; expected a new file name for the rescued notebook"
        )
    try:
        conn = sqlite3.connect(f"{src.resolve().as_uri()}?mode=ro", uri=True)
    except sqlite3.Error as err:
        raise StoreError(f"{src}: cannot open it to rescue ({err})") from err
    report = RescueReport()
    try:
        try:
            version = int(conn.execute("PRAGMA user_version").fetchone()[0])
            tables = {str(r[0]) for r in conn.execute("SELECT name FROM sqlite_master")}
        except sqlite3.DatabaseError as err:
            raise StoreError(
                f"{src}: its table list is damaged ({err}); nothing can be rescued by odolab "
                "(try SQLite's `sqlite3 FILE .recover`)"
            ) from err
        if version != SCHEMA_VERSION or not set(TABLES) <= tables:
            raise StoreError(
                f"{src}: schema {version}; the rescue reads notebooks of schema {SCHEMA_VERSION} "
                "(an older one: open a copy of it with this odolab first, if it still opens)"
            )
        with Notebook(dst) as nb:
            _copy(conn, nb, report)
            _drop_invalid(nb, report)
    finally:
        conn.close()
    return report


def _copy(src: sqlite3.Connection, nb: Notebook, report: RescueReport) -> None:
    with nb._write() as out:
        for table in TABLES:
            theirs = set(_columns(src, table))
            columns = [c for c in _columns(out, table) if c in theirs]
            insert = (
                f"INSERT INTO {table} (rowid, {', '.join(columns)}) "
                f"VALUES ({', '.join('?' * (len(columns) + 1))})"
            )
            kept = broken = 0
            for row in _readable_rows(src, table, columns, report):
                values = dict(zip(columns, row[1:], strict=True))
                if table == "params_versions" and not _valid_params(values):
                    broken += 1
                    continue
                try:
                    out.execute("SAVEPOINT row")
                    out.execute(insert, row)
                    out.execute("RELEASE row")
                    kept += 1
                except sqlite3.Error:
                    out.execute("ROLLBACK TO row")
                    out.execute("RELEASE row")
                    broken += 1
            report.kept[table] = kept
            if broken:
                report.broken_rows[table] = broken
        # a child whose parent was lost (a trial of an unreadable campaign, ...) goes too
        orphans = {(str(r[0]), int(r[1])) for r in out.execute("PRAGMA foreign_key_check")}
        for table, rowid in sorted(orphans):
            out.execute(f"DELETE FROM {table} WHERE rowid = ?", (rowid,))
            report.kept[table] -= 1
            report.broken_rows[table] = report.broken_rows.get(table, 0) + 1


def _valid_params(values: dict[str, object]) -> bool:
    try:
        params_from_columns(values, "rescued parameter version")
    except (OdolabError, ValueError, TypeError, KeyError):
        return False
    return True


def _drop_invalid(nb: Notebook, report: RescueReport) -> None:
    """Trials that do not load (or fail validate_trial) are dropped with their logs."""
    bad = []
    for tid in sorted(nb.trial_ids()):
        try:
            validate_trial(nb.get_trial(tid))
        except OdolabError:
            bad.append(tid)
    if not bad:
        return
    with nb._write() as conn:
        for tid in bad:
            conn.execute("DELETE FROM measurement_history WHERE trial_id = ?", (tid,))
            conn.execute("DELETE FROM encoder_logs WHERE trial_id = ?", (tid,))
            conn.execute("DELETE FROM trials WHERE trial_id = ?", (tid,))
    report.dropped_trials = bad
    report.kept["trials"] -= len(bad)
