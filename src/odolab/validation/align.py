"""Time alignment of a phone IMU log with a robot's odometry: find the clock offset.

The phone and the robot keep different clocks. ``clock_offset`` is what the phone's clock reads
minus what the robot's reads at the same instant (s): a phone sample at ``t_phone`` happened at
robot time ``t_phone - clock_offset``. It is found by cross-correlating the two yaw RATES (the
odometry's heading rate and the gyro's), resampled to a common grid, over the offsets allowed by
``nominal_offset +- max_offset``; the peak is refined to a fraction of a grid step by a parabola
through its three highest points. Rates, not headings, are compared: a heading has an arbitrary
zero and a scale error that grows with time, a rate only a scale error, which a correlation
ignores. Each offset is scored by the correlation normalised by the two rates' energies inside
the overlap (a cosine, exactly 1 where one rate is a multiple of the other): the plain,
zero-padded correlation would favour offsets that overlap more, which shifts its peak (by
seconds for a rotation at constant rate seen only in part by one log).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.errors import ImuLogError, opt
from odolab.io.sensorlog import ImuLog

__all__ = [
    "MAX_SMOOTH_S",
    "ClockAlignment",
    "check_search",
    "find_clock_offset",
    "rate_on_grid",
    "require_overlap",
]


@dataclass(frozen=True)
class ClockAlignment:
    """The clock offset found (s, phone minus robot), the peak rate correlation (-1..1; nan when
    the offset was fixed), the grid step (s), the overlap of the aligned logs on the robot clock
    (s) and the range of offsets searched (s)."""

    clock_offset: float
    correlation: float
    grid_step: float
    overlap_start: float
    overlap_end: float
    searched: tuple[float, float]


def rate_on_grid(t: FloatArray, heading: FloatArray, grid: FloatArray) -> FloatArray:
    """Heading rate (rad/s) at ``grid`` times from heading samples: finite differences at the
    mid-points of the samples, linearly interpolated. Shapes (n,), (n,), (m,) -> (m,)."""
    dt = np.diff(t)
    ok = dt > 0
    mid = 0.5 * (t[1:] + t[:-1])[ok]
    rate = np.diff(heading)[ok] / dt[ok]
    return np.asarray(np.interp(grid, mid, rate), dtype=np.float64)


def _imu_rate_on_grid(imu: ImuLog, grid_phone: FloatArray) -> FloatArray:
    if imu.yaw_rate is not None:
        return np.asarray(np.interp(grid_phone, imu.t, imu.yaw_rate), dtype=np.float64)
    return rate_on_grid(imu.t, imu.yaw, grid_phone)


def require_overlap(
    robot_t: FloatArray,
    imu: ImuLog,
    lo: float,
    hi: float,
    *,
    min_overlap: float,
    robot_source: str = "encoder log",
) -> None:
    """Raise :class:`ImuLogError` unless some clock offset in [lo, hi] (s) overlaps the logs by
    at least ``min_overlap`` seconds.

    Raises:
        ImuLogError: the IMU log does not overlap the robot's log, or the overlap is too short.
    """
    r0, r1 = float(robot_t[0]), float(robot_t[-1])
    p0, p1 = float(imu.t[0]), float(imu.t[-1])
    # a log shorter than the overlap: no offset can help, so say which one
    for name, span in ((f"the {robot_source}", r1 - r0), (f"{imu.source}: the IMU log", p1 - p0)):
        if span < min_overlap:
            raise ImuLogError(
                f"{name} lasts {span:g} s; expected at least {min_overlap:g} s of log to line "
                "the clocks up"
            )
    # on the robot clock the phone spans [p0 - off, p1 - off]; the best overlap over off in [lo, hi]
    best = 0.0
    for off in (lo, hi, p0 - r0, p1 - r1, p0 - r1 + min_overlap, p1 - r0 - min_overlap):
        o = min(max(off, lo), hi)
        best = max(best, min(r1, p1 - o) - max(r0, p0 - o))
    if best < min_overlap:
        if lo == hi:
            allowed = f"a clock offset of {lo:g} s (phone minus robot)"
        else:
            allowed = f"any clock offset from {lo:g} to {hi:g} s (phone minus robot)"
        raise ImuLogError(
            f"{imu.source}: the IMU log (phone time {p0:.3f} to {p1:.3f} s) does not overlap the "
            f"{robot_source} (robot time {r0:.3f} to {r1:.3f} s) by at least {min_overlap:g} s "
            f"for {allowed}; give the offset between the clocks ({opt('offset')}) or widen the search "
            "({{max_offset}})"
        )


#: Widest low-pass of the yaw rates (Gaussian sigma, s): wider blurs every start and stop of a
#: turn into the next, and its kernel (8 sigma on a millisecond grid) stops fitting in memory.
MAX_SMOOTH_S = 10.0


def check_search(nominal_offset: float, max_offset: float, smooth: float) -> None:
    """Refuse clock-offset search settings :func:`find_clock_offset` cannot use, in one sentence.

    Raises:
        ImuLogError: the offset, the search range or the smoothing is out of range.
    """
    if not math.isfinite(nominal_offset):
        raise ImuLogError(
            f"offset (phone minus robot) is {nominal_offset:g} s; expected a finite number of "
            "seconds"
        )
    if not max_offset >= 0:  # NaN too
        raise ImuLogError(
            f"max_offset is {max_offset:g} s; expected a number >= 0 (0 fixes the offset, inf "
            "searches every offset)"
        )
    if not 0 <= smooth <= MAX_SMOOTH_S:  # NaN too
        raise ImuLogError(
            f"smooth is {smooth:g} s; expected a number from 0 to {MAX_SMOOTH_S:g} s "
            "(0 = no smoothing)"
        )


def _rates_on_grids(
    robot_t: FloatArray,
    robot_heading: FloatArray,
    imu: ImuLog,
    h: float,
    gaps: Sequence[tuple[float, float]],
    smooth: float,
) -> tuple[FloatArray, FloatArray, FloatArray, bool]:
    """The robot's and the sensor's yaw rates on grids of step ``h`` from each log's start,
    low-passed, and where the sensor's rate is known (1, else 0; whether any is unknown)."""
    # robot grid starts at robot_t[0]; phone grid starts at imu.t[0]; both step h
    na = math.floor((robot_t[-1] - robot_t[0]) / h) + 1
    nb = math.floor((imu.t[-1] - imu.t[0]) / h) + 1
    a = rate_on_grid(robot_t, robot_heading, robot_t[0] + h * np.arange(na))
    grid_b = imu.t[0] + h * np.arange(nb)
    b = _imu_rate_on_grid(imu, grid_b)
    known = np.ones(nb)  # 0 where the sensor's rate is unknown (``gaps``)
    for g0, g1 in gaps:
        known[(grid_b > g0) & (grid_b < g1)] = 0.0
    masked = bool((known == 0.0).any())
    if smooth > 0:  # the same zero-phase (symmetric) low-pass on both: no shift, less noise
        from scipy import ndimage

        a = ndimage.gaussian_filter1d(a, smooth / h, mode="nearest")
        if masked:  # from the known samples only (normalised convolution)
            weight = ndimage.gaussian_filter1d(known, smooth / h, mode="nearest")
            b = ndimage.gaussian_filter1d(b * known, smooth / h, mode="nearest")
            b = b / np.maximum(weight, 1e-12)
            # and only where the low-pass saw no unknown sample: near a gap's edge the robot's
            # smoothed rate carries what happened inside the gap, the sensor's cannot
            known = known * (weight > 0.999)
        else:
            b = ndimage.gaussian_filter1d(b, smooth / h, mode="nearest")
    return a, b, known, masked


def _correlate(a: FloatArray, b: FloatArray) -> FloatArray:
    """``scipy.signal.correlate(a, b, "full")``; scipy.signal (0.8 s to import, scipy.stats with
    it) is imported here, when clocks are aligned, not with the module."""
    from scipy import signal

    return np.asarray(signal.correlate(a, b, mode="full", method="auto"), dtype=np.float64)


def _energies(
    a: FloatArray, b: FloatArray, known: FloatArray, masked: bool, lags: NDArray[np.int64]
) -> FloatArray:
    """Per lag, the product of both rates' energies inside the overlap."""
    na, nb = a.size, b.size
    ca = np.concatenate(([0.0], np.cumsum(a * a)))
    cb = np.concatenate(([0.0], np.cumsum(b * b)))
    r0 = np.maximum(0, lags)
    r1 = np.minimum(na, lags + nb)
    if masked:  # the robot's energy only where the sensor's rate is known, lag by lag
        energy_a = _correlate(a * a, known)
        energy = np.maximum(energy_a, 0.0) * (cb[r1 - lags] - cb[r0 - lags])
    else:
        energy = (ca[r1] - ca[r0]) * (cb[r1 - lags] - cb[r0 - lags])
    return np.asarray(energy, dtype=np.float64)


def _grid_step(robot_t: FloatArray, imu: ImuLog, grid_step: float | None) -> float:
    """The given step, or the finer of the two logs' median sample spacing in [1 ms, 50 ms]."""
    if grid_step is None:
        spacing = min(float(np.median(np.diff(robot_t))), float(np.median(np.diff(imu.t))))
        grid_step = min(max(spacing, 1e-3), 0.05)
    return float(grid_step)


def _check_sign(imu: ImuLog, fine: FloatArray, k: int) -> None:
    """Refuse a best match that the same rates with the sign reversed beat."""
    worst = float(np.min(np.where(np.isfinite(fine), fine, np.inf)))
    if fine[k] < 0.5 and -worst > fine[k]:
        raise ImuLogError(
            f"{imu.source}: the IMU's yaw rate matches the odometry's best with its sign "
            f"reversed (correlation {worst:.2f} against {float(fine[k]):.2f}); if the phone lay "
            "face down, flip the IMU's heading ({{flip_imu}})"
        )


def _vertex(fine: FloatArray, k: int) -> float:
    """The parabola's vertex through the scores around the best lag ``k``, in grid steps
    (within +-0.5; 0 at an edge or where it opens upwards)."""
    delta = 0.0
    if 0 < k < fine.size - 1 and np.isfinite(fine[k - 1]) and np.isfinite(fine[k + 1]):
        y0, y1, y2 = fine[k - 1], fine[k], fine[k + 1]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            delta = float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5))
    return delta


def find_clock_offset(
    robot_t: FloatArray,
    robot_heading: FloatArray,
    imu: ImuLog,
    *,
    nominal_offset: float = 0.0,
    max_offset: float = 30.0,
    grid_step: float | None = None,
    min_overlap: float = 1.0,
    min_fraction: float = 0.5,
    smooth: float = 0.1,
    robot_source: str = "encoder log",
    gaps: Sequence[tuple[float, float]] = (),
) -> ClockAlignment:
    """Find the phone-minus-robot clock offset (s) by cross-correlating yaw rates.

    ``robot_t``/``robot_heading``: odometry times (s, robot clock) and unwrapped heading (rad),
    shape (n,). The offset is searched in ``nominal_offset +- max_offset`` (``max_offset`` = 0
    fixes it, ``math.inf`` allows any offset that leaves ``min_overlap`` seconds of overlap).
    ``grid_step`` (s) defaults to the finer of the two logs' median sample spacing, kept within
    [1 ms, 50 ms]. Offsets are scored by the correlation normalised inside the overlap, among
    those that overlap by at least ``min_fraction`` of the shorter log (where the bounds allow
    any). Both rates are first smoothed by the same Gaussian of standard deviation ``smooth``
    seconds (zero phase, so it shifts nothing; 0 = none). Raises :class:`ImuLogError` if no
    allowed offset makes the logs overlap.

    ``gaps``: intervals (start, end) on the phone's (sensor's) clock where its rate is unknown
    (a tracked marker hidden): they are left out of the correlation and of both rates' energies
    at every lag (the sensor's rate there smoothed from its known samples only). Taking the
    unknown rate as zero instead biases the offset: the encoders' turn inside the gap meets
    zeros, and the few frames of the turn left on the gap's edges fit a range of offsets
    equally (the hidden-marker drive: 1.539 to 1.571 s for the true 1.5 s, by corner method).
    """
    check_search(nominal_offset, max_offset, smooth)
    lo, hi = nominal_offset - max_offset, nominal_offset + max_offset
    require_overlap(robot_t, imu, lo, hi, min_overlap=min_overlap, robot_source=robot_source)
    if max_offset == 0:
        o0 = max(float(robot_t[0]), float(imu.t[0]) - nominal_offset)
        o1 = min(float(robot_t[-1]), float(imu.t[-1]) - nominal_offset)
        return ClockAlignment(nominal_offset, math.nan, 0.0, o0, o1, (lo, hi))

    h = _grid_step(robot_t, imu, grid_step)
    a, b, known, masked = _rates_on_grids(robot_t, robot_heading, imu, h, gaps, smooth)
    na, nb = a.size, b.size
    b = b * known
    norm = float(np.linalg.norm(a) * np.linalg.norm(b))
    if norm == 0.0:
        raise ImuLogError(
            f"{imu.source}: neither log shows any rotation to align the clocks with; give the "
            "clock offset ({{offset}} with {{max_offset}} 0)"
        )
    # c[k] = sum_j a[j + k - (nb - 1)] * b[j]; lag L = k - (nb - 1) grid steps means phone
    # sample j sits at robot grid index j + L, i.e. offset = (imu.t0 - robot.t0) - L*h
    c = _correlate(a, b) / norm
    lags = np.arange(-(nb - 1), na)
    offsets = (float(imu.t[0]) - float(robot_t[0])) - lags * h
    # overlap (s) of each lag, to keep only offsets that leave enough common time
    overlap = (np.minimum(na, lags + nb) - np.maximum(0, lags)) * h
    allowed = (offsets >= lo - 0.5 * h) & (offsets <= hi + 0.5 * h) & (overlap >= min_overlap)
    if not allowed.any():  # pragma: no cover - require_overlap makes this rare (grid rounding)
        require_overlap(
            robot_t, imu, lo, hi, min_overlap=min_overlap + h, robot_source=robot_source
        )
        raise ImuLogError(f"{imu.source}: no clock offset in [{lo:g}, {hi:g}] s fits the grid")
    # the correlation normalised by the energies inside the overlap: a cosine, exactly 1 where
    # one rate is a multiple of the other, for any overlap (no bias towards longer overlaps)
    energy = _energies(a, b, known, masked, lags)
    solid = energy > 1e-9 * norm * norm  # where the FFT's rounding cannot dominate
    local = np.where(solid, c * norm / np.sqrt(np.where(solid, energy, 1.0)), -np.inf)
    # short overlaps match by chance: ask for half the shorter log where the bounds allow it
    need = max(min_overlap, min_fraction * min(na, nb) * h)
    long_enough = allowed & (overlap >= need)
    fine = np.where(long_enough if long_enough.any() else allowed, local, -np.inf)
    k = int(np.argmax(fine))
    _check_sign(imu, fine, k)
    offset = float(offsets[k] - _vertex(fine, k) * h)
    offset = min(max(offset, lo), hi)
    o0 = max(float(robot_t[0]), float(imu.t[0]) - offset)
    o1 = min(float(robot_t[-1]), float(imu.t[-1]) - offset)
    return ClockAlignment(offset, float(local[k]), h, o0, o1, (lo, hi))
