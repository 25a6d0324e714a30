"""The Dr Robot Jaguar 4x4 of 2014 and later behind :class:`odolab.robot.interface.Driver`:
text lines over TCP (:mod:`.protocol`), the driver (:mod:`.driver`), the virtual board
(:mod:`.board`) and the openers the registry calls (:mod:`.links`)."""

from __future__ import annotations

from odolab.robot.jaguar2014.board import (
    Board2014Config,
    InProcessLines,
    VirtualJaguar2014,
    VirtualJaguar2014Server,
)
from odolab.robot.jaguar2014.driver import (
    Driver2014Config,
    Jaguar2014Driver,
    Jaguar2014Report,
    TcpTransport,
    parse_tcp_url,
)

__all__ = [
    "Board2014Config",
    "Driver2014Config",
    "InProcessLines",
    "Jaguar2014Driver",
    "Jaguar2014Report",
    "TcpTransport",
    "VirtualJaguar2014",
    "VirtualJaguar2014Server",
    "parse_tcp_url",
]
