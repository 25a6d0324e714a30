"""The slip coefficients from runs whose ground truth is noisy: an extended Kalman filter.

The regression of :mod:`odolab.calibration.slipfit` differences the truth over short windows and
turns each cycle's motion by the truth's own heading; with a truth of centimetres and a tenth of
a radian (a lidar's scan matcher, a tracker, GNSS) both are noisy, and the coefficients it finds
extrapolate badly (docs/models.md). Here the truth is what it is, a measurement of the pose, and
the pose is a hidden state (Martinelli, Tomatis and Siegwart's augmented Kalman filter, 2007):
the state is the pose (x, y, heading) and the 24 slip coefficients; each cycle moves the pose by
the slip model's motion at the current coefficients (:mod:`odolab.core.models.slip`, midpoint
heading), with a variance the model leaves unexplained; each real update of the truth
(:func:`odolab.metrics.truthnoise.real_updates`) measures the pose with the truth's noise.
The coefficients start at the kinematic model the regression's prior is centred on, with the
regression's weak prior, and carry over from run to run (each run's pose starts at its truth).
What the filter ends with is their posterior given every update, with the poses marginalised:
the heading comes from the model's own integration, so the truth's heading noise turns no
cycle's motion, and the positions tell of the heading coefficients too. An update the filter's
own prediction rules out (beyond the 99.9 % of its innovation's chi-square,
:data:`odolab.calibration._slipfilter_jit.GATE`) is a scan matcher's glitch, and is not taken;
in the likelihood it counts by Huber's loss on its distance. The covariance is updated in
Joseph's form, which stays a covariance when the truth is far more precise than the prediction.

The variance a cycle's motion is given: the regression's white and per-metre window noise
(``q dt + k L``; :meth:`odolab.core.models.slip.SlipModel.noise_multipliers`), plus, out of
steady state (the measured speeds still changing: the regression's rule,
:func:`odolab.calibration.slipfit.steady_cycles`),
:data:`UNSTEADY` times the cycle's own motion squared: after a change of command the body lags its
tracks, which no function of the speeds describes, so those cycles teach the coefficients little;
all of that times one scale, chosen by the likelihood of the truth's updates (:data:`SCALES`,
then halfway steps about the best), which is how much the model's noise the data show.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.models.slip import FEATURES, SlipModel
from odolab.core.params import RobotParams
from odolab.metrics.truthnoise import TruthNoise, real_updates

__all__ = ["SCALES", "UNSTEADY", "FilterFit", "RunCycles", "filter_coefficients", "run_cycles"]

#: Which cycles are in steady state, from their times, speeds and turn rates.
SteadyRule = Callable[[FloatArray, FloatArray, FloatArray], NDArray[np.bool_]]
#: Out of steady state a cycle's motion varies by this share of its own size (as a variance:
#: share times the motion squared).
UNSTEADY = 1.0
#: The process noise's scales tried (the best, then the scales a factor of two either side).
SCALES: tuple[float, ...] = tuple(float(2.0**e) for e in range(-12, 13, 2))
#: The least noise taken for the truth (m, rad): a truth without any is a measurement too.
TRUTH_FLOOR = (1e-4, 1e-4)
#: The least per-metre (m^2/m) and per-radian (rad^2/rad) noise taken for the model.
NOISE_FLOOR = 1e-8


@dataclass(frozen=True, eq=False)
class FilterFit:
    """What the filter found: the coefficients (:attr:`SlipModel.COEF_KEYS` order), their 24 x 24
    posterior covariance, the model noise's scale, and how many of the truth's updates it took
    and left out as glitches."""

    beta: FloatArray
    cov: FloatArray
    scale: float
    updates: int
    glitches: int


@dataclass(frozen=True)
class _Cycles:
    """Every run's cycles, one after the other."""

    ds: FloatArray
    dth: FloatArray
    phi: FloatArray  # (cycles, 8): the basis times the duration
    base: FloatArray  # (cycles, 6): noise_multipliers
    motion: FloatArray  # (cycles, 3): the unsteady allowance per unit share (0 in steady state)
    start: NDArray[np.bool_]
    meas: NDArray[np.bool_]
    truth: FloatArray  # (cycles, 3)

    def variances(self, noise: FloatArray, scale: float) -> FloatArray:
        """(cycles, 3): each cycle's forward, lateral and yaw variance at ``scale``."""
        q = self.base * noise[None, :]
        model = np.column_stack((q[:, 0] + q[:, 3], q[:, 1] + q[:, 4], q[:, 2] + q[:, 5]))
        return np.ascontiguousarray(scale * (model + UNSTEADY * self.motion))


@dataclass(frozen=True)
class RunCycles:
    """One prepared run's cycles as the slip fits read them: stamps, each side's travel ``dsl``,
    ``dsr`` (m), the commanded forward motion ``ds`` and turn ``dth`` (the first cycle's 0),
    durations ``dt`` (``tt``: 1 where a cycle has none, ``timed`` where it has), the basis
    ``phi`` (8, cycles) at the measured speeds (the first cycle's 0, the quadratic terms 0
    without a duration), the noise terms' multipliers ``mult`` (cycles, 6), and the truth at the
    stamps (``gh`` unwrapped)."""

    t: FloatArray
    dsl: FloatArray
    dsr: FloatArray
    ds: FloatArray
    dth: FloatArray
    dt: FloatArray
    tt: FloatArray
    timed: NDArray[np.bool_]
    phi: FloatArray
    mult: FloatArray
    gx: FloatArray
    gy: FloatArray
    gh: FloatArray


def run_cycles(run: object, nominal: RobotParams) -> RunCycles | None:
    """:class:`RunCycles` of a prepared run (None: fewer than two samples)."""
    t = np.asarray(run.t, dtype=np.float64)  # type: ignore[attr-defined]
    if t.size < 2:
        return None
    dsl = np.asarray(run.dticks_left) * nominal.left_metres_per_tick  # type: ignore[attr-defined]
    dsr = np.asarray(run.dticks_right) * nominal.right_metres_per_tick  # type: ignore[attr-defined]
    b = nominal.track_width
    tick = 0.5 * (nominal.left_metres_per_tick + nominal.right_metres_per_tick)
    dt = np.diff(t, prepend=t[0])
    ds = 0.5 * (dsl + dsr)
    dth = (dsr - dsl) / b
    ds[0] = dth[0] = 0.0
    timed = dt > 0
    tt = np.where(timed, dt, 1.0)
    phi = SlipModel.features(ds / tt, dth / tt)
    phi[4:, ~timed] = 0.0
    phi[:, 0] = 0.0
    mult = SlipModel.noise_multipliers(dsl, dsr, dt, b, tick / b)
    mult[0] = 0.0
    return RunCycles(
        t, dsl, dsr, ds, dth, dt, tt, timed, phi, mult,
        np.asarray(run.gt_x, dtype=np.float64),  # type: ignore[attr-defined]
        np.asarray(run.gt_y, dtype=np.float64),  # type: ignore[attr-defined]
        np.unwrap(np.asarray(run.gt_heading, dtype=np.float64)),  # type: ignore[attr-defined]
    )  # fmt: skip


def _cycles(runs: Sequence[object], nominal: RobotParams, steady: SteadyRule) -> _Cycles:
    """Every run's cycles, one after the other (runs of fewer than two samples left out)."""
    parts: list[tuple[FloatArray, ...]] = [
        (np.zeros(0), np.zeros(0), np.zeros((0, len(FEATURES))), np.zeros((0, 6)),
         np.zeros((0, 3)), np.zeros(0, bool), np.zeros(0, bool), np.zeros((0, 3)))
    ]  # fmt: skip
    for c in filter(None, (run_cycles(run, nominal) for run in runs)):
        unsteady = ~steady(c.t, c.ds / c.tt, c.dth / c.tt)
        start = np.zeros(c.t.size, dtype=bool)
        start[0] = True
        meas = np.zeros(c.t.size, dtype=bool)
        meas[real_updates(c.t, c.gx, c.gy, c.gh)] = True
        meas[0] = False
        parts.append((
            c.ds, c.dth, (c.phi * c.tt[None, :]).T, c.mult,
            np.column_stack((c.ds**2, c.ds**2, c.dth**2)) * unsteady[:, None],
            start, meas, np.column_stack((c.gx, c.gy, c.gh)),
        ))  # fmt: skip
    cols = list(zip(*parts, strict=True))
    return _Cycles(*(np.ascontiguousarray(np.concatenate(c)) for c in cols))


def filter_coefficients(
    runs: Sequence[object],
    nominal: RobotParams,
    base: FloatArray,
    tau: FloatArray,
    noise: FloatArray,
    truth: TruthNoise,
    steady: SteadyRule,
    scale: float | None = None,
) -> FilterFit:
    """The slip coefficients of prepared runs by the filter (see the module). ``base``,
    ``tau``: the prior's centre and standard deviations (the regression's weak prior);
    ``noise``: the model's ``q_fwd, q_lat, q_yaw, k_fwd, k_lat, k_yaw`` (the regression's window
    noise); ``truth``: the truth's noise; ``steady``: which cycles are in steady state (times,
    speeds, turn rates; :func:`odolab.calibration.slipfit.steady_cycles`); ``scale``: the
    noise's scale (None: chosen by the likelihood, :data:`SCALES`)."""
    from odolab.calibration._slipfilter_jit import filter_pass

    cyc = _cycles(runs, nominal, steady)
    q = np.asarray(noise, dtype=np.float64).copy()
    q[3:] = np.maximum(q[3:], NOISE_FLOOR)
    r = np.array(
        [max(truth.xy, TRUTH_FLOOR[0]) ** 2, max(truth.xy, TRUTH_FLOOR[0]) ** 2,
         max(truth.yaw, TRUTH_FLOOR[1]) ** 2]
    )  # fmt: skip
    p0 = np.diag(np.asarray(tau, dtype=np.float64) ** 2)
    b0 = np.ascontiguousarray(base, dtype=np.float64)

    def run(sc: float) -> FilterFit:
        beta, cov, loglik, taken, gated = filter_pass(
            cyc.ds, cyc.dth, cyc.phi, cyc.variances(q, sc), cyc.start, cyc.meas, cyc.truth,
            r, b0.copy(), p0.copy(),
        )  # fmt: skip
        likely[sc] = float(loglik) if np.isfinite(loglik) else -np.inf
        return FilterFit(beta, 0.5 * (cov + cov.T), sc, int(taken), int(gated))

    likely: dict[float, float] = {}
    if scale is not None:
        return run(scale)
    tried = {sc: run(sc) for sc in SCALES}
    best = max(tried, key=lambda sc: likely[sc])
    for sc in (best / 2.0, best * 2.0):
        tried[sc] = run(sc)
    return tried[max(tried, key=lambda sc: likely[sc])]
