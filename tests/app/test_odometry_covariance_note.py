"""``odolab odometry --covariance`` says where the first-order covariance stops holding (issue 26:
after a long unaided straight, first order understates the spread along the heading)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.params import PRESETS, NoiseParams, save_params


def _straight_log(path: Path, metres: float) -> None:
    robot = PRESETS["jaguar-lite"]
    ticks_per_m = robot.ticks_per_rev / (2 * math.pi * robot.left_wheel_radius)
    n = 200
    rows = ["t,left_ticks,right_ticks"]
    for i in range(n + 1):
        c = round(i / n * metres * ticks_per_m)
        rows.append(f"{0.05 * i:.2f},{c},{c}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


@pytest.mark.parametrize(("metres", "noted"), [(20.0, True), (1.0, False)])
def test_a_long_straight_is_flagged_a_short_one_not(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], metres: float, noted: bool
) -> None:
    params = tmp_path / "noisy.toml"
    save_params(params, PRESETS["jaguar-lite"].with_(noise=NoiseParams(2e-3, 2e-3)))
    log = tmp_path / "log.csv"
    _straight_log(log, metres)
    args = ["odometry", str(log), "-p", str(params), "-o", str(tmp_path / "t.csv"), "--covariance"]
    assert main(args) == 0
    out = capsys.readouterr().out
    note = "note: the first-order covariance understates the spread from t = "
    assert (note in out) is noted, out
