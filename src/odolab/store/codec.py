"""Compact, exact storage of encoder logs as three BLOBs.

Codec ``"shuffle-zlib-v1"``:

- ``t``: the float64 times, little-endian, byte-shuffled (all first bytes, then all second
  bytes, ...), zlib-compressed. Regular sampling makes the high bytes nearly constant.
- ``left_ticks`` / ``right_ticks``: the int64 counters delta-encoded (first value, then
  differences, in wrapping int64 arithmetic so any values round-trip), little-endian,
  byte-shuffled, zlib-compressed. Per-cycle differences are small, so most bytes are 0 or 0xff.

Decoding gives back the very same arrays (bit for bit).
"""

from __future__ import annotations

import zlib
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import StoreError
from odolab.core.trials import EncoderLog

__all__ = ["CODEC", "EncodedLog", "decode_log", "encode_log"]

CODEC = "shuffle-zlib-v1"


class EncodedLog(NamedTuple):
    """An encoder log as stored: sample count, modulus, codec name and three BLOBs."""

    n: int
    modulus: int | None
    codec: str
    t: bytes
    left_ticks: bytes
    right_ticks: bytes


def _pack(a: NDArray[np.generic]) -> bytes:
    raw = np.ascontiguousarray(a).view(np.uint8).reshape(-1, 8)
    return zlib.compress(np.ascontiguousarray(raw.T).tobytes(), 6)


def _unpack(blob: bytes, n: int, dtype: str, what: str) -> NDArray[np.generic]:
    try:
        data = zlib.decompress(blob)
    except zlib.error as err:
        raise StoreError(f"encoder log {what}: corrupt compressed data ({err})") from err
    if len(data) != 8 * n:
        raise StoreError(f"encoder log {what}: {len(data)} bytes, expected {8 * n}")
    shuffled = np.frombuffer(data, dtype=np.uint8).reshape(8, n)
    return np.ascontiguousarray(shuffled.T).view(np.dtype(dtype)).reshape(n)


def _deltas(a: NDArray[np.int64]) -> NDArray[np.int64]:
    out = np.empty_like(a)
    if a.size:
        out[0] = a[0]
        with np.errstate(over="ignore"):
            np.subtract(a[1:], a[:-1], out=out[1:])
    return out


def encode_log(log: EncoderLog) -> EncodedLog:
    """Encode ``log`` (arrays of shape (n,)) for storage.

    Raises:
        StoreError: the arrays are not 1-D of one length.
    """
    t = np.asarray(log.t, dtype="<f8")
    left = np.asarray(log.left_ticks, dtype="<i8")
    right = np.asarray(log.right_ticks, dtype="<i8")
    if not (t.ndim == left.ndim == right.ndim == 1) or not (t.size == left.size == right.size):
        raise StoreError(
            f"encoder log arrays must be 1-D and of one length, got t {t.shape}, "
            f"left {left.shape}, right {right.shape}"
        )
    return EncodedLog(
        n=int(t.size),
        modulus=log.modulus,
        codec=CODEC,
        t=_pack(t),
        left_ticks=_pack(_deltas(left)),
        right_ticks=_pack(_deltas(right)),
    )


def decode_log(enc: EncodedLog) -> EncoderLog:
    """Decode what :func:`encode_log` produced.

    Raises:
        StoreError: the stored codec is unknown.
    """
    if enc.codec != CODEC:
        raise StoreError(f"encoder log: unknown codec {enc.codec!r}; expected {CODEC!r}")
    n = int(enc.n)
    t = _unpack(enc.t, n, "<f8", "t").astype(np.float64)
    with np.errstate(over="ignore"):
        left = np.cumsum(_unpack(enc.left_ticks, n, "<i8", "left_ticks"), dtype=np.int64)
        right = np.cumsum(_unpack(enc.right_ticks, n, "<i8", "right_ticks"), dtype=np.int64)
    return EncoderLog(t=t, left_ticks=left, right_ticks=right, modulus=enc.modulus)
