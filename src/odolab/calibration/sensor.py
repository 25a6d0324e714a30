"""Odometry and an exteroceptive sensor calibrated together (Censi, Franchi, Marchionni, Oriolo,
"Simultaneous calibration of odometry and sensor parameters for mobile robots", IEEE T-RO 2013).

Unknowns: the wheel radii ``r_L``, ``r_R``, the track ``b`` and the sensor's pose on the robot
``l = (l_x, l_y, l_theta)`` (robot body frame: x forward, y left). Data: intervals ``k`` over which
the wheels turned by ``phi_L(t)``, ``phi_R(t)`` (rad, sampled by the encoders) and the sensor
measured its own relative motion ``s_k = (s_x, s_y, s_theta)`` (in its frame at the start of the
interval: a scan matcher's output, or two poses of a sensor trajectory).

With ``J21 = -r_L / b``, ``J22 = r_R / b`` the robot turns by ``o_theta = J21 Phi_L + J22 Phi_R``
over an interval (``Phi`` the wheel rotations), whatever the speed profile, and moves by
``o_t = (r_L c_L + r_R c_R) / 2`` with ``c_side = integral of (cos, sin)(theta(t)) dphi_side``
(``theta(t)`` the heading within the interval, known once J21, J22 are). The sensor sees
``s = l^-1 (+) o (+) l``, i.e. ``o_t + R(o_theta) l_t = l_t + R(l_theta) s_t``.

The estimate, as in the paper:

1. ``s_theta = J21 Phi_L + J22 Phi_R``: linear least squares for J21, J22.
2. With ``r_L = -b J21``, ``r_R = b J22``: ``o_t = b q`` with ``q = (-J21 c_L + J22 c_R) / 2``,
   and the translation constraint is linear in ``x = (b, l_x, l_y, cos l_theta, sin l_theta)``:
   ``L_k x = 0`` with ``L_k = [q_k, R(o_theta,k) - I, -[[s_x, -s_y], [s_y, s_x]]]`` (2x5).
   Minimise ``x^T M x`` (``M = sum L_k^T L_k``) subject to ``x_4^2 + x_5^2 = 1``. The Lagrange
   condition ``(M + lambda W) x = 0`` (``W = diag(0, 0, 0, 1, 1)``) has the closed form: with the
   Schur complement ``S = D - B^T A^-1 B`` of ``M = [[A, B], [B^T, D]]`` (A 3x3),
   ``(cos, sin)`` is the unit eigenvector of ``S`` of its smallest eigenvalue (the cost) and
   ``(b, l_x, l_y) = -A^-1 B (cos, sin)``; the sign is the one with ``b > 0``.
3. Outliers: intervals whose normalised squared residual exceeds the 99.9 % point of chi^2(3) are
   trimmed, the worst first (at most 5 % of the intervals per pass, ``max_outliers`` in all), and
   the fit is repeated until none is left.
4. The closed form is then refined by Gauss-Newton on all three residual components together
   (the maximum-likelihood estimate for independent Gaussian noise on ``s``, per-component
   variances estimated from the residuals), which the closed form starts close to.

Standard errors come from the Fisher information ``I = sum_k J_k^T Sigma^-1 J_k`` (``J_k`` the
derivative of the predicted ``s_k`` by the six parameters) at the estimate; ``I^-1`` is the
Cramér-Rao bound, which the maximum-likelihood estimate attains asymptotically: the
standard errors reported ARE the bound evaluated at the estimate with the estimated noise.
:func:`cramer_rao_bound` evaluates it at any parameters and noise (the true ones, in a study).

Identifiability is checked before any number is returned; each failure is one sentence naming
what the drive lacks (see :func:`check_identifiable`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.arrays import FloatArray, IntArray
from odolab.core.errors import CalibrationError, InsufficientDataError, opt
from odolab.core.kinematics import chord_factors, wrap_angle
from odolab.core.params import RobotParams
from odolab.core.trajectory import Trajectory

__all__ = [
    "PARAM_NAMES",
    "SensorCalibration",
    "SensorMotions",
    "SensorOptions",
    "calibrate_sensor",
    "check_identifiable",
    "closed_form",
    "cramer_rao_bound",
    "motions_from_trajectory",
    "predict_motions",
    "read_sensor_trajectory",
    "relative_motions",
    "robot_trajectory",
    "wheel_angles",
]

PARAM_NAMES = (
    "left_wheel_radius",
    "right_wheel_radius",
    "track_width",
    "sensor_x",
    "sensor_y",
    "sensor_yaw",
)
NO_ROTATION = "no rotation in place: the track is not identifiable"
NO_TRANSLATION = "no straight driving: the wheel radii and the sensor's yaw are not identifiable"
SINGULAR = "Matrix almost singular: drive more straight lines and turns of both signs"
CHI2_3_999 = 16.266236196238129  # 99.9 % point of chi^2 with 3 degrees of freedom


@dataclass(frozen=True, eq=False)
class SensorMotions:
    """Intervals of wheel rotation and the sensor's relative motion over each.

    ``t0``, ``t1``: shape (n,) start and end of each interval (s, encoder clock). ``motion``:
    (n, 3) the sensor's measured relative motion (x, y in its frame at ``t0``, m; theta, rad).
    ``dphi_left``, ``dphi_right``: (m,) wheel rotations (rad) of the encoder sub-steps inside the
    intervals, in time order; ``interval``: (m,) which interval each sub-step belongs to
    (non-decreasing). ``source`` names the data in messages.
    """

    t0: FloatArray
    t1: FloatArray
    motion: FloatArray
    dphi_left: FloatArray
    dphi_right: FloatArray
    interval: IntArray
    source: str = "sensor motions"

    def __post_init__(self) -> None:
        n = int(np.asarray(self.t0).size)
        motion = np.asarray(self.motion, dtype=np.float64).reshape(-1, 3)
        if motion.shape[0] != n or np.asarray(self.t1).size != n:
            raise CalibrationError(f"{self.source}: t0, t1 and motion differ in length")
        for name in ("dphi_left", "dphi_right", "motion"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if not np.all(np.isfinite(arr)):
                raise CalibrationError(f"{self.source}: {name} has a non-finite value")
        idx = np.asarray(self.interval, dtype=np.int64)
        if idx.size and (np.any(np.diff(idx) < 0) or idx[0] < 0 or idx[-1] >= n):
            raise CalibrationError(f"{self.source}: sub-step interval indices out of order")
        object.__setattr__(self, "motion", motion)
        object.__setattr__(self, "interval", idx)
        for name in ("t0", "t1", "dphi_left", "dphi_right"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))

    def __len__(self) -> int:
        return int(self.t0.size)

    def subset(self, keep: NDArray[np.bool_]) -> SensorMotions:
        """The intervals where ``keep`` (shape (n,)) is true, renumbered."""
        new_index = np.cumsum(keep) - 1
        sub = keep[self.interval]
        return SensorMotions(
            self.t0[keep],
            self.t1[keep],
            self.motion[keep],
            self.dphi_left[sub],
            self.dphi_right[sub],
            new_index[self.interval[sub]].astype(np.int64),
            self.source,
        )

    def wheel_totals(self) -> tuple[FloatArray, FloatArray]:
        """Total wheel rotation (rad) of each interval, left and right, shape (n,) each."""
        n = len(self)
        left = np.bincount(self.interval, self.dphi_left, minlength=n).astype(np.float64)
        right = np.bincount(self.interval, self.dphi_right, minlength=n).astype(np.float64)
        return left, right


def relative_motions(
    x: ArrayLike, y: ArrayLike, heading: ArrayLike, i: ArrayLike, j: ArrayLike
) -> FloatArray:
    """Relative motions ``pose_i^-1 (+) pose_j`` (shape (k, 3)) of a planar trajectory."""
    xa, ya, ha = (np.asarray(v, dtype=np.float64) for v in (x, y, heading))
    ii, jj = np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64)
    c, s = np.cos(ha[ii]), np.sin(ha[ii])
    dx, dy = xa[jj] - xa[ii], ya[jj] - ya[ii]
    return np.column_stack((c * dx + s * dy, -s * dx + c * dy, ha[jj] - ha[ii]))


def motions_from_trajectory(
    t: ArrayLike,
    phi_left: ArrayLike,
    phi_right: ArrayLike,
    sensor: Trajectory,
    *,
    interval_s: float = 0.5,
    time_offset: float = 0.0,
    source: str = "sensor trajectory",
) -> SensorMotions:
    """Intervals between sensor poses at least ``interval_s`` apart, with the wheel sub-steps.

    ``t``, ``phi_left``, ``phi_right``: encoder stamps (s) and cumulative wheel angles (rad),
    shape (n,). ``sensor``: the sensor's poses; its stamps minus ``time_offset`` (s, sensor clock
    minus encoder clock) are encoder time. Sensor poses outside the encoder log are dropped; the
    wheel angles are interpolated linearly at the sensor stamps.
    """
    te = np.asarray(t, dtype=np.float64)
    pl, pr = np.asarray(phi_left, dtype=np.float64), np.asarray(phi_right, dtype=np.float64)
    if not (math.isfinite(interval_s) and interval_s >= 0):
        raise CalibrationError(f"interval is {interval_s!r} s; expected a number of seconds >= 0")
    if not math.isfinite(time_offset):
        raise CalibrationError(f"time offset is {time_offset!r} s; expected a finite number")
    ts = sensor.t - time_offset
    inside = np.flatnonzero((ts >= te[0]) & (ts <= te[-1]))
    if inside.size < 2:
        raise InsufficientDataError(
            f"{source}: the sensor (encoder time {ts[0]:.3f} to {ts[-1]:.3f} s after the "
            f"{time_offset:g} s offset) and the encoder log ({te[0]:.3f} to {te[-1]:.3f} s) do "
            "not overlap; expected logs of the same drive (check {{time_offset}})"
        )
    # interval end points: sensor samples at least interval_s apart
    picks = [int(inside[0])]
    for k in inside[1:]:
        if ts[k] - ts[picks[-1]] >= interval_s - 1e-9 and ts[k] > ts[picks[-1]]:
            picks.append(int(k))
    ends = np.array(picks, dtype=np.int64)
    if ends.size < 2:
        raise InsufficientDataError(f"{source}: no interval of {interval_s:g} s in the overlap")
    tb = ts[ends]  # boundaries, encoder clock
    motion = relative_motions(sensor.x, sensor.y, sensor.heading, ends[:-1], ends[1:])
    # merged timeline: the boundaries and every encoder stamp strictly inside
    enc = te[(te > tb[0]) & (te < tb[-1])]
    grid = np.union1d(tb, enc)
    gl, gr = np.interp(grid, te, pl), np.interp(grid, te, pr)
    mid = 0.5 * (grid[1:] + grid[:-1])
    interval = np.searchsorted(tb, mid, side="right") - 1
    return SensorMotions(
        tb[:-1], tb[1:], motion, np.diff(gl), np.diff(gr), interval.astype(np.int64), source
    )


@dataclass(frozen=True)
class _Rotation:
    """Heading change and the integrals c_L, c_R (shape (n, 2)) of each interval."""

    o_theta: FloatArray
    c_left: FloatArray
    c_right: FloatArray


def _integrals(data: SensorMotions, j21: float, j22: float) -> _Rotation:
    n = len(data)
    dth = j21 * data.dphi_left + j22 * data.dphi_right
    before = np.cumsum(dth) - dth
    first = np.searchsorted(data.interval, np.arange(n))
    first_val = np.where(first < dth.size, before[np.minimum(first, dth.size - 1)], 0.0)
    th_mid = before - first_val[data.interval] + 0.5 * dth
    f = chord_factors(dth)  # sin(d/2) / (d/2): the exact arc of a constant-rate step
    cos, sin = f * np.cos(th_mid), f * np.sin(th_mid)
    idx = data.interval

    def bins(w: FloatArray) -> FloatArray:
        return np.bincount(idx, w, minlength=n).astype(np.float64)

    c_left = np.column_stack((bins(data.dphi_left * cos), bins(data.dphi_left * sin)))
    c_right = np.column_stack((bins(data.dphi_right * cos), bins(data.dphi_right * sin)))
    return _Rotation(bins(dth), c_left, c_right)


def predict_motions(theta: ArrayLike, data: SensorMotions) -> FloatArray:
    """The sensor's relative motions (n, 3) that parameters ``theta`` (the six of
    :data:`PARAM_NAMES`) predict from the wheel rotations."""
    rl, rr, b, lx, ly, lth = (float(v) for v in np.asarray(theta, dtype=np.float64))
    rot = _integrals(data, -rl / b, rr / b)
    ot = 0.5 * (rl * rot.c_left + rr * rot.c_right)
    co, so = np.cos(rot.o_theta), np.sin(rot.o_theta)
    # o (+) l - l, then rotated into the sensor frame
    px = ot[:, 0] + co * lx - so * ly - lx
    py = ot[:, 1] + so * lx + co * ly - ly
    cl, sl = math.cos(lth), math.sin(lth)
    return np.column_stack((cl * px + sl * py, -sl * px + cl * py, rot.o_theta))


def check_identifiable(data: SensorMotions, *, ratio: float = 1e-4, cond: float = 1e6) -> None:
    """Raise :class:`CalibrationError` with one sentence naming what the drive lacks.

    Wheel rotation of each interval split into driving (``Phi_L + Phi_R``) and turning
    (``Phi_R - Phi_L``): turning energy below ``ratio`` of driving is "no rotation in place",
    the reverse "no straight driving"; a condition number of the rotation fit's normal matrix
    above ``cond``, or a standard error of J21 or J22 above 20 % of its value (one curvature
    only: the radii and the track cannot be told apart), is the paper's "Matrix almost
    singular".
    """
    if len(data) < 6:
        raise InsufficientDataError(
            f"{data.source}: {len(data)} intervals for 6 parameters; expected a longer drive"
        )
    pl, pr = data.wheel_totals()
    drive = float(np.sum((pl + pr) ** 2))
    turn = float(np.sum((pr - pl) ** 2))
    if drive + turn == 0.0:
        raise CalibrationError(f"{data.source}: the wheels never turned; {SINGULAR}")
    if turn < ratio * drive:
        raise CalibrationError(f"{data.source}: {NO_ROTATION}")
    if drive < ratio * turn:
        raise CalibrationError(f"{data.source}: {NO_TRANSLATION}")
    g = np.array([[pl @ pl, pl @ pr], [pl @ pr, pr @ pr]])
    if np.linalg.cond(g) > cond:
        raise CalibrationError(f"{data.source}: {SINGULAR}")
    # the rotation fit's own standard errors: J21 and J22 each to better than 20 %
    a1 = np.column_stack((pl, pr))
    j, *_ = np.linalg.lstsq(a1, data.motion[:, 2], rcond=None)
    res = data.motion[:, 2] - a1 @ j
    s2 = float(res @ res) / max(len(data) - 2, 1)
    se = np.sqrt(s2 * np.diag(np.linalg.inv(g)))
    if np.any(se > 0.2 * np.abs(j)):
        raise CalibrationError(f"{data.source}: {SINGULAR}")


def closed_form(data: SensorMotions) -> tuple[FloatArray, float]:
    """The paper's closed-form estimate (the six parameters) and the step-2 cost."""
    pl, pr = data.wheel_totals()
    a1 = np.column_stack((pl, pr))
    (j21, j22), *_ = np.linalg.lstsq(a1, data.motion[:, 2], rcond=None)
    rot = _integrals(data, float(j21), float(j22))
    q = 0.5 * (-j21 * rot.c_left + j22 * rot.c_right)
    co, so = np.cos(rot.o_theta), np.sin(rot.o_theta)
    sx, sy = data.motion[:, 0], data.motion[:, 1]
    n = len(data)
    big = np.zeros((2 * n, 5))
    big[0::2] = np.column_stack((q[:, 0], co - 1.0, -so, -sx, sy))
    big[1::2] = np.column_stack((q[:, 1], so, co - 1.0, -sy, -sx))
    m = big.T @ big
    a, bm, d = m[:3, :3], m[:3, 3:], m[3:, 3:]
    scale = np.sqrt(np.diag(a))
    if not np.all(scale > 0):
        raise CalibrationError(f"{data.source}: {SINGULAR}")
    a_n = a / np.outer(scale, scale)
    if np.linalg.cond(a_n) > 1e10:
        raise CalibrationError(f"{data.source}: {SINGULAR}")
    a_inv_b = np.linalg.solve(a, bm)
    s = d - bm.T @ a_inv_b
    w, v = np.linalg.eigh(0.5 * (s + s.T))
    vec = v[:, 0]
    x3 = -a_inv_b @ vec
    if x3[0] < 0:
        x3, vec = -x3, -vec
    b = float(x3[0])
    if not b > 0:
        raise CalibrationError(f"{data.source}: {SINGULAR}")
    theta = np.array([-b * j21, b * j22, b, x3[1], x3[2], math.atan2(float(vec[1]), float(vec[0]))])
    return theta, float(w[0])


@dataclass(frozen=True)
class SensorOptions:
    """Settings: ``max_outliers`` (fraction of intervals that may be trimmed), ``gate``
    (normalised squared residual beyond which an interval is an outlier), ``refine`` (the
    maximum-likelihood Gauss-Newton step after the closed form)."""

    max_outliers: float = 0.2
    gate: float = CHI2_3_999
    refine: bool = True

    def __post_init__(self) -> None:
        if not (0.0 <= self.max_outliers < 1.0):
            raise CalibrationError(
                f"max_outliers is {self.max_outliers!r}; expected a fraction in [0, 1)"
            )
        if not (math.isfinite(self.gate) and self.gate > 0):
            raise CalibrationError(f"outlier gate is {self.gate!r}; expected a positive number")


@dataclass(frozen=True)
class SensorCalibration:
    """Result of :func:`calibrate_sensor` (SI units; ``sensor_*`` in the robot body frame)."""

    params: RobotParams
    nominal: RobotParams
    values: dict[str, float]
    stderr: dict[str, float]
    covariance: FloatArray
    closed_form: dict[str, float]
    noise_sigma: tuple[float, float, float]
    intervals: int
    outliers: int
    residual_rms: tuple[float, float, float]
    source: str = ""
    time_offset: float = 0.0
    extra: dict[str, object] = field(default_factory=dict)

    def provenance(self) -> dict[str, object]:
        """A ``[provenance]`` table for the saved parameters file."""
        return {
            "method": "Censi et al. 2013 simultaneous odometry and sensor calibration "
            "(odolab calibrate sensor)",
            "sensor": self.source,
            "intervals": self.intervals,
            "outliers_trimmed": self.outliers,
            "time_offset_s": self.time_offset,
            "sensor_pose": {
                "x": self.values["sensor_x"],
                "y": self.values["sensor_y"],
                "yaw": self.values["sensor_yaw"],
            },
            "stderr": self.stderr,
            "stderr_is": "Cramer-Rao bound at the estimate (inverse Fisher information, noise "
            "estimated from the residuals)",
            "noise_sigma": {
                "x": self.noise_sigma[0],
                "y": self.noise_sigma[1],
                "theta": self.noise_sigma[2],
            },
            "closed_form": self.closed_form,
            "nominal": self.nominal.to_dict(),
            **self.extra,
        }

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict: parameters, values, standard errors and the provenance."""
        return {
            "params": self.params.to_dict(),
            "values": self.values,
            "crb": self.stderr,
            **self.provenance(),
        }


def _jacobian(theta: FloatArray, data: SensorMotions) -> FloatArray:
    """d predict / d theta, shape (3n, 6) (rows x0, y0, th0, x1, ...), central differences."""
    steps = np.array([1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6]) * np.maximum(np.abs(theta), 1e-2)
    cols = []
    for k, h in enumerate(steps):
        e = np.zeros(6)
        e[k] = h
        cols.append(
            (
                (predict_motions(theta + e, data) - predict_motions(theta - e, data)) / (2 * h)
            ).reshape(-1)
        )
    return np.column_stack(cols)


def cramer_rao_bound(
    theta: ArrayLike, data: SensorMotions, sigma: tuple[float, float, float]
) -> FloatArray:
    """The Cramér-Rao bound (6x6 covariance) for independent Gaussian noise of standard
    deviations ``sigma`` (x, y m; theta rad) on each interval's sensor motion."""
    th = np.asarray(theta, dtype=np.float64)
    jm = _jacobian(th, data)
    w = np.tile(1.0 / np.asarray(sigma, dtype=np.float64) ** 2, len(data))
    info = jm.T @ (jm * w[:, None])
    return np.asarray(np.linalg.inv(info), dtype=np.float64)


def _sigma(res: FloatArray, dof: int) -> FloatArray:
    n = res.shape[0]
    scale = (3 * n) / max(3 * n - dof, 1)
    return np.asarray(np.sqrt(np.mean(res**2, axis=0) * scale), dtype=np.float64)


def _refine(theta: FloatArray, data: SensorMotions, sigma: FloatArray) -> FloatArray:
    from scipy.optimize import least_squares

    def fun(p: FloatArray) -> FloatArray:
        return ((data.motion - predict_motions(p, data)) / sigma).reshape(-1)

    def jac(p: FloatArray) -> FloatArray:
        return -_jacobian(p, data) / np.tile(sigma, len(data))[:, None]

    sol = least_squares(fun, theta, jac=jac, method="lm", x_scale="jac")
    return np.asarray(sol.x, dtype=np.float64)


def _robust_sigma(res: FloatArray) -> FloatArray:
    med = np.median(res, axis=0)
    mad = 1.4826 * np.median(np.abs(res - med), axis=0)
    rms = np.sqrt(np.mean(res**2, axis=0))
    return np.asarray(np.where(mad > 0, mad, np.maximum(rms, 1e-12)), dtype=np.float64)


def calibrate_sensor(
    data: SensorMotions,
    nominal: RobotParams,
    options: SensorOptions | None = None,
    *,
    time_offset: float = 0.0,
) -> SensorCalibration:
    """Wheel radii, track and the sensor's pose from ``data`` (see the module docstring).

    ``nominal`` supplies what the fit does not change (ticks per revolution, the counter modulus,
    the name). Raises :class:`CalibrationError` naming what the drive lacks when a parameter is
    not identifiable.
    """
    o = options or SensorOptions()
    check_identifiable(data)
    n_all = len(data)
    keep = np.ones(n_all, dtype=bool)
    budget = math.floor(o.max_outliers * n_all)
    per_pass = max(1, math.ceil(0.05 * n_all))
    current = data
    while True:
        theta, _ = closed_form(current)
        res = current.motion - predict_motions(theta, current)
        chi = np.sum((res / _robust_sigma(res)) ** 2, axis=1)
        bad = np.flatnonzero(chi > o.gate)
        left = budget - int(n_all - keep.sum())
        if bad.size == 0 or left <= 0:
            break
        worst = bad[np.argsort(chi[bad])[::-1][: min(per_pass, left)]]
        kept_idx = np.flatnonzero(keep)
        keep[kept_idx[worst]] = False
        current = data.subset(keep)
        check_identifiable(current)
    cf = theta.copy()
    sigma = _sigma(current.motion - predict_motions(theta, current), 6)
    if o.refine:
        for _ in range(2):  # refit with the noise of the refined residuals
            theta = _refine(theta, current, sigma)
            sigma = _sigma(current.motion - predict_motions(theta, current), 6)
    if theta[0] <= 0 or theta[1] <= 0 or theta[2] <= 0:
        raise CalibrationError(
            f"{data.source}: the fit gives a wheel radius or track of {min(theta[:3]):.4g} m "
            "(not positive); expected the sensor's motion in its own frame (x forward) on the "
            "encoder log's clock (check {{time_offset}} and the wheel sides)"
        )
    cov = cramer_rao_bound(theta, current, (float(sigma[0]), float(sigma[1]), float(sigma[2])))
    se = np.sqrt(np.diag(cov))
    res = current.motion - predict_motions(theta, current)
    values = {k: float(v) for k, v in zip(PARAM_NAMES, theta, strict=True)}
    values["sensor_yaw"] = float(wrap_angle(values["sensor_yaw"]))
    params = nominal.with_(
        left_wheel_radius=values["left_wheel_radius"],
        right_wheel_radius=values["right_wheel_radius"],
        track_width=values["track_width"],
        name=f"{nominal.name}-sensor",
    )
    return SensorCalibration(
        params=params,
        nominal=nominal,
        values=values,
        stderr={k: float(v) for k, v in zip(PARAM_NAMES, se, strict=True)},
        covariance=cov,
        closed_form={k: float(v) for k, v in zip(PARAM_NAMES, cf, strict=True)},
        noise_sigma=(float(sigma[0]), float(sigma[1]), float(sigma[2])),
        intervals=len(current),
        outliers=n_all - len(current),
        residual_rms=tuple(float(v) for v in np.sqrt(np.mean(res**2, axis=0))),  # type: ignore[arg-type]
        source=data.source,
        time_offset=time_offset,
    )


def wheel_angles(
    dticks_left: ArrayLike, dticks_right: ArrayLike, ticks_per_rev: float
) -> tuple[FloatArray, FloatArray]:
    """Cumulative wheel angles (rad, from 0) from per-sample count increments."""
    k = 2.0 * math.pi / ticks_per_rev
    dl = np.asarray(dticks_left, dtype=np.float64).copy()
    dr = np.asarray(dticks_right, dtype=np.float64).copy()
    dl[0] = dr[0] = 0.0
    return np.cumsum(dl) * k, np.cumsum(dr) * k


def read_sensor_trajectory(path: str | Path, topic: str | None = None) -> Trajectory:
    """The sensor's poses: a ROS bag topic (PoseStamped / Odometry) when ``topic`` is given or
    the path is a bag, else a trajectory file (CSV ``t,x,y,theta`` / ``t,x,y,heading``, TUM)."""
    from odolab.io.registry import read_trajectory
    from odolab.io.rosbag import read_bag_trajectory

    p = Path(path)
    is_bag = p.suffix in (".bag", ".mcap", ".db3") or (p / "metadata.yaml").is_file()
    if topic is not None or is_bag:
        if topic is None:
            raise CalibrationError(
                f"{p}: is a bag; expected the sensor's pose topic ({opt('sensor_topic')})"
            )
        return read_bag_trajectory(p, topic)
    return read_trajectory(p)


def robot_trajectory(
    sensor: Trajectory, mount: tuple[float, float, float], time_offset: float = 0.0
) -> Trajectory:
    """The robot centre's path from the sensor's: each pose composed with the inverse of the
    sensor's ``mount = (x, y, yaw)`` on the robot, stamps moved onto the encoder clock (minus
    ``time_offset``, the sensor clock minus the encoder clock). Ground truth for
    ``calibrate lsq`` and ``evaluate`` in the sensor's own frame."""
    lx, ly, lyaw = (float(v) for v in mount)
    if not all(math.isfinite(v) for v in (lx, ly, lyaw, time_offset)):
        raise CalibrationError(f"sensor mount {mount!r} and offset {time_offset!r} must be finite")
    h = sensor.heading - lyaw
    c, s = np.cos(h), np.sin(h)
    x = sensor.x - (c * lx - s * ly)
    y = sensor.y - (s * lx + c * ly)
    return Trajectory.from_xyh(sensor.t - time_offset, x, y, h)
