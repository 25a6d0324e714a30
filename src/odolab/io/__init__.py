"""Readers and writers of log and trajectory files (``read_<format>`` / ``write_<format>``)."""

from __future__ import annotations

from odolab.io.encoder_csv import read_encoder_csv, write_encoder_csv
from odolab.io.trajectory_csv import (
    read_trajectory_csv,
    read_tum,
    write_trajectory,
    write_trajectory_csv,
    write_tum,
)

__all__ = [
    "read_encoder_csv",
    "read_trajectory_csv",
    "read_tum",
    "write_encoder_csv",
    "write_trajectory",
    "write_trajectory_csv",
    "write_tum",
]
