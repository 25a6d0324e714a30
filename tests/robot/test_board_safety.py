"""The virtual board's own safety (command timeout, keeping its peer) and the watchdog bound,
in simulated time, where every time is exact."""

from __future__ import annotations

import pytest
from tests.worded import raises_worded

from odolab.core.odometry import Odometry
from odolab.core.params import PRESETS
from odolab.robot.clock import SimClock
from odolab.robot.errors import LinkLostError
from odolab.robot.jaguar.board import BoardConfig, Faults, InProcessLink, VirtualJaguar
from odolab.robot.jaguar.driver import JaguarDriver, driver_config_for
from odolab.robot.jaguar.protocol import (
    STOP_PWM,
    MessageType,
    SystemCode,
    encode_motor_command,
    encode_system,
)
from odolab.robot.loop import ControlLoop
from odolab.robot.motions import Straight
from odolab.robot.plant import IdealPlant

NOMINAL = PRESETS["jaguar-lite"]
ACK = encode_system(SystemCode.ACK)
FULL = encode_motor_command(MessageType.PWM_ALL, [32767, 32767, None, None, None, None])
V = (32767 - 16384) / 16384  # m/s of PWM 32767 at max_wheel_speed 1
A = ("127.0.0.1", 5000)
B = ("127.0.0.1", 6000)


def make_board(**config: float) -> tuple[VirtualJaguar, IdealPlant, list[tuple[float, str]]]:
    plant = IdealPlant(NOMINAL)
    changes: list[tuple[float, str]] = []
    board = VirtualJaguar(
        plant,
        BoardConfig.from_params(NOMINAL, **config),
        on_speeds=lambda t, left, right, why: changes.append((t, why)),
    )
    return board, plant, changes


def test_command_timeout_stops_the_motors_at_exactly_the_timeout() -> None:
    board, plant, changes = make_board(command_timeout=0.5)
    board.handle(ACK, A, 0.0)
    board.handle(FULL, A, 0.2)
    board.step(3.0)  # the host died after its command at 0.2 s
    assert board.wheel_speeds == (0.0, 0.0)
    assert changes == [(0.0, "peer"), (0.2, "command"), (pytest.approx(0.7), "command timeout")]
    # 0.5 s at V m/s, not 2.8 s
    assert plant.true_pose.x == pytest.approx(0.5 * V, abs=1e-12)
    assert board.stats.command_timeouts == 1


def test_commands_within_the_timeout_keep_driving() -> None:
    board, plant, _ = make_board(command_timeout=0.3)
    board.handle(ACK, A, 0.0)
    for k in range(10):  # every 0.25 s up to 2.25 s, then nothing
        board.handle(FULL, A, 0.25 * k)
        board.step(0.25 * k)
    board.step(5.0)
    assert plant.true_pose.x == pytest.approx((2.25 + 0.3) * V, abs=1e-12)


def test_an_ack_from_another_address_does_not_take_a_live_board() -> None:
    board, _, _ = make_board(command_timeout=0.5)
    board.handle(ACK, A, 0.0)
    board.handle(FULL, A, 0.1)
    board.handle(ACK, B, 0.3)  # a stranger, while A is alive
    board.handle(encode_motor_command(MessageType.PWM_ALL, [0, 0] + [None] * 4), B, 0.31)
    assert board.peer == A and board.wheel_speeds == (pytest.approx(V), pytest.approx(V))
    board.handle(STOP_PWM, A, 0.4)  # A's stop is obeyed
    assert board.wheel_speeds == (0.0, 0.0)
    assert board.stats.rejected_acks == 1 and board.stats.ignored_commands == 1
    # reports keep going to A only
    assert {peer for _, peer in board.step(1.0)} == {A}


def test_an_ack_takes_over_only_after_the_peer_was_silent_for_the_timeout() -> None:
    board, _, changes = make_board(command_timeout=0.5)
    board.handle(ACK, A, 0.0)
    board.handle(FULL, A, 1.0)  # A's last word
    board.handle(ACK, B, 1.49)
    assert board.peer == A and board.stats.rejected_acks == 1
    board.handle(ACK, B, 1.5)
    assert board.peer == B and board.stats.takeovers == 1
    # A's motion had already been stopped by the command timeout at 1.5
    assert (pytest.approx(1.5), "command timeout") in changes
    board.handle(FULL, A, 1.6)  # the old peer no longer drives
    assert board.wheel_speeds == (0.0, 0.0)


@pytest.mark.parametrize("rate", [5.0, 10.0, 20.0, 50.0, 100.0])
@pytest.mark.parametrize("report_rate", [2.5, 4.0, 10.0, 40.0])
def test_watchdog_stop_reaches_the_board_within_watchdog_plus_one_cycle(
    rate: float, report_rate: float
) -> None:
    """The board goes quiet at 1.23 s; its wheels stop at most 0.5 s + one cycle after the last
    report ARRIVED, at every loop rate, also when the board reports slower than the loop."""
    plant = IdealPlant(NOMINAL)
    stops: list[float] = []
    board = VirtualJaguar(
        plant,
        BoardConfig.from_params(NOMINAL, report_rate=report_rate, command_timeout=5.0),
        faults=Faults(silent_after=1.23),
        on_speeds=lambda t, left, right, why: (
            stops.append(t) if left == right == 0 and why == "command" else None
        ),
    )
    clock = SimClock(0.0)
    driver = JaguarDriver(InProcessLink(board, clock.now), clock, driver_config_for(NOMINAL))
    watchdog = 0.5
    loop = ControlLoop(driver, Odometry(NOMINAL), clock, rate=rate, watchdog_timeout=watchdog)
    with raises_worded(LinkLostError, match="--link-timeout 1 s"):
        loop.run(Straight(50.0, speed=0.5), link_abort=1.0)
    assert driver.latest is not None
    last_arrival = driver.latest.t
    period = 1.0 / rate
    assert last_arrival <= 1.23 + 1e-9
    assert len(stops) == 1
    delay = stops[0] - last_arrival
    assert watchdog - 1e-9 <= delay <= watchdog + period + 1e-9
