"""Printing tables without cutting numbers.

A rich table squeezed into a narrow terminal wraps or truncates its cells (``[0.91…``). Here
the width is: ``COLUMNS`` when set, else the terminal's width, else (output to a file or a
pipe) as wide as the widest table needs. A table that is wider than that is printed as plain
``name: value`` blocks, one per row, so that every number is whole. Output to a file or pipe
is plain text (no colours, no escape codes).
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterable

    from rich.console import Console
    from rich.table import Table

__all__ = ["HELP_WIDTH_PIPED", "console", "fit_table", "print_table", "wide_help_when_piped"]

#: Width of ``--help`` written to a file or a pipe: rich's tables at its default (80) cut option
#: names (``--pairs-from-re…``) and split lists of choices; at this width none is cut.
HELP_WIDTH_PIPED = 132


def _columns() -> int | None:
    raw = os.environ.get("COLUMNS", "").strip()
    if raw.isdigit() and int(raw) > 0:
        return int(raw)
    return None


def console(*, stderr: bool = False) -> Console:
    """A console for the CLI's output: plain when not a terminal, ``COLUMNS`` honoured."""
    from rich.console import Console

    stream = sys.stderr if stderr else sys.stdout
    tty = stream.isatty()
    width = _columns()
    if width is None and not tty:
        width = 10_000  # a file or a pipe: lines as long as their content, never wrapped
    return Console(
        file=stream,
        width=width,
        force_terminal=tty,
        no_color=not tty,
        highlight=False,
        soft_wrap=not tty,  # a file or a pipe: one line per line, whatever COLUMNS says
    )


def wide_help_when_piped() -> None:
    """Typer's help never cuts an option name or a list of choices: only the description column
    of its tables wraps (rich would shrink every column, folding ``<csv|optiodom|b`` / ``ag>``),
    and when the stream is not a terminal the help is as wide as :data:`HELP_WIDTH_PIPED` (or
    ``COLUMNS``, if wider; ``TERMINAL_WIDTH`` still wins)."""
    from rich.table import Table
    from typer import rich_utils

    make = rich_utils._get_rich_console
    if getattr(make, "_odolab", False):
        return

    class HelpTable(Table):
        """A help table whose columns but the last (the description) never wrap."""

        def add_row(self, *renderables: Any, **kwargs: Any) -> None:
            super().add_row(*renderables, **kwargs)
            for column in self.columns[:-1]:
                column.no_wrap = True

    setattr(rich_utils, "Table", HelpTable)  # noqa: B010 (typer names it; no public hook)

    def wide(stderr: bool = False) -> Console:
        con = make(stderr=stderr)
        stream = sys.stderr if stderr else sys.stdout
        isatty = getattr(stream, "isatty", None)
        if rich_utils.MAX_WIDTH is None and not (isatty is not None and isatty()):
            con.width = max(_columns() or 0, HELP_WIDTH_PIPED)
        return con

    wide._odolab = True  # type: ignore[attr-defined]
    rich_utils._get_rich_console = wide


def fit_table(
    title: str, stderr: str, rows: Iterable[tuple[str, float | None, float, float]]
) -> Table:
    """A calibration's parameters: name, nominal ("-" when none), calibrated and the standard
    error (its column headed ``stderr``), one row per (name, nominal, calibrated, error)."""
    from rich.table import Table

    table = Table(title=title)
    for col in ("parameter", "nominal", "calibrated", stderr):
        table.add_column(col, justify="right")
    for key, nominal, value, err in rows:
        table.add_row(
            key, "-" if nominal is None else f"{nominal:.6f}", f"{value:.6f}", f"{err:.2e}"
        )
    return table


def _natural_width(con: Console, table: Table) -> int:
    """The width ``table`` needs to show every cell on its own lines, unwrapped."""
    import io

    from rich.console import Console

    return Console(width=10_000, file=io.StringIO()).measure(table).maximum


def print_table(con: Console, table: Table) -> None:
    """Print ``table`` whole: as a table when it fits ``con``, else as plain blocks."""
    need = _natural_width(con, table)
    if need <= con.width:
        for col in table.columns:
            col.no_wrap = True
        con.print(table, width=min(con.width, need))
        return
    con.print(_as_blocks(table), soft_wrap=True, markup=False, highlight=False)


def _plain(cell: object) -> str:
    from rich.text import Text

    if isinstance(cell, Text):
        return cell.plain
    return Text.from_markup(str(cell)).plain if isinstance(cell, str) else str(cell)


def _as_blocks(table: Table) -> str:
    """One block per row: ``header: value`` lines (multi-line cells indented)."""
    headers = [_plain(c.header) for c in table.columns]
    cells = [list(c.cells) for c in table.columns]
    rows = len(cells[0]) if cells else 0
    out: list[str] = []
    title = _plain(table.title) if table.title else ""
    if title:
        out.append(title)
        out.append("")
    for i in range(rows):
        for h, col in zip(headers, cells, strict=True):
            value = _plain(col[i])
            lines = value.split("\n") if value else ["-"]
            out.append(f"{h}: {lines[0]}")
            out.extend(" " * (len(h) + 2) + line for line in lines[1:])
        out.append("")
    return "\n".join(out).rstrip("\n")
