"""Evaluation of trajectory files larger than memory: the numbers of :func:`evaluate`, in chunks.

:func:`evaluate_files` reads the reference and the estimate ``chunk_rows`` rows at a time and
gives the :class:`~odolab.metrics.evaluate.Evaluation` that :func:`evaluate` gives on the whole
files (to rounding; tests: ``tests/scale/test_chunked_evaluate.py``). How each step streams:

* **Association** (nearest stamp, or interpolation): a merge-like walk. A first pass counts each
  file's poses and finds its first and last stamp (which one is shorter decides the direction of
  the match, as in evo; the time ranges must overlap). The second walks the shorter file's chunks
  and keeps, of the longer one, only the poses around the stamps being matched (from the last one
  at or before them to the first one after them), so the pairs are those of one whole-file match.
* **Alignment**: ``origin`` takes the first associated pair; ``se2`` needs the means and the
  cross moments of the associated positions, summed chunk by chunk (merged as Chan et al. do, so
  no precision is lost to far-off coordinates) in one more pass before the errors.
* **RPE pairs and drift segments** carry across chunk boundaries what their rule needs: the last
  pose chosen (consecutive pairs, by frames or by path length, the path length since it included),
  the last ``delta`` poses (all pairs by frames), or the poses within ``delta`` metres of path
  from the end (all pairs by path length: memory grows with the poses in ``delta`` metres).
* **Statistics**: rmse, mean, std (merged per chunk), min and max stream exactly. The **median**
  needs every value: each error array (8 bytes a pose) goes to an unnamed temporary file, and the
  median is selected exactly from it by its bits (a radix selection, four passes over the file
  per middle value, one chunk in memory at a time). Memory stays bounded by the chunk; the disk
  holds 8 bytes per pose and per statistic (APE and RPE, translation and rotation) until the
  call returns.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray as F64
from odolab.core.arrays import IntArray as I64
from odolab.core.errors import InsufficientDataError, LogFormatError, opt
from odolab.core.kinematics import wrap_angle
from odolab.core.progress import Progress, no_progress
from odolab.core.trajectory import Trajectory
from odolab.io.chunked import DEFAULT_CHUNK_ROWS, iter_trajectory_chunks
from odolab.metrics.alignment import (
    Alignment,
    Rigid2D,
    align,
    rigid_from_moments,
    transform_trajectory,
)
from odolab.metrics.association import SyncMethod, interpolate_trajectory, matching_time_indices
from odolab.metrics.evaluate import (
    Drift,
    Evaluation,
    EvaluationOptions,
    _check_turn_segment,
    rpe_undefined_note,
)
from odolab.metrics.pose_error import (
    ANGLE_UNITS,
    DeltaUnit,
    Stats,
    all_pairs_by_path,
    ape_rotation,
    ape_translation,
    consecutive_by_path_from,
    consecutive_by_steps_from,
    delta_in_si,
    rpe_errors,
    turn_distances,
)

__all__ = ["ErrorStats", "evaluate_files", "exact_median_from_file"]

Pair = tuple[Trajectory, Trajectory]


def _cat(a: Trajectory | None, b: Trajectory) -> Trajectory:
    if a is None or len(a) == 0:
        return b
    return Trajectory(
        np.concatenate((a.t, b.t)),
        np.concatenate((a.x, b.x)),
        np.concatenate((a.y, b.y)),
        np.concatenate((a.theta, b.theta)),
        np.concatenate((a.heading, b.heading)),
    )


# -- statistics ----------------------------------------------------------------------------------

_SIGN = np.uint64(1 << 63)


def _keys(values: F64) -> NDArray[np.uint64]:
    """Unsigned integers in the order of the doubles (negative ones bit-flipped)."""
    bits = np.ascontiguousarray(values, dtype=np.float64).view(np.uint64)
    return np.where(bits & _SIGN, ~bits, bits | _SIGN)


def _value(key: int) -> float:
    k = np.uint64(key)
    bits = k & ~_SIGN if k & _SIGN else ~k
    return float(np.array([bits], dtype=np.uint64).view(np.float64)[0])


def _select(fh: IO[bytes], n: int, rank: int, block: int) -> float:
    """The ``rank``-th smallest (from 0) of the ``n`` doubles in ``fh``: by 16 bits of the
    order-preserving key per pass, counting the keys that share the bits found so far."""
    prefix = 0
    for shift in (48, 32, 16, 0):
        counts = np.zeros(1 << 16, dtype=np.int64)
        fh.seek(0)
        left = n
        while left > 0:
            vals = np.fromfile(fh, dtype=np.float64, count=min(block, left))
            left -= vals.size
            keys = _keys(vals)
            if shift < 48:
                keys = keys[(keys >> np.uint64(shift + 16)) == np.uint64(prefix)]
            counts += np.bincount(
                ((keys >> np.uint64(shift)) & np.uint64(0xFFFF)).astype(np.int64),
                minlength=1 << 16,
            )
        cum = np.cumsum(counts)
        digit = int(np.searchsorted(cum, rank, side="right"))
        rank -= int(cum[digit - 1]) if digit else 0
        prefix = (prefix << 16) | digit
    return _value(prefix)


def exact_median_from_file(fh: IO[bytes], n: int, *, block: int = DEFAULT_CHUNK_ROWS) -> float:
    """``numpy.median`` of the ``n`` doubles written (``tofile``) to ``fh``, with ``block`` of
    them in memory at a time: the middle value, or the mean of the two middle values.

    Raises:
        InsufficientDataError: there are no values.
    """
    if n < 1:
        raise InsufficientDataError("no values to take the median of")
    hi = _select(fh, n, n // 2, block)
    if n % 2:
        return hi
    lo = _select(fh, n, n // 2 - 1, block)
    return float(np.mean(np.array([lo, hi])))


class ErrorStats:
    """:func:`~odolab.metrics.pose_error.stats_from_errors` of an error array fed in chunks.

    rmse, mean and std (population) from per-chunk sums and centred moments merged exactly as
    Chan et al.; min and max; the median exactly, from the values kept in an unnamed temporary
    file (8 bytes each; :func:`exact_median_from_file`). Use as a context manager (the file is
    closed at the end).
    """

    def __init__(self, what: str = "errors", *, block: int = DEFAULT_CHUNK_ROWS) -> None:
        self.what = what
        self.block = block
        self.n = 0
        self._mean = 0.0
        self._m2 = 0.0  # sum of squared deviations from the mean
        self._sq = 0.0  # sum of squares
        self._min = math.inf
        self._max = -math.inf
        self._file: IO[bytes] | None = None

    def __enter__(self) -> ErrorStats:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Delete the kept values."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def add(self, errors: F64) -> None:
        """Feed the next errors (shape (k,))."""
        e = np.asarray(errors, dtype=np.float64)
        k = int(e.size)
        if k == 0:
            return
        if self._file is None:
            self._file = tempfile.TemporaryFile(prefix="odolab-errors-")  # noqa: SIM115 (closed by close())
        e.tofile(self._file)
        mean_k = float(np.mean(e))
        m2_k = float(np.sum((e - mean_k) ** 2))
        n = self.n + k
        delta = mean_k - self._mean
        self._mean += delta * k / n
        self._m2 += m2_k + delta * delta * self.n * k / n
        self._sq += float(np.sum(e * e))
        self._min = min(self._min, float(np.min(e)))
        self._max = max(self._max, float(np.max(e)))
        self.n = n

    def stats(self) -> Stats:
        """The statistics of everything fed so far."""
        if self.n == 0 or self._file is None:
            raise InsufficientDataError(f"no {self.what} to summarise")
        self._file.flush()
        return Stats(
            rmse=math.sqrt(self._sq / self.n),
            mean=self._mean,
            median=exact_median_from_file(self._file, self.n, block=self.block),
            std=math.sqrt(max(self._m2, 0.0) / self.n),
            min=self._min,
            max=self._max,
            n=self.n,
        )


# -- association -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Span:
    """What the first pass finds in a trajectory file."""

    n: int
    t0: float
    t1: float


class _Source:
    """A trajectory file read again for each pass; reports rows read to ``progress``."""

    def __init__(self, path: Path, chunk_rows: int, tick: Callable[[int, str], None]) -> None:
        self.path = path
        self.chunk_rows = chunk_rows
        self.tick = tick

    def chunks(self) -> Iterator[Trajectory]:
        for chunk in iter_trajectory_chunks(self.path, chunk_rows=self.chunk_rows):
            self.tick(len(chunk), self.path.name)
            yield chunk

    def span(self) -> _Span:
        n, t0, t1 = 0, math.nan, math.nan
        for chunk in self.chunks():
            if n == 0:
                t0 = float(chunk.t[0])
            n += len(chunk)
            t1 = float(chunk.t[-1])
        return _Span(n, t0, t1)


@dataclass(frozen=True)
class _Plan:
    """Which file drives the walk (the shorter, as in evo) and how its stamps are shifted."""

    short: _Source
    long: _Source
    shift: float
    second_longer: bool
    method: SyncMethod
    max_diff: float


def _plan(
    ref: _Source, est: _Source, o: EvaluationOptions, names: tuple[str, str]
) -> tuple[_Plan, _Span, _Span]:
    """The checks of :func:`~odolab.metrics.association.associate` (``max_diff`` is checked
    before), from the first pass over both files."""
    m = SyncMethod(o.sync)
    spans = (ref.span(), est.span())
    for name, sp in zip(names, spans, strict=True):
        if sp.n == 0:
            raise InsufficientDataError(f"{name} has no poses")
    rs, es = spans
    r0, r1 = rs.t0, rs.t1
    e0, e1 = es.t0 + o.offset, es.t1 + o.offset
    if e0 > r1 + o.max_diff or r0 > e1 + o.max_diff:
        raise InsufficientDataError(
            f"{names[0]} ({r0:.6g}..{r1:.6g} s) and {names[1]} ({e0:.6g}..{e1:.6g} s) do not "
            f"overlap in time; expected time ranges that overlap (within {o.max_diff:g} s)"
        )
    second_longer = es.n > rs.n
    short, long_ = (ref, est) if second_longer else (est, ref)
    shift = o.offset if second_longer else -o.offset
    return _Plan(short, long_, shift, second_longer, m, o.max_diff), rs, es


def _associated(plan: _Plan, names: tuple[str, str]) -> Iterator[Pair]:
    """``(reference, estimate)`` chunks of associated poses, as one whole-file association.

    The longer file's poses are kept from the last one at or before the next stamp to match
    (shifted stamps ``t + shift``; for interpolation, the last one before ``stamp - shift``) to
    the first one after the stamps matched now: the nearest-stamp search and the interpolation
    see the neighbours that they would see in the whole file.
    """
    shift, max_diff = plan.shift, plan.max_diff
    interp = plan.method is SyncMethod.INTERPOLATE
    longs = plan.long.chunks()
    buf: Trajectory | None = None
    done = False  # the longer file is read to its end
    matched = 0

    def trim(buf: Trajectory, st: float) -> Trajectory:
        """Drop the poses that no stamp from ``st`` on can need."""
        k1 = int(np.searchsorted(buf.t + shift, st, side="right")) - 1
        k2 = int(np.searchsorted(buf.t, st - shift, side="left")) - 1
        k = max(0, min(k1, k2, len(buf) - 2))  # two kept: interpolation past the end needs them
        return buf[k:] if k else buf

    for sc in plan.short.chunks():
        pos = 0
        while pos < len(sc):
            st = float(sc.t[pos])
            while not done and (
                buf is None
                or len(buf) < 2
                or not (float(buf.t[-1]) + shift > st and float(buf.t[-1]) >= st - shift)
            ):
                nxt = next(longs, None)
                if nxt is None:
                    done = True
                    break
                buf = trim(_cat(buf, nxt), st)
            assert buf is not None  # the first pass found poses in both
            if done:
                end = len(sc)
            else:  # the stamps that the poses kept cover: a later pose of the longer file each
                last = float(buf.t[-1])
                end = min(
                    int(np.searchsorted(sc.t, last + shift, side="left")),
                    int(np.searchsorted(sc.t - shift, last, side="right")),
                )
                end = max(end, pos + 1)
            part = sc[pos:end]
            i_short, i_long = matching_time_indices(part.t, buf.t + shift, max_diff)
            if i_short.size:
                short_m = part[i_short]
                long_m = interpolate_trajectory(buf, short_m.t - shift) if interp else buf[i_long]
                matched += i_short.size
                yield (short_m, long_m) if plan.second_longer else (long_m, short_m)
            buf = trim(buf, float(part.t[-1]))
            pos = end
    if matched == 0:
        raise InsufficientDataError(
            f"no stamp of {names[0]} has a stamp of {names[1]} within {max_diff:g} s; expected "
            "matching stamps (raise max_diff, or use interpolation)"
        )


# -- alignment -----------------------------------------------------------------------------------


class _Moments:
    """Means, cross moments and summed squares of associated positions, merged chunk by chunk
    (Chan et al.)."""

    def __init__(self) -> None:
        self.n = 0
        self.me = np.zeros(2)
        self.mr = np.zeros(2)
        self.s = np.zeros((2, 2))  # s[a, b] = sum (est_a - me_a) (ref_b - mr_b)
        self.ee = 0.0  # sum |est - me|^2
        self.rr = 0.0  # sum |ref - mr|^2
        self.scale = 0.0  # the largest |coordinate| of either

    def add(self, ref: Trajectory, est: Trajectory) -> None:
        k = len(ref)
        if k == 0:
            return
        e = np.column_stack((est.x, est.y))
        r = np.column_stack((ref.x, ref.y))
        me_k, mr_k = e.mean(axis=0), r.mean(axis=0)
        ce, cr = e - me_k, r - mr_k
        n = self.n + k
        de, dr = me_k - self.me, mr_k - self.mr
        w = self.n * k / n
        self.s += ce.T @ cr + np.outer(de, dr) * w
        self.ee += float(np.sum(ce * ce)) + float(de @ de) * w
        self.rr += float(np.sum(cr * cr)) + float(dr @ dr) * w
        self.scale = max(self.scale, float(np.abs(e).max()), float(np.abs(r).max()))
        self.me += de * (k / n)
        self.mr += dr * (k / n)
        self.n = n

    def transform(self) -> Rigid2D:
        """:func:`~odolab.metrics.alignment.rigid_from_points` from the moments."""
        return rigid_from_moments(self.n, self.me, self.mr, self.s, self.ee, self.rr, self.scale)


# -- RPE pairs and drift segments ----------------------------------------------------------------


class _Pairs:
    """RPE errors over the pairs of :func:`~odolab.metrics.pose_error.pair_indices`, fed the
    associated (and aligned) chunks in order; the pairs are chosen on the reference
    (``on_reference``) or on the estimate. Each :meth:`feed` returns that chunk's errors
    ``(translation, rotation, path length of each pair on the choosing trajectory)``."""

    def __init__(
        self, delta: float, unit: DeltaUnit, all_pairs: bool, rel_tol: float, on_reference: bool
    ) -> None:
        if not (delta > 0 and math.isfinite(delta)):
            raise LogFormatError(f"delta must be a positive number, got {delta}")
        if unit is DeltaUnit.FRAMES and float(delta) != int(delta):
            raise LogFormatError(f"delta must be a whole number of frames, got {delta}")
        self.angle = unit in ANGLE_UNITS
        if self.angle and all_pairs:
            raise InsufficientDataError(
                f"RPE over all pairs by angle (delta {delta:g} {unit.value}) compares every pose "
                "with every later one; it needs both trajectories whole, not in chunks "
                "({{chunk_rows}} 0)"
            )
        self.delta = delta_in_si(delta, unit)
        self.unit = unit
        self.all_pairs = all_pairs
        self.tol = self.delta * rel_tol
        self.on_reference = on_reference
        self.rows = 0  # associated poses fed so far
        self.count = 0  # pairs so far
        self.length = 0.0  # path length of the choosing trajectory so far
        # poses carried to the next chunk (the last chosen one, or those still waiting for a
        # partner), with the path length at each
        self._ref: Trajectory | None = None
        self._est: Trajectory | None = None
        self._dist: F64 = np.zeros(0)
        self._prev: Trajectory | None = None  # the choosing trajectory's last pose so far
        self._current = 0.0  # path length since the last chosen pose (consecutive, metres)

    def feed(self, ref: Trajectory, est: Trajectory, final: bool = False) -> tuple[F64, F64, F64]:
        """The errors of the pairs complete with this chunk (``final``: the last chunk)."""
        if self.unit is DeltaUnit.FRAMES:
            out = self._frames(ref, est)
        else:
            chooser = ref if self.on_reference else est
            dist = self._distances(chooser)
            if self.all_pairs:
                out = self._all_by_path(ref, est, dist, final)
            else:
                out = self._consecutive_by_path(ref, est, chooser, dist)
            self._prev = chooser[-1:]
            self.length = float(dist[-1])
        self.rows += len(ref)
        self.count += out[0].size
        return out

    def _distances(self, chooser: Trajectory) -> F64:
        """Path length (or, by angle, angle turned) at each pose of the chunk:
        ``path_distances`` (``turn_distances``) of the whole trajectory."""
        if self.angle:
            return (
                self.length
                + turn_distances(_cat(self._prev, chooser))[(0 if self._prev is None else 1) :]
            )
        if self._prev is None:
            dx, dy = np.diff(chooser.x), np.diff(chooser.y)
            return np.concatenate((np.zeros(1), np.cumsum(np.sqrt(dx * dx + dy * dy))))
        dx = np.diff(np.concatenate((self._prev.x, chooser.x)))
        dy = np.diff(np.concatenate((self._prev.y, chooser.y)))
        steps = np.sqrt(dx * dx + dy * dy)
        return np.cumsum(np.concatenate(([self.length], steps)))[1:]

    def _pairs_of(
        self, r: Trajectory, e: Trajectory, dd: F64, i: I64, j: I64
    ) -> tuple[F64, F64, F64]:
        et, er = rpe_errors(r, e, i, j)
        return et, er, (dd[j] - dd[i]) if dd.size else np.zeros(i.size)

    def _chosen(
        self, ref: Trajectory, est: Trajectory, sel: I64, dist: F64
    ) -> tuple[F64, F64, F64]:
        """Pairs of consecutive chosen poses: the carried one, then ``sel`` of this chunk."""
        r, e = _cat(self._ref, ref[sel]), _cat(self._est, est[sel])
        dd = np.concatenate((self._dist, dist[sel])) if dist.size else dist
        i = np.arange(max(len(r) - 1, 0), dtype=np.int64)
        if len(r):
            self._ref, self._est, self._dist = r[-1:], e[-1:], dd[-1:]
        return self._pairs_of(r, e, dd, i, i + 1)

    def _frames(self, ref: Trajectory, est: Trajectory) -> tuple[F64, F64, F64]:
        d = int(self.delta)
        if self.all_pairs:  # (i, i + d): the last d poses wait for their partners
            r, e = _cat(self._ref, ref), _cat(self._est, est)
            cut = max(len(r) - d, 0)
            i = np.arange(cut, dtype=np.int64)
            self._ref, self._est = r[cut:], e[cut:]
            return self._pairs_of(r, e, np.zeros(0), i, i + d)
        first = -(-self.rows // d) * d - self.rows  # every d-th pose: 0, d, 2d ...
        return self._chosen(ref, est, np.arange(first, len(ref), d, dtype=np.int64), np.zeros(0))

    def _consecutive_by_path(
        self, ref: Trajectory, est: Trajectory, chooser: Trajectory, dist: F64
    ) -> tuple[F64, F64, F64]:
        if self.angle:  # the steps' angles (from the previous chunk's last pose, index 0)
            prev = self._prev
            first = prev is None
            h = chooser.heading if prev is None else np.concatenate((prev.heading, chooser.heading))
            steps = np.concatenate((np.zeros(1), np.abs(wrap_angle(np.diff(h)))))
            ids, self._current = consecutive_by_steps_from(steps, self.delta, self._current, first)
            return self._chosen(ref, est, ids if first else ids - 1, dist)
        if self._prev is None:  # the path's start is chosen
            sel, self._current = consecutive_by_path_from(
                chooser.x, chooser.y, self.delta, 0.0, True
            )
        else:  # after the previous chunk's last pose (index 0 here, never chosen again)
            ids, self._current = consecutive_by_path_from(
                np.concatenate((self._prev.x, chooser.x)),
                np.concatenate((self._prev.y, chooser.y)),
                self.delta,
                self._current,
                False,
            )
            sel = ids - 1
        return self._chosen(ref, est, sel, dist)

    def _all_by_path(
        self, ref: Trajectory, est: Trajectory, dist: F64, final: bool
    ) -> tuple[F64, F64, F64]:
        r, e = _cat(self._ref, ref), _cat(self._est, est)
        dd = np.concatenate((self._dist, dist))
        pairs = all_pairs_by_path(dd, self.delta, self.tol)
        i, j = pairs[:, 0].copy(), pairs[:, 1].copy()
        keep = len(r)
        if not final:  # a pose with no pose delta metres further on yet waits for the next chunk
            keep = int(np.argmax((dd[-1] - dd) - self.delta < 0.0))
            i, j = i[i < keep], j[i < keep]
        self._ref, self._est, self._dist = r[keep:], e[keep:], dd[keep:]
        return self._pairs_of(r, e, dd, i, j)


def _pairs_for(o: EvaluationOptions) -> _Pairs:
    return _Pairs(o.delta, DeltaUnit(o.delta_unit), o.all_pairs, o.rel_tol, o.pairs_from_reference)


# -- the whole evaluation ------------------------------------------------------------------------


def _checked_pairs(o: EvaluationOptions) -> tuple[_Pairs, _Pairs, _Pairs]:
    """The options checked; the RPE pairs, the drift's segments and the turn's pieces."""
    if not (o.max_diff >= 0.0 and np.isfinite(o.max_diff)):
        raise LogFormatError(f"max_diff must be a non-negative number of seconds, got {o.max_diff}")
    pairs = _pairs_for(o)
    if not (o.drift_delta_m > 0 and math.isfinite(o.drift_delta_m)):
        raise LogFormatError(
            f"drift segment must be a positive length in m ({opt('drift_segment')}), got {o.drift_delta_m}"
        )
    drift = _Pairs(o.drift_delta_m, DeltaUnit.METRES, False, 0.1, True)
    _check_turn_segment(o.drift_turn_rad)
    turn = _Pairs(o.drift_turn_rad, DeltaUnit.RADIANS, False, 0.1, True)
    return pairs, drift, turn


def _consume(
    pairs: _Pairs,
    drift: _Pairs,
    turn: _Pairs,
    rpe: ErrorStats,
    rpe_rot: ErrorStats,
    sums: NDArray[np.float64],
    r: Trajectory,
    e: Trajectory,
    final: bool,
) -> None:
    """One chunk's relative errors into ``rpe``, ``rpe_rot`` and the drift ``sums``: the sum
    of % per segment, of deg/m per segment, segments, of % of the angle turned per piece, pieces."""
    et, er, _ = pairs.feed(r, e, final)
    rpe.add(et)
    rpe_rot.add(er)
    dt, dr, seg = drift.feed(r, e, final)
    ok = seg > 0
    sums[0] += float(np.sum(100.0 * dt[ok] / seg[ok]))
    sums[1] += float(np.sum(np.degrees(dr[ok]) / seg[ok]))
    sums[2] += int(ok.sum())
    _, tr, turned = turn.feed(r, e, final)
    ok = turned > 0
    sums[3] += float(np.sum(100.0 * tr[ok] / turned[ok]))
    sums[4] += int(ok.sum())


def _se2_transform(plan: _Plan, labels: tuple[str, str]) -> Rigid2D:
    """The SE(2) alignment from one pass over the associated poses (their moments)."""
    moments = _Moments()
    for r, e in _associated(plan, labels):
        moments.add(r, e)
    return moments.transform()


def _drift(
    o: EvaluationOptions,
    drift: _Pairs,
    turn: _Pairs,
    sums: NDArray[np.float64],
    last: tuple[Trajectory, Trajectory],
) -> Drift:
    """The drift figures from the sums of :func:`_consume` and the last poses."""
    length = drift.length
    end_err = float(ape_translation(*last)[0])
    end_rot = float(ape_rotation(*last)[0])
    segments = int(sums[2]) if length > o.drift_delta_m else 0
    return Drift(
        translation_pct=sums[0] / segments if segments else math.nan,
        rotation_deg_per_m=sums[1] / segments if segments else math.nan,
        segment_m=float(o.drift_delta_m),
        segments=segments,
        endpoint_error=end_err,
        endpoint_heading_error=end_rot,
        path_length=length,
        endpoint_pct=100.0 * end_err / length if length > 0 else math.nan,
        turn=turn.length,
        turn_segment=float(o.drift_turn_rad),
        turn_segments=int(sums[4]),
        rotation_pct_of_turn=sums[3] / sums[4] if sums[4] else math.nan,
    )


# long: 22 lines of signature and docstring; the body is one pass over both files with its
# progress and cleanup
def evaluate_files(
    reference: str | Path,
    estimate: str | Path,
    options: EvaluationOptions | None = None,
    *,
    chunk_rows: int = DEFAULT_CHUNK_ROWS,
    names: tuple[str, str] | None = None,
    progress: Progress | None = None,
) -> Evaluation:
    """:func:`~odolab.metrics.evaluate.evaluate` of two trajectory files, ``chunk_rows`` rows
    in memory at a time (CSV, Parquet, Arrow IPC; TUM text is read whole).

    The same numbers as reading both files whole (to rounding; the median exactly). The files
    are read two times (``none``, ``origin`` alignment) or three (``se2``): a pass for the
    poses' count and time range, one for the alignment's moments, one for the errors.
    ``progress(rows read, rows to read, file name)`` is called after each chunk (the total is 0
    during the first pass, before the rows are counted).

    Raises:
        LogFormatError: the chunk size, the association's max_diff or the drift segment is out of
            range, or a file cannot be read.
    """
    if chunk_rows < 1 or int(chunk_rows) != chunk_rows:
        raise LogFormatError(f"chunk size is {chunk_rows!r}; expected a whole number of rows >= 1")
    o = options or EvaluationOptions()
    rp, ep = Path(reference), Path(estimate)
    labels = names or (str(rp), str(ep))
    report = progress or no_progress
    total = done = 0

    def tick(rows: int, name: str) -> None:
        nonlocal done
        done += rows
        report(done, total, name)

    pairs, drift, turn = _checked_pairs(o)  # every option before the first pass over the files
    alignment = Alignment(o.alignment)
    ref, est = _Source(rp, chunk_rows, tick), _Source(ep, chunk_rows, tick)
    plan, rs, es = _plan(ref, est, o, labels)
    passes = 2 if alignment is Alignment.SE2 else 1
    total = done + passes * (rs.n + es.n)
    tf = _se2_transform(plan, labels) if alignment is Alignment.SE2 else Rigid2D(0.0, 0.0, 0.0)
    with (
        ErrorStats("APE", block=max(chunk_rows, 1 << 16)) as ape,
        ErrorStats("APE", block=max(chunk_rows, 1 << 16)) as ape_rot,
        ErrorStats("RPE", block=max(chunk_rows, 1 << 16)) as rpe,
        ErrorStats("RPE", block=max(chunk_rows, 1 << 16)) as rpe_rot,
    ):
        sums = np.zeros(5)  # drift: sum of % per segment, of deg/m per segment, segments,
        # of % of the angle turned per piece, pieces
        n = 0
        last: Pair | None = None
        pending: Pair | None = None  # one chunk behind: the last chunk is fed as final

        for r, e in _associated(plan, labels):
            if alignment is Alignment.ORIGIN and n == 0:
                tf = align(r[:1], e[:1], Alignment.ORIGIN)[1]
            if alignment is not Alignment.NONE:
                e = transform_trajectory(e, tf)
            ape.add(ape_translation(r, e))
            ape_rot.add(ape_rotation(r, e))
            if pending is not None:
                _consume(pairs, drift, turn, rpe, rpe_rot, sums, *pending, False)
            pending = (r, e)
            n += len(r)
            last = (r[-1:], e[-1:])
        assert pending is not None and last is not None  # _associated raised otherwise
        _consume(pairs, drift, turn, rpe, rpe_rot, sums, *pending, True)
        note = ""
        if pairs.count == 0:
            which = "the reference" if o.pairs_from_reference else "the estimate"
            note = rpe_undefined_note(o, n, which, pairs.length)
        result = Evaluation(
            ape=ape.stats(),
            ape_rot=ape_rot.stats(),
            rpe=rpe.stats() if pairs.count else Stats.undefined(),
            rpe_rot=rpe_rot.stats() if pairs.count else Stats.undefined(),
            drift=_drift(o, drift, turn, sums, last),
            pairs=n,
            transform=tf,
            options=o,
            rpe_note=note,
        )
    return result
