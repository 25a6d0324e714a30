"""The virtual Jaguar 4x4 of 2014: a board that speaks the text lines over a plant.

:class:`VirtualJaguar2014` is the board's logic without sockets: ``feed`` bytes from the host,
``step`` to a time and collect the bytes due by then; it runs in simulated time in-process
(:class:`InProcessLines`) or in real time behind TCP (:class:`VirtualJaguar2014Server`, one host
at a time: a second connection is closed at once while one is live).

Choices where the fact sheet leaves one (docs/robot.md):

- It starts with the E-stop set: ``!M`` is answered ``-`` and ignored until ``MMW !MG``.
  ``MMW !EX`` sets it again (and stops). Every ``MMW`` command gets ``MM0 +`` / ``MM1 +`` (or
  ``-``) from both drive boards; ``PING`` gets no reply.
- ``!M`` values are power, linear: speed = value / 1000 * ``max_wheel_speed``, with the
  variant's forward sign (4x4 wheels: ch1 +, ch2 -). Out of -1000..1000: ``-``, ignored.
- Host silence: when nothing came from the host for ``silence_timeout`` s (0.5 by default; 0 =
  never, as the real board may behave: unknown) the motors stop, at exactly that time. A closed
  connection stops them at once.
- Reports every 1/``report_rate`` s, in this order: the plant's true pose ``ODOLAB-TRUTH x y
  heading`` (a line only a virtual board speaks: :mod:`odolab.robot.virtual_truth`), ``MM0 C=``, ``MM1 C=`` (front and rear
  count the same plant track: no per-wheel slip), ``MM0 CR=``, ``MM1 CR=``, ``MM0 S=``,
  ``MM1 S=``, ``MM0 FF=``, ``MM1 FF=`` and an IMU line ``#seq,YAW,<rad>,GYRO,x,y,z,ACC,...``
  (gyro z in the TRI unit's 14.375 LSB per deg/s, from the plant's heading change).
  Counters are signed 32-bit and start at ``initial_count``; ch1 counts up driving forward,
  ch2 down (4x4 wheels; tracks: the opposite).
"""

from __future__ import annotations

import contextlib
import math
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

from odolab.core.encoders import counter_delta
from odolab.core.kinematics import wrap_angle
from odolab.core.params import RobotParams
from odolab.robot.errors import BoardConfigError
from odolab.robot.jaguar2014.driver import VARIANTS
from odolab.robot.jaguar2014.protocol import (
    POWER_LIMIT,
    LineSplitter,
    int32,
    parse_host_line,
)
from odolab.robot.plant import Plant
from odolab.robot.virtual_board import BoardServer, check_silent_after
from odolab.robot.virtual_truth import encode_line

__all__ = [
    "Board2014Config",
    "Board2014Stats",
    "InProcessLines",
    "VirtualJaguar2014",
    "VirtualJaguar2014Server",
]

GYRO_LSB_PER_DEG_S = 14.375


@dataclass(frozen=True)
class Board2014Config:
    """The virtual board's settings (s, m/s, Hz)."""

    max_wheel_speed: float = 1.0
    report_rate: float = 10.0
    silence_timeout: float = 0.5  #: 0 = never stop for silence
    variant: str = "wheel"
    plant_modulus: int | None = 32768  #: the plant's counters wrap here
    initial_count: int = 0  #: where the int32 C= counters start
    metres_per_tick: float = 2.0 * math.pi * 0.0835 / 380  #: for S= (RPM) only
    silent_after: float | None = None  #: fault: s after a host connects, send nothing more

    def __post_init__(self) -> None:
        for name in ("max_wheel_speed", "report_rate", "metres_per_tick"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise BoardConfigError(f"board {name} is {v!r}; expected a positive number")
        if not 0.5 <= self.report_rate <= 1000:
            raise BoardConfigError(f"report rate is {self.report_rate} Hz; expected 0.5..1000")
        if not (math.isfinite(self.silence_timeout) and 0 <= self.silence_timeout <= 60):
            raise BoardConfigError(
                f"silence timeout is {self.silence_timeout!r} s; expected 0 (never) to 60 s"
            )
        check_silent_after(self.silent_after)
        if self.variant not in VARIANTS:
            raise BoardConfigError(
                f"variant is {self.variant!r}; expected one of {', '.join(VARIANTS)}"
            )

    @classmethod
    def from_params(cls, params: RobotParams, **changes: object) -> Board2014Config:
        """A board whose plant modulus and RPM unit follow ``params`` (nominal)."""
        base: dict[str, object] = {
            "plant_modulus": params.encoder_modulus,
            "metres_per_tick": params.left_metres_per_tick,
        }
        base.update(changes)
        return cls(**base)  # type: ignore[arg-type]


@dataclass
class Board2014Stats:
    """What the virtual board has done (counts)."""

    lines: int = 0
    pings: int = 0
    commands: int = 0  #: !M lines obeyed
    rejected: int = 0  #: !M lines refused (E-stop set, out of range)
    other: int = 0
    silence_stops: int = 0
    disconnect_stops: int = 0
    reports: int = 0
    refused_peers: int = 0  #: connections closed at once because one was live


class VirtualJaguar2014:
    """The board's logic over a :class:`Plant`, in the time of whoever calls it."""

    def __init__(
        self,
        plant: Plant,
        config: Board2014Config | None = None,
        on_speeds: Callable[[float, float, float, str], None] | None = None,
    ) -> None:
        self.plant = plant
        self.config = config or Board2014Config()
        self.on_speeds = on_speeds
        self.stats = Board2014Stats()
        self._splitter = LineSplitter()
        (self._cmd_l, self._cmd_r), (self._enc_l, self._enc_r) = VARIANTS[self.config.variant]
        self.estop = True
        self.connected = False
        self._speeds = (0.0, 0.0)
        self._now: float | None = None
        self._heard = -math.inf
        self._next_report = math.inf
        self._report_base = 0.0
        self._report_n = 0
        self._plant_last = plant.encoder_counts()
        self._acc = [0, 0]  #: plant counts since start, left/right, forward +
        self._last_c = [self.config.initial_count] * 2
        self._seq = 0
        self._last_heading = plant.true_pose.heading
        self._outbox: list[tuple[float, bytes]] = []
        self._connected_at = math.inf
        self._silent_noted = False

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        return self._speeds

    def _advance_to(self, t: float) -> None:
        if self._now is None:
            self._now = t
        timeout = self.config.silence_timeout
        if timeout > 0 and self._speeds != (0.0, 0.0):
            cutoff = self._heard + timeout
            if self._now <= cutoff <= t:
                self._run(cutoff)
                self._set_speeds(0.0, 0.0, "silence timeout", cutoff)
                self.stats.silence_stops += 1
        self._run(t)

    def _run(self, t: float) -> None:
        assert self._now is not None
        if t > self._now:
            self.plant.advance(t - self._now)
            self._now = t
            self._count()

    def _count(self) -> None:
        now = self.plant.encoder_counts()
        m = self.config.plant_modulus
        for i in (0, 1):
            d = now[i] - self._plant_last[i]
            if m is not None:
                d = counter_delta(d, m)
            self._acc[i] += d
        self._plant_last = now

    def _set_speeds(self, left: float, right: float, why: str, t: float) -> None:
        """Set the wheel speeds; ``on_speeds`` hears of a change only."""
        changed = (left, right) != self._speeds
        self._speeds = (left, right)
        self.plant.set_wheel_speeds(left, right)
        if changed and self.on_speeds is not None:
            self.on_speeds(t, left, right, why)

    def _say(self, t: float, text: str) -> None:
        self._outbox.append((t, (text + "\r\n").encode("ascii")))

    def connect(self, t: float) -> None:
        """A host connected at ``t``: reports start."""
        self._advance_to(t)
        self.connected = True
        self._heard = t
        self._last_heading = self.plant.true_pose.heading  # the gyro counts from here
        self._connected_at = t
        self._silent_noted = False
        self._report_base = t
        self._report_n = 0
        self._next_report = t

    def disconnect(self, t: float) -> None:
        """The host's connection closed at ``t``: stop at once, reports end."""
        self._advance_to(t)
        self.connected = False
        self._next_report = math.inf
        self._splitter = LineSplitter()
        if self._speeds != (0.0, 0.0):
            self._set_speeds(0.0, 0.0, "disconnect", t)
            self.stats.disconnect_stops += 1

    def feed(self, data: bytes, t: float) -> None:
        """Bytes from the host, arrived at ``t``: the reports due before them first (a board
        starved by a loaded machine reads late, and its reports keep the plant of their own
        times: its gyro's rate was 1.31 and 0.69 rad/s around a late command on a 1.0 rad/s
        turn), then the lines."""
        self._reports_until(t)
        self._advance_to(t)
        for line in self._splitter.feed(data):
            self._handle(line, t)

    def _handle(self, text: str, t: float) -> None:
        self.stats.lines += 1
        self._heard = t
        cmd = parse_host_line(text)
        if cmd.kind == "ping":
            self.stats.pings += 1
            return
        boards = ("0", "1") if cmd.target == "W" else (cmd.target,)
        if cmd.kind == "drive":
            left, right = cmd.values
            ok = (
                not self.estop
                and cmd.target == "W"
                and all(-POWER_LIMIT <= v <= POWER_LIMIT for v in cmd.values)
            )
            if ok:
                vmax = self.config.max_wheel_speed
                self._set_speeds(
                    self._cmd_l * left / POWER_LIMIT * vmax,
                    self._cmd_r * right / POWER_LIMIT * vmax,
                    "command",
                    t,
                )
                self.stats.commands += 1
            else:
                self.stats.rejected += 1
            for b in boards:
                self._say(t, f"MM{b} {'+' if ok else '-'}")
        elif cmd.kind == "release":
            self.estop = False
            for b in boards:
                self._say(t, f"MM{b} +")
        elif cmd.kind == "estop":
            self.estop = True
            self._set_speeds(0.0, 0.0, "e-stop", t)
            for b in boards:
                self._say(t, f"MM{b} +")
        elif cmd.kind == "query":
            for b in boards:
                self._say(t, f"MM{b} MMOD=0:0")
        else:
            self.stats.other += 1

    def _report(self, t: float) -> None:
        period = 1.0 / self.config.report_rate
        c = [
            int32(self.config.initial_count + self._enc_l * self._acc[0]),
            int32(self.config.initial_count + self._enc_r * self._acc[1]),
        ]
        cr = [int32(c[i] - self._last_c[i]) for i in (0, 1)]
        self._last_c = c
        ticks_per_rev = 2 * math.pi * 0.0835 / self.config.metres_per_tick
        rpm = [round(v / period / ticks_per_rev * 60) for v in cr]
        ff = 16 if self.estop else 0
        pose = self.plant.true_pose  # the side channel only a virtual board speaks
        self._say(t, encode_line(pose.x, pose.y, pose.heading))
        for b in (0, 1):
            self._say(t, f"MM{b} C={c[0]}:{c[1]}")
        for b in (0, 1):
            self._say(t, f"MM{b} CR={cr[0]}:{cr[1]}")
        for b in (0, 1):
            self._say(t, f"MM{b} S={rpm[0]}:{rpm[1]}")
        for b in (0, 1):
            self._say(t, f"MM{b} FF={ff}")
        heading = self.plant.true_pose.heading
        rate = (heading - self._last_heading) / period  # rad/s
        self._last_heading = heading
        yaw = wrap_angle(heading)
        gz = round(math.degrees(rate) * GYRO_LSB_PER_DEG_S)
        self._say(t, f"#{self._seq},YAW,{yaw:.4f},GYRO,0,0,{gz},ACC,0,0,251,COMP,0,0,0")
        self._seq = (self._seq + 1) % 256
        self.stats.reports += 1

    def _reports_until(self, now: float) -> None:
        """Each report due by ``now``, made with the plant at its own time."""
        period = 1.0 / self.config.report_rate
        while self.connected and self._next_report <= now:
            t = self._next_report
            self._advance_to(t)
            self._report(t)
            self._report_n += 1
            self._next_report = self._report_base + self._report_n * period

    def step_timed(self, now: float) -> list[tuple[bytes, float]]:
        """Run the board up to ``now``; the bytes due by then, each with its due time."""
        self._reports_until(now)
        self._advance_to(now)
        out = self._outbox
        self._outbox = []
        quiet = self.config.silent_after
        if quiet is not None:
            cutoff = self._connected_at + quiet
            out = [(t, data) for t, data in out if t < cutoff]
            if now >= cutoff and not self._silent_noted and self.on_speeds is not None:
                self._silent_noted = True
                self.on_speeds(cutoff, *self._speeds, "silent")
        return [(data, t) for t, data in out]

    def next_event(self) -> float:
        """The time of the next report or silence stop (inf when idle)."""
        t = self._next_report if self.connected else math.inf
        if self.config.silence_timeout > 0 and self._speeds != (0.0, 0.0):
            t = min(t, self._heard + self.config.silence_timeout)
        return t


class InProcessLines:
    """A driver transport wired straight to a :class:`VirtualJaguar2014`, in a clock's time."""

    def __init__(self, board: VirtualJaguar2014, clock: Callable[[], float]) -> None:
        self.board = board
        self._clock = clock
        self.closed = False
        board.connect(clock())

    def send(self, data: bytes) -> None:
        if not self.closed:
            self.board.feed(data, self._clock())

    def receive(self) -> list[tuple[bytes, float]]:
        if self.closed:
            return []
        return self.board.step_timed(self._clock())

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.board.disconnect(self._clock())


class VirtualJaguar2014Server(BoardServer[VirtualJaguar2014]):
    """The virtual board behind a TCP listening socket, served by a thread in real time.

    One host at a time: while a connection is live, a second one is accepted and closed at
    once (counted in ``stats.refused_peers``). :attr:`address` is the bound (host, port).
    """

    thread_name = "virtual-jaguar-2014"
    name = "the virtual Jaguar 2014"
    socket_type = socket.SOCK_STREAM
    bind_failure = "cannot listen for the virtual Jaguar 2014 on"

    def __init__(self, board: VirtualJaguar2014, host: str = "127.0.0.1", port: int = 0) -> None:
        self._peer: socket.socket | None = None
        super().__init__(board, host, port)

    def _warm_up(self) -> None:
        super()._warm_up()
        self.board._plant_last = self.board.plant.encoder_counts()

    def _bind(self, sock: socket.socket, host: str, port: int) -> None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(4)

    def _drop_peer(self, now: float) -> None:
        if self._peer is not None:
            with contextlib.suppress(OSError):
                self._peer.close()
            self._peer = None
            self.board.disconnect(now)

    def _watched(self) -> list[socket.socket]:
        return [self._sock] + ([self._peer] if self._peer is not None else [])

    def _exchange(self, readable: list[socket.socket], now: float) -> None:
        with self._lock:
            if self._sock in readable:
                with contextlib.suppress(BlockingIOError, InterruptedError):
                    conn, _ = self._sock.accept()
                    if self._peer is not None:
                        self.board.stats.refused_peers += 1
                        conn.close()
                    else:
                        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                        conn.settimeout(0.5)
                        self._peer = conn
                        self.board.connect(now)
            if self._peer is not None and self._peer in readable:
                try:
                    data = self._peer.recv(65536)
                except OSError:
                    data = b""
                if data:
                    self.board.feed(data, now)
                else:
                    self._drop_peer(now)
            out = self.board.step_timed(now)
            if self._peer is not None and out:
                try:
                    self._peer.sendall(b"".join(d for d, _ in out))
                except OSError:
                    self._drop_peer(now)

    def _release(self) -> None:
        with self._lock:
            self._drop_peer(time.perf_counter())
