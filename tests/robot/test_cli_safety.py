"""`odolab robot` as a user runs it (in-process ``main``): every invalid option is refused with one
sentence naming it before anything is sent; a dead board ends the run with exit 1 after
``--link-timeout`` (also with ``--quiet``), the robot commanded to stop and the partial run
saved; a second client's ACK does not take the board; "robot stopped" only when the robot's
data confirms it."""

from __future__ import annotations

import json
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotConfigError
from odolab.robot.jaguar.board import BoardConfig, Faults, VirtualJaguar, VirtualJaguarServer
from odolab.robot.jaguar.protocol import SystemCode, encode_system
from odolab.robot.plant import IdealPlant

NOMINAL = PRESETS["jaguar-lite"]


# (command, option, value, what the sentence must say about the accepted values)
INVALID = [
    ("drive", "--max-wheel-speed", "-1", "(0, 3] m/s"),
    ("drive", "--max-wheel-speed", "0", "(0, 3] m/s"),
    ("drive", "--max-wheel-speed", "nan", "(0, 3] m/s"),
    ("drive", "--max-wheel-speed", "inf", "(0, 3] m/s"),
    ("drive", "--rate", "0.2", "[5, 1000] Hz"),
    ("drive", "--rate", "nan", "[5, 1000] Hz"),
    ("drive", "--rate", "1e6", "[5, 1000] Hz"),
    ("drive", "--rate", "4.9999999", "--rate is 4.9999999; expected"),  # it said "is 5"
    ("drive", "--watchdog", "1e9", "[0.05, 2] s"),
    ("drive", "--watchdog", "0", "[0.05, 2] s"),
    ("drive", "--watchdog", "-1", "[0.05, 2] s"),
    ("drive", "--link-timeout", "1e9", "[0.1, 60] s"),
    ("drive", "--link-timeout", "0.2", "shorter than --watchdog"),
    ("drive", "--stall-timeout", "0", "[0.2, 60] s"),
    ("drive", "--command-timeout", "0", "[0.05, 5] s"),
    ("drive", "--command-timeout", "nan", "[0.05, 5] s"),
    ("drive", "--decel", "-0.1", "[0, 100] m or rad"),
    ("drive", "--decel", "nan", "[0, 100] m or rad"),
    ("drive", "--speed", "0", "(0, 1] m/s"),
    ("drive", "--speed", "-0.3", "(0, 1] m/s"),
    ("drive", "--speed", "nan", "(0, 1] m/s"),
    ("drive", "--speed", "5", "(0, 1] m/s"),
    ("drive", "--distance", "0", "(0, 100] m"),
    ("drive", "--distance", "1e9", "(0, 100] m"),
    ("drive", "--distance", "nan", "(0, 100] m"),
    ("rotate", "--turns", "inf", "(0, 100] turns"),
    ("rotate", "--speed", "0", "rad/s"),
    ("rotate", "--speed", "100", "rad/s"),
    ("pivot", "--degrees", "0", "(0, 36000] degrees"),
    ("square", "--side", "-4", "(0, 50] m"),
    ("square", "--speed", "0", "(0, 1] m/s"),
    ("drive", "--left-channel", "2", "expected 0 or 1"),
    ("drive", "--right-channel", "0", "expected one track on channel 0"),
    ("drive", "--left-encoder-sign", "0", "expected 1 or -1"),
    ("drive", "--right-motor-sign", "2", "expected 1 or -1"),
    # the virtual Jaguar's options on a real link: a typo, or any value, drove the robot
    ("drive", "--truth", "foo", "--truth is 'foo'; expected one of"),
    ("rotate", "--terrain", "gras", "expected one of"),
    ("drive", "--truth", "jaguar-lab-tracked", "for the virtual Jaguar (sim://) only"),
    ("pivot", "--terrain", "grass", "for the virtual Jaguar (sim://) only"),
    ("square", "--seed", "5", "for the virtual Jaguar (sim://) only"),
]


@pytest.mark.parametrize(("command", "option", "value", "expected"), INVALID)
def test_invalid_option_is_refused_before_anything_is_sent(
    listener: socket.socket,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: str,
    option: str,
    value: str,
    expected: str,
) -> None:
    port = listener.getsockname()[1]
    out = tmp_path / "run"
    code = main(
        [
            "robot",
            command,
            option,
            value,
            "--robot",
            f"udp://127.0.0.1:{port}",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 1
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("odolab: error: ")
    assert option in lines[0] and expected in lines[0]
    with pytest.raises(BlockingIOError):
        listener.recv(2048)  # nothing at all was sent to the robot
    assert not out.exists()


@pytest.mark.parametrize(
    ("option", "value"),
    [("--report-rate", "0"), ("--command-timeout", "0"), ("--drop", "2"), ("--silent-after", "-1")],
)
def test_sim_server_refuses_bad_options(
    capsys: pytest.CaptureFixture[str], option: str, value: str
) -> None:
    code = main(["robot", "sim-server", "--port", "0", option, value])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and option in err


def test_run_config_names_the_option_and_keeps_good_values() -> None:
    c = RunConfig(rate=50, watchdog=0.2, link_timeout=1.0)
    assert (c.rate, c.period, c.watchdog) == (50.0, 0.02, 0.2)
    with raises_worded(RobotConfigError, match=r"^--watchdog is 0.05 s, shorter than two loop"):
        RunConfig(rate=20, watchdog=0.05)
    with raises_worded(RobotConfigError, match=r"^--mode is 'fast'"):
        RunConfig(mode="fast")  # type: ignore[arg-type]
    assert RunConfig().to_dict()["mode"] == "pwm"


@pytest.fixture
def board_server() -> Iterator[VirtualJaguarServer]:
    board = VirtualJaguar(IdealPlant(NOMINAL), BoardConfig.from_params(NOMINAL))
    with VirtualJaguarServer(board, "127.0.0.1", 0) as server:
        yield server


def test_dead_board_quiet_cli_gives_up_after_link_timeout(
    board_server: VirtualJaguarServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board_server.set_faults(Faults(silent_after=0.6))  # the board dies 0.6 s into the run
    host, port = board_server.address
    out = tmp_path / "run"
    t0 = time.perf_counter()
    code = main(
        [
            "robot",
            "drive",
            "--distance",
            "5",
            "--speed",
            "0.5",
            "--robot",
            f"udp://{host}:{port}",
            "--quiet",
            "--link-timeout",
            "1",
            "--out",
            str(out),
            "--no-realtime",
        ]
    )
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert code == 1
    assert "link lost" in err  # said even with --quiet
    assert "--link-timeout 1 s" in err
    # it cannot know the robot stopped (no data): it must not say so
    assert "does not confirm that it stopped" in err and "robot stopped (" not in err
    assert f"the partial run is saved to {out}" in err
    doc = json.loads((out / "run.json").read_text())
    assert doc["completed"] is False and doc["stop_confirmed"] is False
    assert doc["config"]["link_timeout"] == 1.0
    assert board_server.call(lambda b: b.wheel_speeds) == (0.0, 0.0)  # the stop did arrive
    assert elapsed < 30  # it gave up (the old CLI waited until Ctrl-C)


def test_second_clients_ack_does_not_take_the_board_during_a_cli_run(
    board_server: VirtualJaguarServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    host, port = board_server.address
    done = threading.Event()

    def stranger() -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            while not done.wait(0.3):
                if board_server.call(lambda b: b.stats.commands) > 5:
                    sock.sendto(encode_system(SystemCode.ACK), (host, port))
                    return

    thread = threading.Thread(target=stranger)
    thread.start()
    try:
        code = main(
            [
                "robot",
                "drive",
                "--distance",
                "0.6",
                "--speed",
                "0.5",
                "--robot",
                f"udp://{host}:{port}",
                "--quiet",
                "--out",
                str(tmp_path / "r"),
                "--no-realtime",
            ]
        )
    finally:
        done.set()
        thread.join()
    captured = capsys.readouterr()
    assert code == 0, captured.err
    stats = board_server.call(lambda b: b.stats)
    assert stats.rejected_acks == 1 and stats.takeovers == 0
    assert "robot stopped (its sensor data confirms it)" in captured.err
    assert board_server.call(lambda b: b.wheel_speeds) == (0.0, 0.0)
    # it drove its 0.6 m (more when the loaded test machine wakes the loop late)
    assert 0.55 < board_server.call(lambda b: b.plant.true_pose.x) < 1.0


class StuckPlant(IdealPlant):
    """A robot whose tracks do not turn (lifted, blocked, or a board ignoring the commands)."""

    def advance(self, duration: float) -> None:
        self._t += duration


def test_commands_without_effect_abort_the_cli_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board = VirtualJaguar(StuckPlant(NOMINAL), BoardConfig.from_params(NOMINAL))
    with VirtualJaguarServer(board, "127.0.0.1", 0) as server:
        host, port = server.address
        code = main(
            [
                "robot",
                "drive",
                "--distance",
                "1",
                "--robot",
                f"udp://{host}:{port}",
                "--quiet",
                "--stall-timeout",
                "0.5",
                "--out",
                str(tmp_path / "r"),
                "--no-realtime",
            ]
        )
        speeds = server.call(lambda b: b.wheel_speeds)
    err = capsys.readouterr().err
    assert code == 1
    assert "have not moved for 0.5 s" in err
    assert speeds == (0.0, 0.0)
    # the counters never moved, so two equal reports after the stop confirm it honestly
    assert "robot stopped (its sensor data confirms it)" in err


def test_the_control_loop_never_draws_the_live_view(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The live view was drawn inside the control cycle: a terminal that stopped reading
    (Ctrl-S, a stalled ssh session) froze the loop with the motion in force, 8 s on a board
    with a 5 s timeout (a robot-safety review). rich's own thread draws it now, from the
    latest cycle; the loop only hands the cycle over."""
    import threading

    from rich.live import Live

    loop_thread = threading.current_thread()
    drawn: list[str] = []

    def update(self: Live, *args: object, **kwargs: object) -> None:
        raise AssertionError("the control loop updated the live view")

    original = Live.refresh

    def refresh(self: Live) -> None:
        if threading.current_thread() is loop_thread and self.is_started and drawn:
            raise AssertionError("the control loop drew the live view")
        drawn.append(threading.current_thread().name)
        original(self)

    monkeypatch.setattr(Live, "update", update)
    monkeypatch.setattr(Live, "refresh", refresh)
    out = tmp_path / "run"
    code = main(["robot", "drive", "--distance", "0.5", "--speed", "0.5", "--no-realtime",
                 "--out", str(out)])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 0, err
    assert (out / "run.json").is_file()
