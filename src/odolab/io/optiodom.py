"""OptiOdom runs (``data/optiodom``): 20 Hz wheel increments with motion-capture ground truth.

Layout: ``<kind>/<id>/<id>_run-NN.csv`` with no header and columns
``t, x_gt, y_gt, theta_gt, dticks_right, dticks_left`` (increments, RIGHT first; ground truth in
the robot's start frame), and ``<kind>/<id>/<id>_metadata.csv`` with rows ``key,value,...``:
``ngear`` x ``encRes`` = counts per wheel revolution, ``Di`` = wheel DIAMETERS (left, right; the
radius is half), ``Li`` = track width, ``L`` = side of the square path (m).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

from odolab.core.errors import LogFormatError, ParamsError
from odolab.core.params import RobotParams
from odolab.core.text import quote_input
from odolab.core.trajectory import Trajectory, check_positions, check_times
from odolab.io._table import data_line_numbers, read_numeric_columns
from odolab.io.limits import check_text_file
from odolab.io.run import OdometryRun, ReadOptions

__all__ = [
    "OptiOdomReader",
    "find_optiodom_runs",
    "is_optiodom_run",
    "read_optiodom_metadata",
    "read_optiodom_run",
]

COLUMNS = ("t", "x_gt", "y_gt", "theta_gt", "dticks_right", "dticks_left")
_RUN = re.compile(r"^(?P<id>.+)_run-(?P<nn>\d+)\.csv$")


def is_optiodom_run(path: Path) -> bool:
    """Whether ``path`` is named ``<id>_run-NN.csv`` and has its ``<id>_metadata.csv`` beside it."""
    m = _RUN.match(path.name)
    return m is not None and path.with_name(f"{m['id']}_metadata.csv").is_file()


def read_optiodom_metadata(path: str | Path) -> dict[str, list[str]]:
    """Rows of a ``<id>_metadata.csv`` as ``key -> [values]`` (empty cells dropped).

    Raises:
        LogFormatError: the metadata file is missing or malformed.
    """
    p = Path(path)
    if not p.is_file():
        raise LogFormatError(f"{p}: no such OptiOdom metadata file")
    check_text_file(p, expected="an OptiOdom metadata CSV")
    with p.open(newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    return {r[0].strip(): [c.strip() for c in r[1:] if c.strip()] for r in rows if r and r[0]}


def _number(meta: dict[str, list[str]], key: str, source: Path, index: int = 0) -> float:
    try:
        return float(meta[key][index])
    except (KeyError, IndexError) as err:
        raise LogFormatError(f"{source}: missing value {index + 1} of key {key!r}") from err
    except ValueError as err:
        raise LogFormatError(
            f"{source}: key {key!r} value {quote_input(meta[key][index])} is not a number"
        ) from err


def params_from_metadata(meta: dict[str, list[str]], source: Path, name: str) -> RobotParams:
    """Nominal :class:`RobotParams` from OptiOdom metadata (radius = diameter / 2).

    Raises:
        LogFormatError: the metadata's robot parameters are out of range.
    """
    d_left = _number(meta, "Di", source, 0)
    d_right = _number(meta, "Di", source, 1) if len(meta.get("Di", [])) > 1 else d_left
    try:
        return RobotParams(
            left_wheel_radius=d_left / 2.0,
            right_wheel_radius=d_right / 2.0,
            track_width=_number(meta, "Li", source),
            ticks_per_rev=_number(meta, "ngear", source) * _number(meta, "encRes", source),
            name=name,
        )
    except ParamsError as err:
        raise LogFormatError(f"{source}: {err}") from err


def read_optiodom_run(path: str | Path) -> OdometryRun:
    """One ``<id>_run-NN.csv`` with its ground truth and the nominal parameters of its metadata.

    Raises:
        LogFormatError: the file is missing, misnamed, lacks its metadata file beside it, or has
            fewer than two samples.
    """
    p = Path(path)
    m = _RUN.match(p.name)
    if m is None:
        raise LogFormatError(f"{p}: not an OptiOdom run file; expected a name like <id>_run-01.csv")
    meta_path = p.with_name(f"{m['id']}_metadata.csv")
    if not p.is_file():  # name the log the user gave, not the metadata looked for beside it
        raise LogFormatError(f"{p}: no such OptiOdom run log")
    if not meta_path.is_file():
        raise LogFormatError(
            f"{p}: its OptiOdom metadata file {meta_path.name} is not beside it; expected the "
            "run's folder as OptiOdom writes it"
        )
    meta = read_optiodom_metadata(meta_path)
    d = read_numeric_columns(p, COLUMNS, names=COLUMNS)
    if d["t"].size < 2:
        raise LogFormatError(f"{p}: {d['t'].size} samples; expected at least two")
    t = d["t"]

    def line_of(i: int) -> int:
        return int(data_line_numbers(p, has_header=False)[i])

    check_times(t, str(p), line_of=line_of)
    check_positions(d["x_gt"], d["y_gt"], str(p), line_of=line_of)
    gt = Trajectory.from_xytheta(t, d["x_gt"], d["y_gt"], d["theta_gt"])
    kind = p.parent.parent.name
    params = params_from_metadata(meta, meta_path, name=f"optiodom-{m['id']}")
    info: dict[str, float | str] = {
        "experiment": m["id"],
        "run": int(m["nn"]),
        "params_source": str(meta_path),  # where the nominal parameters come from
    }
    if meta.get("L"):
        info["side_length"] = _number(meta, "L", meta_path)
    dl = d["dticks_left"].copy()
    dr = d["dticks_right"].copy()
    dl[0] = dr[0] = 0.0
    return OdometryRun(
        name=f"{kind}/{m['id']}/run-{m['nn']}",
        source=str(p),
        t=t,
        dticks_left=dl,
        dticks_right=dr,
        ground_truth=gt,
        params=params,
        kind=kind,
        meta=info,
    )


def find_optiodom_runs(path: str | Path) -> list[Path]:
    """Run files under ``path`` (a run file, an experiment folder, a kind folder or the root).

    Raises:
        LogFormatError: the path is missing, or a folder without OptiOdom runs.
    """
    p = Path(path)
    if p.is_file():
        return [p]
    if not p.is_dir():
        raise LogFormatError(f"{p}: no such OptiOdom run file or folder")
    runs = sorted(q for q in p.rglob("*_run-*.csv") if _RUN.match(q.name))
    if not runs:
        raise LogFormatError(f"{p}: no OptiOdom runs (<id>_run-NN.csv) in this folder")
    return runs


class OptiOdomReader:
    """Registry entry for :class:`odolab.io.registry.LogFormat` ``optiodom``."""

    def find(self, path: Path) -> list[Path]:
        """Run files under ``path``."""
        return find_optiodom_runs(path)

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """Read one run (``options.ground_truth`` replaces the motion-capture trajectory)."""
        run = read_optiodom_run(path)
        if options.ground_truth is None:
            return run
        from odolab.io.trajectory_csv import read_trajectory

        return OdometryRun(
            run.name,
            run.source,
            run.t,
            run.dticks_left,
            run.dticks_right,
            read_trajectory(options.ground_truth),
            run.params,
            run.estimate,
            run.kind,
            run.meta,
        )
