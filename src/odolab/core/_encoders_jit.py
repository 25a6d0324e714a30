"""The compiled counter step of :mod:`odolab.core.encoders` (numba), in its own module so that
importing :mod:`odolab.core.encoders` does not import numba; ``from odolab.core.encoders import
unwrap_diff`` loads it on first use."""

from __future__ import annotations

from odolab.core._jit import njit

__all__ = ["unwrap_diff"]


@njit(cache=True, inline="always")
def unwrap_diff(d: int, modulus: int, half: int) -> int:  # pragma: no cover - compiled
    """Compiled: a raw counter difference ``d`` mapped into [-half, modulus - half)."""
    # |d| < modulus for counters in range; map d into [-half, modulus - half) without a division
    if modulus > 0:
        if d >= modulus - half:
            d -= modulus
            if d >= modulus - half:  # raw values outside 0..modulus-1: fall back to modulo
                d = (d + half) % modulus - half
        elif d < -half:
            d += modulus
            if d < -half:
                d = (d + half) % modulus - half
    return d
