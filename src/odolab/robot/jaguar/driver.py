"""The Jaguar driver: talks to a board over a transport (UDP, or in-process in simulated time).

It sends the ACK handshake, answers the board's PINGs with ACK, sends drive commands as
all-channel PWM (type 6) or velocity (type 27) packets, and parses motor sensor packets into
encoder readings in the robot's left/right frame (configurable channels and encoder signs).
"""

from __future__ import annotations

import math
import socket
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Protocol
from urllib.parse import urlparse

from odolab.errors import ProtocolError, RobotLinkError
from odolab.robot.clock import Clock
from odolab.robot.protocol import (
    N_CHANNELS,
    PWM_STOP,
    Decoder,
    MessageType,
    SystemCode,
    decode_motor_sensor,
    decode_system,
    encode_motor_command,
    encode_system,
)

__all__ = [
    "ChannelMap",
    "CommandMode",
    "DriverConfig",
    "DriverStats",
    "EncoderReading",
    "JaguarDriver",
    "Transport",
    "UdpTransport",
    "parse_robot_url",
]


class Transport(Protocol):
    """Datagrams to and from one board."""

    def send(self, data: bytes) -> None:
        """Send one datagram to the board."""
        ...

    def receive(self) -> list[bytes]:
        """All datagrams that have arrived (never blocks)."""
        ...

    def close(self) -> None:
        """Release the link."""
        ...


def parse_robot_url(url: str) -> tuple[str, int]:
    """``udp://HOST:PORT`` -> (host, port)."""
    parsed = urlparse(url)
    try:
        port = parsed.port  # raises ValueError for a non-number or out of 0..65535
    except ValueError as err:
        raise RobotLinkError(
            f"robot address {url!r} has a bad port ({err}); expected udp://HOST:PORT with a port "
            "in 0..65535"
        ) from err
    if parsed.scheme != "udp" or not parsed.hostname or port is None:
        raise RobotLinkError(f"robot address {url!r} is not of the form udp://HOST:PORT")
    return parsed.hostname, port


class UdpTransport:
    """A connected, non-blocking UDP socket to the board at (host, port)."""

    def __init__(self, host: str, port: int) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.connect((host, port))
        except OSError as err:
            self._sock.close()
            raise RobotLinkError(f"cannot reach the robot at udp://{host}:{port} ({err})") from err
        self._sock.setblocking(False)
        self.address = (host, port)
        self.send_errors = 0

    def send(self, data: bytes) -> None:
        try:
            self._sock.send(data)
        except OSError:  # nobody listening yet (ICMP), buffer full: the watchdog will see it
            self.send_errors += 1

    def receive(self) -> list[bytes]:
        out: list[bytes] = []
        while True:
            try:
                out.append(self._sock.recv(2048))
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # ICMP port unreachable: no board yet
                return out

    def close(self) -> None:
        self._sock.close()


class CommandMode(StrEnum):
    """How drive commands are sent."""

    PWM = "pwm"  #: all-channel PWM, type 6
    VELOCITY = "velocity"  #: all-channel velocity, type 27


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
            raise ProtocolError(
                f"channels left={self.left} right={self.right}: expected 0 and 1, one each "
                "(the motor sensor packet reports encoders of motors 0 and 1 only)"
            )
        for name in (
            "left_encoder_sign",
            "right_encoder_sign",
            "left_motor_sign",
            "right_motor_sign",
        ):
            if getattr(self, name) not in (1, -1):
                raise ProtocolError(f"{name} is {getattr(self, name)!r}, expected 1 or -1")


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


@dataclass(frozen=True)
class EncoderReading:
    """One motor sensor packet in the robot frame: counters (signed and wrapped), time received."""

    t: float
    left_ticks: int
    right_ticks: int
    left_rate: int  #: encoder velocity field (counts/s, magnitude)
    right_rate: int
    direction: int


@dataclass
class DriverStats:
    """What the driver has seen and sent (counts)."""

    datagrams: int = 0
    sensor_packets: int = 0
    bad_sensor_packets: int = 0
    pings_answered: int = 0
    acks_received: int = 0
    other_packets: int = 0
    commands_sent: int = 0
    stops_sent: int = 0


class JaguarDriver:
    """Client of one Jaguar board over ``transport``; times come from ``clock``."""

    def __init__(self, transport: Transport, clock: Clock, config: DriverConfig | None = None):
        self.transport = transport
        self.clock = clock
        self.config = config or DriverConfig()
        self.decoder = Decoder()
        self.stats = DriverStats()
        self.latest: EncoderReading | None = None
        self.last_command: tuple[float, float] = (0.0, 0.0)

    @property
    def decode_errors(self) -> int:
        """Packets discarded for a bad length, CRC or ETX."""
        return self.decoder.stats.discarded

    def connect(self) -> EncoderReading:
        """Send ACK until the first sensor packet arrives; raise :class:`RobotLinkError` if none."""
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
                assert self.latest is not None
                return self.latest
            if now >= deadline:
                raise RobotLinkError(
                    f"no sensor data from the robot within {self.config.connect_timeout:g} s "
                    "after ACK; is it on and reachable?"
                )
            clock.sleep_until(min(now + 0.005, deadline, next_ack))

    def poll(self) -> int:
        """Read everything that has arrived; answer PINGs; return the number of new readings."""
        n = 0
        for datagram in self.transport.receive():
            self.stats.datagrams += 1
            for packet in self.decoder.feed_datagram(datagram):
                if packet.type == MessageType.MOTOR_SENSOR:
                    try:
                        sensor = decode_motor_sensor(packet)
                    except ProtocolError:
                        self.stats.bad_sensor_packets += 1
                        continue
                    self.latest = self._reading(
                        sensor.encoder_position, sensor.encoder_velocity, sensor.direction
                    )
                    self.stats.sensor_packets += 1
                    n += 1
                elif packet.type == MessageType.SYSTEM:
                    code = decode_system(packet)
                    if code == SystemCode.PING:
                        self.transport.send(encode_system(SystemCode.ACK))
                        self.stats.pings_answered += 1
                    elif code == SystemCode.ACK:
                        self.stats.acks_received += 1
                    else:
                        self.stats.other_packets += 1
                else:
                    self.stats.other_packets += 1
        return n

    def _reading(
        self, position: tuple[int, int], velocity: tuple[int, int], direction: int
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
            self.clock.now(), left, right, velocity[ch.left], velocity[ch.right], direction
        )

    def _value(self, speed: float, metres_per_tick: float) -> int:
        vmax = self.config.max_wheel_speed
        s = min(max(speed, -vmax), vmax)
        if self.config.mode is CommandMode.PWM:
            return int(min(max(round(PWM_STOP + s / vmax * PWM_STOP), 0), 32767))
        return int(min(max(round(s / metres_per_tick), -32767), 32767))

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        """Command the left and right track speeds (m/s, forward positive)."""
        if not (math.isfinite(left_mps) and math.isfinite(right_mps)):
            raise RobotLinkError(f"wheel speeds must be finite, got {left_mps!r}, {right_mps!r}")
        cfg = self.config
        ch = cfg.channels
        values: list[int | None] = [None] * N_CHANNELS
        values[ch.left] = self._value(ch.left_motor_sign * left_mps, cfg.left_metres_per_tick)
        values[ch.right] = self._value(ch.right_motor_sign * right_mps, cfg.right_metres_per_tick)
        kind = MessageType.PWM_ALL if cfg.mode is CommandMode.PWM else MessageType.VELOCITY_ALL
        self.transport.send(encode_motor_command(kind, values))
        self.last_command = (left_mps, right_mps)
        self.stats.commands_sent += 1

    def stop(self) -> None:
        """Command both tracks to stop (PWM 16384 or velocity 0)."""
        self.set_wheel_speeds(0.0, 0.0)
        self.stats.stops_sent += 1

    def close(self) -> None:
        """Stop the robot and close the transport (safe to call twice)."""
        try:
            self.stop()
        finally:
            self.transport.close()
