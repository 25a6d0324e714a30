"""The virtual Jaguar: a motion/sensor board that speaks the Jaguar protocol over a plant.

:class:`VirtualJaguar` is the board's logic without sockets: ``handle`` a datagram from a peer,
``step`` to a time and collect the datagrams due by then. It is driven by a clock, so it runs in
real time behind a UDP socket (:class:`VirtualJaguarServer`) or in simulated time in-process
(:class:`InProcessLink`). :class:`Faults` makes the link lossy for tests: drop, delay (with
jitter, hence reordering), duplicate and corrupt outgoing packets, or go silent.

Choices where JAGUAR_PROTOCOL.md leaves one (see docs/robot.md):

- Channel 0 drives the left track, channel 1 the right; forward is positive for both, the
  encoder counters of both count up when driving forward and wrap at 32768 (15 bits).
- PWM (type 6): wheel speed = (pwm - 16384) / 16384 * ``max_wheel_speed``.
- Velocity (type 27): the value is the wheel's encoder rate in counts per second, signed;
  speed = value * metres per tick of the board's (nominal) wheel, clipped to ``max_wheel_speed``.
- The optional time field of a PWM/velocity command is accepted and ignored (speeds change at
  once); position commands (type 4) are counted and ignored.
- Before the first ACK the board answers PINGs with ACK and ignores motor commands; an ACK makes
  its sender the peer the board streams to. The board keeps its peer while that peer is alive:
  an ACK from another address takes over only after the current peer has sent nothing valid for
  ``command_timeout`` seconds. It also pings its peer every ``ping_interval`` seconds.
- Command timeout (like real motor boards): when no valid motor command came from the peer for
  ``command_timeout`` seconds (0.5), the motors stop, at exactly that time in the board's clock.
- Motor sensor packets carry the plant's true pose after their 33 documented bytes (a tagged
  trailer only a virtual board sends: :mod:`odolab.robot.virtual_truth`).
- Encoder velocity fields: |counter change| over the last report interval, in counts per second;
  direction bits: 1 when the counter went up (forward), 0 when it went down, unchanged when
  it did not move (1 at start).
"""

from __future__ import annotations

import contextlib
import heapq
import math
import socket
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from odolab.core.encoders import counter_delta
from odolab.core.errors import ProtocolError
from odolab.core.params import RobotParams
from odolab.robot.config import BOUNDS, Bound, check_bound
from odolab.robot.errors import BoardConfigError, RobotConfigError
from odolab.robot.jaguar.driver import Datagram
from odolab.robot.jaguar.protocol import (
    DES_BOARD,
    DES_PC,
    LEAVE_ALONE,
    N_CHANNELS,
    PWM_STOP,
    Decoder,
    MessageType,
    MotorSensorData,
    SystemCode,
    decode_motor_command,
    decode_system,
    encode_motor_sensor,
    encode_system,
)
from odolab.robot.plant import Plant
from odolab.robot.virtual_board import BoardServer, check_fault, check_silent_after
from odolab.robot.virtual_truth import encode_trailer

__all__ = [
    "BoardConfig",
    "BoardStats",
    "Faults",
    "InProcessLink",
    "VirtualJaguar",
    "VirtualJaguarServer",
]


LEFT_CHANNEL = 0
RIGHT_CHANNEL = 1


_REPORT_RATE = Bound("report_rate", 0.5, 1000.0, "Hz")
_PING_INTERVAL = Bound("ping interval", 0.0, 60.0, "s")


@dataclass(frozen=True)
class BoardConfig:
    """How the virtual board maps commands to wheel speeds and reports its encoders."""

    report_rate: float = 10.0  #: motor sensor packets per second
    max_wheel_speed: float = 1.0  #: m/s at full PWM (0 or 32767); also the velocity clip
    left_metres_per_tick: float = 2.0 * math.pi * 0.0835 / 380
    right_metres_per_tick: float = 2.0 * math.pi * 0.0835 / 380
    modulus: int = 32768  #: encoder counters wrap here (15 bits)
    ping_interval: float = 1.0  #: s between PINGs to the peer (0 = never)
    command_timeout: float = 0.5  #: s without a valid motor command -> motors stop

    def __post_init__(self) -> None:
        try:
            check_bound(_REPORT_RATE, self.report_rate)
            check_bound(BOUNDS["max_wheel_speed"], self.max_wheel_speed)
            check_bound(BOUNDS["command_timeout"], self.command_timeout)
            check_bound(_PING_INTERVAL, self.ping_interval)
        except RobotConfigError as err:
            raise BoardConfigError(err) from err
        for name in ("left_metres_per_tick", "right_metres_per_tick"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise BoardConfigError(f"board {name} is {v}, expected a positive number")
        if not 2 <= self.modulus <= 65536:
            raise BoardConfigError(f"board modulus is {self.modulus}, expected 2..65536")

    @classmethod
    def from_params(cls, params: RobotParams, **changes: float) -> BoardConfig:
        """A board whose velocity unit and counter modulus follow ``params`` (nominal)."""
        return cls(
            left_metres_per_tick=params.left_metres_per_tick,
            right_metres_per_tick=params.right_metres_per_tick,
            modulus=min(params.encoder_modulus or 65536, 65536),
            **changes,
        )


@dataclass(frozen=True)
class Faults:
    """Link faults applied to the board's outgoing packets (probabilities per packet).

    ``delay`` (s) is added to every packet, plus a uniform random ``jitter`` (s) in [0, jitter):
    a jitter longer than the report period reorders packets.
    """

    drop: float = 0.0
    duplicate: float = 0.0
    corrupt: float = 0.0
    delay: float = 0.0
    jitter: float = 0.0
    drop_incoming: float = 0.0  #: probability that a packet to the board is lost
    silent_after: float | None = None  #: s after the first ACK: send nothing from then on

    def __post_init__(self) -> None:
        for name in ("drop", "duplicate", "corrupt", "drop_incoming"):
            check_fault(name, getattr(self, name), 1.0, "a probability in [0, 1]")
        check_silent_after(self.silent_after)
        for name in ("delay", "jitter"):
            check_fault(name, getattr(self, name), 10.0, "a number in [0, 10] s")


@dataclass
class BoardStats:
    """What the virtual board has done (counts)."""

    received: int = 0
    commands: int = 0
    ignored_commands: int = 0  #: motor commands not from the peer, or of an unsupported type
    rejected_acks: int = 0  #: ACKs from another address while the peer was alive
    takeovers: int = 0  #: ACKs from another address accepted after the peer went silent
    command_timeouts: int = 0  #: times the motors were stopped for lack of commands
    pings_received: int = 0
    acks_received: int = 0
    pings_sent: int = 0
    reports: int = 0  #: sensor packets generated (before faults)
    sent: int = 0  #: datagrams delivered (after faults)
    dropped: int = 0
    duplicated: int = 0
    corrupted: int = 0
    decode: Decoder = field(default_factory=lambda: Decoder({DES_BOARD}))


Address = Hashable


class VirtualJaguar:
    """The board's logic over a :class:`Plant`, in the time of whoever calls it."""

    def __init__(
        self,
        plant: Plant,
        config: BoardConfig | None = None,
        *,
        faults: Faults | None = None,
        seed: int = 0,
        on_speeds: Callable[[float, float, float, str], None] | None = None,
    ) -> None:
        self.plant = plant
        #: called as ``on_speeds(t, left, right, why)`` whenever the wheel speeds change (why:
        #: "command", "command timeout", "peer replaced"), and with the unchanged speeds on the
        #: link events "peer" (a peer accepted) and "silent" (``Faults.silent_after`` began)
        self.on_speeds = on_speeds
        self._silent_noted = False
        self.config = config or BoardConfig()
        self.faults = faults or Faults()
        self.stats = BoardStats()
        self.silent = False
        self.peer: Address | None = None
        self._rng = np.random.default_rng(seed)
        self._now: float | None = None
        self._next_report = math.inf
        self._report_base = 0.0
        self._report_n = 0
        self._next_ping = math.inf
        self._outbox: list[tuple[float, int, bytes, Address]] = []
        self._seq = 0
        self._speeds = (0.0, 0.0)
        self._last_counts: tuple[int, int] | None = None
        self._direction = 0b11
        self._pwm = [PWM_STOP] * N_CHANNELS
        self._first_ack: float | None = None  #: board time of the first accepted ACK
        self._last_command = -math.inf  #: board time of the peer's last valid motor command
        self._peer_heard = -math.inf  #: board time of the peer's last valid packet

    # --- time ---------------------------------------------------------------------------

    def _advance_to(self, t: float) -> None:
        if self._now is None:
            self._now = t
            return
        if t <= self._now:
            return
        cutoff = self._last_command + self.config.command_timeout
        if self._speeds != (0.0, 0.0) and cutoff <= t:
            # the command timeout falls in this interval: stop the motors exactly then
            if cutoff > self._now:
                self.plant.advance(cutoff - self._now)
                self._now = cutoff
            self.stats.command_timeouts += 1
            self._set_speeds(0.0, 0.0, "command timeout")
        if t > self._now:
            self.plant.advance(t - self._now)
            self._now = t

    def _set_speeds(self, left: float, right: float, why: str) -> None:
        if (left, right) == self._speeds:
            return
        self._speeds = (left, right)
        if left == 0.0 and right == 0.0:
            self._pwm[LEFT_CHANNEL] = self._pwm[RIGHT_CHANNEL] = PWM_STOP
        self.plant.set_wheel_speeds(left, right)
        self._note(why)

    def _note(self, why: str, t: float | None = None) -> None:
        if self.on_speeds is not None:
            when = t if t is not None else (self._now if self._now is not None else 0.0)
            self.on_speeds(when, self._speeds[0], self._speeds[1], why)

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """The commanded (left, right) wheel speeds, m/s."""
        return self._speeds

    # --- incoming -----------------------------------------------------------------------

    def handle(self, datagram: bytes, peer: Address, now: float) -> None:
        """Process one datagram from ``peer`` received at ``now``."""
        self._advance_to(now)
        if self.faults.drop_incoming and self._rng.random() < self.faults.drop_incoming:
            return
        for packet in self.stats.decode.feed_datagram(datagram):
            self.stats.received += 1
            if packet.type == MessageType.SYSTEM:
                code = decode_system(packet)
                if code == SystemCode.ACK:
                    self.stats.acks_received += 1
                    if self.peer is not None and self.peer != peer:
                        if now - self._peer_heard < self.config.command_timeout:
                            self.stats.rejected_acks += 1  # the peer is alive: keep it
                            continue
                        self.stats.takeovers += 1
                        self._set_speeds(0.0, 0.0, "peer replaced")
                    if peer == self.peer:
                        self._peer_heard = now
                    else:
                        self.peer = peer
                        if self._first_ack is None:
                            self._first_ack = now
                        self._peer_heard = now
                        self._last_command = -math.inf
                        self._note("peer", now)
                        self._report_base = self._now if self._now is not None else now
                        self._report_n = 0
                        self._next_report = self._report_base
                        interval = self.config.ping_interval
                        self._next_ping = now + interval if interval > 0 else math.inf
                elif code == SystemCode.PING:
                    if peer == self.peer:
                        self._peer_heard = now
                    self.stats.pings_received += 1
                    self._queue(encode_system(SystemCode.ACK, DES_PC), peer, now, faults=False)
            elif packet.type in (MessageType.PWM_ALL, MessageType.VELOCITY_ALL):
                if peer != self.peer:
                    self.stats.ignored_commands += 1
                    continue
                try:
                    cmd = decode_motor_command(packet)
                except ProtocolError:
                    self.stats.ignored_commands += 1
                    continue
                self.stats.commands += 1
                self._peer_heard = now
                self._last_command = now
                self._apply(cmd.kind, cmd.values)
            else:
                self.stats.ignored_commands += 1

    def _apply(self, kind: MessageType, values: tuple[int | None, ...]) -> None:
        left, right = self._speeds
        out = []
        for ch, current in ((LEFT_CHANNEL, left), (RIGHT_CHANNEL, right)):
            v = values[ch]
            if v is None or v == LEAVE_ALONE:
                out.append(current)
                continue
            if kind is MessageType.PWM_ALL:
                self._pwm[ch] = v
                speed = (v - PWM_STOP) / PWM_STOP * self.config.max_wheel_speed
            else:
                mpt = (
                    self.config.left_metres_per_tick
                    if ch == LEFT_CHANNEL
                    else self.config.right_metres_per_tick
                )
                speed = v * mpt
                self._pwm[ch] = self._pwm_of(speed)
            vmax = self.config.max_wheel_speed
            out.append(min(max(speed, -vmax), vmax))
        self._set_speeds(out[0], out[1], "command")

    def _pwm_of(self, speed: float) -> int:
        p = round(PWM_STOP + speed / self.config.max_wheel_speed * PWM_STOP)
        return int(min(max(p, 0), 32767))

    # --- outgoing -----------------------------------------------------------------------

    def _report(self) -> bytes:
        m = self.config.modulus
        left, right = self.plant.encoder_counts()
        counts = (int(left) % m, int(right) % m)
        period = 1.0 / self.config.report_rate
        vel = [0, 0]
        if self._last_counts is not None:
            for i in (0, 1):
                d = counter_delta(counts[i] - self._last_counts[i], m)
                vel[i] = min(round(abs(d) / period), 0xFFFF)
                if d > 0:
                    self._direction |= 1 << i
                elif d < 0:
                    self._direction &= ~(1 << i)
        self._last_counts = counts
        self.stats.reports += 1
        pose = self.plant.true_pose  # the side channel only a virtual board speaks
        return encode_motor_sensor(
            MotorSensorData(
                encoder_position=counts,
                encoder_velocity=(vel[0], vel[1]),
                direction=self._direction,
                pwm=tuple(self._pwm),
                extra=encode_trailer(pose.x, pose.y, pose.heading),
            )
        )

    def _queue(self, data: bytes, peer: Address, t: float, *, faults: bool = True) -> None:
        f = self.faults
        copies = 1
        if (
            f.silent_after is not None
            and self._first_ack is not None
            and t >= self._first_ack + f.silent_after
        ):
            if not self._silent_noted:
                self._silent_noted = True
                self._note("silent", self._first_ack + f.silent_after)
            self.stats.dropped += 1
            return
        if faults:
            if self.silent:
                self.stats.dropped += 1
                return
            if f.drop and self._rng.random() < f.drop:
                self.stats.dropped += 1
                return
            if f.duplicate and self._rng.random() < f.duplicate:
                copies = 2
                self.stats.duplicated += 1
        elif self.silent:
            return
        for _ in range(copies):
            payload = data
            if faults and f.corrupt and self._rng.random() < f.corrupt:
                b = bytearray(data)
                i = int(self._rng.integers(len(b)))
                b[i] ^= int(self._rng.integers(1, 256))
                payload = bytes(b)
                self.stats.corrupted += 1
            due = t + f.delay + (f.jitter * float(self._rng.random()) if f.jitter else 0.0)
            self._seq += 1
            heapq.heappush(self._outbox, (due, self._seq, payload, peer))

    def step(self, now: float) -> list[tuple[bytes, Address]]:
        """Run the board up to ``now``; return the datagrams due by then, in delivery order."""
        return [(data, peer) for data, peer, _ in self.step_timed(now)]

    def step_timed(self, now: float) -> list[tuple[bytes, Address, float]]:
        """:meth:`step`, each datagram with the time it was due (its delivery time)."""
        if self._now is None:
            self._now = now
        period = 1.0 / self.config.report_rate
        while self.peer is not None and min(self._next_report, self._next_ping) <= now:
            if self._next_ping < self._next_report:
                self._advance_to(self._next_ping)
                self._queue(encode_system(SystemCode.PING, DES_PC), self.peer, self._next_ping)
                self.stats.pings_sent += 1
                self._next_ping += self.config.ping_interval
                continue
            t = max(self._next_report, self._now)
            self._advance_to(t)
            self._queue(self._report(), self.peer, t)
            self._report_n += 1  # absolute schedule: base + n * period, no summed drift
            self._next_report = self._report_base + self._report_n * period
        self._advance_to(now)
        out: list[tuple[bytes, Address, float]] = []
        while self._outbox and self._outbox[0][0] <= now:
            due, _, data, peer = heapq.heappop(self._outbox)
            out.append((data, peer, due))
            self.stats.sent += 1
        return out

    def next_event(self) -> float:
        """The time of the next report, ping or delivery (inf when idle)."""
        t = self._outbox[0][0] if self._outbox else math.inf
        if self.peer is not None:
            t = min(t, self._next_report, self._next_ping)
        if self._speeds != (0.0, 0.0):
            t = min(t, self._last_command + self.config.command_timeout)
        return t


class InProcessLink:
    """A driver transport wired straight to a :class:`VirtualJaguar`, in a clock's time.

    ``send`` hands the datagram to the board at the clock's current time; ``receive`` steps the
    board to the clock's time and returns what it sent to this link.
    """

    PEER = "in-process"

    def __init__(self, board: VirtualJaguar, clock: Callable[[], float]) -> None:
        self.board = board
        self._clock = clock
        self.closed = False

    def send(self, data: bytes) -> None:
        if self.closed:
            return
        self.board.handle(data, self.PEER, self._clock())

    def receive(self) -> list[Datagram]:
        if self.closed:
            return []
        return [
            (d, due) for d, peer, due in self.board.step_timed(self._clock()) if peer == self.PEER
        ]

    def close(self) -> None:
        self.closed = True


class VirtualJaguarServer(BoardServer[VirtualJaguar]):
    """The virtual Jaguar behind a UDP socket, run by a background thread in real time.

    Use as a context manager, or call :meth:`start` and :meth:`close`. Port 0 lets the OS pick;
    :attr:`address` is the bound (host, port).
    """

    thread_name = "virtual-jaguar"
    name = "the virtual Jaguar"
    socket_type = socket.SOCK_DGRAM
    bind_failure = "cannot bind the virtual Jaguar to"

    def _bind(self, sock: socket.socket, host: str, port: int) -> None:
        sock.bind((host, port))

    def set_silent(self, silent: bool) -> None:
        """Stop (True) or resume (False) sending anything."""
        with self._lock:
            self.board.silent = silent

    def set_faults(self, faults: Faults) -> None:
        """Change the link faults while running."""
        with self._lock:
            self.board.faults = faults

    def _exchange(self, readable: list[socket.socket], now: float) -> None:
        sock = self._sock
        with self._lock:
            if readable:
                while True:
                    try:
                        data, peer = sock.recvfrom(2048)
                    except (BlockingIOError, InterruptedError):
                        break
                    except OSError:  # e.g. ICMP port unreachable from an old peer
                        break
                    self.board.handle(data, peer, now)
            out = self.board.step(now)
        for data, peer in out:
            with contextlib.suppress(OSError):
                sock.sendto(data, cast(tuple[str, int], peer))
