"""Fleets of robots and their logs: a simulated fleet data set, the per-run table, the summary.

- :mod:`odolab.fleet.dataset`: :func:`simulate_fleet` writes many robots' runs over days (each
  robot with its own true parameters and wear), as encoder CSV runs with ground truth.
- :mod:`odolab.fleet.table`: one row per evaluated run (robot, date, length, APE/RPE, drift per
  metre, end-point error), as a Parquet table; :func:`summarize` per robot and per day.
- :mod:`odolab.fleet.section`: the fleet report section (which robot needs recalibration, with
  the evidence) as figures, a table and an HTML fragment.

See docs/scale.md.
"""

from __future__ import annotations

from odolab.fleet.dataset import FleetSpec, RobotTruth, simulate_fleet
from odolab.fleet.table import FleetSummary, fleet_rows, robot_and_date, summarize

__all__ = [
    "FleetSpec",
    "FleetSummary",
    "RobotTruth",
    "fleet_rows",
    "robot_and_date",
    "simulate_fleet",
    "summarize",
]
