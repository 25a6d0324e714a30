"""One registry of run readers, keyed by :class:`LogFormat`, each behind :class:`RunReader`.

The readers never import the registry (it imports them); :func:`read_trajectory` lives in
:mod:`odolab.io.trajectory_csv` and is re-exported here.

A *run* is one recorded drive: wheel increments and, where the log has it, ground truth and
nominal parameters (:class:`odolab.io.run.OdometryRun`). Every format answers two questions: which
runs lie under a path (``find``), and what one of them holds (``read``).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Protocol

from odolab.defaults import LogFormat  # (defined there: the CLI names them at no cost)
from odolab.io.csv_run import CsvRunReader
from odolab.io.optiodom import OptiOdomReader
from odolab.io.rosbag import RosbagReader
from odolab.io.run import OdometryRun, ReadOptions
from odolab.io.trajectory_csv import read_trajectory

__all__ = [
    "READERS",
    "LogFormat",
    "RunReader",
    "find_runs",
    "read_run",
    "read_trajectory",
]


class RunReader(Protocol):
    """What every run format provides."""

    def find(self, path: Path) -> list[Path]:
        """The runs at or under ``path`` (a file, or a folder of runs)."""
        ...

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """One run."""
        ...


READERS: dict[LogFormat, RunReader] = {
    LogFormat.CSV: CsvRunReader(),
    LogFormat.OPTIODOM: OptiOdomReader(),
    LogFormat.BAG: RosbagReader(),
}


def find_runs(paths: Iterable[str | Path], fmt: LogFormat | str) -> list[Path]:
    """Every run at or under each of ``paths``, in order, without repeats."""
    reader = READERS[LogFormat(fmt)]
    out: list[Path] = []
    seen: set[Path] = set()
    for p in paths:
        for run in reader.find(Path(p)):
            if run not in seen:
                seen.add(run)
                out.append(run)
    return out


def read_run(
    path: str | Path, fmt: LogFormat | str, options: ReadOptions | None = None
) -> OdometryRun:
    """Read one run in the given format."""
    return READERS[LogFormat(fmt)].read(Path(path), options or ReadOptions())
