"""The safety suite over the 2014 link (issue 27): the virtual Jaguar 4x4 of 2014 in its OWN
process (``odolab robot sim-server --link jaguar2014``, TCP on loopback, an OS-assigned port), the
driver (the CLI) in another, as tests/robot/test_safety_process.py does for the UDP board.

Times are the host's monotonic clock, shared by both processes. W = watchdog 0.5 s, P = one cycle
0.05 s, C = the board's host-silence timeout 0.5 s, plus SLACK for a loaded machine.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

from .freeze import refused_after_freeze

#: slow: real-time robot processes (`make test-fast` leaves them out; `make test` runs them)
pytestmark = [
    pytest.mark.skipif(sys.platform != "linux", reason="needs a shared monotonic clock"),
    pytest.mark.slow,
]

W, P, C = 0.5, 0.05, 0.5
SLACK = 0.15
ODOLAB = [sys.executable, "-m", "odolab.cli"]


@dataclass
class Board:
    proc: subprocess.Popen[str]
    port: int
    trace: Path

    @property
    def url(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def lines(self) -> list[tuple[float, float, float, str]]:
        out = []
        for line in self.trace.read_text().splitlines():
            if line and not line.startswith("#"):
                t, left, right, why = line.split()
                out.append((float(t), float(left), float(right), why))
        return out

    def summary(self) -> dict[str, int]:
        for line in self.trace.read_text().splitlines():
            if line.startswith("# lines"):
                words = line[2:].split()
                return {k: int(v) for k, v in zip(words[::2], words[1::2], strict=True)}
        raise AssertionError(f"the board wrote no summary (exit code {self.proc.returncode})")

    def late(self) -> float:
        """The most the board's thread woke late (s): how long the OS kept the board from
        running, which its trace's times include (0 on an idle machine). After it stopped."""
        return self.summary()["late_ms"] / 1000.0

    def moving(self) -> bool:
        rows = self.lines()
        return bool(rows) and (rows[-1][1], rows[-1][2]) != (0.0, 0.0)

    def final_stop(self) -> tuple[float, str]:
        rows = self.lines()
        assert rows and (rows[-1][1], rows[-1][2]) == (0.0, 0.0), rows[-3:]
        last_move = max(i for i, r in enumerate(rows) if (r[1], r[2]) != (0.0, 0.0))
        stop = next(r for r in rows[last_move + 1 :] if (r[1], r[2]) == (0.0, 0.0))
        return stop[0], stop[3]


@contextmanager
def board(tmp_path: Path, *extra: str, timeout: float = C) -> Iterator[Board]:
    trace = tmp_path / "board.trace"
    proc = subprocess.Popen(
        [
            *ODOLAB,
            "robot",
            "sim-server",
            "--link",
            "jaguar2014",
            "--port",
            "0",
            "--truth",
            "ideal",
            "--trace",
            str(trace),
            "--command-timeout",
            str(timeout),
            *extra,
        ],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        m = re.search(r"tcp://127\.0\.0\.1:(\d+)", line)
        assert m, line
        yield Board(proc, int(m.group(1)), trace)
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - a hung board
            proc.kill()
            proc.wait()


def cli(b: Board, out: Path, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [*ODOLAB, "robot", *args, "--robot", b.url, "--quiet", "--no-realtime", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_moving(b: Board, seconds: float = 0.5, timeout: float = 20.0) -> None:
    end = time.perf_counter() + timeout
    while time.perf_counter() < end:
        if b.moving() and time.perf_counter() - b.lines()[-1][0] >= seconds:
            return
        time.sleep(0.02)
    raise AssertionError("the robot never started moving")


def lateness_max(run: Path) -> float:
    return float(json.loads((run / "run.json").read_text())["stats"]["lateness_max"])


@pytest.mark.slow
def test_rotate_drive_pivot_square_over_tcp(tmp_path: Path) -> None:
    motions = {
        "rotate": ("rotate", "--turns", "0.25", "--speed", "1"),
        "drive": ("drive", "--distance", "0.3", "--speed", "0.5"),
        "pivot": ("pivot", "--degrees", "45", "--speed", "1"),
        "square": ("square", "--side", "0.2", "--speed", "0.5"),
    }
    with board(tmp_path) as b:
        for name, args in motions.items():
            run = tmp_path / name
            _out, err = cli(b, run, *args).communicate(timeout=120)
            assert "robot stopped (its sensor data confirms it)" in err, (name, err)
            doc = json.loads((run / "run.json").read_text())
            assert doc["completed"] is True and doc["aborted"] is None, (name, doc)
            # the first cycles (warm-up) and every later one within the watchdog bound
            assert doc["stats"]["lateness_max"] < W, (name, doc["stats"])
            assert doc["stats"]["keepalives"] > 0
    s = b.summary()
    # one refusal a run: the zero command sent before the E-stop release
    assert s["commands"] > 0 and s["rejected"] == 4 and s["silence_stops"] == 0
    _, why = b.final_stop()
    assert why == "command"  # the driver's own fixed stop line, not the board's timeout


def test_invalid_option_sends_nothing(tmp_path: Path) -> None:
    with board(tmp_path) as b:
        proc = cli(b, tmp_path / "run", "drive", "--distance", "1", "--speed", "-0.5")
        _out, err = proc.communicate(timeout=60)
        assert proc.returncode != 0 and "--speed" in err
    assert b.summary()["lines"] == 0  # not even a PING: refused before connecting


def test_ctrl_c_stops_within_one_cycle_and_a_second_host_is_refused(tmp_path: Path) -> None:
    with board(tmp_path) as b:
        drv = cli(b, tmp_path / "run", "drive", "--distance", "5", "--speed", "0.5")
        wait_moving(b)
        second = socket.create_connection(("127.0.0.1", b.port), timeout=5.0)
        try:  # closed at once (a FIN, or a reset when our lines were still unread)
            second.sendall(b"MMW !MG\r\nMMW !M 0 0\r\n")
            assert second.recv(100) == b""
        except (ConnectionResetError, BrokenPipeError):
            pass
        second.close()
        assert b.moving()  # the stranger's stop line never reached the motors
        t_int = time.perf_counter()
        drv.send_signal(signal.SIGINT)
        _out, err = drv.communicate(timeout=30)
    stop, why = b.final_stop()
    assert why == "command"
    late = lateness_max(tmp_path / "run") + b.late()  # the host's and the board's
    assert stop - t_int <= P + late + SLACK, (stop - t_int, late)
    assert drv.returncode == 130 and "robot stopped (its sensor data confirms it)" in err
    assert b.summary()["refused_peers"] == 1


def test_kill_9_of_the_driver_stops_the_board(tmp_path: Path) -> None:
    with board(tmp_path) as b:
        drv = cli(b, tmp_path / "run", "drive", "--distance", "5", "--speed", "0.5")
        wait_moving(b)
        t_kill = time.perf_counter()
        os.kill(drv.pid, signal.SIGKILL)
        drv.wait(timeout=10)
        time.sleep(C + 0.3)
    stop, why = b.final_stop()
    # the kernel closes the dead host's socket: the board stops at once (or by silence)
    assert stop - t_kill <= C + b.late() + SLACK, (stop - t_kill, why, b.late())
    assert why in ("disconnect", "silence-timeout")


def test_a_frozen_host_stops_the_robot_by_silence_and_fails_the_run(tmp_path: Path) -> None:
    freeze = 1.0
    with board(tmp_path) as b:
        drv = cli(b, tmp_path / "run", "drive", "--distance", "5", "--speed", "0.5")
        wait_moving(b, 0.3)
        t_stop = time.perf_counter()
        os.kill(drv.pid, signal.SIGSTOP)
        time.sleep(freeze)
        os.kill(drv.pid, signal.SIGCONT)
        _out, err = drv.communicate(timeout=60)
    rows = b.lines()
    silence = [r for r in rows if r[3] == "silence-timeout"]
    assert silence and silence[0][0] - t_stop <= C + b.late() + SLACK, (rows[-4:], b.late())
    assert drv.returncode == 1
    refused_after_freeze(err, freeze)  # the loop's lateness check or the send-by check
    # after the resume the driver never drove again (the late-cycle rule)
    assert not [r for r in rows if r[0] > silence[0][0] and (r[1], r[2]) != (0.0, 0.0)]


def test_lost_link_stops_within_watchdog_plus_one_cycle(tmp_path: Path) -> None:
    # the board goes silent 1.5 s after the host connects but obeys on: only the host's watchdog
    # can stop it (its own silence timeout needs the host silent, and the host is not)
    with board(tmp_path, "--silent-after", "1.5") as b:
        drv = cli(b, tmp_path / "run", "drive", "--distance", "5", "--speed", "0.5")
        _out, err = drv.communicate(timeout=60)
    rows = b.lines()
    silent = next(r[0] for r in rows if r[3] == "silent")
    stop, why = b.final_stop()
    # the host's lateness and the board's: each process's own record of how late the OS woke
    # it (0 on an idle machine; 0.5 s once on a starved one, where the stop reached the
    # board 1.09 s after its silence)
    late = lateness_max(tmp_path / "run") + b.late()
    assert why == "command" and stop - silent <= W + P + late + SLACK, (stop - silent, late, err)
    assert drv.returncode == 1 and "does not confirm that it stopped" in err
