"""Options that do nothing on a real link, and robot URLs that do not say what they mean, are
refused before anything is sent (issue 39, item 3): ``--command-timeout`` on ``udp://`` and
``tcp://`` drove the robot (it is the virtual board's, like ``--truth``); ``--foxglove-port -1``,
``0`` or a 400-digit number without ``--foxglove``; a URL with a leading space or a trailing
newline; a host written ``0x7f000001`` or ``2130706433``."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.cli import main
from odolab.robot.errors import RobotConfigError, RobotUrlError
from odolab.robot.registry import check_robot_url, check_virtual_only


def _refused(args: list[str], capsys: pytest.CaptureFixture[str], out: Path) -> str:
    code = main([*args, "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("odolab: error: "), err[-2000:]
    assert not out.exists()
    return lines[0]


@pytest.mark.parametrize("scheme", ["udp", "tcp"])
def test_the_command_timeout_is_refused_on_a_real_link(
    scheme: str, listener: socket.socket, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    port = listener.getsockname()[1]
    url = f"{scheme}://127.0.0.1:{port}"
    line = _refused(["robot", "drive", "--robot", url, "--command-timeout", "1"], capsys,
                    tmp_path / "run")  # fmt: skip
    assert line == (
        f"odolab: error: --command-timeout is for the virtual Jaguar (sim://) only, and the "
        f"robot is {url}: nothing was sent; leave it out to drive this robot (a real board has "
        "its own command timeout), or use --robot sim:// to drive the simulator"
    )
    with pytest.raises(BlockingIOError):
        listener.recv(2048)  # nothing at all was sent to the robot


@pytest.mark.parametrize(
    ("port", "expected"),
    [
        ("-1", "--foxglove-port is -1; expected a port number 0..65535"),
        ("9" * 400, "--foxglove-port is 99999999999999999999"),
        ("0", "--foxglove-port 0 without --foxglove does nothing"),
        ("9000", "--foxglove-port 9000 without --foxglove does nothing"),
    ],
)
def test_a_foxglove_port_that_does_nothing_or_cannot_be_is_refused(
    port: str,
    expected: str,
    listener: socket.socket,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    url = f"udp://127.0.0.1:{listener.getsockname()[1]}"
    line = _refused(["robot", "drive", "--robot", url, "--foxglove-port", port], capsys,
                    tmp_path / "run")  # fmt: skip
    assert expected in line and len(line) < 300
    with pytest.raises(BlockingIOError):
        listener.recv(2048)


@pytest.mark.parametrize(
    ("url", "expected"),
    [
        (" udp://127.0.0.1:{p}", "has a space or control character at position 1"),
        ("udp://127.0.0.1:{p}\n", "has a space or control character at position"),
        ("tcp://127.0.0.1:{p}\t", "has a space or control character at position"),
        ("udp://0x7f000001:{p}", "the host '0x7f000001' is the IPv4 address 127.0.0.1 written"),
        ("udp://2130706433:{p}", "the host '2130706433' is the IPv4 address 127.0.0.1 written"),
        ("tcp://127.1:{p}", "the host '127.1' is the IPv4 address 127.0.0.1 written"),
        ("udp://0177.0.0.1:{p}", "is the IPv4 address 127.0.0.1 written another way"),
    ],
)
def test_a_url_that_does_not_say_what_it_means_is_refused(
    url: str,
    expected: str,
    listener: socket.socket,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    url = url.format(p=listener.getsockname()[1])
    line = _refused(["robot", "drive", "--robot", url], capsys, tmp_path / "run")
    assert expected in line
    with pytest.raises(BlockingIOError):
        listener.recv(2048)


def test_the_url_rules_hold_below_the_face() -> None:
    assert check_robot_url("udp://127.0.0.1:9") == "udp://127.0.0.1:9"
    assert check_robot_url("tcp://[::1]:9") == "tcp://[::1]:9"
    assert check_robot_url("udp://jaguar.local:10001") == "udp://jaguar.local:10001"
    with pytest.raises(RobotUrlError, match="written another way"):
        check_robot_url("udp://127.000.000.001:9")
    check_virtual_only("sim://", {"command_timeout": 1.0, "truth": "ideal"})
    check_virtual_only("udp://127.0.0.1:9", {"command_timeout": 0.5, "seed": 0})
    with raises_worded(RobotConfigError, match=r"^--command-timeout, --seed are for the virtual"):
        check_virtual_only("tcp://127.0.0.1:9", {"command_timeout": 2.0, "seed": 1})
