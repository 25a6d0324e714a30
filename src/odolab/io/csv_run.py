"""Encoder CSV runs: an encoder log (raw counters or increments) plus a ground-truth file.

The log is read by :func:`odolab.io.read_encoder_csv` (``t,left_ticks,right_ticks`` or
``t,dticks_left,dticks_right``). The ground truth is ``ReadOptions.ground_truth`` when given, or
else the first sibling file that exists among ``<stem>_gt.csv``, ``<stem>_gt.tum``,
``<stem>_gt.txt`` (trajectory CSV ``t,x,y,theta[,heading]`` or TUM text).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odolab.core.encoders import dticks_from_ticks
from odolab.core.errors import LogFormatError
from odolab.io.encoder_csv import read_encoder_csv
from odolab.io.run import OdometryRun, ReadOptions
from odolab.io.trajectory_csv import read_trajectory

__all__ = ["CsvRunReader", "ground_truth_beside", "read_csv_run"]

GT_SUFFIXES = ("_gt.csv", "_gt.tum", "_gt.txt")


def ground_truth_beside(path: Path) -> Path | None:
    """The ground-truth file next to an encoder log, if there is one."""
    for suffix in GT_SUFFIXES:
        q = path.with_name(path.stem + suffix)
        if q.is_file():
            return q
    return None


def read_csv_run(path: str | Path, options: ReadOptions | None = None) -> OdometryRun:
    """An encoder CSV log as an :class:`OdometryRun` (ground truth as described above)."""
    o = options or ReadOptions()
    p = Path(path)
    log = read_encoder_csv(p, modulus=o.modulus)
    dl = np.zeros(len(log))
    dr = np.zeros(len(log))
    dl[1:] = dticks_from_ticks(log.left_ticks, log.modulus, name=f"{p}: left_ticks")
    dr[1:] = dticks_from_ticks(log.right_ticks, log.modulus, name=f"{p}: right_ticks")
    gt_path = Path(o.ground_truth) if o.ground_truth else ground_truth_beside(p)
    gt = read_trajectory(gt_path) if gt_path is not None else None
    return OdometryRun(
        name=p.stem,
        source=str(p),
        t=log.t,
        dticks_left=dl,
        dticks_right=dr,
        ground_truth=gt,
        kind="csv",
    )


class CsvRunReader:
    """Registry entry for :class:`odolab.io.registry.LogFormat` ``csv``."""

    def find(self, path: Path) -> list[Path]:
        """The file itself, or the encoder logs in a folder (not the ``*_gt.*`` files).

        Raises:
            LogFormatError: the path is missing, or a folder without encoder CSV logs.
        """
        if path.is_file():
            return [path]
        if not path.is_dir():
            raise LogFormatError(f"{path}: no such encoder CSV file or folder")
        runs = sorted(q for q in path.glob("*.csv") if not q.stem.endswith("_gt"))
        if not runs:
            raise LogFormatError(f"{path}: no encoder CSV logs (*.csv) in this folder")
        return runs

    def read(self, path: Path, options: ReadOptions) -> OdometryRun:
        """Read one log and its ground truth."""
        return read_csv_run(path, options)
