"""Window tables of real robots (``--format drive``): many short runs in one CSV.

The DRIVE project's data sets (Baril et al., ICRA 2024; ``shared/data/drive-husky``) store a
robot's exploration as *windows*: ``window, calib_step, t, left_wheel_vel, right_wheel_vel,
icp_x, icp_y, icp_yaw`` (and the commands and the IMU), each window 2 s at 20 Hz with the lidar-ICP
pose in the frame of the window's first pose, held between its updates (about 10 Hz). Each
window is one :class:`~odolab.io.run.OdometryRun`:

* **ticks** are the wheel angle integrated from the measured wheel speeds (trapezoid rule over
  the rows), times ``ticks_per_rev / (2 pi)`` (:func:`wheel_angles`; the gyro calibration's
  DRIVE reader integrates the same way);
* **ground truth** keeps only the rows where the ICP pose *changes* (and the window's first row):
  a held value is the last measurement again, not a new one, and a staircase of held values
  makes a smooth motion look like jumps every 0.1 s;
* the run's ``meta`` holds its ``window`` and its command step ``calib_step``.

A run is named by a path with a fragment: ``TABLE.csv#window-12``. ``TABLE.csv`` alone means every
window, ``TABLE.csv#even`` / ``TABLE.csv#odd`` the windows of even / odd command steps (DRIVE's
advice: split by command step, never window by window inside one step), ``TABLE.csv#steps-0-99``
the steps 0 to 99.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError
from odolab.core.text import quote_input
from odolab.core.trajectory import Trajectory, check_positions, check_times
from odolab.io.run import OdometryRun, ReadOptions

__all__ = [
    "WINDOW_COLUMNS",
    "WindowTableReader",
    "find_window_runs",
    "is_window_table",
    "read_window_run",
    "truth_updates",
    "wheel_angles",
]

#: The columns a window table must have (others, such as the IMU's, are not read here).
WINDOW_COLUMNS = (
    "window",
    "calib_step",
    "t",
    "left_wheel_vel",
    "right_wheel_vel",
    "icp_x",
    "icp_y",
    "icp_yaw",
)
_SELECTOR = re.compile(
    r"^(?:window-(?P<window>\d+)|(?P<parity>even|odd)|steps-(?P<a>\d+)-(?P<b>\d+))$"
)
_SELECTORS_TEXT = "#window-N, #even, #odd or #steps-A-B"
#: Fastest a wheel may turn (rad/s): far past any robot's (the Husky's wheels reach about 10).
MAX_WHEEL_RAD_S = 1000.0
#: Largest heading a window's pose may have (rad): wrapped, or a few turns at most.
MAX_YAW_RAD = 100.0


def wheel_angles(t: NDArray[np.float64], speed: NDArray[np.float64]) -> NDArray[np.float64]:
    """A wheel's angle (rad, 0 at the first row) integrated from its speed (rad/s) by the
    trapezoid rule over the rows."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))))


def truth_updates(
    x: NDArray[np.float64], y: NDArray[np.float64], yaw: NDArray[np.float64]
) -> NDArray[np.int64]:
    """Indices of the rows where a held pose changes, and the first row: the instants the
    pose was measured (a value repeated in the next row is the same measurement held)."""
    changed = (np.diff(x) != 0) | (np.diff(y) != 0) | (np.diff(yaw) != 0)
    return np.concatenate(([0], np.flatnonzero(changed) + 1)).astype(np.int64)


def split_selector(path: Path) -> tuple[Path, str]:
    """``TABLE.csv#sel`` -> (``TABLE.csv``, ``sel``); a path without ``#`` -> (path, "")."""
    text = str(path)
    if "#" not in Path(text).name:
        return path, ""
    head, _, sel = text.rpartition("#")
    return Path(head), sel


def is_window_table(path: Path) -> bool:
    """Whether ``path`` (with or without a ``#`` selector) is a CSV with the window columns."""
    from odolab.io.tabular import is_csv_with

    table, _ = split_selector(path)
    return is_csv_with(table, WINDOW_COLUMNS)


@dataclass(frozen=True)
class _Table:
    """A window table read once: each window's rows as ``(start, end)`` and its step."""

    path: Path
    columns: dict[str, NDArray[np.float64]]
    rows: dict[int, tuple[int, int]]
    steps: dict[int, int]
    lines: NDArray[np.int64]


@lru_cache(maxsize=4)
def _read_table(path: Path, stamp: tuple[float, int]) -> _Table:
    """The table at ``path`` (``stamp``: its mtime and size, so a changed file is read again)."""
    from odolab.io._table import data_line_numbers, read_numeric_columns

    del stamp  # only the cache's key
    cols = read_numeric_columns(path, WINDOW_COLUMNS)
    lines = data_line_numbers(path)
    window = cols["window"]
    if window.size == 0:
        raise LogFormatError(f"{path}: no rows; expected a window table (one row a sample)")
    for name in ("window", "calib_step"):
        v = cols[name]
        bad = (v != np.round(v)) | (v < 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(
                f"{path}: line {lines[i]}, column {name!r} is {v[i]:g}; expected a whole "
                "number of at least 0"
            )
    starts = np.flatnonzero(np.concatenate(([True], np.diff(window) != 0)))
    ends = np.concatenate((starts[1:], [window.size]))
    rows: dict[int, tuple[int, int]] = {}
    steps: dict[int, int] = {}
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        w = int(window[a])
        if w in rows:
            raise LogFormatError(
                f"{path}: line {lines[a]}, window {w} starts again after other windows; "
                "expected each window's rows together"
            )
        step = cols["calib_step"][a:b]
        if (step != step[0]).any():
            i = a + int(np.argmax(step != step[0]))
            raise LogFormatError(
                f"{path}: line {lines[i]}, window {w} changes its calib_step from "
                f"{int(step[0])} to {int(cols['calib_step'][i])}; expected one command step a "
                "window"
            )
        rows[w] = (a, b)
        steps[w] = int(step[0])
    return _Table(path, cols, rows, steps, lines)


def _table(path: Path) -> _Table:
    if not path.exists():
        raise LogFormatError(f"{path}: no such window table")
    if not path.is_file():
        raise LogFormatError(f"{path}: is a folder; expected a window table CSV")
    st = path.stat()
    return _read_table(path.resolve(), (st.st_mtime, st.st_size))


def _selected(table: _Table, given: Path, selector: str) -> list[int]:
    m = _SELECTOR.match(selector)
    if m is None:
        raise LogFormatError(
            f"{given}: {quote_input(selector)} after '#' selects no windows; expected "
            f"{_SELECTORS_TEXT}"
        )
    if m["window"] is not None:
        w = int(m["window"])
        if w not in table.rows:
            raise LogFormatError(
                f"{given}: no window {w} in the table; expected one of its {len(table.rows)} "
                f"windows ({min(table.rows)}-{max(table.rows)})"
            )
        return [w]
    if m["parity"] is not None:
        want = 0 if m["parity"] == "even" else 1
        return [w for w in table.rows if table.steps[w] % 2 == want]
    a, b = int(m["a"]), int(m["b"])
    return [w for w in table.rows if a <= table.steps[w] <= b]


def find_window_runs(path: str | Path) -> list[Path]:
    """One path ``TABLE.csv#window-N`` per window that ``path`` selects (see the module).

    Raises:
        LogFormatError: the selector picks no window of the table.
    """
    table_path, selector = split_selector(Path(path))
    table = _table(table_path)
    windows = _selected(table, Path(path), selector) if selector else list(table.rows)
    if not windows:
        raise LogFormatError(
            f"{path}: selects no window of the table (command steps "
            f"{min(table.steps.values())}-{max(table.steps.values())}); expected a selection "
            "that holds some"
        )
    return [Path(f"{table_path}#window-{w}") for w in windows]


def read_window_run(path: str | Path, ticks_per_rev: float = 2.0 * math.pi) -> OdometryRun:
    """The window ``TABLE.csv#window-N`` as a run (see the module): ticks are the wheel angle
    times ``ticks_per_rev / (2 pi)`` (the default makes one tick one radian).

    Raises:
        LogFormatError: the path names no single window, or the window has too few rows, a time that
            does not advance, or a value out of range (the line is named).
    """
    table_path, selector = split_selector(Path(path))
    m = _SELECTOR.match(selector)
    if not selector or m is None or m["window"] is None:
        raise LogFormatError(
            f"{path}: names no single window; expected TABLE.csv#window-N (a window's number)"
        )
    table = _table(table_path)
    (w,) = _selected(table, Path(path), selector)
    a, b = table.rows[w]
    c = {k: v[a:b] for k, v in table.columns.items()}
    where = f"{table_path}: window {w}"
    if b - a < 2:
        raise LogFormatError(f"{where} has {b - a} row; expected at least two")
    t = c["t"]

    def line_of(i: int) -> int:
        return int(table.lines[a + i])

    check_times(t, f"{table_path}: window {w}", line_of=line_of)
    dt = np.diff(t)
    if not (dt > 0).all():
        i = int(np.argmax(~(dt > 0))) + 1
        raise LogFormatError(
            f"{table_path}: line {line_of(i)}, window {w}: time {t[i]:g} s does not "
            "advance; expected increasing times within a window"
        )
    check_positions(c["icp_x"], c["icp_y"], f"{table_path}: window {w}", line_of=line_of)
    for name, limit, unit in (
        ("left_wheel_vel", MAX_WHEEL_RAD_S, "rad/s"),
        ("right_wheel_vel", MAX_WHEEL_RAD_S, "rad/s"),
        ("icp_yaw", MAX_YAW_RAD, "rad"),
    ):
        v = c[name]
        bad = ~(np.abs(v) <= limit)  # (NaN too)
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(
                f"{table_path}: line {line_of(i)}, window {w}: {name} is {v[i]:g}; expected "
                f"at most {limit:g} {unit} either way"
            )
    per_rad = float(ticks_per_rev) / (2.0 * math.pi)
    left = per_rad * wheel_angles(t, c["left_wheel_vel"])
    right = per_rad * wheel_angles(t, c["right_wheel_vel"])
    keep = truth_updates(c["icp_x"], c["icp_y"], c["icp_yaw"])
    yaw = np.unwrap(c["icp_yaw"][keep])
    truth = Trajectory.from_xyh(t[keep], c["icp_x"][keep], c["icp_y"][keep], yaw)
    meta: dict[str, float | str] = {
        "window": w,
        "calib_step": table.steps[w],
        "truth_updates": int(keep.size),
        "truth_rows": int(t.size),
        # every window's truth comes from the one mounted lidar: one yaw offset for all
        "truth_frame": str(table_path.resolve()),
    }
    if keep.size < 2:
        meta["no_ground_truth"] = (
            f"window {w}: the ICP pose never changes in its {t.size} rows; expected a ground "
            "truth that updates"
        )
    return OdometryRun(
        name=f"{table_path.stem}/step-{table.steps[w]}/window-{w}",
        source=f"{table_path}#window-{w}",
        t=t.copy(),
        dticks_left=np.concatenate(([0.0], np.diff(left))),
        dticks_right=np.concatenate(([0.0], np.diff(right))),
        ground_truth=truth if keep.size >= 2 else None,
        params=None,
        kind=table_path.stem,
        meta=meta,
    )


class WindowTableReader:
    """Registry entry for :class:`odolab.io.registry.LogFormat` ``drive``."""

    def find(self, path: Path) -> list[Path]:
        """One path a window (see the module)."""
        return find_window_runs(path)

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """One window; ``options.ticks_per_rev`` turns its wheel angles into ticks."""
        tpr = options.params.ticks_per_rev if options.params else options.ticks_per_rev
        return read_window_run(path, tpr)
