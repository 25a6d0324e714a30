"""A TurtleBot/Nav2 bag (issue 30): no /joint_states, the robot's /odom (nav_msgs/Odometry) and
AMCL's /amcl_pose (PoseWithCovarianceStamped). Read as a run whose wheel increments are the
robot's own odometry turned back into wheel turns (and say so), against AMCL's pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import shared_data
from odolab.cli import main
from odolab.core.errors import LogFormatError
from odolab.core.params import PRESETS
from odolab.io import read_bag, read_bag_trajectory
from odolab.io.rosbag import increments_from_odometry
from odolab.io.run import ReadOptions
from odolab.metrics import evaluate
from odolab.metrics.runs import RUN_OPTIONS


@pytest.fixture(scope="module")
def nav2() -> Path:
    return shared_data.require("evo-testdata") / "nav2_turtlebot.mcap"


def test_increments_give_the_odometry_back() -> None:
    """Wheel turns -> odometry (midpoint) -> wheel turns: the same turns, to rounding."""
    from odolab.core.odometry import integrate_increments

    rng = np.random.default_rng(30)
    t = np.arange(200) * 0.05
    dl = rng.uniform(-5.0, 40.0, t.size)
    dr = rng.uniform(-5.0, 40.0, t.size)
    dl[0] = dr[0] = 0.0
    p = PRESETS["jaguar-lite"]
    odom = integrate_increments(t, dl, dr, p)
    got_l, got_r = increments_from_odometry(odom, p)
    assert np.max(np.abs(got_l - dl)) < 1e-8 and np.max(np.abs(got_r - dr)) < 1e-8


def test_nav2_bag_is_a_run(nav2: Path) -> None:
    run = read_bag(nav2)
    assert len(run) == 2639 and run.ground_truth is not None and len(run.ground_truth) == 135
    assert "the robot's own odometry on '/odom'" in str(run.meta["wheels"])
    assert "not encoder counts" in str(run.meta["wheels"])
    assert str(run.meta["reference"]).startswith("AMCL's pose on '/amcl_pose'")
    odom = read_bag_trajectory(nav2, "/odom")
    e = odom
    replay = run.odometry(start=(e.x[0], e.y[0], e.heading[0]))
    assert np.max(np.hypot(replay.x - e.x, replay.y - e.y)) < 1e-3  # 0.18 mm measured
    assert np.max(np.abs(replay.heading - e.heading)) < 1e-9


def test_evaluate_bag_equals_odom_against_amcl(
    nav2: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    amcl = read_bag_trajectory(nav2, "/amcl_pose")
    direct = evaluate(amcl, read_bag_trajectory(nav2, "/odom"), RUN_OPTIONS)
    out = tmp_path / "ev.json"
    assert main(["evaluate", str(nav2), "-f", "bag", "--workers", "1", "--json", str(out)]) == 0
    said = capsys.readouterr().out
    assert "note: wheels: the robot's own odometry on '/odom'" in said
    assert "note: reference: AMCL's pose on '/amcl_pose'" in said
    import json

    row = json.loads(out.read_text())["runs"][0]
    # 0.6513 m both; they differ by the sideways steps no wheel makes (0.18 mm at most)
    assert row["ape"]["rmse"] == pytest.approx(direct.ape.rmse, abs=1e-4)
    assert row["data_notes"][0].startswith("wheels: ")


def test_odometry_command_says_what_the_wheels_are(
    nav2: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert main(["odometry", str(nav2), "-f", "bag", "-o", str(tmp_path / "t.csv")]) == 0
    said = capsys.readouterr().out
    assert "parameters odom-replay" in said and "not encoder counts" in said
    assert "2639 poses" in said


def test_a_bag_without_wheel_data_says_what_it_lacks(nav2: Path) -> None:
    with pytest.raises(LogFormatError) as err:
        read_bag(nav2, ReadOptions(odometry_topic="/wheel_odom"))
    msg = str(err.value)
    assert msg.startswith(f"{nav2}: no wheel data: no sensor_msgs/msg/JointState on")
    assert "no nav_msgs/msg/Odometry on '/wheel_odom'" in msg
    assert "/amcl_pose (geometry_msgs/msg/PoseWithCovarianceStamped)" in msg
