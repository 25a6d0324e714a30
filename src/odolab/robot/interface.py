"""The interface between the control loop and a robot link: :class:`Driver`.

The loop (:mod:`odolab.robot.loop`) knows only this interface; a robot link (the Jaguar over
UDP, :mod:`odolab.robot.jaguar`) implements it, and :mod:`odolab.robot.registry` picks one by
the scheme of the ``--robot`` URL. A new robot link is one new package plus one registry line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

__all__ = ["Datagram", "Driver", "DriverStats", "EncoderReading", "Transport"]


@dataclass(frozen=True)
class EncoderReading:
    """One sensor report in the robot frame: counters (signed and wrapped) and ARRIVAL time.

    ``t`` is when the report arrived at the host (the receive timestamp, on the driver's clock),
    not when the loop got round to reading it: the watchdog is timed from it.
    """

    t: float
    left_ticks: int
    right_ticks: int
    left_rate: int  #: encoder velocity field (counts/s, magnitude)
    right_rate: int
    direction: int


@dataclass
class DriverStats:
    """What a driver has seen and sent (counts)."""

    datagrams: int = 0
    sensor_packets: int = 0
    bad_sensor_packets: int = 0
    pings_answered: int = 0
    acks_received: int = 0
    other_packets: int = 0
    commands_sent: int = 0
    stops_sent: int = 0


#: One datagram and the time it arrived (s, on the receiver's clock).
Datagram = tuple[bytes, float]


class Transport(Protocol):
    """Datagrams to and from one board."""

    def send(self, data: bytes) -> None:
        """Send one datagram to the board."""
        ...

    def receive(self) -> list[Datagram]:
        """All datagrams that have arrived, with their arrival times (never blocks)."""
        ...

    def close(self) -> None:
        """Release the link."""
        ...


class Driver(Protocol):
    """What the control loop needs from a robot link.

    ``stop`` sends the link's fixed stop packet (never computed from user settings);
    ``confirm_stopped`` says whether the robot's own sensor data shows it has stopped.
    """

    stats: DriverStats

    @property
    def latest(self) -> EncoderReading | None:
        """The newest reading, or None before the first."""
        ...

    @property
    def decode_errors(self) -> int:
        """Packets discarded as malformed."""
        ...

    def connect(self) -> EncoderReading:
        """Handshake; return the first reading or raise a :class:`RobotLinkError`."""
        ...

    def poll(self) -> int:
        """Read what arrived; return the number of new readings."""
        ...

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        """Command the track speeds (m/s, forward positive)."""
        ...

    def stop(self) -> None:
        """Send the fixed stop packet."""
        ...

    def confirm_stopped(self, timeout: float) -> bool:
        """Command stop until sensor data shows the robot still, for at most ``timeout`` s."""
        ...

    def close(self) -> None:
        """Stop the robot and release the link (safe to call twice)."""
        ...
