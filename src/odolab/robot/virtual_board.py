"""What the virtual boards share: the real-time server around a board, and the fault checks.

:class:`BoardServer` runs a board's logic (:class:`odolab.robot.jaguar.board.VirtualJaguar`
over UDP, :class:`odolab.robot.jaguar2014.board.VirtualJaguar2014` over TCP) behind a socket in
a background thread, in real time: it owns the thread, the lock under which the board is read
and the socket's lifetime; a link's server opens its socket and exchanges its bytes.
:func:`check_fault` refuses a fault setting out of its range in the words of the other options.
"""

from __future__ import annotations

import math
import select
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar, Generic, Protocol, Self, TypeVar

from odolab.core.errors import RobotLinkError, opt
from odolab.robot.errors import BoardConfigError
from odolab.robot.plant import Plant

__all__ = ["BoardServer", "check_fault", "check_silent_after"]

_T = TypeVar("_T")


class _Board(Protocol):
    """What :class:`BoardServer` uses of a board: its plant and the time of its next event."""

    @property
    def plant(self) -> Plant: ...

    def next_event(self) -> float: ...


_B = TypeVar("_B", bound=_Board)


def check_fault(name: str, value: float, high: float, allowed: str) -> None:
    """Refuse a fault setting outside [0, ``high``] (or not finite) with :class:`BoardConfigError`;
    ``allowed`` words the range (``"a number in [0, 10] s"``)."""
    if not (math.isfinite(value) and 0.0 <= value <= high):
        raise BoardConfigError(
            f"{opt(name)} is {value}; expected {allowed}",
            option=name,
            value=value,
            allowed=allowed,
        )


def check_silent_after(silent_after: float | None) -> None:
    """The ``silent_after`` fault of either board: None, or s in [0, 3600]."""
    if silent_after is not None:
        check_fault("silent_after", silent_after, 3600.0, "a number in [0, 3600] s")


class BoardServer(ABC, Generic[_B]):
    """A virtual board behind a socket, run by a background thread in real time.

    Use as a context manager, or call :meth:`start` and :meth:`close`. Port 0 lets the OS pick;
    :attr:`address` is the bound (host, port). A link's server names its socket's type
    and binds it (:meth:`_bind`), names the sockets to wait on (:meth:`_watched`) and exchanges the bytes
    that came and are due (:meth:`_exchange`, holding the lock while it touches the board).
    """

    #: the serving thread's name
    thread_name: ClassVar[str]
    #: the board in a failure's words ("the virtual Jaguar")
    name: ClassVar[str]
    #: the socket's type (``socket.SOCK_DGRAM``, ``socket.SOCK_STREAM``)
    socket_type: ClassVar[int]
    #: what failed when :meth:`_bind` fails, before "HOST:PORT (why)" ("cannot bind ... to")
    bind_failure: ClassVar[str]

    def __init__(self, board: _B, host: str = "127.0.0.1", port: int = 0) -> None:
        self.board = board
        self._warm_up()
        self._sock = self._open(host, port)
        self._sock.setblocking(False)
        self.address: tuple[str, int] = self._sock.getsockname()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        #: the most the serving thread woke after the time it asked to (s): how long the OS kept
        #: the board from running (a starved test machine), so that its timings can be read
        #: with it (0 on an idle machine)
        self.late_max = 0.0

    def _warm_up(self) -> None:
        """Warm up the plant (a compiled simulator loads or compiles its physics on the first
        step, which would otherwise stall the first reports; `odolab robot sim-server`'s runs
        its step as Python and has nothing to load): one millisecond with the wheels still."""
        self.board.plant.advance(1e-3)

    def _open(self, host: str, port: int) -> socket.socket:
        """The socket bound to (host, port); :class:`RobotLinkError` when that fails."""
        sock = socket.socket(socket.AF_INET, self.socket_type)
        try:
            self._bind(sock, host, port)
        except OSError as err:
            sock.close()
            raise RobotLinkError(f"{self.bind_failure} {host}:{port} ({err})") from err
        return sock

    @abstractmethod
    def _bind(self, sock: socket.socket, host: str, port: int) -> None:
        """Bind ``sock`` to (host, port) (and listen on it)."""

    def _watched(self) -> list[socket.socket]:
        """The sockets to wait on."""
        return [self._sock]

    @abstractmethod
    def _exchange(self, readable: list[socket.socket], now: float) -> None:
        """Hand the board what came on ``readable`` and send what is due at ``now``."""

    def _release(self) -> None:
        """Let go of what the server holds besides its socket (called once the thread ended)."""

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        """Start serving in a daemon thread."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name=self.thread_name, daemon=True)
            self._thread.start()

    def call(self, fn: Callable[[_B], _T]) -> _T:
        """Run ``fn(board)`` under the server's lock (to read the plant safely)."""
        with self._lock:
            return fn(self.board)

    def serve_forever(self) -> None:
        """Serve in the calling thread until :meth:`close` (or Ctrl-C); re-raise a failure."""
        self._serve()
        if self.error is not None:
            raise RobotLinkError(f"{self.name} stopped: {self.error!r}") from self.error

    def _serve(self) -> None:
        try:
            while not self._stop.is_set():
                now = time.perf_counter()
                with self._lock:
                    wait = min(self.board.next_event() - now, 0.01)
                readable, _, _ = select.select(self._watched(), [], [], max(wait, 0.0))
                woke = time.perf_counter()
                self.late_max = max(self.late_max, woke - now - max(wait, 0.0))
                self._exchange(readable, woke)
        except Exception as err:  # keep the thread's failure for whoever checks
            self.error = err

    def close(self) -> None:
        """Stop the thread and close the socket(s)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._release()
        self._sock.close()
