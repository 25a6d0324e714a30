"""The compiled pair choosers of :mod:`odolab.metrics.pose_error` (numba), in their own module so
that importing the metrics (``odolab evaluate``) does not import numba (0.15-0.35 s): the
functions of the same names there load this on their first call."""

from __future__ import annotations

import math

import numpy as np

from odolab.core._jit import njit
from odolab.core._kinematics_jit import wrap
from odolab.core.arrays import FloatArray, IntArray


@njit(cache=True)
def consecutive_by_steps_from(
    steps: FloatArray, delta: float, current: float, first: bool
) -> tuple[IntArray, float]:  # pragma: no cover
    """:func:`consecutive_by_path_from` with the step sizes given: ``steps[i]`` is the amount
    (an angle turned) from pose ``i - 1`` to pose ``i`` (``steps[0]`` is not used)."""
    n = steps.shape[0]
    ids = np.empty(n, dtype=np.int64)
    k = 0
    if first and n > 0:
        ids[0] = 0
        k = 1
    for i in range(1, n):
        current += steps[i]
        if current >= delta:
            ids[k] = i
            k += 1
            current = 0.0
    return ids[:k], current


@njit(cache=True)
def all_pairs_by_angle(
    heading: FloatArray, delta: float, tol: float
) -> IntArray:  # pragma: no cover
    """Every ``(i, j)``, ``j > i``, with ``|wrap(heading[j] - heading[i]) - delta| <= tol``, in
    the order of ``i`` then ``j`` (evo's all pairs by angle; O(n^2), as evo's)."""
    n = heading.shape[0]
    lo = delta - tol
    hi = delta + tol
    count = 0
    for i in range(n - 1):
        for j in range(i + 1, n):
            a = abs(wrap(heading[j] - heading[i]))
            if lo <= a <= hi:
                count += 1
    out = np.empty((count, 2), dtype=np.int64)
    k = 0
    for i in range(n - 1):
        for j in range(i + 1, n):
            a = abs(wrap(heading[j] - heading[i]))
            if lo <= a <= hi:
                out[k, 0] = i
                out[k, 1] = j
                k += 1
    return out


@njit(cache=True)
def consecutive_by_path_from(
    x: FloatArray, y: FloatArray, delta: float, current: float, first: bool
) -> tuple[IntArray, float]:  # pragma: no cover
    """Indexes where the path length since the previous chosen index reaches ``delta``.

    ``current``: path length since the previous chosen index before ``x[0]``; ``first``: index
    0 is the path's start (chosen). Chunk by chunk, pass the previous chunk's last position
    as ``x[0], y[0]`` with ``first=False`` and the ``current`` it returned: the same indexes
    as one call over the whole path. Returns the indexes and the new ``current``.
    """
    n = x.shape[0]
    steps = np.zeros(n)
    for i in range(1, n):
        dx = x[i] - x[i - 1]
        dy = y[i] - y[i - 1]
        steps[i] = math.sqrt(dx * dx + dy * dy)
    return consecutive_by_steps_from(steps, delta, current, first)


@njit(cache=True)
def all_pairs_by_path(dist: FloatArray, delta: float, tol: float) -> IntArray:  # pragma: no cover
    n = dist.shape[0]
    out = np.empty((max(n - 1, 0), 2), dtype=np.int64)
    k = 0
    for i in range(n - 1):
        di = dist[i]
        # g(j) = (dist[j] - dist[i]) - delta is non-decreasing in j: first j with g >= 0
        lo = i + 1
        hi = n
        while lo < hi:
            mid = (lo + hi) // 2
            if (dist[mid] - di) - delta >= 0.0:
                hi = mid
            else:
                lo = mid + 1
        best = -1
        best_val = 0.0
        if lo > i + 1:
            j0 = lo - 1
            g0 = (dist[j0] - di) - delta
            # first index with the same value (argmin takes the first minimum)
            a = i + 1
            b = j0
            while a < b:
                mid = (a + b) // 2
                if (dist[mid] - di) - delta >= g0:
                    b = mid
                else:
                    a = mid + 1
            best = a
            best_val = abs(g0)
        if lo < n:
            g1 = (dist[lo] - di) - delta
            if best < 0 or abs(g1) < best_val:
                best = lo
                best_val = abs(g1)
        if best_val > tol:
            continue
        out[k, 0] = i
        out[k, 1] = best
        k += 1
    return out[:k]
