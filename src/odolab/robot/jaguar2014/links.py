"""Open a Jaguar 4x4 (2014) link for a run: a board over TCP, or a virtual board in-process."""

from __future__ import annotations

from odolab.core.params import RobotParams
from odolab.robot.clock import Clock, SimClock
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotUrlError
from odolab.robot.interface import RobotLink, VirtualSpec
from odolab.robot.jaguar2014.board import Board2014Config, InProcessLines, VirtualJaguar2014
from odolab.robot.jaguar2014.driver import (
    Driver2014Config,
    Jaguar2014Driver,
    TcpTransport,
    parse_tcp_url,
)
from odolab.robot.plant import Plant

__all__ = ["open_in_process", "open_tcp"]


def open_tcp(url: str, config: RunConfig, params: RobotParams, clock: Clock) -> RobotLink:
    """A Jaguar 4x4 (2014) at ``tcp://HOST:PORT[?variant=wheel|track]``."""
    host, port, variant = parse_tcp_url(url)
    transport = TcpTransport(host, port, clock.now, timeout=config.connect_timeout)
    driver = Jaguar2014Driver(transport, clock, Driver2014Config.from_run(config, params, variant))
    # a virtual board (odolab robot sim-server --link jaguar2014) says its true pose; a real
    # board never does
    return RobotLink(driver, url, driver.virtual_truth.relative, driver.close, driver.headings)


def open_in_process(
    config: RunConfig, params: RobotParams, clock: SimClock, plant: Plant, virtual: VirtualSpec
) -> RobotLink:
    """A virtual 2014 board over ``plant`` wired to the driver in-process, in ``clock``'s time.

    Its silence timeout is ``config.command_timeout``."""
    if virtual.faults is not None:
        raise RobotUrlError("the virtual Jaguar 2014 has no link faults; pass faults=None")
    board = VirtualJaguar2014(
        plant,
        Board2014Config.from_params(
            params,
            report_rate=virtual.report_rate,
            max_wheel_speed=config.max_wheel_speed,
            silence_timeout=config.command_timeout,
        ),
    )
    link = InProcessLines(board, clock.now)
    driver = Jaguar2014Driver(link, clock, Driver2014Config.from_run(config, params))
    return RobotLink(
        driver, "simulated (Jaguar 2014)", lambda: plant.true_pose, driver.close, driver.headings
    )
