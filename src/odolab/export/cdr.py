"""CDR (ROS 2's encoding) of many messages of one fixed layout at once, with NumPy.

``mcap-ros2-support`` encodes a message from a dict of its fields, one field at a time in
Python: about 80 us a message, which made ``odolab export mcap`` of a campaign (97,000 messages)
take 9 s. The messages odolab writes have the same strings and sequence lengths in every message
of a topic (the frame names, two wheel joints), so each topic's layout (where every field sits,
with CDR's alignment) is the same for all its messages: :class:`Layout` builds it once as a NumPy
structured type, fills it column by column and cuts the buffer into messages. The bytes are
``mcap-ros2-support``'s to the byte (tests/export/test_cdr.py encodes the same messages both ways).

The encoding is plain CDR, little-endian (the 4-byte encapsulation header ``00 01 00 00``), as
ROS 2 (Fast DDS, Cyclone DDS) and ``mcap-ros2-support`` write it: a value is aligned to its own
size counted from the end of the header, padding is zero bytes, a string is its length with the
terminating NUL (uint32), its UTF-8 bytes and a NUL, and a sequence is its length (uint32) and its
elements.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Layout"]

#: CDR's encapsulation header: plain CDR, little-endian
HEADER = b"\x00\x01\x00\x00"


class Layout:
    """The layout of one message type whose strings and sequence lengths are fixed: add the
    fields in the order of the message definition (:meth:`i32`, :meth:`u32`, :meth:`f64`,
    :meth:`string`, :meth:`count`), then :meth:`pack` rows of values."""

    def __init__(self) -> None:
        self._names: list[str] = ["header"]
        self._formats: list[str] = ["V4"]
        self._offsets: list[int] = [0]
        self._constants: dict[str, object] = {"header": np.void(HEADER)}
        self._end = 0  # bytes after the encapsulation header

    def _field(self, name: str, fmt: str, size: int, align: int) -> None:
        if name in self._constants or name in self._names:
            raise ValueError(f"CDR layout: field {name!r} given twice")
        self._end += -self._end % align
        self._names.append(name)
        self._formats.append(fmt)
        self._offsets.append(len(HEADER) + self._end)
        self._end += size

    def i32(self, name: str) -> Layout:
        """A signed 32-bit integer column (a stamp's seconds)."""
        self._field(name, "<i4", 4, 4)
        return self

    def u32(self, name: str) -> Layout:
        """An unsigned 32-bit integer column (a stamp's nanoseconds)."""
        self._field(name, "<u4", 4, 4)
        return self

    def f64(self, name: str, size: int = 1) -> Layout:
        """A float64 column, or ``size`` of them in a row (a fixed array such as a covariance)."""
        self._field(name, "<f8" if size == 1 else f"({size},)<f8", 8 * size, 8)
        return self

    def count(self, n: int) -> Layout:
        """A sequence's length, the same in every message (its elements follow)."""
        name = f"_count{len(self._names)}"
        self._field(name, "<u4", 4, 4)
        self._constants[name] = n
        return self

    def string(self, text: str) -> Layout:
        """A string, the same in every message (a frame or joint name)."""
        data = text.encode("utf-8") + b"\0"
        self.count(len(data))
        name = f"_text{len(self._names)}"
        self._field(name, f"V{len(data)}", len(data), 1)
        self._constants[name] = np.void(data)
        return self

    @property
    def dtype(self) -> np.dtype[np.void]:
        """The NumPy structured type of one message (itemsize: the message's bytes)."""
        return np.dtype(
            {
                "names": self._names,
                "formats": self._formats,
                "offsets": self._offsets,
                "itemsize": len(HEADER) + self._end,
            }
        )

    def pack(self, n: int, columns: dict[str, ArrayLike]) -> list[bytes]:
        """``n`` messages, the column ``name`` giving each message's field ``name`` (a
        scalar: the same in all); every column the layout has must be given."""
        rows: NDArray[np.void] = np.zeros(n, dtype=self.dtype)  # padding: zero bytes
        for name, value in self._constants.items():
            rows[name] = value
        wanted = [k for k in self._names if k not in self._constants]
        missing = sorted(set(wanted) - set(columns))
        extra = sorted(set(columns) - set(wanted))
        if missing or extra:
            raise ValueError(f"CDR layout: columns missing {missing}, unknown {extra}")
        for name, value in columns.items():
            rows[name] = value
        buf = rows.tobytes()
        size = rows.dtype.itemsize
        return [buf[i : i + size] for i in range(0, n * size, size)]
