"""The log and parameter writers replace a link planted at their path, never follow it (the
params TOML, TUM, SensorLog writers once wrote through ``write_text``/``open("w")``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from odolab.io.sensorlog import write_sensorlog
from odolab.io.trajectory_csv import write_tum
from odolab.params import PRESETS, save_params
from odolab.trajectory import Trajectory

SECRET = b"not odolab's to change\n"


def _traj() -> Trajectory:
    t = np.linspace(0.0, 1.0, 5)
    return Trajectory(t=t, x=0.3 * t, y=0 * t, theta=0 * t, heading=0 * t)


WRITERS: dict[str, Callable[[Path], object]] = {
    "robot.toml": lambda p: save_params(p, PRESETS["jaguar-lite"]),
    "traj.tum": lambda p: write_tum(p, _traj()),
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
