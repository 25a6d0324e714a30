"""Association of two trajectories by time: nearest stamp within a tolerance, or interpolation.

Both methods pick the same pairs as evo's ``associate_trajectories``: the trajectory with fewer
poses keeps those of its poses that have a stamp of the other within ``max_diff`` seconds; with
``interpolation`` the other trajectory is then resampled (positions linearly, heading linearly
along the shortest arc, i.e. slerp about z) exactly at those stamps instead of snapping to its
nearest pose.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from odolab.core.defaults import SyncMethod  # its home is odolab.core.defaults; re-exported here
from odolab.core.errors import InsufficientDataError, LogFormatError
from odolab.core.trajectory import Trajectory

__all__ = ["SyncMethod", "associate", "interpolate_trajectory", "matching_time_indices"]


def matching_time_indices(
    stamps_1: NDArray[np.float64], stamps_2: NDArray[np.float64], max_diff: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Indexes ``(i1, i2)`` of stamps of 1 with their nearest stamp of 2 within ``max_diff``.

    ``stamps_1`` shape (n,), ``stamps_2`` shape (m,), non-decreasing. On a tie between the stamp
    before and after, the earlier one wins (as in evo).
    """
    s1 = np.asarray(stamps_1, dtype=np.float64)
    s2 = np.asarray(stamps_2, dtype=np.float64)
    if s1.size == 0 or s2.size == 0:
        empty = np.empty(0, dtype=np.int64)
        return empty, empty
    inside = (s1 >= s2[0] - max_diff) & (s1 <= s2[-1] + max_diff)
    idx1 = np.flatnonzero(inside)
    st = s1[idx1]
    up = np.minimum(np.searchsorted(s2, st, side="right"), s2.size - 1)
    diff_ub = s2[up] - st
    diff_lb = np.where(up > 0, st - s2[np.maximum(up - 1, 0)], np.inf)
    take_ub = (diff_ub <= max_diff) & (diff_ub < diff_lb)
    take_lb = ~take_ub & (diff_lb <= max_diff) & (diff_lb <= diff_ub)
    keep = take_ub | take_lb
    idx2 = np.where(take_ub, up, up - 1)
    return idx1[keep].astype(np.int64), idx2[keep].astype(np.int64)


def interpolate_trajectory(traj: Trajectory, t: NDArray[np.float64]) -> Trajectory:
    """Poses of ``traj`` at times ``t`` (shape (k,)), clamped to its first and last pose.

    Positions are interpolated linearly and the unwrapped heading linearly (for steps under pi,
    the same as slerp of the rotation about z).

    Raises:
        InsufficientDataError: the trajectory has fewer than two poses.
    """
    if len(traj) < 2:
        raise InsufficientDataError("cannot interpolate a trajectory with fewer than two poses")
    tq = np.asarray(t, dtype=np.float64)
    idx = np.clip(np.searchsorted(traj.t, tq, side="left"), 1, len(traj) - 1)
    t0 = traj.t[idx - 1]
    dt = traj.t[idx] - t0
    frac = np.where(dt > 0.0, (tq - t0) / np.where(dt > 0.0, dt, 1.0), 0.0)
    frac = np.clip(frac, 0.0, 1.0)

    def lerp(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return a[idx - 1] + frac * (a[idx] - a[idx - 1])

    return Trajectory.from_xyh(tq, lerp(traj.x), lerp(traj.y), lerp(traj.heading))


def associate(
    reference: Trajectory,
    estimate: Trajectory,
    *,
    method: SyncMethod | str = SyncMethod.NEAREST,
    max_diff: float = 0.01,
    offset: float = 0.0,
    names: tuple[str, str] = ("reference", "estimate"),
) -> tuple[Trajectory, Trajectory]:
    """Pair the poses of two trajectories by time: ``(reference, estimate)`` of equal length.

    ``offset`` (s) is added to the estimate's stamps for the matching only. Raises
    :class:`InsufficientDataError` when the trajectories do not overlap in time, or when no stamp
    pairs within ``max_diff``.
    """
    m = SyncMethod(method)
    if not (max_diff >= 0.0 and np.isfinite(max_diff)):
        raise LogFormatError(f"max_diff must be a non-negative number of seconds, got {max_diff}")
    for name, tr in zip(names, (reference, estimate), strict=True):
        if len(tr) == 0:
            raise InsufficientDataError(f"{name} has no poses")
    r0, r1 = float(reference.t[0]), float(reference.t[-1])
    e0, e1 = float(estimate.t[0]) + offset, float(estimate.t[-1]) + offset
    if e0 > r1 + max_diff or r0 > e1 + max_diff:
        raise InsufficientDataError(
            f"{names[0]} ({r0:.6g}..{r1:.6g} s) and {names[1]} ({e0:.6g}..{e1:.6g} s) do not "
            f"overlap in time; expected time ranges that overlap (within {max_diff:g} s)"
        )
    second_longer = len(estimate) > len(reference)
    short, long_ = (reference, estimate) if second_longer else (estimate, reference)
    shift = offset if second_longer else -offset
    i_short, i_long = matching_time_indices(short.t, long_.t + shift, max_diff)
    if i_short.size == 0:
        raise InsufficientDataError(
            f"no stamp of {names[0]} has a stamp of {names[1]} within {max_diff:g} s; expected "
            "matching stamps (raise max_diff, or use interpolation)"
        )
    short_m = short[i_short]
    if m is SyncMethod.INTERPOLATE:
        long_m = interpolate_trajectory(long_, short_m.t - shift)
    else:
        long_m = long_[i_long]
    return (short_m, long_m) if second_longer else (long_m, short_m)
