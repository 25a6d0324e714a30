"""A rich progress bar for long CLI work; library code reports through a callback."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["progress_bar"]


@contextmanager
def progress_bar(
    label: str, *, unit: str = "", of_total: bool = False
) -> Iterator[Callable[[int, int, str], None]]:
    """Yield ``report(done, total, name)``; a total of 0 means unknown. Silent off a terminal.
    ``of_total``: show "done/total" (runs) instead of the count done (rows)."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        ProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    count: ProgressColumn = (
        MofNCompleteColumn()
        if of_total
        else TextColumn("{task.completed:,} " + unit if unit else "{task.completed:,}")
    )
    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        count,
        TimeElapsedColumn(),
        TextColumn("{task.fields[name]}"),
        transient=True,
        console=console,
        disable=not console.is_terminal,
    ) as bar:
        task = bar.add_task(label, total=None, name="")

        def report(done: int, total: int, name: str) -> None:
            bar.update(task, completed=done, total=total or None, name=Path(name).name)

        yield report
