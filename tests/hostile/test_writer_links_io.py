"""The log and parameter writers replace a link planted at their path, never follow it (the
params TOML, TUM, SensorLog writers once wrote through ``write_text``/``open("w")``; the
trajectory and encoder tables, which ``odolab odometry -o`` and ``sim explore`` write, through
polars straight to the path)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from odolab.core.params import PRESETS, save_params
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io.chunked import integrate_file
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.sensorlog import write_sensorlog
from odolab.io.trajectory_csv import write_trajectory_csv, write_tum

SECRET = b"not odolab's to change\n"


def _log() -> EncoderLog:
    t = np.linspace(0.0, 1.0, 5)
    return EncoderLog(t, np.arange(5, dtype=np.int64) * 10, np.arange(5, dtype=np.int64) * 11)


def _integrate(out: Path) -> object:
    src = write_encoder_csv(out.parent.parent / "log.csv", _log())
    return integrate_file(src, out, PRESETS["jaguar-lite"])


def _traj() -> Trajectory:
    t = np.linspace(0.0, 1.0, 5)
    return Trajectory(t=t, x=0.3 * t, y=0 * t, theta=0 * t, heading=0 * t)


WRITERS: dict[str, Callable[[Path], object]] = {
    "robot.toml": lambda p: save_params(p, PRESETS["jaguar-lite"]),
    "traj.tum": lambda p: write_tum(p, _traj()),
    "traj.csv": lambda p: write_trajectory_csv(p, _traj()),
    "traj.parquet": lambda p: write_trajectory_csv(p, _traj()),
    "encoders.arrow": lambda p: write_encoder_csv(p, _log()),
    "odometry.csv": _integrate,
    "phone.csv": lambda p: write_sensorlog(
        p, np.linspace(0, 1, 5), np.zeros(5), np.zeros(5), compass_every=1
    ),
}


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_a_link_at_the_output_is_replaced_not_followed(tmp_path: Path, name: str) -> None:
    outside = tmp_path / "outside" / "precious"
    outside.parent.mkdir()
    outside.write_bytes(SECRET)
    out = tmp_path / "out" / name
    out.parent.mkdir()
    out.symlink_to(outside)
    WRITERS[name](out)
    assert outside.read_bytes() == SECRET
    assert not out.is_symlink() and out.stat().st_size > 0
