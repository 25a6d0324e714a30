"""Encoder counters: rollover unwrapping, in batch and streaming, with the same answers.

A counter with modulus ``M`` counts ``0 .. M-1`` and wraps. Between two samples the true change
``d`` is taken as the representative of ``(c1 - c0) mod M`` in ``[-M/2, M/2)``: a wrap forward or
backward between two consecutive samples is handled. A change whose magnitude exceeds
``max_dticks`` (per cycle) is too large to be plausible motion and raises
:class:`~odolab.core.errors.EncoderJumpError` instead of being integrated silently.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import EncoderJumpError, LogFormatError

__all__ = [
    "EncoderUnwrapper",
    "as_tick_array",
    "counter_delta",
    "default_max_dticks",
    "dticks_from_ticks",
    "unwrap_diff",
    "unwrap_ticks",
]

if TYPE_CHECKING:
    from odolab.core._encoders_jit import unwrap_diff


def __getattr__(name: str) -> object:
    """The compiled :func:`unwrap_diff` (in :mod:`odolab.core._encoders_jit`), loaded on first use
    so that importing this module does not import numba."""
    if name == "unwrap_diff":
        from odolab.core._encoders_jit import unwrap_diff

        return unwrap_diff
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def default_max_dticks(modulus: int | None) -> int | None:
    """Default plausibility limit per cycle: a quarter of the counter range (None: no limit)."""
    return None if modulus is None else max(1, modulus // 4)


def as_tick_array(values: ArrayLike, name: str = "ticks") -> NDArray[np.int64]:
    """Counter values as int64, refusing NaN, infinities and non-integers with a clear error."""
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise LogFormatError(f"{name} must be a 1-D sequence, got shape {arr.shape}")
    if arr.dtype.kind in "iu":
        return arr.astype(np.int64, copy=False)
    if arr.dtype.kind != "f":
        raise LogFormatError(f"{name} must be numeric, got dtype {arr.dtype}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise LogFormatError(f"{name}[{i}] is {arr[i]}, expected a finite integer count")
    rounded = np.rint(arr)
    off = np.abs(arr - rounded) > 1e-6
    if off.any():
        i = int(np.argmax(off))
        raise LogFormatError(f"{name}[{i}] is {arr[i]}, expected an integer count")
    ints: NDArray[np.int64] = rounded.astype(np.int64)
    return ints


IntOrArray = TypeVar("IntOrArray", int, NDArray[np.int64])


def counter_delta(d: IntOrArray, modulus: int) -> IntOrArray:
    """A raw counter difference (an int or an int64 array) as the true change: its
    representative of ``d mod modulus`` in ``[-modulus/2, modulus/2)``. The one statement of the
    rollover rule; :func:`unwrap_diff` is its compiled twin (tests/core/test_encoders.py)."""
    half = modulus // 2
    return (d + half) % modulus - half


def dticks_from_ticks(
    ticks: ArrayLike,
    modulus: int | None,
    max_dticks: int | None = None,
    *,
    name: str = "ticks",
) -> NDArray[np.int64]:
    """Per-cycle increments of a raw counter (length n-1), unwrapped at ``modulus``."""
    raw = as_tick_array(ticks, name)
    d = np.diff(raw)
    if modulus is not None:
        d = counter_delta(d, modulus)
    if max_dticks is not None and d.size:
        too_big = np.abs(d) > max_dticks
        if too_big.any():
            i = int(np.argmax(too_big))
            raise EncoderJumpError(
                f"{name} jumps by {int(d[i])} counts between samples {i} and {i + 1}, more than "
                f"the {max_dticks} counts per cycle that a wrap or plausible motion allows"
            )
    return d


def unwrap_ticks(
    ticks: ArrayLike, modulus: int | None, max_dticks: int | None = None, *, name: str = "ticks"
) -> NDArray[np.int64]:
    """Continuous counts (starting at the first raw value) from a wrapping counter."""
    raw = as_tick_array(ticks, name)
    if raw.size == 0:
        return raw.copy()
    d = dticks_from_ticks(raw, modulus, max_dticks, name=name)
    out = np.empty_like(raw)
    out[0] = raw[0]
    np.cumsum(d, out=out[1:])
    out[1:] += raw[0]
    return out


class EncoderUnwrapper:
    """Streaming counterpart of :func:`dticks_from_ticks` for one counter."""

    def __init__(self, modulus: int | None, max_dticks: int | None = None, name: str = "ticks"):
        self.modulus = modulus
        self.max_dticks = max_dticks
        self.name = name
        self._last: int | None = None
        self._index = -1

    def reset(self) -> None:
        self._last = None
        self._index = -1

    def update(self, raw: int) -> int:
        """Feed a raw counter value; return the increment since the last (0 for the first)."""
        self._index += 1
        value = int(raw)
        if self._last is None:
            self._last = value
            return 0
        d = value - self._last
        if self.modulus is not None:
            d = counter_delta(d, self.modulus)
        if self.max_dticks is not None and abs(d) > self.max_dticks:
            raise EncoderJumpError(
                f"{self.name} jumps by {d} counts between samples {self._index - 1} and "
                f"{self._index}, more than the {self.max_dticks} counts per cycle that a wrap or "
                "plausible motion allows"
            )
        self._last = value
        return d
