"""Trajectory files: CSV with header ``t,x,y,theta,heading``, and TUM text.

The same columns in Parquet (``.parquet``) or Arrow IPC (``.arrow``, ``.feather``) are read and
written by extension (:mod:`odolab.io.tabular`); CSV numbers are the shortest round-trip text.

TUM format: one line per pose, ``timestamp tx ty tz qx qy qz qw`` (space separated, ``#``
comments); planar poses have ``tz = qx = qy = 0`` and the yaw in the quaternion.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal, overload

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError
from odolab.core.trajectory import Trajectory, check_positions, check_times, yaw_from_quaternions
from odolab.core.writing import path_first
from odolab.io._table import as_float64, data_line_numbers, read_numeric_columns
from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells
from odolab.io.tabular import (
    BINARY_SUFFIXES,
    read_columns,
    read_header,
    table_format,
    write_columns,
)

__all__ = [
    "heading_from_path",
    "read_trajectory",
    "read_trajectory_csv",
    "read_tum",
    "write_trajectory",
    "write_trajectory_csv",
    "write_tum",
]

COLUMNS = ("t", "x", "y", "theta", "heading")
TUM_COLUMNS = ("t", "tx", "ty", "tz", "qx", "qy", "qz", "qw")


@overload
def write_trajectory_csv(path: str | Path, traj: Trajectory) -> Path: ...
@overload
def write_trajectory_csv(path: Trajectory, traj: str | Path) -> Path: ...  # the old order
def write_trajectory_csv(path: str | Path | Trajectory, traj: Trajectory | str | Path) -> Path:
    """Write a trajectory table to ``path`` (every float in its shortest round-trip form; Parquet
    or Arrow IPC by extension)."""
    p, entry = path_first(path, traj, Trajectory, "write_trajectory_csv")
    columns = dict(
        zip(COLUMNS, (entry.t, entry.x, entry.y, entry.theta, entry.heading), strict=True)
    )
    what = "trajectory CSV" if table_format(p) == "csv" else "trajectory table"
    return write_columns(p, columns, what)


def heading_from_path(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Heading (rad, unwrapped) of a position-only path: the direction from each point to the
    next (the last point keeps the one before it); a point that repeats the one before keeps its
    heading. Right for a robot driving forwards; half a turn off where it reverses."""
    dx, dy = np.diff(x), np.diff(y)
    if len(dx) == 0:
        return np.zeros(len(x))
    still = np.hypot(dx, dy) == 0
    h = np.arctan2(dy, dx)
    for i in np.nonzero(still)[0]:
        h[i] = h[i - 1] if i > 0 else 0.0
    return np.asarray(np.unwrap(np.append(h, h[-1])), dtype=np.float64)


def trajectory_columns(header: list[str]) -> tuple[str, ...]:
    """The trajectory columns a file with this header is read by (``t,x,y`` alone: position-only
    ground truth, such as ``odolab track-photo`` writes)."""
    if "theta" not in header and "heading" not in header:
        return COLUMNS[:3]
    if "heading" in header and "theta" not in header:  # t,x,y,heading (odolab track writes it)
        return ("t", "x", "y", "heading")
    return COLUMNS if "heading" in header else COLUMNS[:4]


def read_trajectory_csv(path: str | Path) -> Trajectory:
    """Read a trajectory CSV; ``heading`` is optional (derived by unwrapping theta), and so is
    ``theta`` where ``heading`` is there (``t,x,y,heading``; theta is derived by wrapping); with
    neither (``t,x,y``, position-only ground truth) the heading is the path's tangent
    (:func:`heading_from_path`).

    Raises:
        LogFormatError: the file is missing, a folder, empty, or has a bad time or position (the
            line is named).
    """
    p = Path(path)
    if p.exists() and not p.is_file():
        raise LogFormatError(f"{p}: is not a file (a folder?); expected a trajectory CSV")
    if table_format(p) != "csv":
        header = read_header(p)
        d = as_float64(read_columns(p, trajectory_columns(header)))
        _check_some(p, d["t"].size)
        check_times(d["t"], str(p), row_offset=1, what="row")
        check_positions(d["x"], d["y"], str(p), line_of=lambda i: i + 1, what="row")
        return _trajectory(d)
    check_text_file(p, expected="a trajectory CSV")
    try:
        header = first_line_cells(p)  # checked text: the header without pandas' import
    except FileNotFoundError as err:
        raise LogFormatError(f"{p}: no such file") from err
    if not header:
        raise LogFormatError(f"{p}: empty file; expected header {','.join(COLUMNS)}")
    check_columns_unique(p, header)
    d = as_float64(read_columns(p, trajectory_columns(header), checked=True))
    _check_some(p, d["t"].size)

    def line_of(i: int) -> int:
        return int(data_line_numbers(p)[i])

    check_times(d["t"], str(p), line_of=line_of)
    check_positions(d["x"], d["y"], str(p), line_of=line_of)
    return _trajectory(d)


def _trajectory(d: dict[str, NDArray[np.float64]]) -> Trajectory:
    if "heading" in d:
        return Trajectory.from_xyh(d["t"], d["x"], d["y"], d["heading"])
    if "theta" in d:
        return Trajectory.from_xytheta(d["t"], d["x"], d["y"], d["theta"])
    return Trajectory.from_xyh(d["t"], d["x"], d["y"], heading_from_path(d["x"], d["y"]))


def _check_some(p: Path, rows: int) -> None:
    if rows == 0:
        raise LogFormatError(f"{p}: no poses after the header; expected at least one row")


@overload
def write_tum(path: str | Path, traj: Trajectory) -> Path: ...
@overload
def write_tum(path: Trajectory, traj: str | Path) -> Path: ...  # the old order
def write_tum(path: str | Path | Trajectory, traj: Trajectory | str | Path) -> Path:
    """Write TUM text (planar: z = 0, quaternion about z) to ``path``."""
    p, entry = path_first(path, traj, Trajectory, "write_tum")
    return _write_tum(entry, p)


def _write_tum(traj: Trajectory, path: str | Path) -> Path:
    p = Path(path)
    half = 0.5 * traj.theta
    zeros = np.zeros_like(traj.t)
    from odolab.core.numfmt import csv_lines

    body = csv_lines(
        (traj.t, traj.x, traj.y, zeros, zeros, zeros, np.sin(half), np.cos(half)), sep=" "
    )
    from odolab.core.writing import write_text_file

    return write_text_file(p, body, what="TUM trajectory", error=LogFormatError)


def read_tum(path: str | Path) -> Trajectory:
    """Read TUM text; yaw from the quaternion (roll and pitch are ignored).

    Raises:
        LogFormatError: the file has no poses or a malformed line.
    """
    p = Path(path)
    d = read_numeric_columns(p, TUM_COLUMNS, sep=r"\s+", names=TUM_COLUMNS)
    if d["t"].size == 0:
        raise LogFormatError(f"{p}: no poses")

    def line_of(i: int) -> int:
        return int(data_line_numbers(p, sep=r"\s+", has_header=False)[i])

    check_times(d["t"], str(p), line_of=line_of)
    check_positions(d["tx"], d["ty"], str(p), line_of=line_of)
    yaw = yaw_from_quaternions(d["qx"], d["qy"], d["qz"], d["qw"], str(p), line_of=line_of)
    return Trajectory.from_xytheta(d["t"], d["tx"], d["ty"], yaw)


@overload
def write_trajectory(
    path: str | Path, traj: Trajectory, fmt: Literal["csv", "tum"] = "csv"
) -> Path: ...
@overload
def write_trajectory(  # the old order
    path: Trajectory, traj: str | Path, fmt: Literal["csv", "tum"] = "csv"
) -> Path: ...
def write_trajectory(
    path: str | Path | Trajectory, traj: Trajectory | str | Path, fmt: Literal["csv", "tum"] = "csv"
) -> Path:
    """Write ``traj`` to ``path`` in the named format."""
    p, entry = path_first(path, traj, Trajectory, "write_trajectory")
    if fmt == "csv":
        return write_trajectory_csv(p, entry)
    if fmt == "tum":
        return write_tum(p, entry)
    raise LogFormatError(f"unknown trajectory format {fmt!r}; expected csv or tum")


def read_trajectory(path: str | Path) -> Trajectory:
    """A trajectory file by its extension: ``.csv`` (``t,x,y,theta[,heading]``), Parquet or Arrow
    IPC (``.parquet``, ``.arrow``, ``.feather``: the same columns), else TUM text.

    Raises:
        LogFormatError: the file is missing or not a readable trajectory.
    """
    p = Path(path)
    if not p.is_file():
        raise LogFormatError(f"{p}: no such trajectory file")
    if p.suffix.lower() in (".csv", *BINARY_SUFFIXES):
        return read_trajectory_csv(p)
    return read_tum(p)
