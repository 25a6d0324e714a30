"""Pose covariance of odometry with the slip model (:class:`odolab.core.models.SlipModel`).

The slip model's predictive variance has three parts, each propagated through the pose by the
midpoint rule from an exact start:

- **white noise** of each cycle's body motion, independent from cycle to cycle: ``q dt`` plus
  ``k L`` (the model's ``q_*``, ``k_*``; :meth:`SlipModel.noise_multipliers`);
- **drift**: an error of the slip that persists, one unknown value for the whole stretch
  integrated, of the forward, lateral and heading motion per metre of track travel (``d_fwd``,
  ``d_lat``, ``d_yaw``) and of the heading per radian of commanded turn (``d_turn``): what the
  model's basis misses keeps its sign for a while, so its pose error grows like the distance,
  not like its square root;
- the coefficients' **posterior** (one error for the whole stretch too), through the pose's
  sensitivity to them.

All three are first order, linear in the terms. Where the heading grows uncertain first order
is not enough: a step ``a`` taken with a heading error ``d`` moves the pose by ``a (cos d - 1) +
a_perp sin d`` off the odometry's, which first order takes as ``a_perp d``, so it misses the
path's shortfall (on average ``1 - exp(-s / 2)`` of every step, ``s`` the heading's variance)
and understates the spread along the path (:func:`odolab.core.uncertainty.second_order_index`
measures it for the kinematic models). For a Gaussian heading error the second moments are
exact: with ``s_k``, ``s_j`` the heading variances at two steps and ``c`` their covariance,
``E[(cos d_k - 1)(cos d_j - 1)] = exp(-(s_k + s_j) / 2) cosh c - exp(-s_k / 2) - exp(-s_j / 2)
+ 1`` and ``E[sin d_k sin d_j] = exp(-(s_k + s_j) / 2) sinh c``. The heading's share of the
position covariance is taken from these over every pair of steps instead of first order's ``c``
(:func:`heading_moments`), so the covariance is the second moment of the error about the
odometry's pose, which is what NEES compares it with; the position's covariance with the
heading likewise (``E[sin d_k d] = c exp(-s_k / 2)``, where first order has ``c``). The heading
itself, and the motion's own noise along and across the path, stay first order.

:func:`propagate_covariance` gives it along a whole log; :class:`SlipCovarianceStepper` the same
one cycle at a time (streaming odometry); :func:`end_second_order` at the end of many pieces at
once, with its derivatives by the terms (fitting them, :mod:`odolab.calibration.slipfit`).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, cast

import numpy as np

from odolab.core._jit import HAVE_NUMBA
from odolab.core.arrays import FloatArray
from odolab.core.errors import InsufficientDataError
from odolab.core.models.slip_terms import DRIFT_KEYS, FEATURES, KIND, NOISE_KEYS, TURN_CYCLES

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from odolab.core.models.base import RobotLike
    from odolab.core.models.slip import SlipModel

__all__ = [
    "HEADING_DRIFT",
    "HEADING_TERMS",
    "TERMS",
    "EndPairs",
    "SlipCovarianceStepper",
    "SlipPropagation",
    "describe_covariance",
    "end_second_order",
    "heading_moments",
    "propagate_covariance",
    "propagate_terms",
    "terms_of",
]

#: The slip model's variance terms, in the order of :attr:`SlipPropagation.basis`.
TERMS: tuple[str, ...] = (*NOISE_KEYS, *DRIFT_KEYS)
#: the body output (forward, lateral, heading) each white noise term enters through
_NOISE_OUTPUT = np.array([0, 1, 2, 0, 1, 2], dtype=np.int64)
#: ... and each drift term
_DRIFT_OUTPUT = np.array([0, 1, 2, 2], dtype=np.int64)
#: Whether the propagation's two loops run compiled (:mod:`._slip_covariance_jit`, where numba
#: is installed) or as the numpy loops here; the tests run both and hold them equal.
COMPILED: bool = HAVE_NUMBA
#: The terms that move the heading (the rest move only the position), :data:`TERMS` indices.
HEADING_TERMS = np.array([TERMS.index(k) for k in ("q_yaw", "k_yaw", "d_yaw", "d_turn")])
#: ... and the drift terms among them, :data:`DRIFT_KEYS` indices
HEADING_DRIFT = np.array([DRIFT_KEYS.index(k) for k in ("d_yaw", "d_turn")])


@dataclass(frozen=True, eq=False)
class SlipPropagation:
    """A stretch of odometry with the slip model: poses (n, 3); at every cycle the pose
    covariance of each variance term at unit size (n, len(TERMS), 3, 3) and of the
    coefficients' posterior (n, 3, 3); and the heading's sensitivity to each drift rate (n, 4)
    and to each coefficient (n, 24), with the coefficients' posterior covariance (24, 24; zeros
    without one): what the heading's covariance between two cycles is made of."""

    poses: FloatArray
    basis: FloatArray
    post: FloatArray
    drift_heading: FloatArray
    coef_heading: FloatArray
    sigma: FloatArray

    def heading_covariance(self, theta: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """What the heading's covariance between cycles ``k <= j`` is made of, with the terms
        ``theta``: the white noise's variance at ``k`` (n,) (a random walk: it is also the
        covariance with every later cycle) plus ``u_k . v_j`` for the drift and the posterior
        ((n, 4 + 24) each)."""
        nw = len(NOISE_KEYS)
        white = np.einsum("c,nc->n", theta[:nw], self.basis[:, :nw, 2, 2])
        u = np.concatenate((self.drift_heading, self.coef_heading), axis=1)
        v = np.concatenate(
            (self.drift_heading * theta[nw:], self.coef_heading @ self.sigma), axis=1
        )
        return white, u, v

    def covariance(self, theta: FloatArray, *, second_order: bool = True) -> FloatArray:
        """The pose covariance (n, 3, 3) with the terms ``theta`` (:data:`TERMS` order): first
        order and, unless ``second_order`` is False, the heading's share of the position block
        from the exact Gaussian moments (module doc)."""
        cov = np.einsum("c,ncij->nij", theta, self.basis) + self.post
        if second_order and self.poses.shape[0] > 1:
            xy, xyh = self._second_order(theta)
            cov[:, :2, :2] += xy
            cov[:, :2, 2] += xyh
            cov[:, 2, :2] += xyh
        return np.asarray(cov, dtype=np.float64)

    def _second_order(self, theta: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per cycle, the exact less the first-order heading share of the position covariance
        (n, 2, 2), summed over the pairs of steps so far, one new step at a time; and of the
        position's covariance with the heading (n, 2): ``E[sin d_k d] = c exp(-s_k / 2)``
        for a Gaussian pair, where first order has ``c``."""
        n = self.poses.shape[0]
        white, u, v = self.heading_covariance(theta)
        s = (white + np.einsum("ni,ni->n", u, v))[:-1]  # heading variance at each step's start
        a = np.diff(self.poses[:, :2], axis=0)  # step j goes from cycle j to cycle j + 1
        ap = np.column_stack((-a[:, 1], a[:, 0]))
        half = np.exp(-0.5 * s)
        out = np.zeros((n, 2, 2))
        cross = np.zeros((n, 2))
        if COMPILED:  # the same loop compiled (its twin below runs without numba)
            from odolab.core.models._slip_covariance_jit import second_order

            second_order(
                np.ascontiguousarray(white), np.ascontiguousarray(u), np.ascontiguousarray(v),
                np.ascontiguousarray(s), half, np.ascontiguousarray(a), out, cross,
            )  # fmt: skip
            return out, cross
        acc = np.zeros((2, 2))
        for j in range(n - 1):
            c = white[: j + 1] + u[: j + 1] @ v[j]  # covariance of the steps k <= j with step j
            f, g = heading_moments(s[: j + 1], s[j], c, half[: j + 1], half[j])
            _add_pair_shares(acc, f, g, a[: j + 1], ap[: j + 1])
            out[j + 1] = acc
            c_end = white[: j + 1] + u[: j + 1] @ v[j + 1]  # ... and with the heading after it
            cross[j + 1] = ((half[: j + 1] - 1.0) * c_end) @ ap[: j + 1]
        return out, cross

    def end_pairs(self) -> EndPairs:
        """The stretch's :class:`EndPairs` (one stretch: m = 1)."""
        n = self.poses.shape[0]
        nw = len(NOISE_KEYS)
        white = self.basis[:, :nw, 2, 2][:, HEADING_TERMS[nw > HEADING_TERMS]]  # (n, 2)
        u, e = self.drift_heading[:-1], self.drift_heading[-1]
        k = np.arange(n - 1)
        first = np.minimum(k[:, None], k[None, :])
        cc = np.concatenate(
            (white[first], (u[:, None, :] * u[None, :, :])[..., HEADING_DRIFT]), axis=-1
        )
        p = self.coef_heading
        c0 = p[:-1] @ self.sigma @ p[:-1].T
        ce = np.concatenate((white[:-1], (u * e)[:, HEADING_DRIFT]), axis=-1)
        ce0 = p[:-1] @ self.sigma @ p[-1]
        steps = np.diff(self.poses[:, :2], axis=0)
        return EndPairs(steps[None], cc[None], c0[None], ce[None], ce0[None])


def heading_moments(
    s_k: FloatArray,
    s_j: FloatArray | float,
    c: FloatArray,
    half_k: FloatArray,
    half_j: FloatArray | float,
) -> tuple[FloatArray, FloatArray]:
    """For pairs of steps with heading variances ``s_k``, ``s_j``, covariance ``c`` and
    ``half = exp(-s / 2)``: ``E[(cos d_k - 1)(cos d_j - 1)]``, and ``E[sin d_k sin d_j] - c``
    (exact less first order; module doc). Stable at any variance, as ``|c| <= (s_k + s_j) / 2``."""
    m = -0.5 * (s_k + s_j)
    up, down = np.exp(m + c), np.exp(m - c)
    return 0.5 * (up + down) - half_k - half_j + 1.0, 0.5 * (up - down) - c


@dataclass(frozen=True, eq=False)
class EndPairs:
    """What the second-order share at the end of stretches depends on, for ``m`` stretches of
    up to ``K`` steps (zero steps pad the shorter ones): the steps (m, K, 2), the heading's
    covariance between steps ``k``, ``j`` per unit heading term (m, K, K, 4; :data:`HEADING_TERMS`)
    and from the posterior (m, K, K), and between each step and the end, the same (m, K, 4) and
    (m, K). Built by :meth:`SlipPropagation.end_pairs`; :func:`end_second_order` evaluates it."""

    steps: FloatArray
    cc: FloatArray
    c0: FloatArray
    ce: FloatArray
    ce0: FloatArray

    @cached_property
    def cc_by_term(self) -> FloatArray:
        """``cc`` with the heading term first, (m, 4, K, K), contiguous: what
        :func:`end_second_order` weighs by each term at every call of a fit."""
        return np.ascontiguousarray(self.cc.transpose(0, 3, 1, 2))

    @cached_property
    def _work(self) -> threading.local:
        """:func:`end_second_order`'s arrays, made once for these pairs (a fit evaluates them
        some hundred times): making arrays of a few MB anew at every call cost about as much
        as the arithmetic done in them. One set a thread."""
        return threading.local()

    def __getstate__(self) -> dict[str, object]:
        """Pickled and deep-copied without the arrays of :meth:`work` (made again on use)."""
        return {k: v for k, v in self.__dict__.items() if k != "_work"}

    def work(self, name: str, shape: tuple[int, ...]) -> FloatArray:
        """The calling thread's array ``name`` of ``shape`` for :func:`end_second_order`
        (its content is whatever the last call left)."""
        arrays: dict[str, FloatArray] = self._work.__dict__
        out = arrays.get(name)
        if out is None or out.shape != shape:
            out = arrays[name] = np.empty(shape)
        return out

    @staticmethod
    def join(parts: Sequence[EndPairs]) -> EndPairs:
        k = max((p.steps.shape[1] for p in parts), default=0)

        def pad(x: FloatArray, axes: int) -> FloatArray:
            width = [(0, 0)] * x.ndim
            for ax in range(1, 1 + axes):
                width[ax] = (0, k - x.shape[ax])
            return np.pad(x, width)

        return EndPairs(
            np.concatenate([pad(p.steps, 1) for p in parts]),
            np.concatenate([pad(p.cc, 2) for p in parts]),
            np.concatenate([pad(p.c0, 2) for p in parts]),
            np.concatenate([pad(p.ce, 1) for p in parts]),
            np.concatenate([pad(p.ce0, 1) for p in parts]),
        )


def end_second_order(
    theta: FloatArray, pairs: EndPairs
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The second-order share at the end of each stretch of ``pairs`` with the terms ``theta``
    (all of :data:`TERMS`): position block (m, 2, 2) and position-heading column (m, 2), and
    their derivatives by each term (m, T, 2, 2), (m, T, 2): :meth:`SlipPropagation.covariance`'s
    last cycle, all pairs at once, for fitting the terms."""
    th = theta[HEADING_TERMS]
    a = pairs.steps
    ap = np.stack((-a[..., 1], a[..., 0]), axis=-1)
    cct = pairs.cc_by_term  # (m, 4, K, K)
    kk = (a.shape[0], a.shape[1], a.shape[1])
    # the (m, K, K) and (m, 4, K, K) arrays are the pairs' own, reused from call to call (the
    # arithmetic is the same, operation for operation, as with new arrays: the same bits)
    c = np.einsum("h,mhkj->mkj", th, pairs.cc.transpose(0, 3, 1, 2), out=pairs.work("c", kk))
    c += pairs.c0
    s = np.einsum("mkk->mk", c)
    ds = np.einsum("mkkh->mkh", pairs.cc)
    half = np.exp(-0.5 * s)
    # heading_moments, with its two exponentials kept for the derivatives
    mm = np.add(s[:, :, None], s[:, None, :], out=pairs.work("mm", kk))
    mm *= -0.5
    up = np.add(mm, c, out=pairs.work("up", kk))
    np.exp(up, out=up)
    down = np.exp(np.subtract(mm, c, out=mm), out=mm)
    p = np.add(up, down, out=pairs.work("p", kk))
    p *= 0.5
    q = np.subtract(up, down, out=up)
    q *= 0.5
    f = np.subtract(p, half[:, :, None], out=down)  # p - half_k - half_j + 1
    f -= half[:, None, :]
    f += 1.0
    g = np.subtract(q, c, out=c)
    at, apt = a.transpose(0, 2, 1), ap.transpose(0, 2, 1)  # (m, 2, K)
    xy = at @ f @ a + apt @ g @ ap
    ce = np.einsum("h,mkh->mk", th, pairs.ce) + pairs.ce0
    xyh = np.einsum("mk,mki->mi", (half - 1.0) * ce, ap)
    # derivatives by each heading term: with dc = cc[..., h], dm = -(ds_k + ds_j) / 2,
    # df = p dm + q dc + (half_k ds_k + half_j ds_j) / 2 and dg = q dm + (p - 1) dc, each part
    # contracted with the steps as it comes, so that no (m, K, K, 4) array but the two dc
    # products is made (4.5x faster at 60 steps than forming df and dg)
    pa, qap = p @ a, q @ ap  # (m, K, 2); p and q are symmetric
    t_m = np.einsum("mkh,mki,mkl->mhil", ds, a, pa) + np.einsum("mkh,mki,mkl->mhil", ds, ap, qap)
    w = np.multiply(q[:, None], cct, out=pairs.work("w", cct.shape))
    t_c = at[:, None] @ (w @ a[:, None])
    p -= 1.0
    t_c += apt[:, None] @ (np.multiply(p[:, None], cct, out=w) @ ap[:, None])
    u = np.einsum("mk,mkh,mki->mhi", half, ds, a)
    t_h = 0.5 * u[..., :, None] * a.sum(axis=1)[:, None, None, :]
    d_heading = t_c + _plus_transpose(t_h - 0.5 * t_m)
    nt = len(TERMS)
    d_xy = np.zeros((a.shape[0], nt, 2, 2))
    d_xy[:, HEADING_TERMS] = d_heading
    d_xyh = np.zeros((a.shape[0], nt, 2))
    dxh = -0.5 * (half * ce)[:, :, None] * ds + (half - 1.0)[:, :, None] * pairs.ce
    d_xyh[:, HEADING_TERMS] = np.einsum("mkh,mki->mhi", dxh, ap)
    return xy, xyh, d_xy, d_xyh


def _plus_transpose(x: FloatArray) -> FloatArray:
    """``x`` plus its transpose in the last two axes."""
    return x + x.swapaxes(-1, -2)


def _cycle(
    heading: float,
    motion: tuple[float, float, float],
    mult: FloatArray,
    drift: FloatArray,
    dphi: FloatArray,
    state: tuple[FloatArray, FloatArray, FloatArray | None],
) -> tuple[float, float, tuple[FloatArray, FloatArray, FloatArray | None]]:
    """One cycle of the first-order propagation, midpoint rule: the body ``motion`` (forward,
    lateral, dtheta) from ``heading``; the cycle's white-noise multipliers ``mult`` (6,), drift
    multipliers ``drift`` (4,) and d(body motion)/d(coefficients) ``dphi`` (8,). ``state``: the
    pose covariance per unit white term (6, 3, 3), d(pose)/d(drift rates) (4, 3) and
    d(pose)/d(coefficients) (3, 24; None: no posterior). Returns the step (dx, dy) and the new
    state: what :func:`propagate_terms` and :class:`SlipCovarianceStepper` both do each cycle."""
    fwd, lat, dth = motion
    white, jd, jac = state
    m = heading + 0.5 * dth
    c, s = math.cos(m), math.sin(m)
    dx = fwd * c - lat * s
    dy = fwd * s + lat * c
    f = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx], [0.0, 0.0, 1.0]])
    g = np.array([[c, -s, -0.5 * dy], [s, c, 0.5 * dx], [0.0, 0.0, 1.0]])
    cols = g[:, _NOISE_OUTPUT].T  # (6, 3): the column each term enters through
    white = f @ white @ f.T + mult[:, None, None] * (cols[:, :, None] * cols[:, None, :])
    jd = jd @ f.T + drift[:, None] * g[:, _DRIFT_OUTPUT].T
    if jac is not None:
        k = dphi.size
        jac = f @ jac
        for j in range(3):
            jac[:, j * k : (j + 1) * k] += np.outer(g[:, j], dphi)
    return dx, dy, (white, jd, jac)


def _add_pair_shares(
    acc: FloatArray,
    f: FloatArray,
    g: FloatArray,
    steps: FloatArray,
    perps: FloatArray,
) -> None:
    """Add to ``acc`` (2, 2) the pairs of the last of ``steps`` (k, 2) with every one up to it
    (itself once): ``f``, ``g`` (k,) from :func:`heading_moments`, along the steps and across
    them (``perps``, the steps turned left by 90 degrees)."""
    a, ap = steps[-1], perps[-1]
    fa, ga = f @ steps, g @ perps
    acc += np.outer(fa, a) + np.outer(a, fa) - f[-1] * np.outer(a, a)
    acc += np.outer(ga, ap) + np.outer(ap, ga) - g[-1] * np.outer(ap, ap)


def _slip_model(params: RobotLike) -> SlipModel:
    """The parameters' slip model, or the error that they have another."""
    model = params.model
    if model.kind != KIND:
        raise InsufficientDataError(
            f"the parameters' model is {model.kind!r}; expected the slip model (kind = 'slip')"
        )
    return cast("SlipModel", model)  # the registry's class of KIND


def describe_covariance(model: SlipModel) -> str:
    """What the slip model's covariance is made of, in words, for every face that uses it
    (``odometry --covariance``, ``evaluate --nees``, ``export mcap``): whether the file carries
    the coefficients' posterior is said, as it changes the covariance."""
    head = (
        "the slip model's predictive variance (its white noise q_*, k_* per cycle, its drift "
        "d_* over each stretch integrated"
    )
    if model.posterior:
        return head + " and its coefficients' posterior; docs/models.md)"
    return (
        head + "; the parameters have no [model] posterior, so the coefficients' own "
        "uncertainty is not in it; docs/models.md)"
    )


def terms_of(model: SlipModel) -> FloatArray:
    """The model's variance terms in :data:`TERMS` order."""
    return np.array([getattr(model, key) for key in TERMS], dtype=np.float64)


def propagate_terms(
    t: FloatArray,
    dsl: FloatArray,
    dsr: FloatArray,
    params: RobotLike,
    start: tuple[float, float, float],
) -> SlipPropagation:
    """Poses along a stretch of track motion ``dsl``, ``dsr`` (m per cycle; the first cycle's is
    the start's, not moved) with the slip model's mean, and the covariance's parts
    (:class:`SlipPropagation`)."""
    model = _slip_model(params)
    n = t.size
    dt = np.diff(t, prepend=t[:1])
    fwd, lat, dth = model.body_motion_arrays(dsl, dsr, dt, params.track_width)
    tick_turn = 0.5 * (params.left_metres_per_tick + params.right_metres_per_tick)
    mult = model.noise_multipliers(dsl, dsr, dt, params.track_width, tick_turn / params.track_width)
    drift = model.drift_multipliers(dsl, dsr, params.track_width)
    k = len(FEATURES)
    sigma = np.array(model.posterior).reshape(3 * k, 3 * k) if model.posterior else None
    timed = dt > 0
    tt = np.where(timed, dt, 1.0)
    phi = model.features(0.5 * (dsl + dsr) / tt, (dsr - dsl) / params.track_width / tt)
    phi[4:, ~timed] = 0.0
    big_phi = (phi * tt[None, :]).T  # (n, 8): d(body motion) / d(coefficients) of a cycle
    poses = np.empty((n, 3))
    nw = len(NOISE_KEYS)
    basis = np.zeros((n, len(TERMS), 3, 3))
    post = np.zeros((n, 3, 3))
    x, y, h = start
    white = np.zeros((nw, 3, 3))
    jd = np.zeros((len(DRIFT_KEYS), 3))  # d(pose) / d(drift rate), one row per drift term
    jac = np.zeros((3, 3 * k))
    drift_heading = np.zeros((n, len(DRIFT_KEYS)))
    coef_heading = np.zeros((n, 3 * k))
    if n:
        poses[0] = start
    if COMPILED and n:  # the same loop compiled (its twin below, _cycle's, runs without numba)
        from odolab.core.models._slip_covariance_jit import first_order

        first_order(
            np.array(start, dtype=np.float64), np.ascontiguousarray(fwd, dtype=np.float64),
            np.ascontiguousarray(lat, dtype=np.float64),
            np.ascontiguousarray(dth, dtype=np.float64),
            np.ascontiguousarray(mult, dtype=np.float64),
            np.ascontiguousarray(drift, dtype=np.float64), np.ascontiguousarray(big_phi),
            sigma if sigma is not None else np.zeros((3 * k, 3 * k)), sigma is not None,
            _NOISE_OUTPUT, _DRIFT_OUTPUT, poses, basis, post, drift_heading, coef_heading,
        )  # fmt: skip
        if sigma is None:
            sigma = np.zeros((3 * k, 3 * k))
        return SlipPropagation(poses, basis, post, drift_heading, coef_heading, sigma)
    state = (white, jd, jac if sigma is not None else None)
    for i in range(1, n):
        motion = (float(fwd[i]), float(lat[i]), float(dth[i]))
        dx, dy, state = _cycle(h, motion, mult[i], drift[i], big_phi[i], state)
        white, jd, jac_i = state
        basis[i, :nw] = white
        basis[i, nw:] = jd[:, :, None] * jd[:, None, :]
        drift_heading[i] = jd[:, 2]
        if sigma is not None and jac_i is not None:
            post[i] = jac_i @ sigma @ jac_i.T
            coef_heading[i] = jac_i[2]
        x, y, h = x + dx, y + dy, h + dth[i]
        poses[i] = (x, y, h)
    if sigma is None:
        sigma = np.zeros((3 * k, 3 * k))
    return SlipPropagation(poses, basis, post, drift_heading, coef_heading, sigma)


def propagate_covariance(
    t: ArrayLike,
    dticks_left: ArrayLike,
    dticks_right: ArrayLike,
    params: RobotLike,
    start: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> tuple[FloatArray, FloatArray]:
    """Poses (n, 3: x, y, heading) and their covariance (n, 3, 3) along a run of count
    increments with the slip model's predictive variance (module doc), from an exact start.
    The poses are :func:`odolab.core.odometry.integrate_increments`'s to rounding."""
    t = np.asarray(t, dtype=np.float64)
    dsl = np.asarray(dticks_left, dtype=np.float64) * params.left_metres_per_tick
    dsr = np.asarray(dticks_right, dtype=np.float64) * params.right_metres_per_tick
    prop = propagate_terms(t, dsl, dsr, params, start)
    model = _slip_model(params)
    return prop.poses, prop.covariance(terms_of(model))


class SlipCovarianceStepper:
    """:func:`propagate_covariance` one cycle at a time, for streaming odometry
    (:class:`odolab.core.odometry.Odometry` with ``covariance=True`` and a slip model): the same
    covariance at every cycle, to rounding. The second-order share needs every earlier step, so
    a cycle costs time in proportion to the cycles so far (a 10-minute run at 20 Hz: well
    under a millisecond a cycle at its end)."""

    def __init__(self, params: RobotLike) -> None:
        model = _slip_model(params)
        self.model = model
        self.track_width = params.track_width
        tick = 0.5 * (params.left_metres_per_tick + params.right_metres_per_tick)
        self.tick_turn = tick / params.track_width
        self.theta = terms_of(model)
        k = len(FEATURES)
        self.sigma = (
            np.array(model.posterior).reshape(3 * k, 3 * k)
            if model.posterior
            else np.zeros((3 * k, 3 * k))
        )
        self.reset()

    def reset(self) -> None:
        """Back to an exact start (zero covariance, heading 0)."""
        nw = len(NOISE_KEYS)
        k = len(FEATURES)
        self._white = np.zeros((nw, 3, 3))
        self._jd = np.zeros((len(DRIFT_KEYS), 3))
        self._jac = np.zeros((3, 3 * k))
        self._turns: list[float] = []
        # per pose so far (buffers that grow by doubling; ``_n`` poses held): the heading's
        # white variance, its u and v (heading_covariance), its total variance; per step after
        # it: the step and the step turned left by 90 degrees
        self._n = 1
        self._w = np.zeros(64)
        self._u = np.zeros((64, len(DRIFT_KEYS) + 3 * k))
        self._v = np.zeros_like(self._u)
        self._s = np.zeros(64)
        self._a = np.zeros((64, 2))
        self._ap = np.zeros((64, 2))
        self._acc = np.zeros((2, 2))
        self.cov = np.zeros((3, 3))

    def _grow(self) -> None:
        for name in ("_w", "_u", "_v", "_s", "_a", "_ap"):
            old = getattr(self, name)
            new = np.zeros((2 * old.shape[0], *old.shape[1:]))
            new[: old.shape[0]] = old
            setattr(self, name, new)

    @property
    def terms(self) -> tuple[float, float, float, float, float, float]:
        """The covariance now in :data:`odolab.core.uncertainty.COV_COLUMNS` order."""
        c = self.cov
        return (c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2])

    def step(self, heading: float, ds_left: float, ds_right: float, dt: float) -> None:
        """One cycle of track motion (m) over ``dt`` seconds from ``heading`` (rad)."""
        nw = len(NOISE_KEYS)
        model = self.model
        b = self.track_width
        dsl, dsr = np.array([ds_left]), np.array([ds_right])
        fwd, lat, dth = (float(x[0]) for x in model.body_motion_arrays(dsl, dsr, np.array([dt]), b))
        self._turns = [*self._turns[-(TURN_CYCLES - 1) :], (ds_right - ds_left) / b]
        travel = 0.5 * (abs(ds_left) + abs(ds_right))
        tt = dt if dt > 0 else 0.0
        mult = np.array([tt, tt, tt, travel, travel,
                         model.turn_multiplier(self._turns, self.tick_turn)])  # fmt: skip
        drift = model.drift_multipliers(dsl, dsr, b)[0]
        timed = dt > 0
        t1 = dt if timed else 1.0
        phi = model.features(np.array([0.5 * (ds_left + ds_right) / t1]),
                                 np.array([(ds_right - ds_left) / b / t1]))[:, 0]  # fmt: skip
        if not timed:
            phi[4:] = 0.0
        n = self._n
        if n + 1 > self._w.shape[0]:
            self._grow()
        w, u, v, s_all = self._w[:n], self._u[:n], self._v[:n], self._s[:n]
        half = np.exp(-0.5 * s_all)
        dx, dy, (self._white, self._jd, jac) = _cycle(
            heading, (fwd, lat, dth), mult, drift, phi * t1, (self._white, self._jd, self._jac)
        )
        assert jac is not None
        self._jac = jac
        # the second-order share of this step, from the poses before it (_second_order)
        self._a[n - 1], self._ap[n - 1] = (dx, dy), (-dy, dx)
        f2, g2 = heading_moments(s_all, s_all[-1], w + u @ v[-1], half, half[-1])
        _add_pair_shares(self._acc, f2, g2, self._a[:n], self._ap[:n])
        jd2 = self._jd[:, :, None] * self._jd[:, None, :]
        cov = np.einsum("c,cij->ij", self.theta[:nw], self._white)
        cov += np.einsum("c,cij->ij", self.theta[nw:], jd2)
        cov += self._jac @ self.sigma @ self._jac.T
        # this pose's heading parts, and the position-heading share with it
        w_new = float(self.theta[:nw] @ self._white[:, 2, 2])
        u_new = np.concatenate((self._jd[:, 2], self._jac[2]))
        v_new = np.concatenate((self._jd[:, 2] * self.theta[nw:], self._jac[2] @ self.sigma))
        c_end = w + u @ v_new
        cross = ((half - 1.0) * c_end) @ self._ap[:n]
        self._w[n], self._u[n], self._v[n] = w_new, u_new, v_new
        self._s[n] = w_new + u_new @ v_new
        self._n = n + 1
        cov[:2, :2] += self._acc
        cov[:2, 2] += cross
        cov[2, :2] += cross
        self.cov = cov
