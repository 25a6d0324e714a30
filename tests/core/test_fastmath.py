from __future__ import annotations

import numpy as np
from numba import njit

from odolab.core._fastmath import SINCOS_LIMIT, sincos


@njit
def _apply(x):  # type: ignore[no-untyped-def]
    s = np.empty_like(x)
    c = np.empty_like(x)
    for i in range(x.size):
        s[i], c[i] = sincos(x[i])
    return s, c


def test_sincos_matches_numpy_over_wide_range() -> None:
    rng = np.random.default_rng(7)
    x = np.concatenate(
        [
            rng.uniform(-10, 10, 100_000),
            rng.uniform(-1e5, 1e5, 100_000),
            np.arange(-40, 41) * (np.pi / 4),  # quadrant boundaries
            [0.0, -0.0, 1e-300, SINCOS_LIMIT * 2, -SINCOS_LIMIT * 3],
        ]
    )
    s, c = _apply(x)
    assert np.max(np.abs(s - np.sin(x))) < 1e-15
    assert np.max(np.abs(c - np.cos(x))) < 1e-15
