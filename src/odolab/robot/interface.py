"""The interface between the control loop and a robot link: :class:`Driver`.

The loop (:mod:`odolab.robot.loop`) knows only this interface, in wheel terms: counters per side
and the time a report arrived. A robot link implements it (the Jaguar over UDP,
:mod:`odolab.robot.jaguar`; the Jaguar 4x4 of 2014 over TCP, :mod:`odolab.robot.jaguar2014`);
:mod:`odolab.robot.registry` picks one by the scheme of the ``--robot`` URL. What a link sees
beyond that (rates, status bits, keep-alives, a second board) is the link's own typed record, in
:attr:`EncoderReading.link` and :attr:`DriverStats.link`; nothing here names a link's messages.
A new robot link is one new package plus one registry line.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from odolab.core.trajectory import Pose
from odolab.robot.clock import Clock
from odolab.robot.plant import PlantFactory

__all__ = [
    "Driver",
    "DriverStats",
    "EncoderReading",
    "RobotLink",
    "VirtualSpec",
    "check_send_by",
]

D = TypeVar("D")


@dataclass(frozen=True)
class EncoderReading:
    """One sensor report in the robot frame: counters per side (signed and wrapped) and ARRIVAL
    time.

    ``t`` is when the report arrived at the host (the receive timestamp, on the driver's clock),
    not when the loop got round to reading it: the watchdog is timed from it. ``left_ticks`` and
    ``right_ticks`` count up when that side rolls forward and wrap at the nominal parameters'
    ``encoder_modulus``. ``link`` is the link's own typed record of the rest of the report
    (None when it has none); the loop never reads it.
    """

    t: float
    left_ticks: int
    right_ticks: int
    link: object | None = None


@dataclass
class DriverStats(Generic[D]):
    """What a driver has seen and sent (counts); ``link`` is the link's own typed record."""

    received: int = 0  #: messages received (datagrams, lines)
    sensor_packets: int = 0  #: encoder reports decoded
    bad_sensor_packets: int = 0  #: encoder reports that did not decode
    other_packets: int = 0  #: messages that were not encoder reports
    commands_sent: int = 0
    stops_sent: int = 0
    keepalives: int = 0  #: keep-alive messages exchanged (answered or sent)
    link: D | None = None


class Driver(Protocol):
    """What the control loop needs from a robot link.

    ``stop`` sends the link's fixed stop message (never computed from user settings);
    ``confirm_stopped`` says whether the robot's own sensor data shows it has stopped.
    """

    stats: DriverStats[Any]

    @property
    def latest(self) -> EncoderReading | None:
        """The newest reading, or None before the first."""
        ...

    @property
    def decode_errors(self) -> int:
        """Messages discarded as malformed."""
        ...

    def connect(self) -> EncoderReading:
        """Handshake; return the first reading or raise a :class:`RobotLinkError`."""
        ...

    def poll(self) -> int:
        """Read what arrived; return the number of new readings."""
        ...

    def set_wheel_speeds(
        self, left_mps: float, right_mps: float, *, send_by: float | None = None
    ) -> None:
        """Command the track speeds (m/s, forward positive). ``send_by`` (the driver's clock):
        the latest time the command may go out; the driver checks it with
        :func:`check_send_by` just before the bytes go to its transport, and sends stop instead
        when it has passed."""
        ...

    def stop(self) -> None:
        """Send the fixed stop message."""
        ...

    def confirm_stopped(self, timeout: float) -> bool:
        """Command stop until sensor data shows the robot still, for at most ``timeout`` s."""
        ...

    def close(self) -> None:
        """Stop the robot and release the link (safe to call twice)."""
        ...


def check_send_by(now: float, send_by: float | None) -> None:
    """The control loop's lateness check at the moment of sending: raise
    :class:`~odolab.robot.errors.LateCycleError` when ``now`` is past ``send_by``. A driver calls
    it with its clock read just before a motion command's bytes go to the transport (after
    encoding them), so that a host frozen between the loop's own check and the send (SIGSTOP,
    swapping) never sends the stale command; the driver then sends stop."""
    if send_by is not None and now > send_by:
        from odolab.robot.errors import LateCycleError

        raise LateCycleError(
            f"the motion command was {now - send_by:.3f} s past its send-by time when it was "
            "about to go out (the host was frozen, swapped out or starved after the loop's "
            "lateness check); not sent, stop sent and the run failed instead of resuming the "
            "motion"
        )


class _Stoppable(Protocol):
    """What :func:`confirm_stopped` uses of a driver: its clock, stop, poll and latest."""

    @property
    def clock(self) -> Clock: ...

    @property
    def latest(self) -> EncoderReading | None: ...

    def stop(self) -> None: ...

    def poll(self) -> int: ...


def confirm_stopped(driver: _Stoppable, timeout: float) -> bool:
    """The stop rule of every link: send the link's fixed stop every 50 ms until two consecutive
    readings, both arrived after the first stop, show the same counters; True then, False when
    ``timeout`` s pass first.

    False means the robot's state is unknown (no data, or the counters still move): the caller
    must not claim it stopped.
    """
    clock = driver.clock
    t_stop = clock.now()
    deadline = t_stop + timeout
    previous: EncoderReading | None = None
    next_stop = t_stop
    while True:
        now = clock.now()
        if now >= next_stop:
            driver.stop()
            next_stop = now + 0.05
        if driver.poll() > 0:
            reading = driver.latest
            assert reading is not None
            if reading.t >= t_stop:
                if previous is not None and (previous.left_ticks, previous.right_ticks) == (
                    reading.left_ticks,
                    reading.right_ticks,
                ):
                    return True
                previous = reading
        if now >= deadline:
            return False
        clock.sleep_until(min(now + 0.005, deadline, next_stop))


@dataclass(frozen=True)
class VirtualSpec:
    """What a virtual robot needs from outside: its plant (None: an ideal one), faults, seed.

    ``faults`` is link-specific (for the Jaguar over UDP: :class:`odolab.robot.jaguar.board.Faults`);
    a link that has none refuses any.
    """

    plant: PlantFactory | None = None
    faults: object | None = None
    seed: int = 0
    report_rate: float = 10.0


@dataclass(frozen=True, eq=False)
class RobotLink:
    """An open link: its driver, a description, the true pose (virtual robots) and a closer."""

    driver: Driver
    description: str
    true_pose: Callable[[], Pose | None]
    close: Callable[[], None]
    #: the robot's own heading sensor, if it has one: (arrival time on the driver's clock, yaw
    #: rad or None, yaw rate rad/s or None) of every sample so far
    headings: Callable[[], list[tuple[float, float | None, float | None]]] | None = None
