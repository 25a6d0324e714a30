"""Open a Jaguar link for a run: a real board over UDP, or a virtual board on loopback."""

from __future__ import annotations

import contextlib
from urllib.parse import urlparse

from odolab.core.errors import opt
from odolab.core.params import RobotParams
from odolab.robot.clock import Clock, SimClock
from odolab.robot.config import RunConfig
from odolab.robot.errors import RobotUrlError
from odolab.robot.interface import RobotLink, VirtualSpec
from odolab.robot.jaguar.board import (
    BoardConfig,
    Faults,
    InProcessLink,
    VirtualJaguar,
    VirtualJaguarServer,
)
from odolab.robot.jaguar.driver import DriverConfig, JaguarDriver, UdpTransport, parse_robot_url
from odolab.robot.plant import IdealPlant, Plant

__all__ = ["open_in_process", "open_udp", "open_virtual"]


def open_udp(url: str, config: RunConfig, params: RobotParams, clock: Clock) -> RobotLink:
    """A Jaguar board at ``udp://HOST:PORT``."""
    host, port = parse_robot_url(url)
    transport = UdpTransport(host, port, clock.now)
    driver = JaguarDriver(transport, clock, DriverConfig.from_run(config, params))
    # a virtual board (odolab robot sim-server) says its true pose; a real board never does
    return RobotLink(driver, url, driver.virtual_truth.relative, driver.close)


def open_virtual(
    url: str, config: RunConfig, params: RobotParams, clock: Clock, virtual: VirtualSpec
) -> RobotLink:
    """A virtual Jaguar on 127.0.0.1 (OS-assigned port) over ``virtual.plant`` (else ideal).

    The board's command timeout is ``config.command_timeout``.
    """
    parsed = urlparse(url)
    if parsed.netloc or parsed.path or parsed.params or parsed.query or parsed.fragment:
        raise RobotUrlError(f"{opt('robot')} {url!r}: expected plain sim:// (a virtual Jaguar)")
    faults = virtual.faults
    if faults is not None and not isinstance(faults, Faults):
        raise RobotUrlError(f"faults of a virtual Jaguar must be Faults, got {type(faults)}")
    plant = virtual.plant() if virtual.plant is not None else IdealPlant(params)
    board = BoardConfig.from_params(
        params,
        report_rate=virtual.report_rate,
        max_wheel_speed=config.max_wheel_speed,
        command_timeout=config.command_timeout,
    )
    jaguar = VirtualJaguar(plant, board, faults=faults, seed=virtual.seed)
    server = VirtualJaguarServer(jaguar)
    server.start()
    host, port = server.address
    try:
        transport = UdpTransport(host, port, clock.now)
    except BaseException:
        server.close()
        raise
    driver = JaguarDriver(transport, clock, DriverConfig.from_run(config, params))

    def close() -> None:
        try:
            driver.close()
        finally:
            with contextlib.suppress(Exception):
                server.close()

    return RobotLink(
        driver,
        f"virtual (udp://{host}:{port})",
        lambda: server.call(lambda b: b.plant.true_pose),
        close,
    )


def open_in_process(
    config: RunConfig,
    params: RobotParams,
    clock: SimClock,
    plant: Plant,
    *,
    faults: object | None = None,
    seed: int = 0,
    report_rate: float = 10.0,
) -> RobotLink:
    """A virtual Jaguar over ``plant`` wired to the driver in-process, in ``clock``'s time."""
    if faults is not None and not isinstance(faults, Faults):
        raise RobotUrlError(f"faults of a virtual Jaguar must be Faults, got {type(faults)}")
    board = BoardConfig.from_params(
        params,
        report_rate=report_rate,
        max_wheel_speed=config.max_wheel_speed,
        command_timeout=config.command_timeout,
    )
    jaguar = VirtualJaguar(plant, board, faults=faults, seed=seed)
    link = InProcessLink(jaguar, clock.now)
    driver = JaguarDriver(link, clock, DriverConfig.from_run(config, params))
    return RobotLink(driver, "simulated", lambda: plant.true_pose, driver.close)
