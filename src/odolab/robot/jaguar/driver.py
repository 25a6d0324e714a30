"""The Jaguar driver: talks to a board over a transport (UDP, or in-process in simulated time).

It sends the ACK handshake, answers the board's PINGs with ACK, sends drive commands as
all-channel PWM (type 6) or velocity (type 27) packets, and parses motor sensor packets into
encoder readings in the robot's left/right frame (configurable channels and encoder signs).
Stop is the fixed packet :data:`STOP_PWM` / :data:`STOP_VELOCITY`, never computed from the
settings. Every reading carries its arrival time: the kernel's receive timestamp over UDP
(``SO_TIMESTAMPNS`` on Linux), the delivery time in simulated time.
"""

from __future__ import annotations

import math
import socket
import struct
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from odolab.core.errors import ProtocolError, RobotLinkError, opt
from odolab.core.params import RobotParams
from odolab.robot.clock import Clock
from odolab.robot.config import CommandMode, RunConfig, check_signs
from odolab.robot.driver_base import LinkDriver, split_link_url
from odolab.robot.errors import (
    NoSensorDataError,
    RobotConfigError,
    RobotUrlError,
)
from odolab.robot.interface import DriverStats, EncoderReading
from odolab.robot.jaguar.protocol import (
    DES_PC,
    N_CHANNELS,
    PWM_STOP,
    STOP_PWM,
    STOP_VELOCITY,
    Decoder,
    MessageType,
    SystemCode,
    decode_motor_sensor,
    decode_system,
    encode_motor_command,
    encode_system,
)
from odolab.robot.virtual_truth import decode_trailer

__all__ = [
    "ChannelMap",
    "CommandMode",
    "Datagram",
    "DriverConfig",
    "DriverStats",
    "EncoderReading",
    "JaguarDriver",
    "JaguarLinkStats",
    "JaguarReport",
    "Transport",
    "UdpTransport",
    "driver_config_for",
    "parse_robot_url",
]


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


@dataclass(frozen=True)
class JaguarReport:
    """What a motor sensor packet says beyond the counters (:attr:`EncoderReading.link`)."""

    left_rate: int  #: encoder velocity field (counts/s, magnitude)
    right_rate: int
    direction: int  #: direction bits as sent (bit 0 motor 0, bit 1 motor 1; 1 = forward)


@dataclass
class JaguarLinkStats:
    """The Jaguar link's own counts (:attr:`DriverStats.link`)."""

    pings_answered: int = 0
    acks_received: int = 0


def parse_robot_url(url: str) -> tuple[str, int]:
    """``udp://HOST:PORT`` -> (host, port)."""
    parsed, host, port = split_link_url(url, "udp")
    if parsed.fragment:
        raise RobotUrlError(f"{opt('robot')} {url!r} is not of the form udp://HOST:PORT")
    if parsed.query:  # was ignored: udp://...?variant=track, meant for tcp://, drove the board
        raise RobotUrlError(
            f"{opt('robot')} {url!r}: udp://HOST:PORT takes no query (variant= is for the 2014 "
            "Jaguar's tcp://HOST:PORT?variant=wheel|track)"
        )
    return host, port


# Linux socket options for kernel receive timestamps (not named in Python's socket module)
_SO_TIMESTAMPNS = 35
_TIMESPEC = struct.Struct("@qq")


class UdpTransport:
    """A connected, non-blocking UDP socket to the board at (host, port).

    ``clock``: the clock arrival times are given on (the driver's; default
    ``time.perf_counter``). On Linux each datagram's arrival time is the kernel's receive
    timestamp mapped onto that clock; elsewhere it is the time it was read.
    """

    def __init__(
        self, host: str, port: int, clock: Callable[[], float] = time.perf_counter
    ) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.connect((host, port))
        except OSError as err:
            self._sock.close()
            raise RobotLinkError(f"cannot reach the robot at udp://{host}:{port} ({err})") from err
        self._sock.setblocking(False)
        self._clock = clock
        self.kernel_timestamps = False
        if sys.platform == "linux":
            try:
                self._sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)
                self.kernel_timestamps = True
            except OSError:
                pass
        self.address = (host, port)
        self.send_errors = 0

    def send(self, data: bytes) -> None:
        try:
            self._sock.send(data)
        except OSError:  # nobody listening yet (ICMP), buffer full: the watchdog will see it
            self.send_errors += 1

    def receive(self) -> list[Datagram]:
        out: list[Datagram] = []
        ancillary = socket.CMSG_SPACE(_TIMESPEC.size)
        while True:
            try:
                data, anc, _flags, _addr = self._sock.recvmsg(2048, ancillary)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # ICMP port unreachable: no board yet
                return out
            now = self._clock()
            t = now
            for level, kind, payload in anc:
                if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS:
                    sec, nsec = _TIMESPEC.unpack(payload[: _TIMESPEC.size])
                    age = time.time() - (sec + nsec * 1e-9)
                    t = now - min(max(age, 0.0), 60.0)
            out.append((data, t))

    def close(self) -> None:
        self._sock.close()


@dataclass(frozen=True)
class ChannelMap:
    """Which board channels are the left and right tracks, and their signs.

    ``*_encoder_sign`` = -1 when that counter counts down while driving forward;
    ``*_motor_sign`` = -1 when a positive command drives that track backward.
    """

    left: int = 0
    right: int = 1
    left_encoder_sign: int = 1
    right_encoder_sign: int = 1
    left_motor_sign: int = 1
    right_motor_sign: int = 1

    def __post_init__(self) -> None:
        if self.left not in (0, 1) or self.right not in (0, 1) or self.left == self.right:
            raise RobotConfigError(
                f"channels left={self.left} right={self.right}: expected 0 and 1, one each "
                "(the motor sensor packet reports encoders of motors 0 and 1 only)"
            )
        check_signs(
            self,
            (
                "left_encoder_sign",
                "right_encoder_sign",
                "left_motor_sign",
                "right_motor_sign",
            ),
        )


@dataclass(frozen=True)
class DriverConfig:
    """Driver settings. Speeds in m/s; see docs/robot.md for the unit choices."""

    channels: ChannelMap = field(default_factory=ChannelMap)
    mode: CommandMode = CommandMode.PWM
    max_wheel_speed: float = 1.0  #: m/s at full PWM; commands are clipped to it
    left_metres_per_tick: float = 2.0 * math.pi * 0.0835 / 380  #: velocity mode unit
    right_metres_per_tick: float = 2.0 * math.pi * 0.0835 / 380
    modulus: int = 32768  #: the counters wrap here
    connect_timeout: float = 2.0  #: s to wait for the first sensor packet
    ack_retry: float = 0.2  #: s between ACKs while connecting

    def __post_init__(self) -> None:
        for name in ("max_wheel_speed", "left_metres_per_tick", "right_metres_per_tick"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise RobotConfigError(f"driver {name} is {v!r}; expected a positive number")
        if not 2 <= self.modulus <= 65536:
            raise RobotConfigError(f"driver modulus is {self.modulus}; expected 2..65536")
        if not (math.isfinite(self.connect_timeout) and self.connect_timeout > 0):
            raise RobotConfigError(f"connect timeout is {self.connect_timeout!r} s; expected > 0")
        if not (math.isfinite(self.ack_retry) and self.ack_retry > 0):
            raise RobotConfigError(f"ACK retry is {self.ack_retry!r} s; expected > 0")

    @classmethod
    def from_run(cls, config: RunConfig, params: RobotParams) -> DriverConfig:
        """The driver settings of a validated run configuration and nominal parameters."""
        return cls(
            channels=ChannelMap(
                left=config.left_channel,
                right=config.right_channel,
                left_encoder_sign=config.left_encoder_sign,
                right_encoder_sign=config.right_encoder_sign,
                left_motor_sign=config.left_motor_sign,
                right_motor_sign=config.right_motor_sign,
            ),
            mode=config.mode,
            max_wheel_speed=config.max_wheel_speed,
            left_metres_per_tick=params.left_metres_per_tick,
            right_metres_per_tick=params.right_metres_per_tick,
            modulus=min(params.encoder_modulus or 65536, 65536),
            connect_timeout=config.connect_timeout,
        )


def driver_config_for(params: RobotParams, **changes: object) -> DriverConfig:
    """Jaguar driver settings whose velocity unit and counter modulus follow ``params``."""
    base: dict[str, object] = {
        "left_metres_per_tick": params.left_metres_per_tick,
        "right_metres_per_tick": params.right_metres_per_tick,
        "modulus": min(params.encoder_modulus or 65536, 65536),
    }
    base.update(changes)
    return DriverConfig(**base)  # type: ignore[arg-type]


class JaguarDriver(LinkDriver[Transport, JaguarLinkStats]):
    """Client of one Jaguar board over ``transport``; times come from ``clock``.

    Implements :class:`odolab.robot.interface.Driver`. Drive commands are all-channel PWM or
    velocity packets; the stop is the fixed packet (PWM 16384 or velocity 0 on channels 0 and
    1); closing stops the robot and closes the transport.
    """

    def __init__(self, transport: Transport, clock: Clock, config: DriverConfig | None = None):
        super().__init__(transport, clock, JaguarLinkStats())
        self.config = config or DriverConfig()
        self.decoder = Decoder({DES_PC})
        self._stop_packet = STOP_PWM if self.config.mode is CommandMode.PWM else STOP_VELOCITY

    @property
    def decode_errors(self) -> int:
        """Candidate packets discarded (unknown destination or type, bad length, CRC or ETX)."""
        return self.decoder.stats.discarded

    def connect(self) -> EncoderReading:
        """Send ACK until the first sensor packet arrives; raise :class:`NoSensorDataError`."""
        clock = self.clock
        t0 = clock.now()
        deadline = t0 + self.config.connect_timeout
        next_ack = t0
        while True:
            now = clock.now()
            if now >= next_ack:
                self.transport.send(encode_system(SystemCode.ACK))
                next_ack = now + self.config.ack_retry
            if self.poll() > 0:
                assert self._latest is not None
                return self._latest
            if now >= deadline:
                raise NoSensorDataError(
                    f"no sensor data from the robot within {self.config.connect_timeout:g} s "
                    "after ACK; is it on and reachable, and not held by another host (a board "
                    "answers one host at a time)?"
                )
            clock.sleep_until(min(now + 0.005, deadline, next_ack))

    def poll(self) -> int:
        """Read everything that has arrived; answer PINGs; return the number of new readings."""
        n = 0
        for datagram, arrived in self.transport.receive():
            self.stats.received += 1
            for packet in self.decoder.feed_datagram(datagram):
                if packet.type == MessageType.MOTOR_SENSOR:
                    try:
                        sensor = decode_motor_sensor(packet)
                    except ProtocolError:
                        self.stats.bad_sensor_packets += 1
                        continue
                    truth = decode_trailer(sensor.extra)
                    if truth is not None:
                        self.virtual_truth.heard(truth)
                    self._latest = self._reading(
                        arrived, sensor.encoder_position, sensor.encoder_velocity, sensor.direction
                    )
                    self.stats.sensor_packets += 1
                    n += 1
                elif packet.type == MessageType.SYSTEM:
                    code = decode_system(packet)
                    if code == SystemCode.PING:
                        self.transport.send(encode_system(SystemCode.ACK))
                        self._link.pings_answered += 1
                        self.stats.keepalives += 1
                    elif code == SystemCode.ACK:
                        self._link.acks_received += 1
                    else:
                        self.stats.other_packets += 1
                else:
                    self.stats.other_packets += 1
        return n

    def _reading(
        self, t: float, position: tuple[int, int], velocity: tuple[int, int], direction: int
    ) -> EncoderReading:
        ch = self.config.channels
        m = self.config.modulus
        left = position[ch.left] % m
        right = position[ch.right] % m
        if ch.left_encoder_sign < 0:
            left = (-left) % m
        if ch.right_encoder_sign < 0:
            right = (-right) % m
        return EncoderReading(
            t, left, right, JaguarReport(velocity[ch.left], velocity[ch.right], direction)
        )

    def _value(self, speed: float, metres_per_tick: float) -> int:
        vmax = self.config.max_wheel_speed
        s = min(max(speed, -vmax), vmax)
        if self.config.mode is CommandMode.PWM:
            return int(min(max(round(PWM_STOP + s / vmax * PWM_STOP), 0), 32767))
        return int(min(max(round(s / metres_per_tick), -32767), 32767))

    def _encode_speeds(self, left_mps: float, right_mps: float) -> bytes:
        cfg = self.config
        ch = cfg.channels
        values: list[int | None] = [None] * N_CHANNELS
        values[ch.left] = self._value(ch.left_motor_sign * left_mps, cfg.left_metres_per_tick)
        values[ch.right] = self._value(ch.right_motor_sign * right_mps, cfg.right_metres_per_tick)
        kind = MessageType.PWM_ALL if cfg.mode is CommandMode.PWM else MessageType.VELOCITY_ALL
        return encode_motor_command(kind, values)
