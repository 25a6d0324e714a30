"""ROS 1 and ROS 2 bags written here with rosbags read back, evaluate and calibrate."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import write_bag

from odolab.calibration.lsq import LsqOptions, calibrate_lsq
from odolab.core.errors import LogFormatError
from odolab.core.odometry import integrate_increments
from odolab.core.params import RobotParams
from odolab.io import LogFormat, ReadOptions, bag_topics, find_runs, read_bag, read_run
from odolab.metrics import evaluate_run

TRUE = RobotParams(
    left_wheel_radius=0.101,
    right_wheel_radius=0.099,
    track_width=0.52,
    ticks_per_rev=2 * math.pi,
    name="true",
)
NOMINAL = TRUE.with_(left_wheel_radius=0.1, right_wheel_radius=0.1, track_width=0.5, name="nom")


def drive(seed: int = 3, n: int = 600) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stamps (20 Hz) and wheel angles (rad) of a drive with straights and turns."""
    rng = np.random.default_rng(seed)
    t = 100.0 + 0.05 * np.arange(n)
    v = np.repeat(rng.uniform(-0.2, 1.0, n // 50), 50)  # rad per cycle, piecewise constant
    w = np.repeat(rng.uniform(-0.5, 0.5, n // 50), 50)
    left = np.cumsum(v - w)
    right = np.cumsum(v + w)
    return t, left - left[0], right - right[0]


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    t, left, right = drive()
    dl = np.diff(left, prepend=0.0)
    dr = np.diff(right, prepend=0.0)
    gt = integrate_increments(t, dl, dr, TRUE)[::2]  # 10 Hz ground truth
    return write_bag(tmp_path / "run_ros2", t, left, right, gt)


def test_ros2_bag_reads_back(bag: Path) -> None:
    t, left, right = drive()
    run = read_bag(bag)
    np.testing.assert_allclose(run.t, t, atol=1e-9)
    np.testing.assert_allclose(np.cumsum(run.dticks_left), left, atol=1e-9)
    np.testing.assert_allclose(np.cumsum(run.dticks_right), right, atol=1e-9)
    assert run.ground_truth is not None
    assert len(run.ground_truth) == 300
    assert bag_topics(bag) == {
        "/ground_truth": "geometry_msgs/msg/PoseStamped",
        "/joint_states": "sensor_msgs/msg/JointState",
    }
    assert find_runs([bag], LogFormat.BAG) == [bag]


def test_ros2_bag_evaluates_and_calibrates(bag: Path) -> None:
    run = read_run(bag, LogFormat.BAG)
    exact = evaluate_run(run, TRUE).evaluation
    assert exact.ape.max < 1e-9  # the ground truth was integrated with TRUE
    assert exact.rpe.max < 1e-9
    wrong = evaluate_run(run, NOMINAL).evaluation
    assert wrong.ape.rmse > 0.1
    cal = calibrate_lsq([run], NOMINAL, LsqOptions(segment_s=1.0))
    assert cal.params.left_wheel_radius == pytest.approx(0.101, abs=1e-6)
    assert cal.params.right_wheel_radius == pytest.approx(0.099, abs=1e-6)
    assert cal.params.track_width == pytest.approx(0.52, abs=1e-5)


def test_ticks_per_rev_scales_the_angles(bag: Path) -> None:
    run = read_bag(bag, ReadOptions(ticks_per_rev=1000.0))
    plain = read_bag(bag)
    np.testing.assert_allclose(run.dticks_left, plain.dticks_left * 1000.0 / (2 * math.pi))


def test_mcap_and_ros1_bags_read_the_same(tmp_path: Path) -> None:
    t, left, right = drive(n=200)
    a = read_bag(write_bag(tmp_path / "m", t, left, right, None, storage="mcap"))
    b = read_bag(write_bag(tmp_path / "r1.bag", t, left, right, None, ros1=True))
    np.testing.assert_allclose(a.dticks_right, b.dticks_right, atol=1e-12)
    np.testing.assert_allclose(a.t, b.t, atol=1e-9)
    assert a.ground_truth is None


def test_missing_topic_lists_the_topics(bag: Path) -> None:
    with pytest.raises(LogFormatError) as err:
        read_bag(bag, ReadOptions(joint_topic="/wheels"))
    msg = str(err.value)
    assert "no topic '/wheels'" in msg
    assert "/joint_states (sensor_msgs/msg/JointState)" in msg
    assert "/ground_truth (geometry_msgs/msg/PoseStamped)" in msg


def test_missing_joint_names_are_named(bag: Path) -> None:
    with pytest.raises(LogFormatError, match="expected joints 'l' and 'r'"):
        read_bag(bag, ReadOptions(joint_names=("l", "r")))


def test_not_a_bag(tmp_path: Path) -> None:
    p = tmp_path / "x.bag"
    p.write_text("hello")
    with pytest.raises(LogFormatError, match="not a readable ROS 1 or ROS 2 bag"):
        read_bag(p)


def test_cli_on_a_bag(bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from odolab.cli import main
    from odolab.core.params import load_params, save_params

    nominal = save_params(tmp_path / "nominal.toml", NOMINAL)
    out = tmp_path / "eval.json"
    args = ["evaluate", str(bag), "--format", "bag", "-p", str(nominal), "--json", str(out)]
    assert main(args) == 0
    doc = json.loads(out.read_text())
    assert doc["runs"][0]["ape"]["rmse"] > 0.1
    new = tmp_path / "new.toml"
    args = ["calibrate", "lsq", str(bag), "--format", "bag", "-p", str(nominal), "-o", str(new)]
    assert main([*args, "--segment", "1.0", "--workers", "1"]) == 0
    assert load_params(new).track_width == pytest.approx(0.52, abs=1e-5)
    capsys.readouterr()
    args = ["evaluate", str(bag), "--format", "bag", "-p", str(nominal), "--gt-topic", "/mocap"]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "no ground-truth topic '/mocap' in the bag; it has /ground_truth" in err


def test_odometry_messages_as_ground_truth_and_estimate(tmp_path: Path) -> None:
    t, left, right = drive(n=200)
    gt = integrate_increments(t, np.diff(left, prepend=0.0), np.diff(right, prepend=0.0), TRUE)
    bag = write_bag(tmp_path / "odo", t, left, right, gt, gt_as_odometry=True, gt_topic="/odom")
    run = read_bag(bag, ReadOptions(ground_truth_topic="/odom", odometry_topic="/odom"))
    assert run.ground_truth is not None and run.estimate is not None
    np.testing.assert_allclose(run.ground_truth.x, gt.x, atol=1e-12)
    np.testing.assert_allclose(run.estimate.heading, gt.heading, atol=1e-9)
    with pytest.raises(LogFormatError, match="carries sensor_msgs/msg/JointState; expected"):
        read_bag(bag, ReadOptions(ground_truth_topic="/joint_states"))


def test_calibrate_a_bag_without_ground_truth_from_a_csv_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a bag of wheel angles only, and the path from a tracker as a CSV trajectory
    from odolab.cli import main
    from odolab.core.params import load_params, save_params
    from odolab.io.trajectory_csv import write_trajectory

    t, left, right = drive()
    gt = integrate_increments(t, np.diff(left, prepend=0.0), np.diff(right, prepend=0.0), TRUE)
    bag = write_bag(tmp_path / "wheels_only", t, left, right, None)
    truth = write_trajectory(tmp_path / "truth.csv", gt)
    nominal = save_params(tmp_path / "nominal.toml", NOMINAL)
    new = tmp_path / "new.toml"
    args = ["calibrate", "lsq", str(bag), "-f", "bag", "-p", str(nominal), "-o", str(new),
            "--segment", "1.0", "--workers", "1"]  # fmt: skip
    assert main(args) == 1  # the bag alone has no ground truth: one sentence
    assert "no ground-truth topic '/ground_truth' in the bag" in capsys.readouterr().err
    assert main([*args, "--ground-truth", str(truth)]) == 0
    assert load_params(new).track_width == pytest.approx(TRUE.track_width, abs=1e-5)
    capsys.readouterr()
    assert main([*args, "--ground-truth", str(truth), "--validate", str(bag)]) == 1
    assert "expected exactly one run and no --validate" in capsys.readouterr().err
    assert main([*args, "--ground-truth", str(tmp_path / "nope.csv")]) == 1
    assert "nope.csv: no such file" in capsys.readouterr().err
