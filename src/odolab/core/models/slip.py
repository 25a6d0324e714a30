"""A slip-aware model: the body's slip as a function of the measured track speeds.

After DRIVE (Baril et al., ICRA 2024): the differential drive of the ``[robot]`` table gives the
commanded body speeds from the measured track speeds ``v_l = ds_l / dt``, ``v_r = ds_r / dt``::

    v = (v_l + v_r) / 2          w = (v_r - v_l) / track_width

and the body's true velocity is that plus a slip that is linear in a small basis of them::

    v_x = v + phi . beta_fwd     v_y = phi . beta_lat     omega = w + phi . beta_yaw
    phi = (v, w, |v|, |w|, v|v|, v|w|, w|v|, w|w|)          (SI units: m/s, rad/s)

The terms of degree one are what the ICR model fits (per-side scales, the turning track, the
sideways offset) and, with ``|v|`` and ``|w|``, a robot that drives differently forward and in
reverse (the lab's forward and reverse ratios); the quadratic ones let the slip grow with speed
and turn rate (a tracked robot turns less at speed). One cycle of ``dt`` seconds moves the body by ``dt`` times these
velocities; a cycle of zero duration has no quadratic terms. The coefficients come from Bayesian
linear regression on runs with ground truth (:mod:`odolab.calibration.slipfit`), which also gives
the noise of the slip: a white body-velocity noise of spectral density ``q_fwd``, ``q_lat``
(m^2/s) and ``q_yaw`` (rad^2/s) plus a noise per metre of track travel ``k_fwd``, ``k_lat``
(m^2/m) and per radian of commanded turn ``k_yaw`` (rad^2/rad: the lab's turn scrub), so a
cycle's body motion has variance ``q dt + k L`` on top of the posterior variance of
``phi . beta`` (:meth:`SlipModel.step_variance`). The drift terms ``d_fwd``, ``d_lat`` (m^2/m^2),
``d_yaw`` (rad^2/m^2) and ``d_turn`` (rad^2/rad^2) are the variances of a slip error that
persists (per metre of track travel; per radian of turn): one value over a whole stretch, not
a new one every cycle (:mod:`odolab.core.slip_uncertainty` propagates all of them).

In a parameters file the ``[model]`` table has ``kind = "slip"``, the 24 coefficients
``fwd_v``, ``fwd_w``, ..., ``yaw_w_absw`` (missing ones are 0), the six noise terms ``q_*``,
``k_*``, the four drift terms ``d_*`` (missing ones are 0: a file written before they existed
reads as it did), and ``posterior``, the coefficients' posterior covariance (576 numbers, row-major;
optional: without it the predictive variance has the noise part only). The notebook keeps a
parameter set's coefficients and noise terms, not its posterior.

Everything that uses a model's six linear coefficients (the covariance stepper, the virtual
board's truth, the ROS 2 export) sees the linear part of this model (:meth:`coefficients`);
batch and streaming odometry integrate the whole model.

This module imports neither numpy nor numba (numpy is imported inside the array functions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from odolab.core.errors import ParamsError
from odolab.core.models.base import ModelCoefficients, check_number
from odolab.core.models.registry import register
from odolab.core.models.slip_terms import (
    _COEF_KEYS,
    _NOISE_KEYS,
    DRIFT_KEYS,
    FEATURES,
    KIND,
    NOISE_KEYS,
    OUTPUTS,
    TURN_CYCLES,
    _features,
)

if TYPE_CHECKING:
    from collections.abc import Iterable

    import numpy as np
    from numpy.typing import NDArray

    from odolab.core.models.base import RobotLike
    from odolab.core.models.slip_covariance import SlipCovarianceStepper


__all__ = ["DRIFT_KEYS", "FEATURES", "NOISE_KEYS", "OUTPUTS", "TURN_CYCLES", "SlipModel"]


def _check_posterior(values: tuple[float, ...], k: int, limit: float) -> None:
    """A posterior covariance (``k`` x ``k``, row-major) must be one: every value finite, the
    matrix symmetric and positive semi-definite, no variance beyond ``limit`` squared (a
    negative variance gave negative covariances on /odom and in the odometry's output)."""
    import numpy as np

    m = np.asarray(values, dtype=np.float64).reshape(k, k)
    if not np.all(np.isfinite(m)):
        raise ParamsError("posterior has a value that is not a finite number")
    scale = max(float(np.max(np.abs(np.diag(m)))), 1e-300)
    worst = np.unravel_index(int(np.argmax(np.abs(m - m.T))), m.shape)
    if abs(m[worst] - m[worst[::-1]]) > 1e-6 * scale:  # an inverse is symmetric to rounding
        i, j = (int(x) for x in worst)
        raise ParamsError(
            f"posterior is not symmetric (entry {i},{j} is {m[i, j]:.6g}, entry {j},{i} "
            f"{m[j, i]:.6g}); expected a covariance matrix"
        )
    d = np.diag(m)
    if np.any(d < 0) or np.any(d > limit**2):
        i = int(np.argmax((d < 0) | (d > limit**2)))
        raise ParamsError(
            f"posterior variance of {_COEF_KEYS[i]} is {d[i]:.6g}; expected 0 to {limit**2:g}"
        )
    low = float(np.linalg.eigvalsh(0.5 * (m + m.T))[0])
    if low < -1e-9 * scale:
        raise ParamsError(
            f"posterior is not positive semi-definite (smallest eigenvalue {low:.6g}); expected "
            "a covariance matrix"
        )


@register
@dataclass(frozen=True)
class SlipModel:
    """Differential drive plus body slip linear in a basis of the measured speeds (see module)."""

    fwd_v: float = 0.0
    fwd_w: float = 0.0
    fwd_absv: float = 0.0
    fwd_absw: float = 0.0
    fwd_v_absv: float = 0.0
    fwd_v_absw: float = 0.0
    fwd_w_absv: float = 0.0
    fwd_w_absw: float = 0.0
    lat_v: float = 0.0
    lat_w: float = 0.0
    lat_absv: float = 0.0
    lat_absw: float = 0.0
    lat_v_absv: float = 0.0
    lat_v_absw: float = 0.0
    lat_w_absv: float = 0.0
    lat_w_absw: float = 0.0
    yaw_v: float = 0.0
    yaw_w: float = 0.0
    yaw_absv: float = 0.0
    yaw_absw: float = 0.0
    yaw_v_absv: float = 0.0
    yaw_v_absw: float = 0.0
    yaw_w_absv: float = 0.0
    yaw_w_absw: float = 0.0
    q_fwd: float = 0.0
    q_lat: float = 0.0
    q_yaw: float = 0.0
    k_fwd: float = 0.0
    k_lat: float = 0.0
    k_yaw: float = 0.0
    d_fwd: float = 0.0
    d_lat: float = 0.0
    d_yaw: float = 0.0
    d_turn: float = 0.0
    #: posterior covariance of the coefficients, row-major 24 x 24 in :data:`KEYS` order (empty:
    #: unknown); not part of the ``[model]`` table
    posterior: tuple[float, ...] = field(default=(), compare=False, repr=False)
    kind: ClassVar[str] = KIND
    #: its body motion depends on each cycle's duration (:class:`odolab.core.models.TimedModel`)
    time_dependent: ClassVar[bool] = True
    #: it carries its own pose covariance (:class:`odolab.core.models.CovarianceModel`), by this name
    covariance_name: ClassVar[str] = KIND
    KEYS: ClassVar[tuple[str, ...]] = (*_COEF_KEYS, *_NOISE_KEYS, *DRIFT_KEYS)
    COEF_KEYS: ClassVar[tuple[str, ...]] = _COEF_KEYS
    #: a slip coefficient beyond this size (in SI units of its feature) is a wrong file, not slip
    LIMIT: ClassVar[float] = 100.0
    #: a variance term (q_*, k_*, d_*) beyond this is a wrong file: a heading variance of 100
    #: rad^2 per second, metre or radian leaves nothing known of the pose
    VARIANCE_LIMIT: ClassVar[float] = 100.0

    def __post_init__(self) -> None:
        for key in self.KEYS:
            value = getattr(self, key)
            check_number(key, value)
            if key in _NOISE_KEYS and value < 0:
                raise ParamsError(f"{key} must be >= 0 (a noise spectral density), got {value!r}")
            if key in DRIFT_KEYS and value < 0:
                raise ParamsError(f"{key} must be >= 0 (a drift variance), got {value!r}")
            if key in (*_NOISE_KEYS, *DRIFT_KEYS) and value > self.VARIANCE_LIMIT:
                raise ParamsError(
                    f"{key} = {value:.6g} is outside the plausible 0 to {self.VARIANCE_LIMIT:g} "
                    "(a variance term in SI units: larger would be no odometry at all)"
                )
            if key in _COEF_KEYS and abs(value) > self.LIMIT:
                raise ParamsError(
                    f"{key} = {value:.6g} is outside the plausible -{self.LIMIT:g} to "
                    f"{self.LIMIT:g} (a slip coefficient in SI units)"
                )
            object.__setattr__(self, key, float(value))
        k = len(_COEF_KEYS)
        if self.posterior and len(self.posterior) != k * k:
            raise ParamsError(
                f"posterior has {len(self.posterior)} values; expected {k * k} ({k} x {k})"
            )
        object.__setattr__(self, "posterior", tuple(float(v) for v in self.posterior))
        if self.posterior:
            _check_posterior(self.posterior, k, self.LIMIT)

    # -- the KinematicModel protocol ------------------------------------------------------------

    def coefficients(self, track_width: float) -> ModelCoefficients:
        """The model's linear part (its ``v`` and ``w`` terms; no sideways motion)."""
        b = float(track_width)
        a = 1.0 + self.fwd_v
        c = 1.0 + self.yaw_w
        return ModelCoefficients(
            0.5 * a - self.fwd_w / b,
            0.5 * a + self.fwd_w / b,
            c / b - 0.5 * self.yaw_v,
            c / b + 0.5 * self.yaw_v,
            1.0,
            0.0,
        )

    def to_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in self.KEYS}

    @property
    def is_differential_drive(self) -> bool:
        return all(getattr(self, k) == 0.0 for k in _COEF_KEYS)

    def words(self) -> str:
        """The model in words (:func:`odolab.core.models.model_words`): its largest coefficients and
        its variance terms."""
        table = self.to_dict()
        coefs = sorted(self.COEF_KEYS, key=lambda k: -abs(table[k]))
        big = ", ".join(f"{k} {table[k]:.3g}" for k in coefs[:3] if table[k])
        terms = [k for k in self.KEYS if k not in coefs and table[k] >= 1e-6]
        shown = ", ".join(f"{k} {table[k]:.3g}" for k in terms) or "none"
        return (
            f"slip (24 coefficients, the largest {big or 'all 0'}; variance terms "
            f"{shown}, those under 1e-6 not shown; every value is in the parameters "
            "file)"
        )

    # -- the TimedModel capability --------------------------------------------------------------

    @property
    def is_linear(self) -> bool:
        """True when only the ``v`` and ``w`` terms of the forward and yaw outputs are not 0:
        then :meth:`coefficients` is the whole model."""
        return all(
            getattr(self, k) == 0.0
            for k in self.COEF_KEYS
            if k.startswith("lat_") or k.split("_", 1)[1] not in ("v", "w")
        )

    # -- the CovarianceModel capability (odolab.core.models.slip_covariance) -------------------------

    def describe_covariance(self) -> str:
        """What the covariance is made of, in words (:func:`slip_covariance.describe_covariance`)."""
        from odolab.core.models.slip_covariance import describe_covariance

        return describe_covariance(self)

    def covariance_stepper(self, params: RobotLike) -> SlipCovarianceStepper:
        """The covariance one cycle at a time (:class:`slip_covariance.SlipCovarianceStepper`)."""
        from odolab.core.models.slip_covariance import SlipCovarianceStepper

        return SlipCovarianceStepper(params)

    def propagate_covariance(
        self,
        t: NDArray[np.float64],
        dticks_left: NDArray[np.float64],
        dticks_right: NDArray[np.float64],
        params: RobotLike,
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Poses and covariance along a run (:func:`slip_covariance.propagate_covariance`)."""
        from odolab.core.models.slip_covariance import propagate_covariance

        return propagate_covariance(t, dticks_left, dticks_right, params, start)

    def pose_covariance(
        self,
        t: NDArray[np.float64],
        ds_left: NDArray[np.float64],
        ds_right: NDArray[np.float64],
        params: RobotLike,
        start: tuple[float, float, float],
    ) -> NDArray[np.float64]:
        """The pose covariance (n, 3, 3) along a stretch of track motion (m per cycle)."""
        from odolab.core.models.slip_covariance import propagate_terms, terms_of

        return propagate_terms(t, ds_left, ds_right, params, start).covariance(terms_of(self))

    def straight_turn_sd(self, speed: float) -> float | None:
        """The posterior standard deviation (rad per metre) of the heading change of a straight
        run at ``speed`` m/s; None without a posterior."""
        if not self.posterior:
            return None
        import numpy as np

        k = len(FEATURES)
        phi = np.zeros(3 * k)  # the yaw output's basis on a straight run at ``speed``
        phi[2 * k : 3 * k] = self.features(np.array([speed]), np.array([0.0]))[:, 0]
        post = np.asarray(self.posterior).reshape(3 * k, 3 * k)
        return math.sqrt(max(float(phi @ post @ phi), 0.0)) / speed

    # -- the model itself -----------------------------------------------------------------------

    def beta(self, output: str) -> tuple[float, ...]:
        """The coefficients of one output (``fwd``, ``lat``, ``yaw``) in :data:`FEATURES` order."""
        return tuple(float(getattr(self, f"{output}_{f}")) for f in FEATURES)

    def body_motion(
        self, ds_left: float, ds_right: float, dt: float, track_width: float
    ) -> tuple[float, float, float]:
        """(d_forward, d_lateral, d_theta) of one cycle of ``dt`` s (streaming odometry)."""
        ds = 0.5 * (ds_left + ds_right)
        dth = (ds_right - ds_left) / track_width
        if dt > 0.0:
            phi = _features(ds / dt, dth / dt)
        else:  # no time: only the linear terms (dt * v = ds)
            phi = (ds, dth, abs(ds), abs(dth), 0.0, 0.0, 0.0, 0.0)
            dt = 1.0
        out = []
        for o in OUTPUTS:
            b = self.beta(o)
            out.append(dt * sum(p * c for p, c in zip(phi, b, strict=True)))
        return ds + out[0], out[1], dth + out[2]

    def body_motion_arrays(
        self,
        ds_left: NDArray[np.float64],
        ds_right: NDArray[np.float64],
        dt: NDArray[np.float64],
        track_width: float,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`body_motion` for arrays of cycles (batch odometry)."""
        import numpy as np

        ds = 0.5 * (ds_left + ds_right)
        dth = (ds_right - ds_left) / track_width
        timed = dt > 0.0
        tt = np.where(timed, dt, 1.0)
        phi = self.features(ds / tt, dth / tt)
        phi[4:, ~timed] = 0.0
        out = [tt * (np.array(self.beta(o)) @ phi) for o in OUTPUTS]
        return ds + out[0], out[1], dth + out[2]

    @staticmethod
    def features(v: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
        """The basis at speeds ``v`` (m/s) and turn rates ``w`` (rad/s): shape (8, n)."""
        import numpy as np

        av, aw = np.abs(v), np.abs(w)
        return np.array([v, w, av, aw, v * av, v * aw, w * av, w * aw], dtype=np.float64)

    @staticmethod
    def noise_multipliers(
        ds_left: NDArray[np.float64],
        ds_right: NDArray[np.float64],
        dt: NDArray[np.float64],
        track_width: float,
        tick_turn: float = 0.0,
    ) -> NDArray[np.float64]:
        """What each noise term (``q_fwd, q_lat, q_yaw, k_fwd, k_lat, k_yaw``) is multiplied by
        in each cycle's variance, shape (n, 6): the duration ``dt`` (three times), the track
        travel ``(|ds_l| + |ds_r|) / 2`` (twice) and the commanded turn. The turn is the
        magnitude of the turn of the last :data:`TURN_CYCLES` cycles (this one included; none
        before the first) averaged: on a straight drive the encoders' last count flickers
        between the sides, and taken cycle by cycle that flicker would add up to a turn the
        robot never made. The average looks back only, so that streaming odometry, which has
        no later cycles yet, gives the same. ``tick_turn`` (rad): the turn of one count of
        either encoder; so much of the averaged turn (one count over the cycles averaged) is
        taken as that flicker, not as turning."""
        import numpy as np

        dt = np.asarray(dt, dtype=np.float64)
        tt = np.where(dt > 0.0, dt, 0.0)
        travel = 0.5 * (np.abs(ds_left) + np.abs(ds_right))
        dth = (np.asarray(ds_right, dtype=np.float64) - ds_left) / track_width
        c = np.concatenate(([0.0], np.cumsum(dth)))
        back = np.maximum(np.arange(dth.size) + 1 - TURN_CYCLES, 0)
        mean = (c[1:] - c[back]) / TURN_CYCLES
        turn = np.maximum(np.abs(mean) - tick_turn / TURN_CYCLES, 0.0)
        return np.column_stack((tt, tt, tt, travel, travel, turn))

    @staticmethod
    def turn_multiplier(recent_turns: Iterable[float], tick_turn: float = 0.0) -> float:
        """:meth:`noise_multipliers`' turn for one cycle from the turns (rad) of the last
        :data:`TURN_CYCLES` cycles, this one last (fewer at the start): streaming odometry's."""
        return float(max(abs(sum(recent_turns)) / TURN_CYCLES - tick_turn / TURN_CYCLES, 0.0))

    @staticmethod
    def drift_multipliers(
        ds_left: NDArray[np.float64], ds_right: NDArray[np.float64], track_width: float
    ) -> NDArray[np.float64]:
        """What each drift rate (``d_fwd, d_lat, d_yaw, d_turn``; their variances are the
        model's drift terms) is multiplied by in each cycle's motion, shape (n, 4): the track
        travel ``(|ds_l| + |ds_r|) / 2`` (three times) and the turn ``|ds_r - ds_l| / b``."""
        import numpy as np

        travel = 0.5 * (np.abs(ds_left) + np.abs(ds_right))
        turn = np.abs(np.asarray(ds_right, dtype=np.float64) - ds_left) / track_width
        return np.column_stack((travel, travel, travel, turn))

    def step_variance(
        self,
        ds_left: NDArray[np.float64],
        ds_right: NDArray[np.float64],
        dt: NDArray[np.float64],
        track_width: float,
        tick_turn: float = 0.0,
    ) -> NDArray[np.float64]:
        """Predictive variance of each cycle's body motion (d_forward, d_lateral, d_theta):
        shape (n, 3), ``q dt + k L`` (:meth:`noise_multipliers`; ``L`` the track travel, m, or
        for the heading the commanded turn, rad) plus ``dt^2 phi^T Sigma phi`` where the
        posterior is known. The drift terms are left out: they are not a cycle's own."""
        import numpy as np

        dt = np.asarray(dt, dtype=np.float64)
        tt = np.where(dt > 0.0, dt, 0.0)
        safe = np.where(dt > 0.0, dt, 1.0)
        ds = 0.5 * (ds_left + ds_right)
        dth = (ds_right - ds_left) / track_width
        phi = self.features(ds / safe, dth / safe)
        mult = self.noise_multipliers(ds_left, ds_right, dt, track_width, tick_turn)
        terms = np.array([getattr(self, key) for key in _NOISE_KEYS])
        var = mult[:, :3] * terms[:3] + mult[:, 3:] * terms[3:]
        if self.posterior:
            k = len(FEATURES)
            sigma = np.array(self.posterior).reshape(3 * k, 3 * k)
            for j in range(3):
                s = sigma[j * k : (j + 1) * k, j * k : (j + 1) * k]
                var[:, j] += tt**2 * np.einsum("in,ij,jn->n", phi, s, phi)
        return np.asarray(var, dtype=np.float64)

    def speed_slip(self, v: float) -> float:
        """Longitudinal slip ``1 - v_x / v`` when driving straight at ``v`` m/s."""
        if v == 0.0:
            raise ParamsError("speed_slip needs a speed other than 0 m/s")
        b = self.beta("fwd")
        return -(b[0] * v + b[2] * abs(v) + b[4] * v * abs(v)) / v

    def speed_slip_gain(self, v_low: float, v_high: float) -> tuple[float, float, float]:
        """How much more the robot slips driving straight at ``v_high`` than at ``v_low``
        (both m/s, same sign): ``speed_slip(v_high) - speed_slip(v_low)``, with its 95 %
        interval from the posterior (nan bounds without one). The lab's speed question."""
        if v_low == 0.0 or v_high == 0.0 or (v_low > 0) != (v_high > 0):
            raise ParamsError(
                f"speed_slip_gain needs two speeds of the same sign, got {v_low} and {v_high} m/s"
            )
        gain = self.speed_slip(v_high) - self.speed_slip(v_low)
        if not self.posterior:
            return gain, math.nan, math.nan
        k = len(_COEF_KEYS)
        i = _COEF_KEYS.index("fwd_v_absv")
        se = abs(abs(v_high) - abs(v_low)) * math.sqrt(max(self.posterior[i * k + i], 0.0))
        return gain, gain - 1.96 * se, gain + 1.96 * se
