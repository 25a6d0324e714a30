"""The Jaguar 4x4 of 2014 and later: text lines over TCP (``../shared/JAGUAR_2014_PROTOCOL.md``).

Lines end with CR LF in both directions; a bare CR or LF also ends a line (Roboteq style). A line
may arrive split across TCP segments, or several in one: :class:`LineSplitter` reassembles them.
Robot lines by first character: ``#`` IMU, ``$`` GPS (NMEA, kept as text), ``M`` a motor board
(``MM<b> <KEY>=<v1>:<v2>...`` with every key of the fact sheet, or ``MM<b> +`` / ``MM<b> -``).
Anything else, or a known key with values that are not integers, is an unknown line: ignored and
counted, never raised.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from odolab.core.errors import ProtocolError

__all__ = [
    "IMU_LABELS",
    "MOTOR_KEYS",
    "PING",
    "POWER_LIMIT",
    "RELEASE_ESTOP",
    "SET_ESTOP",
    "STOP",
    "CommandReply",
    "GpsLine",
    "HostCommand",
    "ImuLine",
    "LineSplitter",
    "LineStats",
    "MotorLine",
    "encode_drive",
    "int32",
    "parse_host_line",
    "parse_robot_line",
]

#: The keep-alive the host sends (every 20 to 200 ms in public drivers).
PING = b"PING\r\n"
#: Release the emergency stop (needed before the boards drive).
RELEASE_ESTOP = b"MMW !MG\r\n"
#: Set the emergency stop.
SET_ESTOP = b"MMW !EX\r\n"
#: The fixed stop line: both channels of both drive boards to 0. Never computed.
STOP = b"MMW !M 0 0\r\n"
#: ``!M`` values are integers in -POWER_LIMIT..POWER_LIMIT.
POWER_LIMIT = 1000
#: Motor-board keys of the fact sheet (``MM<b> KEY=v1:v2...``).
MOTOR_KEYS = frozenset({"C", "CR", "S", "A", "P", "AI", "T", "V", "FF", "D", "DO", "MMOD"})
#: Labels of an IMU line (``#seq,YAW,y,GYRO,x,y,z,ACC,...``).
IMU_LABELS = frozenset({"YAW", "PITCH", "ROLL", "GYRO", "ACC", "COMP", "ADC"})
#: A line longer than this (bytes, without its end) is garbage: dropped and counted.
MAX_LINE = 512

_MOTOR = re.compile(r"MM([0-9]) (.*)")
_DRIVE = re.compile(r"MM([W0-9]) !M (-?[0-9]+) (-?[0-9]+)")


def int32(value: int) -> int:
    """``value`` as a signed 32-bit integer (two's complement wrap)."""
    return ((value + 2**31) % 2**32) - 2**31


def encode_drive(left: int, right: int) -> bytes:
    """``MMW !M <left> <right>`` CR LF; each an integer in -1000..1000 (raw channel values)."""
    for v in (left, right):
        if not isinstance(v, int) or isinstance(v, bool) or not -POWER_LIMIT <= v <= POWER_LIMIT:
            raise ProtocolError(f"!M value {v!r} is not an integer in -1000..1000")
    return f"MMW !M {left} {right}\r\n".encode("ascii")


@dataclass
class LineStats:
    """What a :class:`LineSplitter` and the parsers have seen (counts)."""

    lines: int = 0
    unknown: int = 0  #: lines ignored: no known form
    overlong: int = 0  #: lines dropped for exceeding MAX_LINE bytes
    by_kind: dict[str, int] = field(default_factory=dict)


class LineSplitter:
    """Bytes from a stream in, whole lines out (text without the end of line; empty lines skipped).

    CR LF, a bare CR and a bare LF all end a line; bytes that are not ASCII are replaced.
    """

    def __init__(self, stats: LineStats | None = None) -> None:
        self._buf = bytearray()
        self.stats = stats or LineStats()

    def feed(self, data: bytes) -> list[str]:
        buf = self._buf
        buf.extend(data)
        out: list[str] = []
        start = 0
        n = len(buf)
        i = 0
        while i < n:
            b = buf[i]
            if b == 13 or b == 10:
                if i > start:
                    if i - start > MAX_LINE:
                        self.stats.overlong += 1
                    else:
                        out.append(buf[start:i].decode("ascii", "replace"))
                        self.stats.lines += 1
                start = i + 1
            i += 1
        del buf[:start]
        if len(buf) > MAX_LINE:  # no end in sight: drop it, resynchronise at the next end
            self.stats.overlong += 1
            buf.clear()
        return out


@dataclass(frozen=True)
class MotorLine:
    """``MM<board> <key>=<v1>:<v2>...``: board 0 front, 1 rear; values per channel."""

    board: int
    key: str
    values: tuple[int, ...]


@dataclass(frozen=True)
class CommandReply:
    """``MM<board> +`` (accepted) or ``MM<board> -`` (rejected)."""

    board: int
    accepted: bool


@dataclass(frozen=True)
class ImuLine:
    """``#<seq>,YAW,<rad>,GYRO,<x>,<y>,<z>,...``: values by label (raw units of the unit)."""

    seq: int
    fields: dict[str, tuple[float, ...]]

    @property
    def yaw(self) -> float | None:
        v = self.fields.get("YAW")
        return v[0] if v else None

    @property
    def gyro(self) -> tuple[float, ...] | None:
        return self.fields.get("GYRO")


@dataclass(frozen=True)
class GpsLine:
    """A raw NMEA sentence (``$GPRMC,...``), kept as text."""

    sentence: str


RobotLine = MotorLine | CommandReply | ImuLine | GpsLine


def _ints(text: str) -> tuple[int, ...] | None:
    parts = text.split(":")
    try:
        return tuple(int(p) for p in parts)
    except ValueError:
        return None


def _imu(line: str) -> ImuLine | None:
    parts = line.split(",")
    while parts and parts[-1].strip() == "":
        parts.pop()  # TRI's unit ends its lines with a comma
    try:
        seq = int(parts[0][1:])
    except ValueError:
        return None
    fields: dict[str, tuple[float, ...]] = {}
    label: str | None = None
    values: list[float] = []
    for tok in parts[1:]:
        tok = tok.strip()
        if tok.upper() in IMU_LABELS:
            if label is not None:
                fields[label] = tuple(values)
            label, values = tok.upper(), []
            continue
        if label is None:
            return None
        try:
            v = float(tok)
        except ValueError:
            return None
        if not math.isfinite(v):
            return None
        values.append(v)
    if label is not None:
        fields[label] = tuple(values)
    if not fields:
        return None
    return ImuLine(seq, fields)


def parse_robot_line(line: str) -> RobotLine | None:
    """One line from the robot, parsed; None for a line of no known form (count it, go on)."""
    line = line.strip()
    if not line:
        return None
    first = line[0]
    if first == "#":
        return _imu(line)
    if first == "$":
        return GpsLine(line)
    m = _MOTOR.fullmatch(line)
    if m is None:
        return None
    board = int(m.group(1))
    rest = m.group(2).strip()
    if rest in ("+", "-"):
        return CommandReply(board, rest == "+")
    key, sep, text = rest.partition("=")
    if not sep or key not in MOTOR_KEYS:
        return None
    values = _ints(text)
    if values is None:
        return None
    return MotorLine(board, key, values)


@dataclass(frozen=True)
class HostCommand:
    """A line from the host, as a board reads it.

    ``kind``: "ping", "drive" (``values`` = (ch1, ch2)), "release" (``!MG``), "estop" (``!EX``),
    "query" (``~...``) or "other" (a line the virtual board does not act on).
    """

    kind: str
    target: str  #: "W" (both drive boards) or a board number
    values: tuple[int, ...] = ()


def parse_host_line(line: str) -> HostCommand:
    """One line from the host, as a board reads it (never raises)."""
    line = line.strip()
    if line == "PING":
        return HostCommand("ping", "")
    m = _DRIVE.fullmatch(line)
    if m is not None:
        return HostCommand("drive", m.group(1), (int(m.group(2)), int(m.group(3))))
    if line.startswith("MM") and len(line) > 3:
        target, rest = line[2], line[3:].strip()
        if rest == "!MG":
            return HostCommand("release", target)
        if rest == "!EX":
            return HostCommand("estop", target)
        if rest.startswith("~"):
            return HostCommand("query", target)
    return HostCommand("other", "")
