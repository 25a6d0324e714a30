"""The Dr Robot Jaguar link behind :class:`odolab.robot.interface.Driver`: the binary protocol
(:mod:`.protocol`), the UDP driver (:mod:`.driver`), the virtual board (:mod:`.board`) and the
openers the registry calls (:mod:`.links`)."""

from __future__ import annotations

from odolab.robot.jaguar.board import (
    BoardConfig,
    Faults,
    InProcessLink,
    VirtualJaguar,
    VirtualJaguarServer,
)
from odolab.robot.jaguar.driver import (
    ChannelMap,
    DriverConfig,
    JaguarDriver,
    UdpTransport,
    parse_robot_url,
)

__all__ = [
    "BoardConfig",
    "ChannelMap",
    "DriverConfig",
    "Faults",
    "InProcessLink",
    "JaguarDriver",
    "UdpTransport",
    "VirtualJaguar",
    "VirtualJaguarServer",
    "parse_robot_url",
]
