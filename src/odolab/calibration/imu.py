"""Calibrate the rotation part of the kinematic model with the robot's own gyro.

Model (planar motion, the gyro's axis vertical): over any interval, the gyro's integral is

    y = s * (c_R * dphi_R - c_L * dphi_L) + b * dt + noise,   c_R = r_R / B, c_L = r_L / B,

with ``dphi`` the wheels' turns (rad) over the interval on the encoders' clock, ``s`` the gyro's
scale, ``b`` its bias (rad/s) and the gyro read on its own clock, ``clock_offset`` seconds ahead
of the encoders'. Only ``a = s * c`` is seen by the gyro. The log is cut into windows of about
``window_s`` seconds at encoder samples (no interpolation of the quantised counts); the gyro's
cumulative integral (trapezoid) is interpolated at the window's ends shifted by the offset.

- ``a_R``, ``a_L`` and one bias per run are linear least squares for a given offset; the offset
  of each run minimises the residual sum of squares (a bounded scalar search, started from the
  rates' cross-correlation of :func:`odolab.validation.find_clock_offset` when the clocks differ).
- The covariance of all of them, the offsets included, is the sandwich of the linearised model
  with Newey-West weights inside each segment (statsmodels' ``hac-panel``, :mod:`odolab.core.regression`), or clustered by
  segment group where there are many (the DRIVE windows' command steps).
- The radius ratio ``r_R / r_L = a_R / a_L`` does not depend on ``s``. The effective track is
  ``B = 2 r_mean s / (a_R + a_L)``: ``r_mean`` (the distance scale) comes from the given
  parameters, since a gyro does not see distance; ``s`` from a reference for the total turn
  (:class:`TurnReference`: turns counted, a compass, a laser or tracker heading), else 1 with
  an assumed uncertainty (1 %, 95 %) carried into the track's interval.
- Intervals are 95 %, by the delta method on the log scale.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.calibration.ratios import CalibrationResult, check_track_model
from odolab.core.arrays import FloatArray
from odolab.core.distributions import Z95
from odolab.core.errors import CalibrationError, ImuLogError
from odolab.core.numfmt import clean
from odolab.core.params import RobotParams
from odolab.io.gyro import GyroRun, GyroSegment

__all__ = [
    "Z95",
    "ImuCalibration",
    "ImuOptions",
    "OffsetEstimate",
    "TurnReference",
    "YawScaleFit",
    "calibrate_imu",
    "check_saturation",
    "reference_from_heading",
    "yaw_scale_from_heading",
]


@dataclass(frozen=True)
class TurnReference:
    """What the robot truly turned (rad, counter-clockwise) in run ``run`` between ``t0`` and
    ``t1`` (encoder clock; None: the run's first and last sample), with its standard
    uncertainty ``sd`` (rad); ``source`` says where it comes from (turns counted, a compass, a
    tracker)."""

    turned: float
    sd: float
    source: str
    run: int = 0
    t0: float | None = None
    t1: float | None = None


@dataclass(frozen=True)
class ImuOptions:
    """Settings of :func:`calibrate_imu` (each with a default).

    ``offset``: the nominal clock offset (s, gyro minus encoders); ``max_offset``: search it
    within ``offset +- max_offset`` (0 fixes it; None: 30 s for a gyro with its own clock, 0.2 s
    for one on the encoders' clock); ``scale_ci95``: the assumed 95 % relative uncertainty of a
    gyro scale taken as 1 (no reference); ``min_turn``: the least turn (rad) in each direction;
    ``gyro_range``: the gyro's full scale (rad/s; None: found from flat maxima)."""

    window_s: float = 0.5
    offset: float = 0.0
    max_offset: float | None = None
    fine_s: float = 0.2
    scale_ci95: float = 0.01
    min_turn: float = math.pi
    gyro_range: float | None = None
    maxlags: int = 2
    #: the gyro's bias when it is known (rad/s) and its standard uncertainty: for a run that
    #: turns one way without standing still (None: fitted, one per run)
    bias: float | None = None
    bias_sd: float = 0.005


@dataclass(frozen=True)
class OffsetEstimate:
    """A run's clock offset (s, gyro minus encoders), its standard error (s; nan when fixed),
    and how it was found."""

    run: str
    offset: float
    se: float
    how: str

    @property
    def ci95(self) -> tuple[float, float]:
        return (self.offset - Z95 * self.se, self.offset + Z95 * self.se)

    def describe(self) -> str:
        if not math.isfinite(self.se):
            return f"{self.run}: clock offset {self.offset:.4f} s (given, not estimated)"
        half = Z95 * self.se
        verdict = (
            "well determined"
            if half <= 0.01
            else "poorly determined: turns that start and stop often fix it better"
        )
        value = (
            f"{1000 * self.offset:.1f} ms +- {1000 * half:.1f} ms"
            if half < 0.1
            else f"{self.offset:.3f} s +- {half:.3f} s"
        )
        return f"{self.run}: clock offset {value} (gyro minus encoders; {verdict}; {self.how})"


def _ci(value: float, log_sd: float) -> tuple[float, float]:
    return (value * math.exp(-Z95 * log_sd), value * math.exp(Z95 * log_sd))


@dataclass(frozen=True, eq=False)
class ImuCalibration:
    """The gyro's estimate of the angular parameters, with 95 % intervals (see the module)."""

    params: RobotParams
    old_params: RobotParams
    track_width: float
    track_width_ci95: tuple[float, float]
    radius_ratio: float  #: r_R / r_L
    radius_ratio_ci95: tuple[float, float]
    yaw_scale: float  #: actual / predicted rotation of the given parameters (B_old / B_new)
    yaw_scale_ci95: tuple[float, float]
    gyro_scale: float
    gyro_scale_ci95: tuple[float, float]
    scale_source: str
    bias: float  #: rad/s, fitted jointly (the first run's when several)
    bias_se: float
    biases: tuple[float, ...]
    still_bias: float | None  #: rad/s, from windows with both wheels still (None: < 1 s still)
    still_bias_se: float | None
    still_s: float
    offsets: tuple[OffsetEstimate, ...]
    radii_source: str
    ratio_note: str
    turned_ccw: float  #: rad, by the encoders with the given parameters
    turned_cw: float
    windows: int
    residual_rms: float  #: rad per window
    covariance: str  #: how the covariance was estimated
    runs: tuple[str, ...]
    a: tuple[float, float]  #: s * r_R / B, s * r_L / B
    a_cov: tuple[tuple[float, float], tuple[float, float]]
    provenance: dict[str, object] = field(default_factory=dict)
    bias_how: str = "fitted jointly"

    @property
    def result(self) -> CalibrationResult:
        return CalibrationResult("imu", self.params, self.old_params, self.provenance)

    def save(self, path: str | Path) -> Path:
        return self.result.save(path)

    def lines(self) -> list[str]:
        """What the CLI prints (one line each)."""
        b0, b1 = self.track_width_ci95
        q0, q1 = self.radius_ratio_ci95
        k0, k1 = self.yaw_scale_ci95
        s0, s1 = self.gyro_scale_ci95
        out = [
            f"effective track {self.track_width:.5f} m, 95 % [{b0:.5f}, {b1:.5f}] "
            f"(was {self.old_params.track_width:.5f} m)",
            f"radius ratio r_R/r_L {self.radius_ratio:.5f}, 95 % [{q0:.5f}, {q1:.5f}]"
            + (f" ({self.ratio_note})" if self.ratio_note else ""),
            f"rotation ratio actual/predicted of {self.old_params.name}: {self.yaw_scale:.5f}, "
            f"95 % [{k0:.5f}, {k1:.5f}]",
            f"gyro scale {self.gyro_scale:.5f}, 95 % [{s0:.5f}, {s1:.5f}] ({self.scale_source})",
            f"gyro bias {self.bias:+.5f} rad/s +- {Z95 * self.bias_se:.5f} ({self.bias_how})"
            + (
                f"; {self.still_bias:+.5f} +- {Z95 * (self.still_bias_se or 0.0):.5f} rad/s "
                f"from {self.still_s:.1f} s standing still"
                if self.still_bias is not None
                else "; under 1 s standing still: no separate still estimate"
            ),
            *(o.describe() for o in self.offsets),
            f"distance scale: {self.radii_source}",
            f"{self.windows} windows, residual RMS {self.residual_rms:.4f} rad; turned "
            f"{self.turned_ccw:.1f} rad counter-clockwise and {self.turned_cw:.1f} rad "
            f"clockwise; covariance: {self.covariance}",
        ]
        return out

    def to_dict(self) -> dict[str, object]:
        return {
            "method": "imu",
            "params": self.params.to_dict(),
            "old_params": self.old_params.to_dict(),
            "track_width": self.track_width,
            "track_width_ci95": list(self.track_width_ci95),
            "radius_ratio": self.radius_ratio,
            "radius_ratio_ci95": list(self.radius_ratio_ci95),
            "yaw_scale": self.yaw_scale,
            "yaw_scale_ci95": list(self.yaw_scale_ci95),
            "gyro_scale": self.gyro_scale,
            "gyro_scale_ci95": list(self.gyro_scale_ci95),
            "scale_source": self.scale_source,
            "bias": self.bias,
            "bias_se": self.bias_se,
            "biases": list(self.biases),
            "still_bias": self.still_bias,
            "still_bias_se": self.still_bias_se,
            "still_s": self.still_s,
            "clock_offsets": [
                {"run": o.run, "offset": o.offset, "se": o.se, "how": o.how} for o in self.offsets
            ],
            "radii_source": self.radii_source,
            "ratio_note": self.ratio_note,
            "turned_ccw": self.turned_ccw,
            "turned_cw": self.turned_cw,
            "windows": self.windows,
            "residual_rms": self.residual_rms,
            "covariance": self.covariance,
            "runs": list(self.runs),
            "provenance": dict(self.provenance),
        }


# ---------------------------------------------------------------------------------------------
# checks


def check_saturation(run: GyroRun, gyro_range: float | None = None, flat: int = 5) -> None:
    """Refuse a gyro that clipped: a reading at or beyond ``gyro_range`` (rad/s), or, without a
    range, its largest magnitude repeated flat over ``flat`` samples or more."""
    for seg in run.segments:
        wz = seg.wz
        mag = np.abs(wz)
        if gyro_range is not None:
            hit = np.flatnonzero(mag >= gyro_range)
            if hit.size:
                i = int(hit[0])
                raise CalibrationError(
                    f"{run.imu_source}: the gyro reads {wz[i]:+.3f} rad/s at {seg.gyro_t[i]:.2f} "
                    f"s, at its range of {gyro_range:g} rad/s: it is saturated; turn slower than "
                    "its range"
                )
            continue
        peak = float(mag.max())
        # a real gyro's readings change from sample to sample (its noise): a flat stretch at
        # the peak is then its clipping; a log that is mostly flat (noise-free) says nothing
        if peak == 0.0 or float(np.mean(np.diff(wz) == 0)) > 0.5:
            continue
        at = mag >= peak * (1.0 - 1e-9)
        # the longest run of consecutive samples at the peak
        edges = np.diff(np.concatenate(([0], at.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        lengths = ends - starts
        k = int(np.argmax(lengths))
        if lengths[k] >= flat:
            i = int(starts[k])
            raise CalibrationError(
                f"{run.imu_source}: the gyro reads {wz[i]:+.4f} rad/s flat for {int(lengths[k])} "
                f"samples from {seg.gyro_t[i]:.2f} s: it is saturated; turn slower than its "
                "range (or give its range)"
            )


def reference_from_heading(
    run: GyroRun, index: int = 0, sd: float = 0.01, source: str = "ground-truth heading"
) -> TurnReference:
    """The turn a run's reference heading (a tracker's, beside the log) saw over the run."""
    if len(run.segments) != 1:
        raise CalibrationError(
            f"{run.source}: a turn reference from a heading needs a run of one piece"
        )
    seg = run.segments[0]
    if seg.heading is None or seg.heading_t is None:
        raise CalibrationError(f"{run.source}: no ground-truth heading beside the log")
    t0 = max(float(seg.t[0]), float(seg.heading_t[0]))
    t1 = min(float(seg.t[-1]), float(seg.heading_t[-1]))
    if t1 - t0 <= 0:
        raise CalibrationError(f"{run.source}: the ground truth does not overlap the encoder log")
    h = np.interp([t0, t1], seg.heading_t, seg.heading)
    return TurnReference(float(h[1] - h[0]), sd, source, index, t0, t1)


# ---------------------------------------------------------------------------------------------
# the windows of one run


@dataclass
class _RunData:
    run: GyroRun
    index: int
    seg: NDArray[np.int64]  #: segment number (global) per window
    group: NDArray[np.int64]
    dl: FloatArray
    dr: FloatArray
    dt: FloatArray
    ta: FloatArray
    tb: FloatArray
    pieces: list[tuple[int, int, GyroSegment, FloatArray]]  #: (row0, row1, seg, cumulative gyro)
    bracket: tuple[float, float]
    offset: float
    fixed: bool
    how: str
    bias0: float = 0.0  #: a known bias, taken off the gyro (0 when the bias is fitted)

    def y(self, tau: float) -> FloatArray:
        out = np.empty(self.dt.size)
        for r0, r1, seg, cum in self.pieces:
            a = np.interp(self.ta[r0:r1] + tau, seg.gyro_t, cum)
            b = np.interp(self.tb[r0:r1] + tau, seg.gyro_t, cum)
            out[r0:r1] = b - a
        return out - self.bias0 * self.dt

    def dy(self, a_r: float, a_l: float) -> FloatArray:
        """d y / d offset, from the model: the yaw rate the encoders predict (``a_R phidot_R -
        a_L phidot_L``, the wheel rates lightly smoothed) at the windows' ends. Not the gyro's
        own rate: its noise (a skid-steer's scrub, a noisy gyro) would pass for information
        about the offset."""
        from scipy import ndimage

        out = np.empty(self.dt.size)
        for r0, r1, seg, _ in self.pieces:
            step = float(np.median(np.diff(seg.t)))
            sigma = max(0.05 / step, 0.5) if step > 0 else 0.5
            rate = a_r * np.gradient(seg.right, seg.t) - a_l * np.gradient(seg.left, seg.t)
            w = ndimage.gaussian_filter1d(rate, sigma, mode="nearest")
            out[r0:r1] = np.interp(self.tb[r0:r1], seg.t, w) - np.interp(self.ta[r0:r1], seg.t, w)
        return out


def _cum(seg: GyroSegment) -> FloatArray:
    dt = np.diff(seg.gyro_t)
    return np.concatenate(([0.0], np.cumsum(0.5 * (seg.wz[1:] + seg.wz[:-1]) * dt)))


def _bracket(
    run: GyroRun, o: ImuOptions, nominal: RobotParams
) -> tuple[tuple[float, float], float, bool, str]:
    max_offset = o.max_offset
    if max_offset is None:
        max_offset = o.fine_s if run.same_clock else 30.0
    if not (math.isfinite(o.offset) and max_offset >= 0):
        raise CalibrationError(
            f"the clock offset search is {o.offset:g} +- {max_offset:g} s; expected a finite "
            "offset and a search half-width >= 0"
        )
    if max_offset == 0:
        return (o.offset, o.offset), o.offset, True, "given"
    if max_offset <= o.fine_s or len(run.segments) != 1:
        lo, hi = o.offset - max_offset, o.offset + max_offset
        return (lo, hi), o.offset, False, f"least squares within {lo:g} to {hi:g} s"
    # two clocks: start from the rates' cross-correlation (as odolab validate)
    from odolab.io.sensorlog import ImuLog
    from odolab.validation.align import find_clock_offset

    seg = run.segments[0]
    heading = (seg.right * nominal.right_wheel_radius - seg.left * nominal.left_wheel_radius) / (
        nominal.track_width
    )
    yaw = np.concatenate(([0.0], np.cumsum(0.5 * (seg.wz[1:] + seg.wz[:-1]) * np.diff(seg.gyro_t))))
    imu = ImuLog(seg.gyro_t, yaw, seg.wz, source=run.imu_source)
    found = find_clock_offset(
        seg.t,
        heading,
        imu,
        nominal_offset=o.offset,
        max_offset=max_offset,
        robot_source=f"encoder log {run.source}",
    )
    lo = max(found.clock_offset - o.fine_s, o.offset - max_offset)
    hi = min(found.clock_offset + o.fine_s, o.offset + max_offset)
    how = (
        f"rate correlation {found.correlation:.3f} at {found.clock_offset:.3f} s, then least "
        "squares"
    )
    return (lo, hi), found.clock_offset, False, how


def _run_data(run: GyroRun, index: int, seg0: int, o: ImuOptions, nominal: RobotParams) -> _RunData:
    (lo, hi), start, fixed, how = _bracket(run, o, nominal)
    dl, dr, dt, ta, tb, sg, gr = [], [], [], [], [], [], []
    pieces = []
    row = 0
    for k, seg in enumerate(run.segments):
        step = float(np.median(np.diff(seg.t)))
        m = max(1, round(o.window_s / step)) if step > 0 else 1
        idx = np.arange(0, seg.t.size, m)
        if idx[-1] != seg.t.size - 1 and seg.t.size - 1 - idx[-1] >= max(1, m // 2):
            idx = np.append(idx, seg.t.size - 1)
        a, b = idx[:-1], idx[1:]
        keep = (seg.t[a] + lo >= seg.gyro_t[0]) & (seg.t[b] + hi <= seg.gyro_t[-1])
        a, b = a[keep], b[keep]
        if a.size == 0:
            continue
        dl.append(seg.left[b] - seg.left[a])
        dr.append(seg.right[b] - seg.right[a])
        ta.append(seg.t[a])
        tb.append(seg.t[b])
        dt.append(seg.t[b] - seg.t[a])
        sg.append(np.full(a.size, seg0 + k))
        gr.append(np.full(a.size, seg.group))
        pieces.append((row, row + a.size, seg, _cum(seg)))
        row += a.size
    if row == 0:
        s0 = run.segments[0]
        raise ImuLogError(
            f"{run.imu_source}: the gyro log (its clock {float(s0.gyro_t[0]):.3f} to "
            f"{float(s0.gyro_t[-1]):.3f} s) does not overlap the encoder log {run.source} "
            f"({float(s0.t[0]):.3f} to {float(s0.t[-1]):.3f} s) for a clock offset from "
            f"{lo:g} to {hi:g} s (gyro minus encoders); give the offset between the clocks"
        )

    def cat(parts: list[NDArray[np.float64]]) -> NDArray[np.float64]:
        return np.concatenate(parts)

    return _RunData(
        run,
        index,
        cat(sg).astype(np.int64),
        cat(gr).astype(np.int64),
        cat(dl),
        cat(dr),
        cat(dt),
        cat(ta),
        cat(tb),
        pieces,
        (lo, hi),
        min(max(start, lo), hi),
        fixed,
        how,
    )


# ---------------------------------------------------------------------------------------------
# the fit


def _design(data: list[_RunData], ratio: float | None, fit_bias: bool = True) -> FloatArray:
    """Columns: a_R and a_L (or a_L alone with a_R = ratio * a_L), then one bias per run (none
    when the bias is known)."""
    n = sum(d.dt.size for d in data)
    nb = len(data) if fit_bias else 0
    ncol = (1 if ratio is not None else 2) + nb
    x = np.zeros((n, ncol))
    row = 0
    for j, d in enumerate(data):
        r = slice(row, row + d.dt.size)
        if ratio is None:
            x[r, 0] = d.dr
            x[r, 1] = -d.dl
        else:
            x[r, 0] = ratio * d.dr - d.dl
        if fit_bias:
            x[r, ncol - nb + j] = d.dt
        row += d.dt.size
    return x


def _solve(x: FloatArray, y: FloatArray) -> tuple[FloatArray, float]:
    theta, *_ = np.linalg.lstsq(x, y, rcond=None)
    r = y - x @ theta
    return np.asarray(theta, dtype=np.float64), float(r @ r)


def _ys(data: list[_RunData], taus: Sequence[float]) -> FloatArray:
    return np.concatenate([d.y(t) for d, t in zip(data, taus, strict=True)])


def _fit_offsets(data: list[_RunData], x: FloatArray) -> list[float]:
    from scipy import optimize

    taus = [d.offset for d in data]
    for _ in range(2 if len(data) > 1 else 1):
        for j, d in enumerate(data):
            if d.fixed:
                continue

            def rss(tau: float, j: int = j) -> float:
                trial = list(taus)
                trial[j] = tau
                return _solve(x, _ys(data, trial))[1]

            lo, hi = d.bracket
            # a coarse scan first (the sum of squares can have local minima), then Brent
            grid = np.linspace(lo, hi, 41)
            vals = [rss(float(g)) for g in grid]
            k = int(np.argmin(vals))
            a, b = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)])
            res = optimize.minimize_scalar(
                rss, bounds=(a, b), method="bounded", options={"xatol": 1e-5}
            )
            taus[j] = float(res.x) if res.fun <= vals[k] else float(grid[k])
    return taus


def _covariance(
    r: FloatArray, jac: FloatArray, data: list[_RunData], maxlags: int
) -> tuple[FloatArray, str]:
    from odolab.core.regression import cluster_cov, newey_west_panel_cov, ols, panel_lags

    groups = np.concatenate([d.group + 1_000_000 * d.index for d in data])
    segs = np.concatenate([d.seg for d in data])
    n_groups = np.unique(groups).size
    fit = ols(r, jac)
    if n_groups >= 20:
        robust = cluster_cov(fit, jac, groups)
        how = f"clustered by {n_groups} segment groups"
    else:
        robust = newey_west_panel_cov(fit, jac, segs, maxlags)
        used = panel_lags(segs, maxlags)
        short = f" of {maxlags}: no segment is longer" if used < maxlags else ""
        how = f"Newey-West (lags {used}{short}) within each segment"
    plain = fit.cov
    # each variance the larger of the two (the robust one can fall short where one column
    # lives on few windows, as the clock offset on the turns' starts and stops), the
    # correlations of the plain one: D C D with D diagonal stays a covariance
    d = np.sqrt(np.maximum(1.0, np.diag(robust) / np.maximum(np.diag(plain), 1e-300)))
    return plain * np.outer(d, d), how + ", no smaller than the plain least-squares variance"


def _still(data: list[_RunData], y: FloatArray) -> tuple[float | None, float | None, float]:
    dl = np.concatenate([d.dl for d in data])
    dr = np.concatenate([d.dr for d in data])
    dt = np.concatenate([d.dt for d in data])
    still = (np.abs(dl) < 1e-9) & (np.abs(dr) < 1e-9)
    total = float(dt[still].sum())
    if total < 1.0 or int(still.sum()) < 2:
        return None, None, total
    rate = y[still] / dt[still]
    w = dt[still] / total
    mean = float(np.sum(w * rate))
    var = float(np.sum(w * (rate - mean) ** 2)) / max(int(still.sum()) - 1, 1)
    return mean, math.sqrt(var), total


def _encoder_windows(
    runs: Sequence[GyroRun], window_s: float
) -> tuple[FloatArray, FloatArray, FloatArray, list[str]]:
    """(dl, dr, dt) of the encoder logs alone, in windows of about ``window_s``."""
    dl, dr, dt = [], [], []
    for run in runs:
        for seg in run.segments:
            step = float(np.median(np.diff(seg.t)))
            m = max(1, round(window_s / step)) if step > 0 else 1
            idx = np.arange(0, seg.t.size, m)
            dl.append(np.diff(seg.left[idx]))
            dr.append(np.diff(seg.right[idx]))
            dt.append(np.diff(seg.t[idx]))
    return np.concatenate(dl), np.concatenate(dr), np.concatenate(dt), [r.source for r in runs]


def _check_turning(
    runs: Sequence[GyroRun], nominal: RobotParams, o: ImuOptions
) -> tuple[float, float]:
    dl, dr, dt, names = _encoder_windows(runs, o.window_s)
    yaw = (dr * nominal.right_wheel_radius - dl * nominal.left_wheel_radius) / nominal.track_width
    still_s = float(dt[(np.abs(dl) < 1e-9) & (np.abs(dr) < 1e-9)].sum())
    ccw, cw = float(yaw[yaw > 0].sum()), abs(float(yaw[yaw < 0].sum()))
    if min(ccw, cw) < o.min_turn and not (max(ccw, cw) >= o.min_turn and still_s >= 2.0):
        raise CalibrationError(
            f"{', '.join(names)}: the robot turned {ccw:.2f} rad counter-clockwise and {cw:.2f} "
            f"rad clockwise by the encoders ({still_s:.1f} s standing still); turn at least "
            f"{o.min_turn:.2f} rad in each direction (or in one, with 2 s standing still) to "
            "determine the track and the gyro's bias"
        )
    return ccw, cw


def _ratio_observable(data: list[_RunData]) -> bool:
    dr = np.concatenate([d.dr for d in data])
    dl = np.concatenate([d.dl for d in data])
    # in place, dR = -dL: only a_R + a_L is seen; driving straight or in arcs separates them
    sa, sb = float(np.sum(dr * dr)), float(np.sum(dl * dl))
    if sa == 0 or sb == 0:
        return False
    corr = float(np.sum(dr * dl)) / math.sqrt(sa * sb)
    return corr > -0.995


def _reference_turn(
    data: list[_RunData], refs: Sequence[TurnReference]
) -> tuple[float, float, float, float, str]:
    """(P_R, P_L, turned, var): the reference's wheel turns (the signed sums), the turn, its
    variance, and the sources in words."""
    pr = pl = turned = var = 0.0
    for ref in refs:
        if not 0 <= ref.run < len(data):
            raise CalibrationError(f"a turn reference names run {ref.run + 1}, which is not given")
        run = data[ref.run].run
        if len(run.segments) != 1:
            raise CalibrationError(
                f"{run.source}: a turn reference needs a run of one piece, not "
                f"{len(run.segments)} windows"
            )
        if not (math.isfinite(ref.turned) and ref.sd > 0 and math.isfinite(ref.sd)):
            raise CalibrationError(
                f"{run.source}: the reference turn {ref.turned:g} rad +- {ref.sd:g}; expected a "
                "finite turn and a positive uncertainty"
            )
        seg = run.segments[0]
        t0 = float(seg.t[0]) if ref.t0 is None else ref.t0
        t1 = float(seg.t[-1]) if ref.t1 is None else ref.t1
        wr = np.interp([t0, t1], seg.t, seg.right)
        wl = np.interp([t0, t1], seg.t, seg.left)
        sign = 1.0 if ref.turned >= 0 else -1.0
        pr += sign * float(wr[1] - wr[0])
        pl += sign * float(wl[1] - wl[0])
        turned += abs(ref.turned)
        var += ref.sd**2
    if turned < 1.0:
        raise CalibrationError(
            f"the reference turns add up to {turned:.2f} rad; a gyro scale needs at least 1 rad "
            "(better several turns) of known turn"
        )
    sources = sorted({r.source for r in refs})
    return pr, pl, turned, var, ", ".join(sources)


def _checked_turning(
    runs: Sequence[GyroRun], params: RobotParams, o: ImuOptions
) -> tuple[float, float]:
    """The options and runs checked; (turned ccw, turned cw) by the encoders."""
    if not runs:
        raise CalibrationError("no runs given; expected encoder logs with a gyro")
    if not o.window_s > 0:
        raise CalibrationError(f"window is {o.window_s:g} s; expected a positive number")
    check_track_model(params, "the gyro calibration")
    for run in runs:
        check_saturation(run, o.gyro_range)
    if o.bias is None:
        return _check_turning(runs, params, o)
    ccw, cw = _check_turning(runs, params, replace(o, min_turn=0.0))
    if ccw + cw < o.min_turn:
        raise CalibrationError(
            f"{', '.join(r.source for r in runs)}: the robot turned {ccw + cw:.2f} rad by the "
            f"encoders; turn at least {o.min_turn:.2f} rad to determine the track"
        )
    return ccw, cw


def _all_run_data(
    runs: Sequence[GyroRun], o: ImuOptions, params: RobotParams, fit_bias: bool
) -> list[_RunData]:
    data = []
    seg0 = 0
    for i, run in enumerate(runs):
        d = _run_data(run, i, seg0, o, params)
        if not fit_bias:
            d.bias0 = float(o.bias or 0.0)
        data.append(d)
        seg0 += len(run.segments)
    return data


def _jacobian(
    data: list[_RunData], x: FloatArray, y: FloatArray, a_fit: tuple[float, float]
) -> tuple[FloatArray, list[int]]:
    """The Jacobian of the fitted values: X, and d y / d offset for each estimated offset (the
    runs whose offset is estimated, in order)."""
    cols = [x]
    est = [j for j, d in enumerate(data) if not d.fixed]
    row = 0
    starts = []
    for d in data:
        starts.append(row)
        row += d.dt.size
    for j in est:
        col = np.zeros(y.size)
        d = data[j]
        col[starts[j] : starts[j] + d.dt.size] = d.dy(a_fit[0], a_fit[1])
        cols.append(col[:, None])
    jac = np.hstack(cols)
    if jac.shape[0] <= jac.shape[1]:  # no residual left to measure the scatter with
        raise CalibrationError(
            f"the gyro calibration fits {jac.shape[1]} unknowns and the turning samples give "
            f"{jac.shape[0]}; expected more samples than unknowns (a longer run, or more runs)"
        )
    return jac, est


def _angular(
    theta: FloatArray, cov: FloatArray, fixed_ratio: float | None
) -> tuple[float, float, FloatArray]:
    """a_R, a_L (= r_R/B, r_L/B) and their covariance."""
    if fixed_ratio is None:
        a_r, a_l = float(theta[0]), float(theta[1])
        ca = cov[:2, :2]
    else:
        a_l = float(theta[0])
        a_r = fixed_ratio * a_l
        g = np.array([[fixed_ratio], [1.0]])
        ca = g @ cov[:1, :1] @ g.T
    if not (a_r > 0 and a_l > 0):
        raise CalibrationError(
            f"the gyro's fit gives r_R/B = {a_r:.4g} and r_L/B = {a_l:.4g}; expected both "
            "positive: is the gyro upside down (its yaw rate against the turn)?"
        )
    return a_r, a_l, ca


def _offsets(
    data: list[_RunData], taus: list[float], cov: FloatArray, nlin: int, est: list[int]
) -> list[OffsetEstimate]:
    offsets = []
    for j, d in enumerate(data):
        if d.fixed:
            offsets.append(OffsetEstimate(d.run.name, taus[j], math.nan, d.how))
        else:
            k = nlin + est.index(j)
            offsets.append(
                OffsetEstimate(d.run.name, taus[j], math.sqrt(max(cov[k, k], 0.0)), d.how)
            )
    return offsets


@dataclass(frozen=True)
class _Scale:
    """The gyro's scale, the variances of log(scale) and log(track) and where the scale came from."""

    scale: float
    var_log_s: float
    var_log_b: float
    source: str


def _gyro_scale(
    data: list[_RunData],
    references: Sequence[TurnReference],
    a_r: float,
    a_l: float,
    ca: FloatArray,
    o: ImuOptions,
) -> _Scale:
    """The gyro's scale from the reference turns (or 1 with the options' assumed interval), by
    the delta method on the log scale."""
    ssum = a_r + a_l
    g_sum = np.array([1.0 / ssum, 1.0 / ssum])
    var_log_sum = float(g_sum @ ca @ g_sum)
    if not references:
        var_log_s = (o.scale_ci95 / Z95) ** 2
        return _Scale(
            1.0,
            var_log_s,
            var_log_sum + var_log_s,
            f"no reference for the total turn: taken as 1 with an assumed +-{100 * o.scale_ci95:g} "
            "% (95 %), carried into the track's interval",
        )
    pr, pl, turned, var_ref, words = _reference_turn(data, references)
    p = a_r * pr - a_l * pl
    if not p > 0:
        raise CalibrationError(
            f"the gyro saw {p:.3g} rad over the reference turns of {turned:.3g} rad; "
            "expected the same sense: check the reference's sign"
        )
    gs = np.array([pr / p, -pl / p])
    gb = gs - g_sum
    return _Scale(
        p / turned,
        float(gs @ ca @ gs) + var_ref / turned**2,
        float(gb @ ca @ gb) + var_ref / turned**2,
        f"from {turned:.2f} rad of reference turn ({words})",
    )


@dataclass(frozen=True)
class _Fit:
    """The joint fit: a_R, a_L and their covariance, the bias of each run, the clock offsets."""

    a_r: float
    a_l: float
    ca: FloatArray
    fixed_ratio: float | None
    ratio_note: str
    biases: tuple[float, ...]
    bias_ses: list[float]
    offsets: list[OffsetEstimate]
    windows: int
    rss: float
    how_cov: str


def _fit(data: list[_RunData], params: RobotParams, o: ImuOptions, fit_bias: bool) -> _Fit:
    n_runs = len(data)
    ratio_note = ""
    fixed_ratio: float | None = None
    if not _ratio_observable(data):
        fixed_ratio = params.right_wheel_radius / params.left_wheel_radius
        ratio_note = (
            "not seen by turning in place alone: kept from the given parameters; drive "
            "straight or in arcs to measure it"
        )
    x = _design(data, fixed_ratio, fit_bias)
    taus = _fit_offsets(data, x)
    y = _ys(data, taus)
    theta, rss = _solve(x, y)
    r = y - x @ theta
    a_fit = (
        (float(theta[0]), float(theta[1]))
        if fixed_ratio is None
        else (
            fixed_ratio * float(theta[0]),
            float(theta[0]),
        )
    )
    jac, est = _jacobian(data, x, y, a_fit)
    cov, how_cov = _covariance(r, jac, data, o.maxlags)
    nlin = x.shape[1]
    if not fit_bias:
        # a known bias, and its uncertainty: theta moves by -(X'X)^-1 X' dt per rad/s of it
        dt_all = np.concatenate([d.dt for d in data])
        g_b = np.linalg.lstsq(x, dt_all, rcond=None)[0]
        cov = cov.copy()
        cov[:nlin, :nlin] += o.bias_sd**2 * np.outer(g_b, g_b)
    a_r, a_l, ca = _angular(theta, cov, fixed_ratio)
    if fit_bias:
        biases = tuple(float(v) for v in theta[nlin - n_runs : nlin])
        bias_ses = [math.sqrt(max(cov[k, k], 0.0)) for k in range(nlin - n_runs, nlin)]
    else:
        biases = tuple(float(o.bias or 0.0) for _ in data)
        bias_ses = [o.bias_sd for _ in data]
    offsets = _offsets(data, taus, cov, nlin, est)
    return _Fit(
        a_r, a_l, ca, fixed_ratio, ratio_note, biases, bias_ses, offsets, int(y.size), rss, how_cov
    )


def _provenance(
    runs: Sequence[GyroRun],
    params: RobotParams,
    sources: Sequence[str],
    track: float,
    sd_b: float,
    ratio: float,
    ratio_ci: tuple[float, float],
    sc: _Scale,
    sd_s: float,
    f: _Fit,
    radii: str,
) -> dict[str, object]:
    """The new parameters' provenance record."""
    return {
        "method": "imu",
        "created": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "source": ", ".join(sources) if sources else ", ".join(r.source for r in runs),
        "imu": ", ".join(r.imu_source for r in runs),
        "from_params": params.name,
        "track_width_ci95": list(_ci(track, sd_b)),
        "radius_ratio": ratio,
        "radius_ratio_ci95": list(ratio_ci),
        "gyro_scale": sc.scale,
        "gyro_scale_ci95": list(_ci(sc.scale, sd_s)),
        "scale_source": sc.source,
        "gyro_bias": f.biases[0],
        "clock_offsets": [o_.offset for o_ in f.offsets],
        "radii_source": radii,
        "old": params.to_dict(),
    }


def calibrate_imu(
    runs: Sequence[GyroRun],
    params: RobotParams,
    *,
    options: ImuOptions | None = None,
    references: Sequence[TurnReference] = (),
    radii_source: str | None = None,
    sources: Sequence[str] = (),
) -> ImuCalibration:
    """Estimate the angular parameters, the gyro's bias (and scale with ``references``) and the
    clock offsets from encoder runs with a gyro (see the module). ``params``: the parameters in
    use (their mean wheel radius is kept). Raises :class:`CalibrationError` (too little turning,
    a saturated gyro, a useless reference) and :class:`~odolab.core.errors.ImuLogError` (clocks that
    do not overlap)."""
    o = options or ImuOptions()
    ccw, cw = _checked_turning(runs, params, o)
    fit_bias = o.bias is None
    data = _all_run_data(runs, o, params, fit_bias)
    y0 = _ys(data, [d.offset for d in data])
    still_bias, still_se, still_s = _still(data, y0)
    if still_bias is not None and not fit_bias:  # y0 has the given bias taken off
        still_bias += float(o.bias or 0.0)
    f = _fit(data, params, o, fit_bias)
    a_r, a_l, ca = f.a_r, f.a_l, f.ca
    r_mean = 0.5 * (params.left_wheel_radius + params.right_wheel_radius)
    sc = _gyro_scale(data, references, a_r, a_l, ca, o)
    track = 2.0 * r_mean * sc.scale / (a_r + a_l)
    ratio = a_r / a_l
    g_ratio = np.array([1.0 / a_r, -1.0 / a_l])
    sd_ratio = math.sqrt(max(float(g_ratio @ ca @ g_ratio), 0.0))  # of log(ratio)
    ratio_ci = (ratio, ratio) if f.fixed_ratio is not None else _ci(ratio, sd_ratio)
    sd_b = math.sqrt(max(sc.var_log_b, 0.0))
    new = params.with_(
        left_wheel_radius=clean(2.0 * r_mean / (1.0 + ratio)),
        right_wheel_radius=clean(2.0 * r_mean * ratio / (1.0 + ratio)),
        track_width=clean(track),
        name=f"{params.name}-imu",
    )
    radii = radii_source or (
        f"the mean wheel radius {r_mean:.6g} m of {params.name} (a gyro does not see distance; "
        "measure straight runs for it)"
    )
    sd_s = math.sqrt(max(sc.var_log_s, 0.0))
    prov = _provenance(runs, params, sources, track, sd_b, ratio, ratio_ci, sc, sd_s, f, radii)
    return ImuCalibration(
        params=new,
        old_params=params,
        track_width=track,
        track_width_ci95=_ci(track, sd_b),
        radius_ratio=ratio,
        radius_ratio_ci95=ratio_ci,
        yaw_scale=params.track_width / track,
        yaw_scale_ci95=_ci(params.track_width / track, sd_b),
        gyro_scale=sc.scale,
        gyro_scale_ci95=_ci(sc.scale, sd_s),
        scale_source=sc.source,
        bias=f.biases[0],
        bias_se=f.bias_ses[0],
        biases=f.biases,
        still_bias=still_bias,
        still_bias_se=still_se,
        still_s=still_s,
        offsets=tuple(f.offsets),
        radii_source=radii,
        ratio_note=f.ratio_note,
        turned_ccw=ccw,
        turned_cw=cw,
        windows=f.windows,
        residual_rms=math.sqrt(f.rss / max(f.windows, 1)),
        covariance=f.how_cov,
        runs=tuple(r.name for r in runs),
        a=(a_r, a_l),
        a_cov=((float(ca[0, 0]), float(ca[0, 1])), (float(ca[1, 0]), float(ca[1, 1]))),
        provenance=prov,
        bias_how=(
            "fitted jointly"
            if fit_bias
            else f"taken as {o.bias or 0.0:+g} +- {o.bias_sd:g} rad/s, not fitted"
        ),
    )


@dataclass(frozen=True)
class YawScaleFit:
    """The rotation ratio actual/predicted of ``params`` fitted to a reference heading (a lidar,
    a tracker), through the origin, one piece per segment, with its 95 % interval
    (clustered by segment group)."""

    yaw_scale: float
    ci95: tuple[float, float]
    pieces: int


def yaw_scale_from_heading(run: GyroRun, params: RobotParams) -> YawScaleFit:
    """Fit ``actual = k * predicted`` over each segment's span: the reference heading's change
    (up to its last update: a lidar's heading is held between scans) against the odometry's
    heading change with ``params``. The independent check of the gyro's ``yaw_scale``."""
    from odolab.core.regression import cluster_cov, ols

    xs, ys, groups = [], [], []
    for seg in run.segments:
        if seg.heading is None or seg.heading_t is None:
            continue
        h = seg.heading
        changed = np.flatnonzero(np.diff(h) != 0) + 1
        if changed.size == 0:
            continue
        t_end = float(seg.heading_t[int(changed[-1])])
        t0 = float(seg.heading_t[0])
        wr = np.interp([t0, t_end], seg.t, seg.right)
        wl = np.interp([t0, t_end], seg.t, seg.left)
        xs.append(
            (
                params.right_wheel_radius * (wr[1] - wr[0])
                - params.left_wheel_radius * (wl[1] - wl[0])
            )
            / params.track_width
        )
        ys.append(float(h[int(changed[-1])] - h[0]))
        groups.append(seg.group)
    if len(xs) < 3:
        raise CalibrationError(f"{run.source}: fewer than 3 pieces with a reference heading")
    design = np.array(xs)[:, None]
    fit = ols(np.array(ys), design)
    k = float(fit.params[0])
    se = float(np.sqrt(cluster_cov(fit, design, np.array(groups))[0, 0]))
    return YawScaleFit(k, (k - Z95 * se, k + Z95 * se), len(xs))
