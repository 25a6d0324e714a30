"""The driver of a Jaguar 4x4 of 2014 and later: a TCP client speaking text lines.

``connect`` opens TCP, sends ``PING``, the fixed stop and then ``MMW !MG`` (the E-stop release,
after a zero command so a release never resumes an old motion), and waits for the first counter
line of the odometry board. ``poll`` sends ``PING`` every ``ping_interval`` s and parses what
arrived. Drive commands are ``MMW !M <L> <R>``: value = speed / ``max_wheel_speed`` * 1000,
times the robot variant's sign per channel (4x4 wheels: forward ``+v -v``; tracks: ``-v +v``).
The stop is the fixed line :data:`STOP`. Counters (``C=``) are signed 32-bit: the driver takes
int32 differences, so a wrap is a small step; ticks go to the loop modulo the nominal
parameters' ``encoder_modulus``. Front (MM0) and rear (MM1) boards report each side twice: the
odometry uses one (``odometry_board``), the difference between them is the slip indicator
(:class:`Jaguar2014Report`). IMU lines are kept (:attr:`Jaguar2014Driver.imu`).
"""

from __future__ import annotations

import contextlib
import math
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol
from urllib.parse import parse_qs

from odolab.core.errors import opt
from odolab.core.params import RobotParams
from odolab.robot.clock import Clock
from odolab.robot.config import RunConfig, check_signs
from odolab.robot.driver_base import LinkDriver, split_link_url
from odolab.robot.errors import (
    NoSensorDataError,
    RobotConfigError,
    RobotUrlError,
)
from odolab.robot.interface import EncoderReading
from odolab.robot.jaguar2014.protocol import (
    PING,
    POWER_LIMIT,
    RELEASE_ESTOP,
    SET_ESTOP,
    STOP,
    CommandReply,
    GpsLine,
    ImuLine,
    LineSplitter,
    LineStats,
    MotorLine,
    encode_drive,
    int32,
    parse_robot_line,
)
from odolab.robot.virtual_truth import LINE_PREFIX, decode_line

__all__ = [
    "VARIANTS",
    "Driver2014Config",
    "ImuSample",
    "Jaguar2014Driver",
    "Jaguar2014Report",
    "Jaguar2014Stats",
    "LineTransport",
    "TcpTransport",
    "parse_tcp_url",
]

#: Robot variants: (left, right) sign of ``!M`` for forward, and of the counters when forward.
VARIANTS: dict[str, tuple[tuple[int, int], tuple[int, int]]] = {
    "wheel": ((1, -1), (1, -1)),  # 4x4 wheels: forward "+v -v"; ch1 counts up, ch2 down
    "track": ((-1, 1), (-1, 1)),  # V4 tracks: the opposite forward sign
}


def parse_tcp_url(url: str) -> tuple[str, int, str]:
    """``tcp://HOST:PORT[?variant=wheel|track]`` -> (host, port, variant)."""
    parsed, host, port = split_link_url(url, "tcp")
    query = parse_qs(parsed.query, keep_blank_values=True)
    variant = "wheel"
    for key, values in query.items():
        if key != "variant" or len(values) != 1 or values[0] not in VARIANTS:
            raise RobotUrlError(
                f"{opt('robot')} {url!r}: the only query is variant=wheel or variant=track"
            )
        variant = values[0]
    if parsed.fragment:
        raise RobotUrlError(f"{opt('robot')} {url!r} is not of the form tcp://HOST:PORT")
    return host, port, variant


class LineTransport(Protocol):
    """Bytes to and from one board over a stream (TCP, or in-process)."""

    def send(self, data: bytes) -> None:
        """Send bytes (whole lines)."""
        ...

    def receive(self) -> list[tuple[bytes, float]]:
        """The bytes that have arrived, each chunk with its arrival time (never blocks)."""
        ...

    def close(self) -> None:
        """Release the link."""
        ...


class TcpTransport:
    """A TCP client; chunks stamped with ``now()`` when read. A closed or broken connection is
    noted (:attr:`closed_by_peer`), never raised: the loop's watchdog sees the data stop."""

    def __init__(
        self, host: str, port: int, now: Callable[[], float], timeout: float = 2.0
    ) -> None:
        from odolab.core.errors import RobotLinkError

        self._now = now
        try:
            self._sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as err:
            raise RobotLinkError(
                f"cannot connect to the Jaguar at tcp://{host}:{port} ({err}); is it on and "
                "reachable?"
            ) from err
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock.setblocking(False)  # neither sends nor receives ever block the loop
        self.closed_by_peer = False
        self.send_errors = 0

    def send(self, data: bytes) -> None:
        if self.closed_by_peer:
            self.send_errors += 1
            return
        try:
            self._sock.sendall(data)
        except (BlockingIOError, InterruptedError):  # send buffer full: the board reads nothing
            self.send_errors += 1
        except OSError:
            self.send_errors += 1
            self.closed_by_peer = True

    def receive(self) -> list[tuple[bytes, float]]:
        out: list[tuple[bytes, float]] = []
        if self.closed_by_peer:
            return out
        while True:
            try:
                data = self._sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self.closed_by_peer = True
                break
            if not data:
                self.closed_by_peer = True
                break
            out.append((data, self._now()))
        return out

    #: how long :meth:`close` reads what the board still sends before it closes (seconds)
    LINGER = 0.5

    def close(self) -> None:
        """Send what is queued and the end of the stream, read what the board still sends until
        it closes its side (at most :attr:`LINGER` s), then close. Closed at once with its
        reports unread, the socket would reset the connection, and a board that writes before it
        reads (the virtual one; a busy one) meets the reset first and drops the link without
        reading the last lines: the stop and the E-stop."""
        with contextlib.suppress(OSError):
            self._sock.shutdown(socket.SHUT_WR)
            deadline = time.monotonic() + self.LINGER
            while (left := deadline - time.monotonic()) > 0:
                self._sock.settimeout(left)
                if not self._sock.recv(65536):
                    break
        self._sock.close()


@dataclass(frozen=True)
class Driver2014Config:
    """Driver settings. Speeds in m/s; signs +1 or -1 (docs/robot.md)."""

    max_wheel_speed: float = 1.0  #: m/s at |!M| = 1000; commands are clipped to it
    left_command_sign: int = 1  #: sign of ``!M`` ch1 for forward (wheels +1, tracks -1)
    right_command_sign: int = -1  #: sign of ``!M`` ch2 for forward (wheels -1, tracks +1)
    left_encoder_sign: int = 1  #: sign of the ch1 counter change when forward
    right_encoder_sign: int = -1
    modulus: int | None = 32768  #: ticks to the loop wrap here (None: never)
    odometry_board: int = 0  #: 0 front, 1 rear
    ping_interval: float = 0.1  #: s between PINGs
    connect_timeout: float = 2.0  #: s to wait for the first counter line
    gyro_lsb_per_deg_s: float = 14.375  #: IMU GYRO units per deg/s (TRI's unit; unknown for yours)

    def __post_init__(self) -> None:
        check_signs(
            self,
            (
                "left_command_sign",
                "right_command_sign",
                "left_encoder_sign",
                "right_encoder_sign",
            ),
        )
        for name in ("max_wheel_speed", "ping_interval", "connect_timeout", "gyro_lsb_per_deg_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise RobotConfigError(f"driver {name} is {v!r}; expected a positive number")
        if self.odometry_board not in (0, 1):
            raise RobotConfigError(f"odometry board is {self.odometry_board!r}; expected 0 or 1")
        if self.modulus is not None and self.modulus < 2:
            raise RobotConfigError(f"driver modulus is {self.modulus}; expected >= 2 or None")

    @classmethod
    def from_run(
        cls, config: RunConfig, params: RobotParams, variant: str = "wheel"
    ) -> Driver2014Config:
        """The settings of a validated run, nominal parameters and robot variant.

        The run's motor and encoder signs multiply the variant's (so +1 keeps the variant's)."""
        if variant not in VARIANTS:
            raise RobotConfigError(f"variant is {variant!r}; expected one of {', '.join(VARIANTS)}")
        (cl, cr), (el, er) = VARIANTS[variant]
        return cls(
            max_wheel_speed=config.max_wheel_speed,
            left_command_sign=cl * config.left_motor_sign,
            right_command_sign=cr * config.right_motor_sign,
            left_encoder_sign=el * config.left_encoder_sign,
            right_encoder_sign=er * config.right_encoder_sign,
            modulus=params.encoder_modulus,
            connect_timeout=config.connect_timeout,
        )


@dataclass(frozen=True)
class Jaguar2014Report:
    """What a counter report says beyond the ticks (:attr:`EncoderReading.link`).

    Counts since connect per side, forward positive; ``slip`` = front minus rear per side, from
    the newest report both boards have sent (None until then): a wheel that slips or spins shows
    here.
    """

    front: tuple[int, int] | None
    rear: tuple[int, int] | None
    slip: tuple[int, int] | None
    rpm: tuple[int, ...] | None  #: the odometry board's last ``S=`` (signed RPM, raw channels)
    faults: int | None  #: the odometry board's last ``FF=`` bits (16 = E-stop)


@dataclass(frozen=True)
class ImuSample:
    """One IMU line: arrival time (driver clock), sequence number, values by label."""

    t: float
    seq: int
    fields: dict[str, tuple[float, ...]]


@dataclass
class Jaguar2014Stats:
    """The 2014 link's own counts (:attr:`DriverStats.link`)."""

    pings_sent: int = 0
    accepted: int = 0  #: ``MM<b> +`` lines
    rejected: int = 0  #: ``MM<b> -`` lines
    imu_lines: int = 0
    gps_lines: int = 0
    motor_lines: dict[str, int] = field(default_factory=dict)  #: by key
    max_abs_slip: int = 0  #: counts, either side, over the run
    lines: LineStats = field(default_factory=LineStats)


class Jaguar2014Driver(LinkDriver[LineTransport, Jaguar2014Stats]):
    """Client of one Jaguar 4x4 (2014) over ``transport``; implements
    :class:`odolab.robot.interface.Driver`. Drive commands are ``!M`` lines; the stop is the
    fixed line ``MMW !M 0 0``; closing stops, sets the E-stop and closes the connection."""

    _stop_packet = STOP

    def __init__(
        self, transport: LineTransport, clock: Clock, config: Driver2014Config | None = None
    ) -> None:
        super().__init__(transport, clock, Jaguar2014Stats())
        self.config = config or Driver2014Config()
        self._splitter = LineSplitter(self._link.lines)
        self._raw: dict[int, tuple[int, int]] = {}  #: last absolute C= per board
        self._acc: dict[int, tuple[int, int]] = {}  #: counts since the first C=, forward +
        self._rpm: tuple[int, ...] | None = None
        self._gen = [0, 0]  #: counter lines per board since the first front one
        self._slip: tuple[int, int] | None = None
        self._faults: int | None = None
        self._next_ping = -math.inf
        self.imu: list[ImuSample] = []

    @property
    def decode_errors(self) -> int:
        """Lines ignored (no known form) or dropped (overlong)."""
        return self._link.lines.unknown + self._link.lines.overlong

    def _ping_if_due(self) -> None:
        now = self.clock.now()
        if now >= self._next_ping:
            self._send(PING)
            self._link.pings_sent += 1
            self.stats.keepalives += 1
            self._next_ping = now + self.config.ping_interval

    def connect(self) -> EncoderReading:
        """PING, stop, release the E-stop; wait for the first counter line of the odometry board."""
        clock = self.clock
        t0 = clock.now()
        deadline = t0 + self.config.connect_timeout
        self._ping_if_due()
        self.stop()
        self._send(RELEASE_ESTOP)
        while True:
            if self.poll() > 0:
                assert self._latest is not None
                return self._latest
            now = clock.now()
            if now >= deadline:
                raise NoSensorDataError(
                    f"no counter lines (MM{self.config.odometry_board} C=) from the robot within "
                    f"{self.config.connect_timeout:g} s of connecting; is it on, and is no other "
                    "host connected to it?"
                )
            clock.sleep_until(min(now + 0.005, deadline))

    def poll(self) -> int:
        """Ping when due, read everything that arrived; return the number of new readings."""
        self._ping_if_due()
        n = 0
        for data, arrived in self.transport.receive():
            for line in self._splitter.feed(data):
                self.stats.received += 1
                n += self._line(line, arrived)
        return n

    def _line(self, text: str, t: float) -> int:
        line = parse_robot_line(text)
        link = self._link
        if line is None and text.startswith(LINE_PREFIX):
            truth = decode_line(text)
            if truth is not None:  # a virtual board's true pose (odolab.robot.virtual_truth)
                self.virtual_truth.heard(truth)
                self.stats.other_packets += 1
                return 0
        if line is None:
            link.lines.unknown += 1
            self.stats.other_packets += 1
            return 0
        if isinstance(line, MotorLine):
            link.motor_lines[line.key] = link.motor_lines.get(line.key, 0) + 1
            if line.key == "C":
                return self._counts(line, t)
            self.stats.other_packets += 1
            if line.board == self.config.odometry_board:
                if line.key == "S":
                    self._rpm = line.values
                elif line.key == "FF":
                    self._faults = line.values[0]
            return 0
        self.stats.other_packets += 1
        if isinstance(line, CommandReply):
            if line.accepted:
                link.accepted += 1
            else:
                link.rejected += 1
        elif isinstance(line, ImuLine):
            link.imu_lines += 1
            self.imu.append(ImuSample(t, line.seq, line.fields))
        elif isinstance(line, GpsLine):
            link.gps_lines += 1
        return 0

    def _counts(self, line: MotorLine, t: float) -> int:
        if len(line.values) != 2 or line.board not in (0, 1):
            self.stats.bad_sensor_packets += 1
            return 0
        board = line.board
        c1, c2 = (int32(v) for v in line.values)
        cfg = self.config
        if board in self._raw:
            p1, p2 = self._raw[board]
            a1, a2 = self._acc[board]
            self._acc[board] = (
                a1 + cfg.left_encoder_sign * int32(c1 - p1),
                a2 + cfg.right_encoder_sign * int32(c2 - p2),
            )
        else:
            self._acc[board] = (0, 0)
        self._raw[board] = (c1, c2)
        # pair the boards' lines of one report: count each board's lines from the first front
        # line on, and compare when both have reported equally often
        if board == 0 or self._gen[0] > 0:
            self._gen[board] += 1
        if self._gen[0] == self._gen[1] and self._gen[0] > 0:
            f, r = self._acc[0], self._acc[1]
            self._slip = (f[0] - r[0], f[1] - r[1])
            self._link.max_abs_slip = max(self._link.max_abs_slip, *map(abs, self._slip))
        if board != cfg.odometry_board:
            return 0
        self.stats.sensor_packets += 1
        front, rear = self._acc.get(0), self._acc.get(1)
        slip = self._slip
        left, right = self._acc[board]
        if cfg.modulus is not None:
            left %= cfg.modulus
            right %= cfg.modulus
        report = Jaguar2014Report(front, rear, slip, self._rpm, self._faults)
        self._latest = EncoderReading(t, left, right, report)
        return 1

    def _value(self, speed: float, sign: int) -> int:
        vmax = self.config.max_wheel_speed
        s = min(max(speed, -vmax), vmax)
        return int(min(max(round(sign * s / vmax * POWER_LIMIT), -POWER_LIMIT), POWER_LIMIT))

    def _encode_speeds(self, left_mps: float, right_mps: float) -> bytes:
        cfg = self.config
        return encode_drive(
            self._value(left_mps, cfg.left_command_sign),
            self._value(right_mps, cfg.right_command_sign),
        )

    def headings(self) -> list[tuple[float, float | None, float | None]]:
        """The IMU lines so far as (arrival time, YAW rad, GYRO z in rad/s), the gyro from
        ``gyro_lsb_per_deg_s`` (14.375, TRI's unit: check yours)."""
        out: list[tuple[float, float | None, float | None]] = []
        k = self.config.gyro_lsb_per_deg_s
        for s in self.imu:
            yaw = s.fields.get("YAW")
            gyro = s.fields.get("GYRO")
            rate = math.radians(gyro[2] / k) if gyro is not None and len(gyro) >= 3 else None
            out.append((s.t, yaw[0] if yaw else None, rate))
        return out

    def _shut_down(self) -> None:
        """Stop, then set the E-stop."""
        super()._shut_down()
        self._send(SET_ESTOP)
