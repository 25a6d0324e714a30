"""Real robot runs (OptiOdom, motion-capture ground truth): the engine on physical data."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from odolab import RobotParams, integrate_increments


def _nominal(exp: Path) -> RobotParams:
    meta: dict[str, list[str]] = {}
    with next(exp.glob("*_metadata.csv")).open(newline="") as fh:
        for row in csv.reader(fh):
            meta[row[0]] = [c for c in row[1:] if c]
    d_left, d_right = (float(v) for v in meta["Di"][:2])
    counts = float(meta["ngear"][0]) * float(meta["encRes"][0])
    return RobotParams(d_left / 2, d_right / 2, float(meta["Li"][0]), counts, name=exp.name)


def test_square_runs_close_with_nominal_parameters(optiodom_dir: Path) -> None:
    runs = sorted((optiodom_dir / "square").glob("*/*_run-??.csv"))
    assert len(runs) >= 40
    for run in runs:
        params = _nominal(run.parent)
        data = np.loadtxt(run, delimiter=",")  # t, x_gt, y_gt, theta_gt, dticks_right, dticks_left
        traj = integrate_increments(data[:, 0], data[:, 5], data[:, 4], params)
        end = traj.final
        assert math.hypot(end.x, end.y) < 0.03, run.name  # odometry believes it closed the loop
        assert abs(abs(end.heading) - 2 * math.pi) < 0.1, run.name
        # and the truth agrees within the few centimetres that make calibration worthwhile
        gt_end = data[-1, 1:3]
        assert math.hypot(end.x - gt_end[0], end.y - gt_end[1]) < 0.15, run.name
        assert np.sign(end.heading) == np.sign(data[-1, 3]), run.name
