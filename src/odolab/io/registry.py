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

from odolab.core.defaults import LogFormat
from odolab.core.errors import LogFormatError  # (defined there: the CLI names them at no cost)
from odolab.io.csv_run import CsvRunReader
from odolab.io.optiodom import OptiOdomReader, is_optiodom_run
from odolab.io.rosbag import RosbagReader, is_bag
from odolab.io.run import OdometryRun, ReadOptions
from odolab.io.trajectory_csv import read_trajectory
from odolab.io.windows import WindowTableReader, is_window_table

__all__ = [
    "READERS",
    "LogFormat",
    "RunReader",
    "detect_format",
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
    LogFormat.DRIVE: WindowTableReader(),
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


def _format_of(p: Path) -> LogFormat | None:
    """The format of the runs at ``p`` (a file or a folder), None when it holds none."""
    if is_window_table(p):
        return LogFormat.DRIVE
    if p.is_file():
        if is_bag(p):
            return LogFormat.BAG
        return LogFormat.OPTIODOM if is_optiodom_run(p) else LogFormat.CSV
    if not p.is_dir():
        return None
    if (p / "metadata.yaml").is_file():
        return LogFormat.BAG
    if any(is_optiodom_run(q) for q in p.rglob("*_run-*.csv")):
        return LogFormat.OPTIODOM
    if any(not q.stem.endswith("_gt") for q in p.glob("*.csv")):
        return LogFormat.CSV
    if any(is_bag(q) for q in p.iterdir()):
        return LogFormat.BAG
    return None


def detect_format(paths: Iterable[str | Path]) -> tuple[LogFormat, str]:
    """The format of the runs at ``paths`` and one clause saying why.

    A bag (``.bag``, ``.mcap``, ``.db3``, a folder with ``metadata.yaml``); an OptiOdom run
    (``<id>_run-NN.csv`` beside its ``<id>_metadata.csv``); any other CSV is odolab's own encoder
    log, and so is a path that does not exist yet (a glob pattern). Paths of two formats are
    refused: one sentence asks for ``--format``.

    Raises:
        LogFormatError: the runs are of several formats, or of none odolab reads.
    """
    found: dict[LogFormat, Path] = {}
    for raw in paths:
        fmt = _format_of(Path(raw))
        if fmt is not None:
            found.setdefault(fmt, Path(raw))
    if len(found) > 1:
        (a, pa), (b, pb) = list(found.items())[:2]
        raise LogFormatError(
            f"{pa} holds {a.value} runs but {pb} holds {b.value} runs; expected runs of one "
            "format (give {{format}})"
        )
    if not found:
        return LogFormat.CSV, "odolab's own encoder log CSV (nothing else found)"
    fmt, where = next(iter(found.items()))
    why = {
        LogFormat.CSV: "odolab's own encoder log CSV (no OptiOdom <id>_metadata.csv beside it)",
        LogFormat.OPTIODOM: "OptiOdom runs (<id>_run-NN.csv beside <id>_metadata.csv)",
        LogFormat.BAG: "a ROS bag",
        LogFormat.DRIVE: "a window table (DRIVE's window, calib_step, wheel speeds, icp_x/y/yaw)",
    }[fmt]
    return fmt, f"{why}, found at {where}"
