"""Absolute and relative pose errors (APE, RPE) with evo's definitions, vectorized, planar.

For poses ``Q`` (reference) and ``P`` (estimate) as planar SE(3) elements:

* APE: ``E_i = P_i^-1 Q_i``; translation part ``|p_i - q_i|``, rotation part the angle of
  ``E_i`` = ``|wrap(heading_ref - heading_est)|`` in [0, pi].
* RPE: ``E_ij = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)`` over index pairs (i, j); translation part
  ``|R(P_i)^T (p_j - p_i) - R(Q_i)^T (q_j - q_i)|``, rotation part
  ``|wrap((h_Pj - h_Pi) - (h_Qj - h_Qi))|``.

The index pairs are chosen as ``evo.core.filters`` does: by frames, every ``delta``-th pose
(consecutive) or every ``(i, i + delta)`` (all pairs); by metres, a new pose each time the path
length since the previous one reaches ``delta`` (consecutive), or for every ``i`` the ``j`` whose
path length from ``i`` is nearest ``delta``, kept if within ``rel_tol * delta`` (all pairs); by
angle (degrees or radians, evo's ``--delta_unit d``/``r``), a new pose each time the heading
turned since the previous one (the sum of the steps' ``|wrap(dh)|``) reaches ``delta``
(consecutive), or every ``(i, j)``, ``j > i``, whose direct angle ``|wrap(h_j - h_i)|`` is within
``rel_tol * delta`` of ``delta`` (all pairs). Angle pairs suit runs that turn in place, where a
step in metres finds no pairs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from odolab.core.arrays import FloatArray, IntArray
from odolab.core.defaults import DeltaUnit  # its home is odolab.core.defaults; re-exported here
from odolab.core.errors import InsufficientDataError, LogFormatError
from odolab.core.kinematics import wrap_angle
from odolab.core.trajectory import Trajectory

__all__ = [
    "ANGLE_UNITS",
    "DeltaUnit",
    "Stats",
    "ape_rotation",
    "ape_translation",
    "delta_in_si",
    "median",
    "pair_indices",
    "path_distances",
    "rpe_errors",
    "stats_from_errors",
    "turn_distances",
]


#: The units that choose pairs by the angle turned.
ANGLE_UNITS = frozenset({DeltaUnit.DEGREES, DeltaUnit.RADIANS})


def delta_in_si(delta: float, unit: DeltaUnit | str) -> float:
    """``delta`` in the library's units: frames, metres, or radians for an angle unit."""
    return math.radians(delta) if DeltaUnit(unit) is DeltaUnit.DEGREES else float(delta)


@dataclass(frozen=True)
class Stats:
    """Summary of an error array: rmse, mean, median, std (population), min, max, and n."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    n: int

    @classmethod
    def undefined(cls) -> Stats:
        """The statistics of no errors (n = 0, every value NaN): a quantity that is undefined."""
        nan = math.nan
        return cls(rmse=nan, mean=nan, median=nan, std=nan, min=nan, max=nan, n=0)

    @property
    def defined(self) -> bool:
        """Whether there were errors to summarise."""
        return self.n > 0

    def to_dict(self) -> dict[str, float | int]:
        """Plain dict for JSON."""
        return asdict(self)


def median(values: FloatArray) -> float:
    """``np.median`` of a 1-D float array (``nan`` when it holds a NaN), without ``np.median``'s
    import of ``numpy.ma`` (16 ms of every ``odolab evaluate``): the middle value, or the mean
    of the two middle values, as ``np.median`` computes it.

    Raises:
        InsufficientDataError: the array is empty."""
    e = np.asarray(values, dtype=np.float64).ravel()
    n = e.size
    if n == 0:
        raise InsufficientDataError("no values to take the median of")
    if np.isnan(e).any():
        return math.nan
    k = n // 2
    if n % 2:
        return float(np.partition(e, k)[k])
    part = np.partition(e, (k - 1, k))
    return float(np.mean(part[k - 1 : k + 1]))


def stats_from_errors(errors: FloatArray, what: str = "errors") -> Stats:
    """Statistics of ``errors`` (shape (n,), n >= 1) as evo computes them.

    Raises:
        InsufficientDataError: there are no errors to summarise.
    """
    e = np.asarray(errors, dtype=np.float64)
    if e.size == 0:
        raise InsufficientDataError(f"no {what} to summarise")
    return Stats(
        rmse=math.sqrt(float(np.mean(e * e))),
        mean=float(np.mean(e)),
        median=median(e),
        std=float(np.std(e)),
        min=float(np.min(e)),
        max=float(np.max(e)),
        n=int(e.size),
    )


def _check_same_length(reference: Trajectory, estimate: Trajectory) -> None:
    if len(reference) != len(estimate):
        raise LogFormatError(
            f"reference has {len(reference)} poses and estimate {len(estimate)}; associate them "
            "first (expected equal lengths)"
        )


def ape_translation(reference: Trajectory, estimate: Trajectory) -> FloatArray:
    """Position error per pose (m), shape (n,)."""
    _check_same_length(reference, estimate)
    dx = estimate.x - reference.x
    dy = estimate.y - reference.y
    return np.sqrt(dx * dx + dy * dy)


def ape_rotation(reference: Trajectory, estimate: Trajectory) -> FloatArray:
    """Heading error angle per pose (rad, in [0, pi]), shape (n,)."""
    _check_same_length(reference, estimate)
    return np.abs(wrap_angle(reference.heading - estimate.heading))


def path_distances(traj: Trajectory) -> FloatArray:
    """Accumulated path length at each pose (m), shape (n,), starting at 0."""
    dx = np.diff(traj.x)
    dy = np.diff(traj.y)
    return np.concatenate((np.zeros(1), np.cumsum(np.sqrt(dx * dx + dy * dy))))


def turn_distances(traj: Trajectory) -> FloatArray:
    """Accumulated angle turned at each pose (rad), shape (n,), starting at 0: the sum of the
    steps' ``|wrap(heading_k - heading_k-1)|`` (evo's consecutive angle steps)."""
    return np.concatenate((np.zeros(1), np.cumsum(np.abs(wrap_angle(np.diff(traj.heading))))))


def consecutive_by_steps_from(
    steps: FloatArray, delta: float, current: float, first: bool
) -> tuple[IntArray, float]:
    """:func:`consecutive_by_path_from` with the step sizes given: ``steps[i]`` is the amount
    (an angle turned) from pose ``i - 1`` to pose ``i`` (``steps[0]`` is not used).

    Compiled (:mod:`odolab.metrics._pairs_jit`, loaded on the first call)."""
    from odolab.metrics import _pairs_jit

    return _pairs_jit.consecutive_by_steps_from(steps, delta, current, first)


def all_pairs_by_angle(heading: FloatArray, delta: float, tol: float) -> IntArray:
    """Every ``(i, j)``, ``j > i``, with ``|wrap(heading[j] - heading[i]) - delta| <= tol``, in
    the order of ``i`` then ``j`` (evo's all pairs by angle; O(n^2), as evo's).

    Compiled (:mod:`odolab.metrics._pairs_jit`, loaded on the first call)."""
    from odolab.metrics import _pairs_jit

    return _pairs_jit.all_pairs_by_angle(heading, delta, tol)


def consecutive_by_path_from(
    x: FloatArray, y: FloatArray, delta: float, current: float, first: bool
) -> tuple[IntArray, float]:
    """Indexes where the path length since the previous chosen index reaches ``delta``.

    ``current``: path length since the previous chosen index before ``x[0]``; ``first``: index
    0 is the path's start (chosen). Chunk by chunk, pass the previous chunk's last position
    as ``x[0], y[0]`` with ``first=False`` and the ``current`` it returned: the same indexes
    as one call over the whole path. Returns the indexes and the new ``current``.

    Compiled (:mod:`odolab.metrics._pairs_jit`, loaded on the first call)."""
    from odolab.metrics import _pairs_jit

    return _pairs_jit.consecutive_by_path_from(x, y, delta, current, first)


#: Above this many pairs expected, :func:`_consecutive` leaves the path to the compiled loop.
_NUMPY_PAIRS_MAX = 20_000


def _consecutive(steps: FloatArray, delta: float) -> IntArray | None:
    """:func:`consecutive_by_steps_from` from pose 0, in numpy (``steps[k]``: from pose ``k``
    to ``k + 1``); loading a compiled kernel (numba's CPU target, which imports scipy.linalg)
    was half a second of ``odolab evaluate``. Each stretch's running sum is ``np.cumsum`` of its
    steps: the kernel's additions, in its order, from 0.0, so the kernel's indexes. One call
    per pair: None where more than :data:`_NUMPY_PAIRS_MAX` are expected (the kernel's turn)."""
    n = steps.shape[0] + 1
    if not float(np.sum(steps)) / delta <= _NUMPY_PAIRS_MAX:  # (also: nan, inf)
        return None
    ids = [0]
    start = 0  # the stretch starts at pose ``start``: its steps are steps[start:]
    window = 256
    while start < n - 1:
        run = np.cumsum(steps[start : start + window])
        k = int(np.searchsorted(run, delta, side="left"))  # first running sum >= delta
        if k < run.size:
            start += k + 1
            ids.append(start)
            window = max(64, 2 * (k + 1))
        elif start + window >= n - 1:
            break
        else:
            window *= 4
    return np.asarray(ids, dtype=np.int64)


def _consecutive_by_path(x: FloatArray, y: FloatArray, delta: float) -> IntArray:
    if x.shape[0] < 2:
        return np.zeros(x.shape[0], dtype=np.int64)
    dx = np.diff(x)
    dy = np.diff(y)
    ids = _consecutive(np.sqrt(dx * dx + dy * dy), delta)  # the kernel's steps
    return consecutive_by_path_from(x, y, delta, 0.0, True)[0] if ids is None else ids


def all_pairs_by_path(dist: FloatArray, delta: float, tol: float) -> IntArray:
    """For every ``i``, the ``(i, j)`` whose path length ``dist[j] - dist[i]`` is nearest
    ``delta`` (the first such ``j``), kept when within ``tol`` of it (evo's all pairs by metres);
    shape (k, 2).

    Compiled (:mod:`odolab.metrics._pairs_jit`, loaded on the first call)."""
    from odolab.metrics import _pairs_jit

    return _pairs_jit.all_pairs_by_path(dist, delta, tol)


def pair_indices(
    traj: Trajectory,
    delta: float,
    unit: DeltaUnit | str = DeltaUnit.FRAMES,
    *,
    all_pairs: bool = False,
    rel_tol: float = 0.1,
    allow_empty: bool = False,
) -> tuple[IntArray, IntArray]:
    """Index pairs ``(i, j)`` (two arrays of shape (k,)) for RPE, chosen on ``traj`` as evo does.

    No pairs raise :class:`InsufficientDataError`, unless ``allow_empty``.

    Raises:
        LogFormatError: delta is not positive (or, in frames, not whole).
        InsufficientDataError: delta gives no pose pairs.
    """
    u = DeltaUnit(unit)
    n = len(traj)
    if not (delta > 0 and math.isfinite(delta)):
        raise LogFormatError(f"delta must be a positive number, got {delta}")
    if u is DeltaUnit.FRAMES:
        if float(delta) != int(delta):
            raise LogFormatError(f"delta must be a whole number of frames, got {delta}")
        d = int(delta)
        if all_pairs:
            i = np.arange(max(n - d, 0), dtype=np.int64)
            j = i + d
        else:
            ids = np.arange(0, n, d, dtype=np.int64)
            i, j = ids[:-1], ids[1:]
    elif u in ANGLE_UNITS:
        rad = delta_in_si(delta, u)
        if all_pairs:
            pairs = all_pairs_by_angle(traj.heading, rad, rad * rel_tol)
            i, j = pairs[:, 0].copy(), pairs[:, 1].copy()
        else:
            steps = np.concatenate((np.zeros(1), np.abs(wrap_angle(np.diff(traj.heading)))))
            found = _consecutive(steps[1:], rad) if n > 1 else None
            ids = consecutive_by_steps_from(steps, rad, 0.0, True)[0] if found is None else found
            i, j = ids[:-1], ids[1:]
    elif all_pairs:
        pairs = all_pairs_by_path(path_distances(traj), float(delta), float(delta) * rel_tol)
        i, j = pairs[:, 0].copy(), pairs[:, 1].copy()
    else:
        ids = _consecutive_by_path(traj.x, traj.y, float(delta))
        i, j = ids[:-1], ids[1:]
    if i.size == 0 and not allow_empty:
        raise InsufficientDataError(
            f"delta = {delta:g} {u.value} gives no pose pairs on {n} poses; "
            "expected a smaller delta"
        )
    return i, j


def rpe_errors(
    reference: Trajectory, estimate: Trajectory, i: IntArray, j: IntArray
) -> tuple[FloatArray, FloatArray]:
    """RPE translation (m) and rotation (rad) errors over pairs ``(i, j)``, shapes (k,) each."""
    _check_same_length(reference, estimate)

    def rel(tr: Trajectory) -> tuple[FloatArray, FloatArray, FloatArray]:
        c, s = np.cos(tr.heading[i]), np.sin(tr.heading[i])
        dx = tr.x[j] - tr.x[i]
        dy = tr.y[j] - tr.y[i]
        return c * dx + s * dy, -s * dx + c * dy, tr.heading[j] - tr.heading[i]

    qx, qy, qh = rel(reference)
    px, py, ph = rel(estimate)
    ex = px - qx
    ey = py - qy
    return np.sqrt(ex * ex + ey * ey), np.abs(wrap_angle(ph - qh))
