"""Readers and writers of log and trajectory files (``read_<format>`` / ``write_<format>``)."""

from __future__ import annotations

from odolab.io.csv_run import read_csv_run
from odolab.io.encoder_csv import read_encoder_csv, write_encoder_csv
from odolab.io.optiodom import find_optiodom_runs, read_optiodom_metadata, read_optiodom_run
from odolab.io.registry import READERS, LogFormat, RunReader, find_runs, read_run, read_trajectory
from odolab.io.rosbag import bag_topics, read_bag, read_bag_trajectory
from odolab.io.run import OdometryRun, ReadOptions
from odolab.io.trajectory_csv import (
    read_trajectory_csv,
    read_tum,
    write_trajectory,
    write_trajectory_csv,
    write_tum,
)
from odolab.io.windows import find_window_runs, read_window_run

__all__ = [
    "READERS",
    "LogFormat",
    "OdometryRun",
    "ReadOptions",
    "RunReader",
    "bag_topics",
    "find_optiodom_runs",
    "find_runs",
    "find_window_runs",
    "read_bag",
    "read_bag_trajectory",
    "read_csv_run",
    "read_encoder_csv",
    "read_optiodom_metadata",
    "read_optiodom_run",
    "read_run",
    "read_trajectory",
    "read_trajectory_csv",
    "read_tum",
    "read_window_run",
    "write_encoder_csv",
    "write_trajectory",
    "write_trajectory_csv",
    "write_tum",
]
