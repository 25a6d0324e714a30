"""What every link's driver shares: commands, the stop rule and closing, over a transport.

:class:`LinkDriver` implements the parts of :class:`odolab.robot.interface.Driver` that do not
depend on the link's messages: a wheel-speed command is refused (stop sent) when not finite,
checked against its send-by time just before its bytes go out (:func:`check_send_by`; stop sent
instead when late), and counted; stop sends the link's fixed stop message; ``confirm_stopped``
is the common stop rule; ``close`` stops and releases the transport once. A link's driver says
how to encode a command (:meth:`LinkDriver._encode_speeds`) and what its stop message is
(:attr:`LinkDriver._stop_packet`), and reads its own messages (``connect``, :meth:`LinkDriver.poll`).
:func:`split_link_url` is the part of reading a ``--robot`` URL that every link shares.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Generic, Protocol, TypeVar
from urllib.parse import ParseResult, urlparse

from odolab.core.errors import opt
from odolab.robot.clock import Clock
from odolab.robot.errors import LateCycleError, RobotConfigError, RobotUrlError
from odolab.robot.interface import DriverStats, EncoderReading, check_send_by, confirm_stopped
from odolab.robot.virtual_truth import TruthTracker

__all__ = ["LinkDriver", "split_link_url"]


def split_link_url(url: str, scheme: str) -> tuple[ParseResult, str, int]:
    """``scheme://HOST:PORT`` -> (the parsed URL, host, port); :class:`RobotUrlError` for a bad
    port, another scheme, no host or port, a path or a user. Its query and fragment are the
    caller's to read or refuse."""
    parsed = urlparse(url)
    try:
        port = parsed.port  # raises ValueError for a non-number or out of 0..65535
    except ValueError as err:
        raise RobotUrlError(
            f"{opt('robot')} {url!r} has a bad port ({err}); expected {scheme}://HOST:PORT with a "
            "port in 0..65535"
        ) from err
    if (
        parsed.scheme != scheme
        or not parsed.hostname
        or port is None
        or parsed.path not in ("", "/")
        or parsed.username is not None
    ):
        raise RobotUrlError(f"{opt('robot')} {url!r} is not of the form {scheme}://HOST:PORT")
    return parsed, parsed.hostname, port


class _Transport(Protocol):
    """What :class:`LinkDriver` uses of a transport."""

    def send(self, data: bytes) -> None: ...

    def close(self) -> None: ...


_Tr = TypeVar("_Tr", bound=_Transport)
_L = TypeVar("_L")


class LinkDriver(ABC, Generic[_Tr, _L]):
    """The link-independent part of a driver over ``transport``; times come from ``clock``;
    ``link`` is the link's own counts (:attr:`DriverStats.link`)."""

    #: the link's fixed stop message (never computed from the settings)
    _stop_packet: bytes

    def __init__(self, transport: _Tr, clock: Clock, link: _L) -> None:
        self.transport = transport
        self.clock = clock
        self._link = link
        self.stats: DriverStats[_L] = DriverStats(link=link)
        self._latest: EncoderReading | None = None
        self.last_command: tuple[float, float] = (0.0, 0.0)
        self._closed = False
        #: the true pose a virtual board sends (:mod:`odolab.robot.virtual_truth`); a real
        #: board's run leaves it empty
        self.virtual_truth = TruthTracker()

    @property
    def latest(self) -> EncoderReading | None:
        """The newest reading (None before the first)."""
        return self._latest

    def _send(self, data: bytes) -> None:
        self.transport.send(data)

    @abstractmethod
    def poll(self) -> int:
        """Read what arrived; return the number of new readings."""

    @abstractmethod
    def _encode_speeds(self, left_mps: float, right_mps: float) -> bytes:
        """The link's message commanding these (finite) left and right speeds, m/s."""

    def set_wheel_speeds(
        self, left_mps: float, right_mps: float, *, send_by: float | None = None
    ) -> None:
        """Command the left and right track speeds (m/s, forward positive; clipped); not after
        ``send_by`` (see :func:`odolab.robot.interface.check_send_by`)."""
        if not (math.isfinite(left_mps) and math.isfinite(right_mps)):
            self.stop()
            raise RobotConfigError(
                f"wheel speeds must be finite, got {left_mps!r}, {right_mps!r}; stopped"
            )
        message = self._encode_speeds(left_mps, right_mps)
        try:
            check_send_by(self.clock.now(), send_by)  # the last thing before the bytes go out
        except LateCycleError:
            self.stop()
            raise
        self._send(message)
        self.last_command = (left_mps, right_mps)
        self.stats.commands_sent += 1

    def stop(self) -> None:
        """Send the link's fixed stop message."""
        self._send(self._stop_packet)
        self.last_command = (0.0, 0.0)
        self.stats.commands_sent += 1
        self.stats.stops_sent += 1

    def confirm_stopped(self, timeout: float) -> bool:
        """Stop until two readings after the stop agree (:func:`~odolab.robot.interface.confirm_stopped`)."""
        return confirm_stopped(self, timeout)

    def _shut_down(self) -> None:
        """What closing sends before the transport closes: the stop."""
        self.stop()

    def close(self) -> None:
        """Stop the robot and close the transport (safe to call twice)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._shut_down()
        finally:
            self.transport.close()
