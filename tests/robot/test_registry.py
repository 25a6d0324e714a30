"""The Driver interface and the --robot registry: links by URL scheme, layers kept."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.robot.clock import RealClock
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotUrlError
from odolab.robot.interface import Driver
from odolab.robot.jaguar.driver import JaguarDriver
from odolab.robot.registry import LINKS, check_robot_url, open_link

NOMINAL = PRESETS["jaguar-lite"]


def test_schemes() -> None:
    assert set(LINKS) >= {"udp", "sim"}
    assert check_robot_url(None) == "sim://"
    assert check_robot_url("udp://10.0.0.1:10001") == "udp://10.0.0.1:10001"
    for bad, what in (
        ("ftp://127.0.0.1:1", "no known scheme"),
        ("udp://127.0.0.1:99999", "bad port"),
        ("127.0.0.1:10001", "no known scheme"),
        # extras were ignored on udp:// and the board driven (a robot-safety review)
        ("udp://127.0.0.1:17201/some/path", "not of the form udp://HOST:PORT"),
        ("udp://user:pw@127.0.0.1:17201", "not of the form udp://HOST:PORT"),
        ("udp://127.0.0.1:17201#frag", "not of the form udp://HOST:PORT"),
        ("udp://127.0.0.1:17201?variant=track", "takes no query"),
        ("tcp://user@127.0.0.1:17201", "not of the form tcp://HOST:PORT"),
    ):
        with pytest.raises(RobotUrlError, match=what):
            check_robot_url(bad)
    with pytest.raises(RobotUrlError, match="plain sim://"):
        open_link("sim://somewhere", RunConfig(), NOMINAL, RealClock())
    # a query or a fragment was ignored: sim://?truth=jaguar-lab-trackd drove the default truth
    for bad in ("sim://?truth=jaguar-lab-tracked", "sim://#x", "sim:///path", "sim://;p"):
        with raises_worded(RobotUrlError, match=r"expected plain sim:// .*--truth"):
            check_robot_url(bad)
        with pytest.raises(RobotUrlError, match="plain sim://"):
            open_link(bad, RunConfig(), NOMINAL, RealClock())


def test_sim_link_is_a_jaguar_driver_behind_the_interface() -> None:
    link = open_link(None, RunConfig(), NOMINAL, RealClock())
    try:
        driver: Driver = link.driver
        assert isinstance(driver, JaguarDriver)
        reading = driver.connect()
        assert (reading.left_ticks, reading.right_ticks) == (0, 0)
        assert driver.confirm_stopped(1.0)
        assert link.true_pose() is not None
        assert link.description.startswith("virtual (udp://127.0.0.1:")
    finally:
        link.close()


def test_cli_sim_url(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(
        [
            "robot",
            "drive",
            "--distance",
            "0.2",
            "--robot",
            "sim://",
            "--truth",
            "ideal",
            "--quiet",
            "--no-realtime",
            "--out",
            str(tmp_path / "r"),
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "robot stopped (its sensor data confirms it)" in captured.err


def test_the_robot_stack_imports_neither_the_simulator_nor_the_jaguar_in_the_loop() -> None:
    code = (
        "import sys, odolab.robot, odolab.robot.loop;"
        "assert not any(m.startswith('odolab.sim') for m in sys.modules), 'sim';"
        "import odolab.robot.loop as l, inspect;"
        "assert 'jaguar' not in inspect.getsource(l)"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
