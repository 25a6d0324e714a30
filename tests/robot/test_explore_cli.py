"""`odolab robot explore` as a user runs it (in-process ``main``): every exploration option is
refused with one sentence naming it before anything is sent; on the virtual Jaguar the run folder
holds the encoder log and the true path, which ``calibrate lsq --model slip`` and ``calibrate
compare`` read as they are; on a robot without recorded truth the folder names the source the
user gave and how to attach it; with ``--db`` the exploration is kept out of Table I; the same
seed draws the same commands."""

from __future__ import annotations

import json
import math
import socket
from pathlib import Path

import numpy as np
import pytest

from odolab.app.selection import select
from odolab.cli import main
from odolab.core.errors import InvalidTrialError
from odolab.core.params import PRESETS, load_params
from odolab.core.trials import Command, Exploration, MotionKind, TrialStatus
from odolab.io import read_trajectory
from odolab.io.encoder_csv import read_encoder_csv
from odolab.robot.config import RunConfig
from odolab.robot.explore import notebook_trial, plan_exploration
from odolab.robot.jaguar.board import BoardConfig, VirtualJaguar, VirtualJaguarServer
from odolab.robot.plant import IdealPlant
from odolab.store import Notebook

NOMINAL = PRESETS["jaguar-lite"]


# (option, value, what the one sentence must say)
INVALID = [
    ("--seconds", "0", "(0, 600] s"),
    ("--seconds", "nan", "(0, 600] s"),
    ("--seconds", "1e6", "(0, 600] s"),
    ("--max-speed", "0", "(0, 1] m/s"),
    ("--max-speed", "-0.5", "(0, 1] m/s"),
    ("--max-speed", "5", "(0, 1] m/s"),
    ("--max-speed", "inf", "(0, 1] m/s"),
    ("--max-turn-rate", "0", "rad/s (a turn in place"),
    ("--max-turn-rate", "100", "rad/s (a turn in place"),
    ("--max-turn-rate", "nan", "rad/s (a turn in place"),
    ("--hold", "3,1", "0 < LOW <= HIGH"),
    ("--hold", "0,1", "(0, 60] s"),
    ("--hold", "1,1e3", "(0, 60] s"),
    ("--hold", "one,two", "LOW,HIGH seconds"),
    ("--hold", "1,2,3", "LOW,HIGH seconds"),
    ("--fence", "0", "(0, 100] m"),
    ("--fence", "-3", "(0, 100] m"),
    ("--fence", "inf", "(0, 100] m"),
    ("--fence", "nan", "(0, 100] m"),
    ("--fence", "3000", "(0, 100] m"),
    ("--distribution", "edge", "'uniform', 'edges'"),
    ("--distribution", "Uniform", "'uniform', 'edges'"),
    ("--explore-seed", "-1", "--explore-seed"),
    ("--ground-truth", "gps", "'virtual', 'mocap', 'track', 'laser'"),
    ("--decel", "0.3", "an exploration has no target to slow down to"),
    # the virtual Jaguar's options on a real link: these drove the robot
    ("--truth", "foo", "--truth is 'foo'; expected one of"),
    ("--terrain", "gras", "--terrain is 'gras'; expected one of"),
    ("--terrain", "grass", "for the virtual Jaguar (sim://) only"),
]


def _one_sentence(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("odolab: error: "), err
    return lines[0]


@pytest.mark.parametrize(("option", "value", "expected"), INVALID)
def test_invalid_exploration_option_is_refused_before_anything_is_sent(
    listener: socket.socket,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    option: str,
    value: str,
    expected: str,
) -> None:
    port = listener.getsockname()[1]
    out = tmp_path / "run"
    args = ["robot", "explore", option, value, "--robot", f"udp://127.0.0.1:{port}"]
    if option != "--ground-truth":
        args += ["--ground-truth", "mocap"]
    code = main([*args, "--quiet", "--out", str(out)])
    line = _one_sentence(capsys.readouterr().err)
    assert code == 1
    assert option in line and expected in line, line
    with pytest.raises(BlockingIOError):
        listener.recv(2048)  # nothing at all was sent to the robot
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        ([], "--ground-truth is missing: an exploration of the robot at udp://127.0.0.1:"),
        (["--ground-truth", "virtual"], "expected one of mocap, track, laser"),
        (
            ["--max-speed", "0.4", "--max-wheel-speed", "0.3", "--ground-truth", "laser"],
            "--max-speed is 0.4; expected a number in (0, 0.3] m/s (--max-wheel-speed 0.3 m/s)",
        ),
    ],
)
def test_a_real_robot_needs_its_ground_truth_named_and_nothing_is_sent_before(
    listener: socket.socket,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    expected: str,
) -> None:
    port = listener.getsockname()[1]
    out = tmp_path / "run"
    code = main(
        ["robot", "explore", *args, "--robot", f"udp://127.0.0.1:{port}", "--quiet", "--out",
         str(out)]
    )  # fmt: skip
    line = _one_sentence(capsys.readouterr().err)
    assert code == 1 and expected in line, line
    with pytest.raises(BlockingIOError):
        listener.recv(2048)
    assert not out.exists()


def test_the_virtual_robot_refuses_a_named_source(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    code = main(["robot", "explore", "--ground-truth", "mocap", "--quiet", "--out", str(out)])
    line = _one_sentence(capsys.readouterr().err)
    assert code == 1 and "--ground-truth is 'mocap'" in line and "true path is recorded" in line
    assert not out.exists()


def test_explore_on_the_virtual_robot_then_fit_a_slip_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """10 s of exploration of the tracked virtual Jaguar (real time, normal scheduling), then
    ``calibrate lsq --model slip`` and ``calibrate compare`` on the run folder's files."""
    run = tmp_path / "explore"
    code = main(
        [
            "robot", "explore", "--seconds", "10", "--truth", "jaguar-lab-tracked",
            "--explore-seed", "4", "--quiet", "--no-realtime", "--out", str(run),
        ]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 0, err
    # what it chose is said; the end says where the run and its truth are, and the stop
    assert (
        "exploration: 10 s, speeds up to 0.5 m/s, turn rates up to 1 rad/s, each held 1-3 s, "
        "drawn uniform (seed 4), fence 3 m about the start; ground truth: the virtual robot's "
        "true path (not given, so chosen: --max-speed 0.5 m/s, --max-turn-rate 1 rad/s)"
    ) in err
    assert "robot stopped (its sensor data confirms it)" in err
    assert f"ground truth: {run / 'encoders_gt.csv'}" in out
    assert f"odolab calibrate lsq {run / 'encoders.csv'} -f csv" in out
    # the line printed writes into the run folder, never over the -p file it names
    assert f"--model slip -o {run / 'slip.toml'}" in out
    for name in ("encoders.csv", "encoders_gt.csv", "predicted.csv", "run.json"):
        assert (run / name).is_file()
    doc = json.loads((run / "run.json").read_text())
    assert doc["command"]["kind"] == "free" and doc["describe"] == "explore 10 s"
    assert doc["trial_id"].startswith("robot-explore-") and run.name == "explore"
    assert doc["command"]["explore"]["max_speed"] == 0.5
    assert doc["completed"] is True and doc["stop_confirmed"] is True
    assert doc["exploration"]["fence_crossed"] is False
    assert doc["ground_truth"] == {"source": "virtual", "file": "encoders_gt.csv", "attach": None}
    # the truth is on the encoder log's clock, row for row; odometry stayed inside the fence
    log = read_encoder_csv(run / "encoders.csv")
    truth = read_trajectory(run / "encoders_gt.csv")
    assert np.array_equal(truth.t, log.t)
    assert (truth.x[0], truth.y[0], truth.heading[0]) == (0.0, 0.0, 0.0)
    predicted = read_trajectory(run / "predicted.csv")
    radius = np.hypot(predicted.x, predicted.y)
    assert radius.max() <= 3.0 and radius.max() == pytest.approx(
        doc["exploration"]["largest_radius"]
    )
    assert len(doc["exploration"]["commands"]) >= 3
    # the slip model is fitted from the folder's files as they are
    slip = tmp_path / "slip.toml"
    code = main(
        [
            "calibrate", "lsq", str(run / "encoders.csv"), "-f", "csv", "-p", "jaguar-lite",
            "--model", "slip", "-o", str(slip),
        ]
    )  # fmt: skip
    assert code == 0, capsys.readouterr().err
    assert load_params(str(slip)).model.kind == "slip"
    # and compared with the kinematic models on a held-out exploration of the simulator
    held = tmp_path / "held"
    assert main(["sim", "explore", "-o", str(held), "--seconds", "10", "--seed", "1"]) == 0
    code = main(
        [
            "calibrate", "compare", str(run / "encoders.csv"), "-f", "csv", "-p", "jaguar-lite",
            "--models", "diff,slip", "--validate", str(held / "explore.csv"),
        ]
    )  # fmt: skip
    assert code == 0, capsys.readouterr().err


def test_a_robot_without_recorded_truth_keeps_the_named_source(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A board on loopback standing in for a real robot: the folder names the source (track)
    and says how to attach it; no truth file is written."""
    board = VirtualJaguar(IdealPlant(NOMINAL), BoardConfig.from_params(NOMINAL))
    with VirtualJaguarServer(board) as server:
        host, port = server.address
        run = tmp_path / "real"
        code = main(
            [
                "robot", "explore", "--seconds", "2", "--ground-truth", "track", "--robot",
                f"udp://{host}:{port}", "--quiet", "--no-realtime", "--out", str(run),
            ]
        )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "ground truth: a filmed marker on the robot (odolab track)" in err
    assert "not attached yet: attach the filmed marker afterwards" in out
    assert f"--encoders {run / 'encoders.csv'} -o {run / 'encoders_gt.csv'}" in out
    assert not (run / "encoders_gt.csv").exists()
    doc = json.loads((run / "run.json").read_text())
    assert doc["ground_truth"]["source"] == "track" and doc["ground_truth"]["file"] is None
    assert "--encoders encoders.csv -o encoders_gt.csv" in doc["ground_truth"]["attach"]


def test_with_a_notebook_the_exploration_is_kept_out_of_table_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "lab.db"
    code = main(
        [
            "robot", "explore", "--seconds", "1.5", "--quiet", "--no-realtime", "--out",
            str(tmp_path / "run"), "--db", str(db),
        ]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "(excluded: an exploration (1.5 s," in out and "not a Table I trial" in out
    nb = Notebook(db)
    try:
        (trial,) = nb.load_trials(with_logs=True)
        assert trial.command.kind is MotionKind.FREE and trial.status is TrialStatus.EXCLUDED
        assert trial.trial_id.startswith("robot-explore-") and trial.encoder_log is not None
        assert "exploration: 1.5 s" in trial.notes
        assert sum(select(nb).used.values()) == 0  # no rotation or translation trial counted
    finally:
        nb.close()


def _commands(seed: int, distribution: str = "uniform") -> list[list[float]]:
    spec = Exploration(seconds=20.0, seed=seed, distribution=distribution)
    plan = plan_exploration(Command.exploration(spec), RunConfig(), NOMINAL, "sim://")
    run = plan.simulate(IdealPlant(NOMINAL), params=NOMINAL)
    return [list(c) for c in run.extra["exploration"]["commands"]]


def test_the_same_seed_draws_the_same_commands() -> None:
    first = _commands(7)
    assert len(first) >= 5 and first == _commands(7)
    assert first != _commands(8)
    edges = _commands(7, "edges")
    assert edges != first
    # each command within the limits: |v| <= 0.5, |w| <= 1, both tracks within 0.5 m/s
    half = 0.5 * NOMINAL.track_width
    for _, v, w in first + edges:
        assert abs(v) <= 0.5 and abs(w) <= 1.0 and abs(v) + abs(w) * half <= 0.5 + 1e-12
    assert not math.isnan(first[0][0])


@pytest.mark.parametrize("rate", [20.0, 50.0])
def test_each_rows_truth_is_the_pose_of_its_own_report(rate: float) -> None:
    """On an ideal robot the odometry of a row and its true pose differ by the counters'
    rounding only (one count: about 1.4 mm of track), whatever the report's age."""
    spec = Exploration(seconds=30.0, seed=3)
    config = RunConfig(rate=rate)
    command = Command.exploration(spec)
    plan = plan_exploration(command, config, NOMINAL, "sim://")
    run = plan.simulate(IdealPlant(NOMINAL), params=NOMINAL, config=config)
    truth, odometry = run.truth, run.loop.log.trajectory()
    assert truth is not None and np.array_equal(truth.t, odometry.t)
    assert np.max(np.hypot(truth.x - odometry.x, truth.y - odometry.y)) < 2e-3
    assert np.max(np.abs(truth.heading - odometry.heading)) < 3e-3
    # the true pose at the cycle instead (the report up to 0.1 s old) would be centimetres off
    assert np.max(np.hypot(np.diff(truth.x), np.diff(truth.y))) > 0.02


def test_an_explorations_settings_never_go_silently_into_a_notebook(tmp_path: Path) -> None:
    spec = Exploration(seconds=2.0, seed=1)
    plan = plan_exploration(Command.exploration(spec), RunConfig(), NOMINAL, "sim://")
    run = plan.simulate(IdealPlant(NOMINAL), params=NOMINAL)
    assert run.trial.command.kind is MotionKind.FREE and run.trial.command.label == "explore"
    nb = Notebook(tmp_path / "lab.db")
    try:
        with pytest.raises(InvalidTrialError, match="an exploration's settings have no place"):
            nb.add_trial(run.trial)
        nb.add_trial(notebook_trial(run.trial))  # what --db records
        back = nb.get_trial(run.trial.trial_id)
        assert back.command == Command(MotionKind.FREE) and back.status is TrialStatus.EXCLUDED
        assert back.exclusion_reason == (
            "an exploration (2 s, speeds up to 0.5 m/s, turn rates up to 1 rad/s, each held 1-3 "
            "s, drawn uniform (seed 1), fence 3 m about the start), not a Table I trial"
        )
    finally:
        nb.close()
