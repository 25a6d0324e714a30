"""The virtual board's side channel: its true pose, which only a virtual board speaks.

A real Jaguar knows nothing of where it truly is; a virtual one does, and a student rehearsing
the lab on ``odolab robot sim-server`` needs it to read the virtual instruments after each run.
Every virtual board (both links) therefore sends its plant's true pose with each sensor report:

- the binary Jaguar over UDP: appended to the motor sensor packet (TYPE 0x7B) after its 33
  documented bytes, as ``TAG`` then x, y (m) and the unwrapped heading (rad), three float64
  little-endian (the protocol keeps a longer packet's extra bytes; a real board sends none);
- the Jaguar 4x4 of 2014 over TCP: a line ``ODOLAB-TRUTH x y heading`` after each report (a
  real board never sends a line of that form; the driver ignores every other unknown line).

The host sends nothing for it: nothing unusual ever reaches a real board. A driver keeps the
first and the newest pose it heard (:class:`TruthTracker`); the run's true pose is the newest in
the frame of the first (the pose at connect, before anything moved). A real board's run has none
(``run.json``: ``"true": null``), and nothing that needs it is offered for such a run.
"""

from __future__ import annotations

import math
import struct

from odolab.core.kinematics import wrap_angle
from odolab.core.trajectory import Pose

__all__ = [
    "LINE_PREFIX",
    "TAG",
    "TruthTracker",
    "decode_line",
    "decode_trailer",
    "encode_line",
    "encode_trailer",
]

#: the trailer's tag in a motor sensor packet's extra bytes
TAG = b"ODOLAB-TRUTH"
_VALUES = struct.Struct("<3d")
#: the first word of the 2014 board's truth line
LINE_PREFIX = "ODOLAB-TRUTH"


def encode_trailer(x: float, y: float, heading: float) -> bytes:
    """The bytes a virtual board appends to a motor sensor packet's data."""
    return TAG + _VALUES.pack(x, y, heading)


def decode_trailer(extra: bytes) -> tuple[float, float, float] | None:
    """The (x, y, heading) of a motor sensor packet's extra bytes; None when they are not the
    virtual board's (a real board's packet, or anything malformed)."""
    if len(extra) != len(TAG) + _VALUES.size or not extra.startswith(TAG):
        return None
    values = _VALUES.unpack(extra[len(TAG) :])
    return values if all(math.isfinite(v) for v in values) else None


def encode_line(x: float, y: float, heading: float) -> str:
    """The 2014 virtual board's truth line (without its line end)."""
    return f"{LINE_PREFIX} {x:.9f} {y:.9f} {heading:.9f}"


def decode_line(text: str) -> tuple[float, float, float] | None:
    """The (x, y, heading) of a truth line; None for any other line."""
    words = text.split()
    if len(words) != 4 or words[0] != LINE_PREFIX:
        return None
    try:
        values = tuple(float(w) for w in words[1:])
    except ValueError:
        return None
    if not all(math.isfinite(v) for v in values):
        return None
    return values[0], values[1], values[2]


class TruthTracker:
    """The first and newest true pose a virtual board sent; :meth:`relative` is the run's."""

    def __init__(self) -> None:
        self.first: tuple[float, float, float] | None = None
        self.latest: tuple[float, float, float] | None = None
        self.count = 0

    def heard(self, pose: tuple[float, float, float]) -> None:
        if self.first is None:
            self.first = pose
        self.latest = pose
        self.count += 1

    def relative(self) -> Pose | None:
        """The newest pose in the frame of the first (None: no virtual board spoke)."""
        if self.first is None or self.latest is None:
            return None
        x0, y0, h0 = self.first
        x1, y1, h1 = self.latest
        c, s = math.cos(h0), math.sin(h0)
        dx, dy = x1 - x0, y1 - y0
        heading = h1 - h0
        theta = wrap_angle(heading)
        return Pose(0.0, c * dx + s * dy, -s * dx + c * dy, theta, heading)
