"""Runs end to end: simulated-time runs, saved folders, the CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from odolab.cli import main
from odolab.core.odometry import integrate
from odolab.core.params import PRESETS
from odolab.core.trials import Command, MotionKind, TrialStatus
from odolab.io import read_encoder_csv, read_trajectory_csv
from odolab.robot.config import RunConfig
from odolab.robot.plant import IdealPlant
from odolab.robot.session import run_motion, run_motion_simulated, save_run
from odolab.sim.plants import make_plant

NOMINAL = PRESETS["jaguar-lite"]


def test_twenty_pi_rotation_in_simulated_time_jaguar_lab() -> None:
    trial, stats = run_motion_simulated(
        Command(MotionKind.ROTATION, angle=20 * math.pi, speed=0.5),
        nominal=NOMINAL,
        seed=2,
        plant=make_plant("jaguar-lab", NOMINAL, seed=2),
    )
    assert trial.status is TrialStatus.AWAITING
    assert trial.predicted.heading >= 20 * math.pi
    assert trial.encoder_log is not None and len(trial.encoder_log) == stats.cycles
    log = trial.encoder_log
    traj = integrate(log.t, log.left_ticks, log.right_ticks, NOMINAL)
    assert traj.heading[-1] == pytest.approx(trial.predicted.heading, abs=1e-9)
    assert trial.true is not None
    # the lab's rotation ratio, within the truth's random spread (sigma 2.94 rad at 20 pi)
    assert trial.true.heading / trial.predicted.heading == pytest.approx(0.875, abs=0.15)
    assert stats.duration > 120  # 20 pi at 0.5 rad/s, simulated


def test_real_time_run_on_loopback_is_saved(tmp_path: Path) -> None:
    run = run_motion(
        Command(MotionKind.TRANSLATION, distance=0.3, speed=0.6),
        config=RunConfig(settle=0.2),
        plant=lambda: make_plant("ideal", NOMINAL),
    )
    assert run.stop_confirmed
    folder = save_run(run, tmp_path / "run")
    enc = read_encoder_csv(folder / "encoders.csv", modulus=NOMINAL.encoder_modulus)
    traj = integrate(enc.t, enc.left_ticks, enc.right_ticks, NOMINAL)
    assert traj.x[-1] == pytest.approx(run.trial.predicted.x, abs=1e-9)
    saved = read_trajectory_csv(folder / "predicted.csv")
    assert saved.x[-1] == pytest.approx(run.trial.predicted.x, abs=1e-9)
    doc = json.loads((folder / "run.json").read_text())
    assert doc["command"] == {"kind": "translation", "distance": 0.3, "speed": 0.6}
    assert doc["status"] == "awaiting" and doc["measured"] is None
    assert doc["true"]["x"] == pytest.approx(run.trial.predicted.x, abs=0.002)


def test_cli_drive_and_bad_robot_url(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cli"
    code = main(
        [
            "robot",
            "drive",
            "--distance",
            "-0.2",
            "--speed",
            "0.5",
            "--quiet",
            "--truth",
            "ideal",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "translation -0.2 m" in text and "saved to" in text
    assert (out / "encoders.csv").exists() and (out / "run.json").exists()
    code = main(["robot", "rotate", "--turns", "1", "--robot", "ftp://127.0.0.1:1", "--quiet"])
    assert code == 1
    assert "udp://HOST:PORT" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args",
    [
        ["drive", "--distance", "0"],
        ["rotate", "--turns", "0"],
        ["pivot", "--degrees", "0"],
        ["rotate", "--turns", "1", "--rate", "nan"],
    ],
)
def test_cli_zero_motion_is_refused_before_driving(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str]
) -> None:
    out = tmp_path / "zero"
    code = main(["robot", *args, "--quiet", "--out", str(out), "--db", str(tmp_path / "l.db")])
    assert code == 1
    err = capsys.readouterr().err
    option = [a for a in args if a.startswith("--")][-1]
    assert err.startswith(f"odolab: error: {option} is ") and err.count("\n") == 1
    assert not out.exists() and not (tmp_path / "l.db").exists()  # nothing driven or recorded


class OffsetPlant(IdealPlant):
    """An ideal robot whose counters start at ``offset`` (left, right) instead of 0."""

    def __init__(self, offset: tuple[int, int]) -> None:
        super().__init__(NOMINAL)
        self.offset = offset

    def encoder_counts(self) -> tuple[int, int]:
        left, right = super().encoder_counts()
        return (left + self.offset[0]) % 32768, (right + self.offset[1]) % 32768


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 32767), st.integers(0, 32767))
def test_rollover_anywhere_gives_the_same_prediction(left0: int, right0: int) -> None:
    # 3 m in reverse is about 2173 counts: offsets below that wrap through 0
    cmd = Command(MotionKind.TRANSLATION, distance=-3.0, speed=1.0)
    trial, _ = run_motion_simulated(cmd, plant=OffsetPlant((left0, right0)))
    ref, _ = run_motion_simulated(cmd, plant=OffsetPlant((20000, 20000)))
    assert trial.predicted.x == pytest.approx(ref.predicted.x, abs=1e-12)
    assert trial.predicted.heading == pytest.approx(0.0, abs=1e-12)


def test_rollover_through_zero_really_happens() -> None:
    cmd = Command(MotionKind.TRANSLATION, distance=-3.0, speed=1.0)
    trial, _ = run_motion_simulated(cmd, plant=OffsetPlant((5, 32760)))
    assert trial.encoder_log is not None
    left = trial.encoder_log.left_ticks
    assert left.max() > 30000 and left.min() < 10  # wrapped below 0
    assert trial.predicted.x <= -3.0


def test_interrupted_run_is_saved_and_robot_stopped(tmp_path: Path) -> None:
    from odolab.robot.loop import CycleInfo

    def ctrl_c(info: CycleInfo) -> None:
        if info.index == 12:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_motion(
            Command(MotionKind.TRANSLATION, distance=2.0, speed=0.5),
            plant=lambda: make_plant("ideal", NOMINAL),
            on_cycle=ctrl_c,
            save_to=tmp_path / "partial",
        )
    doc = json.loads((tmp_path / "partial" / "run.json").read_text())
    assert doc["completed"] is False and doc["aborted"].startswith("aborted: KeyboardInterrupt")
    assert doc["stats"]["cycles"] == 13
    enc = read_encoder_csv(tmp_path / "partial" / "encoders.csv")
    assert len(enc) == 13
    # the board took the stop: the true robot is where the counters say, not further on
    assert doc["true"]["x"] < 0.5


def test_cli_out_that_is_a_file_is_refused_before_driving(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a_file = tmp_path / "run.csv"
    a_file.write_text("x")
    code = main(["robot", "rotate", "--turns", "1", "--quiet", "--out", str(a_file)])
    assert code == 1
    err = capsys.readouterr().err
    assert "expected a folder for the run" in err and "robot stopped" not in err
