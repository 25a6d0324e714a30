"""The Jaguar binary protocol (JAGUAR_PROTOCOL.md): framing, CRC-8, system and motor messages.

Every packet is ``5E 02 | DES SN TYPE LEN | DATA (LEN bytes) | CRC | 5E 0D`` (LEN + 9 bytes), the
CRC-8 (reflected Dallas/Maxim, polynomial 0x8C, register starting at 0) covering DES .. the last
data byte. All multi-byte values are little-endian.

:class:`Decoder` turns a byte stream (or a sequence of UDP datagrams) into packets: it
resynchronises on STX after garbage and discards, and counts, packets whose destination or type is
not one it knows, or whose length, CRC or ETX is wrong. It never raises on bad bytes.

The stop commands are fixed packets (:data:`STOP_PWM`, :data:`STOP_VELOCITY`): PWM 16384 or
velocity 0 on both track channels (0 and 1), the other channels left alone. They are constants,
never computed from user settings, so no sign, channel or speed option can turn a stop into a
drive command.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum

from odolab.core.errors import ProtocolError

__all__ = [
    "DES_BOARD",
    "DES_PC",
    "ETX",
    "LEAVE_ALONE",
    "MOTOR_SENSOR_LEN",
    "N_CHANNELS",
    "PWM_STOP",
    "STOP_PWM",
    "STOP_VELOCITY",
    "STX",
    "DecodeStats",
    "Decoder",
    "MessageType",
    "MotorCommand",
    "MotorSensorData",
    "Packet",
    "SystemCode",
    "crc8",
    "decode_motor_command",
    "decode_motor_sensor",
    "decode_packet",
    "decode_system",
    "encode_motor_command",
    "encode_motor_sensor",
    "encode_packet",
    "encode_system",
]

STX = b"\x5e\x02"
ETX = b"\x5e\x0d"
DES_PC = 0x00
DES_BOARD = 0x01
N_CHANNELS = 6
LEAVE_ALONE = -32768  #: motor command value meaning "leave this channel alone"
PWM_STOP = 16384  #: PWM command value meaning stop (0..32767)
MOTOR_SENSOR_LEN = 33  #: data bytes of a motor sensor packet (offsets 0..32)
_OVERHEAD = 9
_HEADER = 6


class MessageType(IntEnum):
    """The TYPE byte."""

    POSITION_ALL = 4
    PWM_ALL = 6
    VELOCITY_ALL = 27
    MOTOR_SENSOR = 0x7B
    CUSTOM_SENSOR = 0x7C
    STANDARD_SENSOR = 0x7D
    SYSTEM = 0xFF


class SystemCode(IntEnum):
    """DATA[0] of a system (TYPE 0xFF) packet."""

    PING = 0x00
    ACK = 0x01
    URGENT = 0x02
    SKIP = 0x03


_MOTOR_COMMANDS = (MessageType.PWM_ALL, MessageType.VELOCITY_ALL, MessageType.POSITION_ALL)
_KNOWN_TYPES = frozenset(int(t) for t in MessageType)
_KNOWN_DESTINATIONS = frozenset((DES_PC, DES_BOARD))


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        reg = 0
        value = byte
        for _ in range(8):
            feedback = (value ^ reg) & 1
            reg >>= 1
            if feedback:
                reg ^= 0x8C
            value >>= 1
        table.append(reg)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc8(data: bytes | bytearray | memoryview) -> int:
    """CRC-8 of ``data`` as the Jaguar board computes it (reflected Dallas/Maxim, 0x8C, init 0).

    The table is built from the bit-by-bit rule of the fact sheet, so both agree by construction.
    """
    reg = 0
    for b in bytes(data):
        reg = _CRC_TABLE[reg ^ b]
    return reg


@dataclass(frozen=True)
class Packet:
    """One decoded packet: destination, message type (the raw byte), data bytes and SN."""

    des: int
    type: int
    data: bytes
    sn: int = 0


def encode_packet(des: int, msg_type: int, data: bytes = b"", sn: int = 0) -> bytes:
    """Frame ``data`` as one packet (STX, header, data, CRC, ETX)."""
    for name, value in (("DES", des), ("SN", sn), ("TYPE", msg_type)):
        if not 0 <= int(value) <= 0xFF:
            raise ProtocolError(f"packet {name} is {value}, expected a byte 0..255")
    if len(data) > 0xFF:
        raise ProtocolError(f"packet data has {len(data)} bytes, expected at most 255")
    body = bytes((des, sn, msg_type, len(data))) + bytes(data)
    return STX + body + bytes((crc8(body),)) + ETX


def decode_packet(raw: bytes | bytearray) -> Packet:
    """Decode exactly one packet (strict); raise :class:`ProtocolError` naming what is wrong."""
    raw = bytes(raw)
    if len(raw) < _OVERHEAD:
        raise ProtocolError(f"packet has {len(raw)} bytes, expected at least {_OVERHEAD}")
    if raw[:2] != STX:
        raise ProtocolError(f"packet starts with {raw[:2].hex(' ')}, expected STX 5e 02")
    n = raw[5]
    if len(raw) != n + _OVERHEAD:
        raise ProtocolError(
            f"packet has {len(raw)} bytes but LEN {n} implies {n + _OVERHEAD} (bad length)"
        )
    if raw[-2:] != ETX:
        raise ProtocolError(f"packet ends with {raw[-2:].hex(' ')}, expected ETX 5e 0d")
    body = raw[2 : _HEADER + n]
    crc = raw[_HEADER + n]
    if crc8(body) != crc:
        raise ProtocolError(f"packet CRC is 0x{crc:02x}, expected 0x{crc8(body):02x}")
    return Packet(des=raw[2], type=raw[4], data=raw[_HEADER : _HEADER + n], sn=raw[3])


# --- system -------------------------------------------------------------------------------


def encode_system(code: SystemCode | int, des: int = DES_BOARD) -> bytes:
    """A system packet (PING, ACK, URGENT, SKIP) to ``des`` (default the board)."""
    return encode_packet(des, MessageType.SYSTEM, bytes((int(code),)))


def decode_system(packet: Packet) -> SystemCode | int:
    """The code of a system packet (a :class:`SystemCode` when known, else the raw byte)."""
    if packet.type != MessageType.SYSTEM:
        raise ProtocolError(f"packet type 0x{packet.type:02x} is not a system packet (0xff)")
    if len(packet.data) < 1:
        raise ProtocolError("system packet has no data byte, expected LEN 1")
    code = packet.data[0]
    try:
        return SystemCode(code)
    except ValueError:
        return code


# --- motor commands -----------------------------------------------------------------------


@dataclass(frozen=True)
class MotorCommand:
    """An all-channel motor command: six int16 values (None = leave alone) and an optional time."""

    kind: MessageType
    values: tuple[int | None, ...]
    time_ms: int | None = None


def _int16(value: int, what: str) -> int:
    v = int(value)
    if not -32768 <= v <= 32767:
        raise ProtocolError(f"{what} is {value}, expected an int16 (-32768..32767)")
    return v


def encode_motor_command(
    kind: MessageType | int, values: Sequence[int | None], time_ms: int | None = None
) -> bytes:
    """An all-channel motor command to the board: ``values`` has six entries, None = leave alone.

    ``kind`` is :attr:`MessageType.PWM_ALL` (6), :attr:`MessageType.VELOCITY_ALL` (27) or
    :attr:`MessageType.POSITION_ALL` (4). With ``time_ms`` the packet has LEN 14, else 12.
    """
    k = MessageType(kind)
    if k not in _MOTOR_COMMANDS:
        raise ProtocolError(f"message type {int(k)} is not an all-channel motor command (4, 6, 27)")
    if len(values) != N_CHANNELS:
        raise ProtocolError(f"motor command has {len(values)} values, expected {N_CHANNELS}")
    ints = [
        LEAVE_ALONE if v is None else _int16(v, f"channel {i} value") for i, v in enumerate(values)
    ]
    if k is MessageType.PWM_ALL:
        for i, v in enumerate(ints):
            if v != LEAVE_ALONE and not 0 <= v <= 32767:
                raise ProtocolError(f"channel {i} PWM is {v}, expected 0..32767 (16384 = stop)")
    data = struct.pack("<6h", *ints)
    if time_ms is not None:
        data += struct.pack("<h", _int16(time_ms, "command time (ms)"))
    return encode_packet(DES_BOARD, k, data)


#: Stop as PWM (type 6): 16384 on channels 0 and 1, the other channels left alone.
STOP_PWM: bytes = encode_motor_command(
    MessageType.PWM_ALL, (PWM_STOP, PWM_STOP, None, None, None, None)
)
#: Stop as velocity (type 27): 0 on channels 0 and 1, the other channels left alone.
STOP_VELOCITY: bytes = encode_motor_command(
    MessageType.VELOCITY_ALL, (0, 0, None, None, None, None)
)


def decode_motor_command(packet: Packet) -> MotorCommand:
    """Decode an all-channel motor command packet (LEN 12, or 14 with a time)."""
    try:
        kind = MessageType(packet.type)
    except ValueError:
        kind = None
    if kind not in _MOTOR_COMMANDS or kind is None:
        raise ProtocolError(f"packet type {packet.type} is not an all-channel motor command")
    n = len(packet.data)
    if n not in (12, 14):
        raise ProtocolError(f"motor command has LEN {n}, expected 12 or 14")
    raw = struct.unpack_from("<6h", packet.data)
    values = tuple(None if v == LEAVE_ALONE else v for v in raw)
    time_ms = struct.unpack_from("<h", packet.data, 12)[0] if n == 14 else None
    return MotorCommand(kind, values, time_ms)


# --- motor sensor data --------------------------------------------------------------------


@dataclass(frozen=True)
class MotorSensorData:
    """The motor sensor packet (TYPE 0x7B); encoder fields for motor 0 and motor 1.

    ``encoder_position`` and ``encoder_velocity`` are (motor 0, motor 1) as uint16;
    ``direction`` bit 0 is motor 0, bit 1 motor 1 (1 = forward).
    """

    encoder_position: tuple[int, int]
    encoder_velocity: tuple[int, int] = (0, 0)
    direction: int = 0b11
    pwm: tuple[int, ...] = (PWM_STOP,) * N_CHANNELS
    current: tuple[int, ...] = (0,) * N_CHANNELS
    extra: bytes = field(default=b"", compare=True)  #: data bytes after offset 32, if any

    def forward(self, motor: int) -> bool:
        """True when the direction bit of ``motor`` (0 or 1) says forward."""
        return bool((self.direction >> motor) & 1)


def _uint16s(values: Sequence[int], n: int, what: str) -> list[int]:
    if len(values) != n:
        raise ProtocolError(f"{what} has {len(values)} values, expected {n}")
    out = [int(v) for v in values]
    for v in out:
        if not 0 <= v <= 0xFFFF:
            raise ProtocolError(f"{what} value {v} is not a uint16 (0..65535)")
    return out


def encode_motor_sensor(sensor: MotorSensorData, des: int = DES_PC) -> bytes:
    """The motor sensor packet the board sends (LEN 33 plus ``extra``)."""
    pwm = _uint16s(sensor.pwm, N_CHANNELS, "pwm")
    cur = _uint16s(sensor.current, N_CHANNELS, "current")
    pos = _uint16s(sensor.encoder_position, 2, "encoder_position")
    vel = _uint16s(sensor.encoder_velocity, 2, "encoder_velocity")
    if not 0 <= sensor.direction <= 0xFF:
        raise ProtocolError(f"direction is {sensor.direction}, expected a byte")
    data = struct.pack(
        "<6H6HHHHHB", *pwm, *cur, pos[0], vel[0], pos[1], vel[1], sensor.direction
    ) + bytes(sensor.extra)
    return encode_packet(des, MessageType.MOTOR_SENSOR, data)


def decode_motor_sensor(packet: Packet) -> MotorSensorData:
    """Decode a motor sensor packet (LEN >= 33; bytes after offset 32 are kept in ``extra``)."""
    if packet.type != MessageType.MOTOR_SENSOR:
        raise ProtocolError(f"packet type 0x{packet.type:02x} is not motor sensor data (0x7b)")
    if len(packet.data) < MOTOR_SENSOR_LEN:
        raise ProtocolError(
            f"motor sensor packet has LEN {len(packet.data)}, expected at least {MOTOR_SENSOR_LEN}"
        )
    f = struct.unpack_from("<6H6HHHHHB", packet.data)
    return MotorSensorData(
        encoder_position=(f[12], f[14]),
        encoder_velocity=(f[13], f[15]),
        direction=f[16],
        pwm=tuple(f[0:6]),
        current=tuple(f[6:12]),
        extra=bytes(packet.data[MOTOR_SENSOR_LEN:]),
    )


def _length_ok(msg_type: int, n: int) -> bool:
    """Whether LEN ``n`` is valid for a known message type (unknown types: any length)."""
    if msg_type == MessageType.SYSTEM:
        return n >= 1
    if msg_type in (MessageType.PWM_ALL, MessageType.VELOCITY_ALL, MessageType.POSITION_ALL):
        return n in (12, 14)
    if msg_type == MessageType.MOTOR_SENSOR:
        return n >= MOTOR_SENSOR_LEN
    return True


# --- streaming decoder --------------------------------------------------------------------


@dataclass
class DecodeStats:
    """What a :class:`Decoder` has seen (counts)."""

    packets: int = 0
    unknown_destination: int = 0  #: DES not one this decoder accepts
    unknown_type: int = 0  #: TYPE not a known message type
    bad_length: int = 0  #: LEN impossible for the type, or a packet cut short by a datagram end
    bad_crc: int = 0
    bad_etx: int = 0
    garbage_bytes: int = 0  #: bytes skipped while looking for STX

    @property
    def discarded(self) -> int:
        """Candidate packets discarded (unknown destination or type, bad length, CRC or ETX)."""
        return (
            self.unknown_destination
            + self.unknown_type
            + self.bad_length
            + self.bad_crc
            + self.bad_etx
        )


class Decoder:
    """Incremental packet decoder that resynchronises on STX and never raises on bad bytes.

    :meth:`feed` treats the input as a byte stream (an incomplete packet waits for more bytes);
    :meth:`feed_datagram` treats it as one UDP datagram (nothing carries over to the next one:
    an incomplete packet at its end counts as a bad length).

    ``destinations``: the DES bytes accepted (default: the PC 0x00 and the board 0x01; a driver
    passes only ``{DES_PC}``, a board only ``{DES_BOARD}``). ``types``: the TYPE bytes accepted
    (default: the known message types, :class:`MessageType`; benchmarks pass all 256 to
    measure the permissive decoder this one replaced). Everything else is counted and skipped byte by byte, so
    a fake STX in garbage can swallow a real packet only if its DES, TYPE, LEN, ETX and CRC all
    happen to be valid.
    """

    def __init__(
        self,
        destinations: frozenset[int] | set[int] | None = None,
        types: frozenset[int] | set[int] | None = None,
    ) -> None:
        self.stats = DecodeStats()
        self.destinations = _KNOWN_DESTINATIONS if destinations is None else frozenset(destinations)
        self.types = _KNOWN_TYPES if types is None else frozenset(types)
        self._buf = bytearray()

    def reset(self) -> None:
        """Drop buffered bytes (the counts are kept)."""
        self._buf.clear()

    def feed(self, data: bytes | bytearray | memoryview) -> list[Packet]:
        """Add stream bytes; return the complete valid packets found."""
        self._buf += data
        return self._parse(final=False)

    def feed_datagram(self, data: bytes | bytearray | memoryview) -> list[Packet]:
        """Decode one datagram on its own; return its valid packets."""
        self._buf.clear()
        self._buf += data
        out = self._parse(final=True)
        self._buf.clear()
        return out

    def _parse(self, final: bool) -> list[Packet]:
        buf = self._buf
        out: list[Packet] = []
        pos = 0
        st = self.stats
        while True:
            start = buf.find(STX, pos)
            if start < 0:
                # keep a trailing 0x5E: it may be the first half of the next STX
                keep = 1 if (not final and buf.endswith(b"\x5e")) else 0
                st.garbage_bytes += len(buf) - pos - keep
                pos = len(buf) - keep
                break
            st.garbage_bytes += start - pos
            pos = start
            if len(buf) - pos < _HEADER:
                if final:
                    st.bad_length += 1
                    pos += 1
                    continue
                break
            if buf[pos + 2] not in self.destinations:
                st.unknown_destination += 1
                pos += 1
                continue
            msg_type = buf[pos + 4]
            if msg_type not in self.types:
                st.unknown_type += 1
                pos += 1
                continue
            n = buf[pos + 5]
            if not _length_ok(msg_type, n):
                st.bad_length += 1
                pos += 1
                continue
            end = pos + n + _OVERHEAD
            if end > len(buf):
                if final:
                    st.bad_length += 1
                    pos += 1
                    continue
                break
            if buf[end - 2 : end] != ETX:
                st.bad_etx += 1
                pos += 1
                continue
            body = bytes(buf[pos + 2 : pos + _HEADER + n])
            if crc8(body) != buf[pos + _HEADER + n]:
                st.bad_crc += 1
                pos += 1
                continue
            out.append(
                Packet(des=body[0], type=body[2], data=body[4:], sn=body[1]),
            )
            st.packets += 1
            pos = end
        del buf[:pos]
        return out
