"""Issue 24, items 1-3 in-process: nothing loads in a control cycle; a late cycle stops the robot
and fails the run; every output precondition is checked before the robot moves, a run that
has driven is always kept (folder and notebook), an earlier run is never overwritten."""

from __future__ import annotations

import gc
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import odolab.io
from odolab.cli import main
from odolab.core.errors import OdolabError
from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.core.trials import Command, MotionKind, TrialStatus
from odolab.core.writing import OutputFileError
from odolab.robot.clock import SimClock
from odolab.robot.errors import LateCycleError, RunFolderError
from odolab.robot.jaguar.board import BoardConfig, InProcessLink, VirtualJaguar
from odolab.robot.jaguar.driver import JaguarDriver, driver_config_for
from odolab.robot.loop import ControlLoop, CycleInfo
from odolab.robot.motions import Straight
from odolab.robot.plant import IdealPlant
from odolab.robot.session import (
    OPTIONAL_RUN_FILES,
    RUN_FILES,
    check_run_folder,
    keep_run,
    run_motion,
)
from odolab.sim.plants import make_plant
from odolab.store import Notebook

NOMINAL = PRESETS["jaguar-lite"]
SHORT = Command(MotionKind.TRANSLATION, distance=0.1, speed=0.5)


# -- 1. nothing compiles or loads inside a control cycle -----------------------------------------

WARM_UP_CHECK = """
import sys
from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS, NoiseParams

FEED = [(7, 9), (100, 140), (32767, 3)]  # what a driver feeds: ints
odo = Odometry(PRESETS["jaguar-lite"])
odo.warm_up()
for k, ticks in enumerate(FEED):
    odo.update(0.05 * k, *ticks)
print("numba" in sys.modules, odo.cycles)  # the pose step runs as Python: numba never loads

from odolab.core.uncertainty import _stream_step

noisy = PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 3e-4, k_scrub=0.02))
odo = Odometry(noisy, covariance=True)
before = len(_stream_step.signatures)
odo.warm_up()
warm = list(_stream_step.signatures)
assert odo.cycles == 0 and odo.pose.x == 0.0, "warm_up changed the odometry's state"
for k, ticks in enumerate(FEED):
    odo.update(0.05 * k, *ticks)
print(before, len(warm), list(_stream_step.signatures) == warm, odo.cycles)
"""


def test_warm_up_compiles_exactly_what_the_loop_calls(tmp_path: Path) -> None:
    # its own process, with an empty numba cache: the dispatchers start with nothing compiled
    out = subprocess.run(
        [sys.executable, "-c", WARM_UP_CHECK],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")},
    )
    assert out.returncode == 0, out.stderr
    # no numba without covariance; with it, nothing before, the covariance step compiled by the
    # warm-up, and the real updates added no signature
    assert out.stdout.split() == ["False", "2", "0", "1", "True", "2"], out.stdout


def test_warm_up_leaves_the_odometry_as_it_was() -> None:
    odo = Odometry(NOMINAL)
    odo.update(0.0, 10, 10)
    odo.update(0.05, 60, 80)
    pose = odo.pose
    odo.warm_up()
    assert odo.pose == pose and odo.cycles == 1
    odo.update(0.1, 110, 150)
    ref = Odometry(NOMINAL)
    for t, left, right in ((0.0, 10, 10), (0.05, 60, 80), (0.1, 110, 150)):
        ref.update(t, left, right)
    assert odo.pose == ref.pose


def test_the_heap_the_run_starts_with_is_frozen_during_the_cycles() -> None:
    # a full GC collection inside a cycle would scan it all (0.4 s for the CLI's heap)
    loop, _board, _driver, _clock = rig()
    frozen: list[int] = []
    loop.on_cycle = lambda info: frozen.append(gc.get_freeze_count())
    assert gc.get_freeze_count() == 0
    loop.run(Straight(0.2, speed=0.5))
    assert len(frozen) > 10 and min(frozen) > 1000  # every cycle ran with the heap frozen
    assert gc.get_freeze_count() == 0  # and it is given back afterwards


# -- 2. a late cycle stops the robot and fails the run -------------------------------------------


def rig() -> tuple[ControlLoop, VirtualJaguar, JaguarDriver, SimClock]:
    clock = SimClock()
    board = VirtualJaguar(IdealPlant(NOMINAL), BoardConfig.from_params(NOMINAL), seed=3)
    driver = JaguarDriver(InProcessLink(board, clock.now), clock, driver_config_for(NOMINAL))
    return ControlLoop(driver, Odometry(NOMINAL), clock, rate=20.0), board, driver, clock


@pytest.mark.parametrize(("stall", "fails"), [(0.45, False), (0.6, True), (30.0, True)])
def test_a_stalled_cycle_beyond_the_watchdog_stops_and_fails(stall: float, fails: bool) -> None:
    loop, board, driver, clock = rig()
    seen: dict[str, int] = {}

    def freeze(info: CycleInfo) -> None:
        if info.index == 20:  # the host stalls for `stall` s after cycle 20's command
            seen["motion"] = driver.stats.commands_sent - driver.stats.stops_sent
            seen["stops"] = driver.stats.stops_sent
            clock.advance(stall)

    loop.on_cycle = freeze
    if not fails:  # 0.45 s (+ the rest of the cycle) is within the 0.5 s bound: it carries on
        assert loop.run(Straight(0.5, speed=0.5)).completed
        return
    with pytest.raises(
        LateCycleError, match=r"^control cycle 21 ran .* s late, more than the watchdog bound 0.5 s"
    ):
        loop.run(Straight(0.5, speed=0.5))
    # no motion command after the stall, the fixed stop sent (three times, then three more on
    # the way out), the board's wheels still
    assert driver.stats.commands_sent - driver.stats.stops_sent == seen["motion"]
    assert driver.stats.stops_sent == seen["stops"] + 6
    assert board.wheel_speeds == (0.0, 0.0)
    partial = loop.partial
    assert partial is not None and not partial.completed
    assert partial.aborted.startswith("aborted: LateCycleError(")
    assert len(partial.log) == 22 and partial.stats.lateness_max == pytest.approx(stall, abs=0.1)


def test_a_stalled_run_is_saved_as_failed_with_the_reason(tmp_path: Path) -> None:
    def stall(info: CycleInfo) -> None:
        if info.index == 8:
            time.sleep(0.8)  # a stalled cycle on the real clock

    with pytest.raises(LateCycleError):
        run_motion(
            Command(MotionKind.TRANSLATION, distance=2.0, speed=0.5),
            plant=lambda: make_plant("ideal", NOMINAL),
            on_cycle=stall,
            save_to=tmp_path / "run",
        )
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    assert doc["completed"] is False and doc["stats"]["cycles"] == 10
    assert doc["aborted"].startswith("aborted: LateCycleError('control cycle 9 ran")
    assert doc["status"] == "excluded" and "more than the watchdog" in doc["exclusion_reason"]
    assert doc["stats"]["lateness_max"] >= 0.75
    assert doc["true"]["x"] < 0.5  # stopped, not driven on


def test_cli_late_cycle_fails_and_is_recorded_in_the_notebook(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = {"n": 0}
    original = JaguarDriver.set_wheel_speeds

    def slow_tenth(
        self: JaguarDriver, left: float, right: float, *, send_by: float | None = None
    ) -> None:
        calls["n"] += 1
        original(self, left, right, send_by=send_by)
        if calls["n"] == 10:
            time.sleep(0.8)  # the host stalls with the command in force

    monkeypatch.setattr(JaguarDriver, "set_wheel_speeds", slow_tenth)
    db = tmp_path / "lab.db"
    out = tmp_path / "run"
    args = ["robot", "drive", "--distance", "2", "--speed", "0.5", "--truth", "ideal"]
    code = main([*args, "--quiet", "--no-realtime", "--out", str(out), "--db", str(db)])
    err = capsys.readouterr().err
    assert code == 1
    assert "late, more than the watchdog bound 0.5 s" in err and "robot stopped (" in err
    assert f"the partial run is saved to {out}" in err
    doc = json.loads((out / "run.json").read_text())
    with Notebook(db) as nb:
        (trial,) = nb.load_trials()
    assert trial.trial_id == doc["trial_id"] and trial.status is TrialStatus.EXCLUDED
    assert trial.exclusion_reason is not None and "LateCycleError" in trial.exclusion_reason
    assert f"recorded in {db} as {trial.trial_id} (excluded: the run failed)" in err


# -- 3. output preconditions before the robot moves; a driven run is always kept ----------------


CLI_DRIVE = ["robot", "drive", "--distance", "0.1", "--speed", "0.5", "--quiet", "--no-realtime"]


def cli(out: Path, robot: str, *extra: str) -> int:
    truth = ["--truth", "ideal"] if robot.startswith("sim:") else []  # sim:// only
    return main([*CLI_DRIVE, *truth, "--robot", robot, "--out", str(out), *extra])


def test_out_below_a_file_is_refused_before_anything_is_sent(
    tmp_path: Path, listener: socket.socket, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "afile").write_text("x")
    port = listener.getsockname()[1]
    db = tmp_path / "lab.db"
    code = cli(tmp_path / "afile" / "sub", f"udp://127.0.0.1:{port}", "--db", str(db))
    err = capsys.readouterr().err
    assert code == 1
    assert err == (
        f"odolab: error: {tmp_path}/afile/sub: is below {tmp_path}/afile, a file; expected a "
        "folder for the run (--out)\n"
    )
    with pytest.raises(BlockingIOError):
        listener.recv(2048)  # not even the handshake went out
    assert not db.exists()


@pytest.mark.parametrize("name", (*RUN_FILES, *OPTIONAL_RUN_FILES))
def test_out_with_a_folder_in_place_of_a_run_file_is_refused(
    tmp_path: Path, listener: socket.socket, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    (tmp_path / "run" / name).mkdir(parents=True)
    code = cli(tmp_path / "run", f"udp://127.0.0.1:{listener.getsockname()[1]}")
    err = capsys.readouterr().err
    assert code == 1
    assert f"run: has a folder named {name} where the run writes its {name}" in err
    with pytest.raises(BlockingIOError):
        listener.recv(2048)


def test_quiet_runs_in_one_process_leave_no_thread_behind(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--quiet`` says events from a printer thread; each run ends its own (a process that
    drives many runs, as a notebook or a test does, kept one thread a run)."""
    import threading

    def printers() -> int:
        return sum(t.name == "odolab-events" for t in threading.enumerate())

    before = printers()
    for k in range(3):
        assert cli(tmp_path / f"run{k}", "sim://") == 0
    (tmp_path / "afile").write_text("x")
    for k in range(2):  # refused before driving: a folder below a file
        assert cli(tmp_path / "afile" / f"run{k}", "sim://") == 1
    capsys.readouterr()
    assert printers() == before


def test_an_earlier_run_is_never_overwritten(
    tmp_path: Path, listener: socket.socket, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    assert cli(out, "sim://") == 0
    before = {n: (out / n).read_bytes() for n in RUN_FILES}
    capsys.readouterr()
    code = cli(out, f"udp://127.0.0.1:{listener.getsockname()[1]}")
    err = capsys.readouterr().err
    assert code == 1 and "holds an earlier run (run.json); a run folder is never overwritten" in err
    assert {n: (out / n).read_bytes() for n in RUN_FILES} == before
    with pytest.raises(BlockingIOError):
        listener.recv(2048)


def test_check_run_folder_accepts_new_and_empty_folders_and_probes_writing(
    tmp_path: Path,
) -> None:
    assert check_run_folder(tmp_path / "a" / "b") == tmp_path / "a" / "b"
    assert (tmp_path / "a" / "b").is_dir() and list((tmp_path / "a" / "b").iterdir()) == []
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "notes.txt").write_text("mine")  # other files are left alone
    assert check_run_folder(tmp_path / "empty") == tmp_path / "empty"
    (tmp_path / "f").write_text("x")
    with pytest.raises(RunFolderError, match=r"f: is a file; expected a folder"):
        check_run_folder(tmp_path / "f")
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "encoders.csv").write_text("t,left_ticks,right_ticks\n")
    with pytest.raises(RunFolderError, match=r"has a file named encoders.csv"):
        check_run_folder(tmp_path / "old")


def test_a_failed_write_after_driving_keeps_the_run_in_a_sibling_and_the_notebook(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # the first write of the predicted trajectory fails (a full disk, say) after the robot drove
    original = odolab.io.write_trajectory_csv
    failures = {"left": 1}

    def full_disk(path: str | Path, traj: object) -> Path:
        if failures["left"]:
            failures["left"] -= 1
            raise OutputFileError(f"{path}: cannot write the trajectory CSV (No space left)")
        return original(path, traj)  # type: ignore[arg-type]

    monkeypatch.setattr(odolab.io, "write_trajectory_csv", full_disk)
    db = tmp_path / "lab.db"
    out = tmp_path / "run"
    code = cli(out, "sim://", "--db", str(db))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    sibling = tmp_path / "run-2"
    assert (
        f"the run could not be saved to {out}: {out}/predicted.csv: cannot write the trajectory "
        f"CSV (No space left); it is saved to {sibling} instead"
    ) in captured.err
    assert f"saved to {sibling} (status: awaiting measurement)" in captured.out
    doc = json.loads((sibling / "run.json").read_text())
    assert all((sibling / n).is_file() for n in RUN_FILES) and doc["completed"] is True
    with Notebook(db) as nb:
        assert nb.trial_ids() == {doc["trial_id"]}


def test_a_folder_replaced_during_the_run_goes_to_a_sibling(tmp_path: Path) -> None:
    out = tmp_path / "run"

    def replace_folder(info: CycleInfo) -> None:
        if info.index == 3:
            shutil.rmtree(out)
            out.write_text("someone put a file here")

    run = run_motion(
        SHORT, plant=lambda: make_plant("ideal", NOMINAL), on_cycle=replace_folder, save_to=out
    )
    assert run.saved_to == tmp_path / "run-2"
    assert "could not be saved to" in run.save_note and "is a file" in run.save_note
    assert json.loads((tmp_path / "run-2" / "run.json").read_text())["trial_id"] == (
        run.trial.trial_id
    )
    assert out.read_text() == "someone put a file here"  # untouched


def test_when_no_sibling_can_take_it_the_run_goes_to_the_rescue_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rescue = tmp_path / "rescue"
    monkeypatch.setenv("ODOLAB_RESCUE_DIR", str(rescue))
    parent = tmp_path / "parent"
    out = parent / "run"

    def replace_parent(info: CycleInfo) -> None:
        if info.index == 3:
            shutil.rmtree(parent)
            parent.write_text("a file now")

    run = run_motion(
        SHORT, plant=lambda: make_plant("ideal", NOMINAL), on_cycle=replace_parent, save_to=out
    )
    assert run.saved_to is not None and run.saved_to.parent == rescue
    assert run.saved_to.name.startswith(run.trial.trial_id)
    assert f"it is saved to {run.saved_to} instead" in run.save_note
    assert all((run.saved_to / n).is_file() for n in RUN_FILES)
    # and where nothing at all can take it, keep_run says so instead of raising
    monkeypatch.setenv("ODOLAB_RESCUE_DIR", str(parent / "x"))
    saved, note = keep_run(run, out)
    assert saved is None and note.startswith("the run could not be saved anywhere: ")


def test_a_notebook_failure_after_driving_says_where_the_run_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def refuse(self: Notebook, trial: object, **kw: object) -> None:
        raise OdolabError(f"{self.path}: write refused (database is locked)")

    monkeypatch.setattr(Notebook, "add_trial", refuse)
    out = tmp_path / "run"
    code = cli(out, "sim://", "--db", str(tmp_path / "lab.db"))
    err = capsys.readouterr().err
    assert code == 1
    assert f"could not be recorded in the notebook {tmp_path / 'lab.db'}" in err
    assert f"the run is saved to {out}" in err
    assert json.loads((out / "run.json").read_text())["completed"] is True


def test_a_db_that_is_not_a_notebook_is_refused_before_anything_is_sent(
    tmp_path: Path, listener: socket.socket, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "notes.db"
    db.write_text("my own notes, not a notebook\n")
    out = tmp_path / "run"
    code = cli(out, f"udp://127.0.0.1:{listener.getsockname()[1]}", "--db", str(db))
    err = capsys.readouterr().err
    assert code == 1 and err.startswith(f"odolab: error: {db}: ") and err.count("\n") == 1
    with pytest.raises(BlockingIOError):
        listener.recv(2048)
    assert db.read_text() == "my own notes, not a notebook\n"
    assert not out.exists()  # the run folder made by the check is taken back
