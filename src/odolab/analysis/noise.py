"""Per-wheel noise constants ``k_r``, ``k_l`` of ``sigma**2 = k * |ds|``, by maximum likelihood.

Model: each wheel's travelled distance carries a random error that grows like a random walk
along the wheel's path, variance ``k * s`` after a path ``s`` (m**2 per m, so ``k`` is in m).
With track width ``b``, linearised about the commanded motion, the random part of each
trial's result (its residual from the systematic fit, actual side) is Gaussian, zero mean, with a
covariance linear in ``(k_r, k_l)``:

* in-place rotation by ``h`` (each wheel rolls ``s = |h| b / 2``):
  ``var(rotation) = (k_r + k_l) |h| / (2 b)``;
* pivot about a held track by ``h`` (the other rolls ``s = |h| b``):
  ``var(rotation) = k_moving |h| / b``;
* straight line of length ``d`` (sign ``sgn`` = +1 forward, -1 reverse), residuals (x, y):
  ``var x = (k_r + k_l) d / 4``, ``var y = (k_r + k_l) d**3 / (3 b**2)``,
  ``cov(x, y) = sgn (k_r - k_l) d**2 / (4 b)``.

The instrument's variance (``sigma_rotation**2``, ``sigma_xy**2``) is added. The log-likelihood of
all trials is maximised over ``log k_r, log k_l`` (scipy); 95% intervals are Wald intervals on the
log scale from the numerical Hessian (odolab.core.regression). Straight-line trials with both x and y
measured, or pivots, separate the wheels; in-place rotations alone give only ``k_r + k_l`` (then
``identifiable`` is False and ``k_r = k_l = (k_r + k_l) / 2``).

Turn scrub (:func:`fit_separated_noise`): a tracked robot's in-place turns skid far more than
its straight runs roll (on the demo's notebook the rotations' ``k_r + k_l`` is some 300 times
the straight runs'), so pooling both kinds into one pair describes neither. The documented
model (``[noise]``, :mod:`odolab.core.uncertainty`) adds ``k_scrub`` (rad): heading variance per
radian of commanded turning. The separated fit takes ``k_r``, ``k_l`` from the straight runs
alone, then ``k_scrub`` from the turns (rotations, pivots) with the wheels' share fixed at those
values: ``var(rotation) = (k_r + k_l) |h| / (2 b) + k_scrub |h|``. A kind of motion that is
missing leaves its constant unknown (said, not guessed).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from odolab.core.distributions import Z95
from odolab.core.errors import InsufficientDataError
from odolab.core.motion import MotionKind

__all__ = [
    "NoiseConstant",
    "NoiseRecord",
    "SeparatedNoise",
    "WheelNoise",
    "fit_separated_noise",
    "fit_wheel_noise",
    "noise_record",
    "record_pivot",
    "record_rotation",
    "record_translation",
]


@dataclass(frozen=True, eq=False)
class NoiseRecord:
    """One trial's residual ``r`` (shape (m,)) with covariance ``k_r A_r + k_l A_l + M``.

    ``kind``: the commanded kind (its weights: :meth:`odolab.core.motion.MotionKind.noise_weights`);
    ``turn``: the commanded turning (rad, ``|ds_r - ds_l| / b``) that scrub acts on;
    ``trial_id``: the trial it comes from (for the provenance)."""

    kind: MotionKind
    r: NDArray[np.float64]
    a_right: NDArray[np.float64]
    a_left: NDArray[np.float64]
    m: NDArray[np.float64]
    turn: float = 0.0
    trial_id: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", MotionKind.parse(self.kind, "noise record"))


def noise_record(
    kind: MotionKind,
    amount: float,
    track_width: float,
    residuals: Mapping[str, float | None],
    *,
    held: str | None = None,
    sigma: float = 0.0,
    trial_id: str = "",
) -> NoiseRecord:
    """One trial's noise record: a ``kind`` of motion by ``amount`` (a turn's heading change in
    rad, a translation's signed distance in m; a pivot about the ``held`` track, default left),
    with its fits' residuals on the actual side by :attr:`odolab.core.motion.MotionKind.residuals`
    (``turn`` in rad; ``x``, ``y`` in m: either or both) and the instrument's ``sigma``."""
    a_r, a_l, turn = kind.noise_weights(amount, track_width, held=held)
    values = [residuals.get(name) for name in kind.residuals]
    keep = [i for i, v in enumerate(values) if v is not None]
    if not keep:
        wanted = " or ".join(f"{'an' if n == 'x' else 'a'} {n}" for n in kind.residuals)
        raise InsufficientDataError(f"a {kind.value} noise record needs {wanted} residual")
    idx = np.ix_(keep, keep)
    return NoiseRecord(
        kind,
        np.array([values[i] for i in keep], dtype=np.float64),
        a_r[idx],
        a_l[idx],
        np.eye(len(keep)) * sigma**2,
        turn=turn,
        trial_id=trial_id,
    )


def record_rotation(
    residual: float, heading: float, track_width: float, sigma: float = 0.0, trial_id: str = ""
) -> NoiseRecord:
    """In-place rotation by ``heading`` (rad); ``residual`` in rad."""
    turn = {"turn": residual}
    return noise_record(
        MotionKind.ROTATION, heading, track_width, turn, sigma=sigma, trial_id=trial_id
    )


def record_pivot(
    residual: float,
    heading: float,
    track_width: float,
    moving: str,
    sigma: float = 0.0,
    trial_id: str = "",
) -> NoiseRecord:
    """Pivot by ``heading`` about the held track; ``moving`` is "right" or "left"."""
    held = "left" if moving == "right" else "right"
    return noise_record(
        MotionKind.PIVOT, heading, track_width, {"turn": residual}, held=held, sigma=sigma,
        trial_id=trial_id,
    )  # fmt: skip


def record_translation(
    distance: float,
    track_width: float,
    *,
    residual_x: float | None,
    residual_y: float | None,
    sigma: float = 0.0,
    trial_id: str = "",
) -> NoiseRecord:
    """Straight line of signed ``distance`` (m); residuals of actual x and actual y (m)."""
    return noise_record(
        MotionKind.TRANSLATION, distance, track_width, {"x": residual_x, "y": residual_y},
        sigma=sigma, trial_id=trial_id,
    )  # fmt: skip


class _Stack:
    """Records stacked by residual dimension, for a vectorised log-likelihood."""

    def __init__(self, records: list[NoiseRecord]) -> None:
        self.parts: list[tuple[NDArray[np.float64], ...]] = []
        for dim in sorted({rec.r.size for rec in records}):
            sub = [rec for rec in records if rec.r.size == dim]
            self.parts.append(
                (
                    np.stack([rec.r for rec in sub]),
                    np.stack([rec.a_right for rec in sub]),
                    np.stack([rec.a_left for rec in sub]),
                    np.stack([rec.m for rec in sub]),
                )
            )

    def loglik(self, k_r: float, k_l: float) -> float:
        """One and two residuals (a turn; a straight line's x and y) in closed form, which the
        fits' thousands of calls need (3x faster than LAPACK's batched solve on 2x2 matrices)."""
        total = 0.0
        for r, a_r, a_l, m in self.parts:
            cov = k_r * a_r + k_l * a_l + m
            dim = r.shape[1]
            if dim == 1:
                det = cov[:, 0, 0]
                quad = r[:, 0] * r[:, 0] / det
            elif dim == 2:
                # C = [[a, b], [c, d]]: r' C^-1 r = (d r0^2 - (b + c) r0 r1 + a r1^2) / det
                a, b, c, d = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 0], cov[:, 1, 1]
                det = a * d - b * c
                r0, r1 = r[:, 0], r[:, 1]
                quad = (d * r0 * r0 - (b + c) * r0 * r1 + a * r1 * r1) / det
            else:
                sign, logdet = np.linalg.slogdet(cov)
                if np.any(sign <= 0):
                    return -math.inf
                det = np.exp(logdet)  # (no record has more than two residuals)
                quad = np.einsum("ij,ij->i", r, np.linalg.solve(cov, r[..., None])[..., 0])
            if not np.all(det > 0):
                return -math.inf
            total += float(-0.5 * np.sum(dim * math.log(2 * math.pi) + np.log(det) + quad))
        return total


def _loglik(k_r: float, k_l: float, records: list[NoiseRecord]) -> float:
    """Log-likelihood of ``records`` under ``(k_r, k_l)`` (sum of Gaussian log-densities)."""
    return _Stack(records).loglik(k_r, k_l)


@dataclass(frozen=True)
class WheelNoise:
    """ML estimates of ``k_r``, ``k_l`` (m) with 95% intervals, and per-motion sums."""

    n_trials: int
    k_right: float
    k_left: float
    k_right_ci95: tuple[float, float]
    k_left_ci95: tuple[float, float]
    k_sum: float
    k_sum_ci95: tuple[float, float]
    identifiable: bool
    loglik: float
    #: motion kind -> (k_r + k_l) fitted to that kind's trials alone
    k_sum_by_kind: dict[str, float] = field(default_factory=dict)
    #: p-value of the likelihood-ratio test "one k_r + k_l explains every kind of motion"
    same_k_pvalue: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "n_trials": self.n_trials,
            "k_right": self.k_right,
            "k_left": self.k_left,
            "k_right_ci95": list(self.k_right_ci95),
            "k_left_ci95": list(self.k_left_ci95),
            "k_sum": self.k_sum,
            "k_sum_ci95": list(self.k_sum_ci95),
            "identifiable": self.identifiable,
            "loglik": self.loglik,
            "k_sum_by_kind": dict(self.k_sum_by_kind),
            "same_k_pvalue": self.same_k_pvalue,
            "units": "m (variance m^2 per m of wheel travel)",
        }


def _wald95(u: float, se: float) -> tuple[float, float]:
    """95 % Wald interval of ``exp(u)`` from the log-scale standard error ``se``; a bound past
    what a float holds (a constant the trials barely bound) is 0 or inf, not an OverflowError."""
    half = Z95 * se
    lo, hi = u - half, u + half
    return (
        math.exp(lo) if lo > -745.0 else 0.0,
        math.exp(hi) if hi < 709.0 else math.inf,
    )


def _fit_sum(records: list[NoiseRecord]) -> tuple[float, float, tuple[float, float]]:
    """Fit one ``k = k_r + k_l`` (k_r = k_l = k/2); returns (k, loglik, ci95)."""
    from scipy import optimize

    from odolab.core.regression import approx_hess3

    stack = _Stack(records)

    def nll(u: NDArray[np.float64]) -> float:
        k = math.exp(float(u[0]))
        v = -stack.loglik(k / 2, k / 2)
        return v if math.isfinite(v) else 1e300

    # starting value: moment estimate of k from the 1-D variances
    ratios = [float(rec.r[0] ** 2 / (rec.a_right[0, 0] + rec.a_left[0, 0])) for rec in records]
    k0 = max(float(np.mean(ratios)), 1e-12)
    grid = np.log(k0) + np.linspace(-6, 6, 49)
    u0 = grid[int(np.argmin([nll(np.array([g])) for g in grid]))]
    res = optimize.minimize(nll, np.array([u0]), method="Nelder-Mead", options={"xatol": 1e-8})
    u = float(res.x[0])
    h = float(np.asarray(approx_hess3(np.array([u]), nll))[0, 0])
    se = 1.0 / math.sqrt(h) if h > 0 else math.inf
    return math.exp(u), -float(res.fun), _wald95(u, se)


def fit_wheel_noise(records: list[NoiseRecord]) -> WheelNoise:
    """Maximum-likelihood ``k_r``, ``k_l`` from residual records (see the module docstring)."""
    from scipy import optimize

    from odolab.core.distributions import chi2_sf
    from odolab.core.regression import approx_hess3

    if len(records) < 3:
        raise InsufficientDataError(
            f"the wheel noise constants need at least 3 measured trials, got {len(records)}"
        )
    k_sum, ll_sum, k_sum_ci = _fit_sum(records)

    stack = _Stack(records)

    def nll(u: NDArray[np.float64]) -> float:
        v = -stack.loglik(math.exp(float(u[0])), math.exp(float(u[1])))
        return v if math.isfinite(v) else 1e300

    u0 = np.array([math.log(k_sum / 2)] * 2)
    res = optimize.minimize(nll, u0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12})
    res = optimize.minimize(nll, res.x, method="Nelder-Mead", options={"xatol": 1e-9})
    u = np.asarray(res.x, dtype=np.float64)
    hess = np.asarray(approx_hess3(u, nll), dtype=np.float64)
    eig = np.linalg.eigvalsh(hess)
    identifiable = bool(eig.min() > 1e-6 * max(eig.max(), 1e-300) and eig.min() > 0)
    by_kind: dict[str, float] = {}
    same_p: float | None = None
    kinds = sorted({rec.kind for rec in records})
    if len(kinds) > 1:
        ll_sep = 0.0
        for kind in kinds:
            sub = [rec for rec in records if rec.kind == kind]
            k_kind, ll_kind, _ = _fit_sum(sub)
            by_kind[kind] = k_kind
            ll_sep += ll_kind
        lr = max(0.0, 2.0 * (ll_sep - ll_sum))
        same_p = chi2_sf(lr, len(kinds) - 1)
    else:
        by_kind[kinds[0]] = k_sum
    if not identifiable:
        half = (k_sum_ci[0] / 2, k_sum_ci[1] / 2)
        return WheelNoise(
            n_trials=len(records),
            k_right=k_sum / 2,
            k_left=k_sum / 2,
            k_right_ci95=half,
            k_left_ci95=half,
            k_sum=k_sum,
            k_sum_ci95=k_sum_ci,
            identifiable=False,
            loglik=ll_sum,
            k_sum_by_kind=by_kind,
            same_k_pvalue=same_p,
        )
    cov = np.linalg.inv(hess)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    k_r, k_l = math.exp(u[0]), math.exp(u[1])
    return WheelNoise(
        n_trials=len(records),
        k_right=k_r,
        k_left=k_l,
        k_right_ci95=_wald95(float(u[0]), float(se[0])),
        k_left_ci95=_wald95(float(u[1]), float(se[1])),
        k_sum=k_sum,
        k_sum_ci95=k_sum_ci,
        identifiable=True,
        loglik=-float(res.fun),
        k_sum_by_kind=by_kind,
        same_k_pvalue=same_p,
    )


#: At least this many trials of a kind of motion identify its constant(s).
MIN_NOISE_TRIALS = 3


@dataclass(frozen=True)
class NoiseConstant:
    """One constant of the separated fit: its value and 95 % interval, or why it is unknown.

    ``trials``: the trials it was fitted to; ``source``: one phrase, which motion gave it
    (or, when ``value`` is None, why no motion could)."""

    name: str
    value: float | None
    ci95: tuple[float, float] | None
    trials: tuple[str, ...]
    source: str

    @property
    def known(self) -> bool:
        return self.value is not None

    def to_dict(self) -> dict[str, object]:
        """JSON-ready; an unknown constant has ``value`` None and ``unknown`` its reason."""
        out: dict[str, object] = {"value": self.value, "source": self.source}
        if self.value is None:
            out["unknown"] = self.source
        if self.ci95 is not None:
            out["ci95"] = list(self.ci95)
        out["n_trials"] = len(self.trials)
        out["trials"] = list(self.trials)
        return out

    def provenance(self, scale: float = 1.0) -> dict[str, object]:
        """A TOML-able table: value, interval and trials, scaled by ``scale`` (no None)."""
        if self.value is None:
            return {"unknown": self.source, "trials": list(self.trials)}
        out: dict[str, object] = {"value": self.value * scale, "from": self.source}
        if self.ci95 is not None:
            out["ci95"] = [self.ci95[0] * scale, self.ci95[1] * scale]
        out["trials"] = list(self.trials)
        return out


@dataclass(frozen=True)
class SeparatedNoise:
    """``k_left``, ``k_right`` from straight runs and ``k_scrub`` from turns, kept apart.

    ``scrub_pvalue``: p-value of "the straight runs' wheel noise alone explains the turns"
    (likelihood ratio against ``k_scrub = 0``, on the boundary: half a chi-square(1))."""

    k_left: NoiseConstant
    k_right: NoiseConstant
    k_scrub: NoiseConstant
    wheels_separable: bool
    scrub_pvalue: float | None

    @property
    def unknown(self) -> list[str]:
        """Names of the constants no trial identified."""
        return [c.name for c in (self.k_left, self.k_right, self.k_scrub) if not c.known]

    def notes(self) -> list[str]:
        """One sentence per constant that stays unknown or was not separable."""
        out = [f"{c.name} unknown: {c.source}" for c in (self.k_left, self.k_scrub) if not c.known]
        if self.k_left.known and not self.wheels_separable:
            out.append(
                "the straight runs do not separate the wheels (no y residuals): "
                "k_left = k_right = half their sum"
            )
        return out

    def to_dict(self) -> dict[str, object]:
        return {
            "k_left": self.k_left.to_dict(),
            "k_right": self.k_right.to_dict(),
            "k_scrub": self.k_scrub.to_dict(),
            "wheels_separable": self.wheels_separable,
            "scrub_pvalue": self.scrub_pvalue,
            "unknown": self.unknown,
            "units": "k_left, k_right: m (m^2 per m of wheel travel); k_scrub: rad (rad^2 per rad "
            "of commanded turning)",
        }


def _scrub_fit(
    turns: list[NoiseRecord], k_r: float, k_l: float
) -> tuple[float, tuple[float, float], float]:
    """ML ``k_scrub >= 0`` of 1-D turn records with the wheels' share fixed; its 95 % profile
    likelihood interval; the p-value of ``k_scrub = 0``."""
    from scipy import optimize

    from odolab.core.distributions import chi2_ppf, chi2_sf

    r2 = np.array([float(rec.r[0] ** 2) for rec in turns])
    base = np.array(
        [float(k_r * rec.a_right[0, 0] + k_l * rec.a_left[0, 0] + rec.m[0, 0]) for rec in turns]
    )
    h = np.array([rec.turn for rec in turns])

    def ll(ks: float) -> float:
        v = base + ks * h
        if np.any(v <= 0):
            return -math.inf
        return float(-0.5 * np.sum(np.log(2 * math.pi * v) + r2 / v))

    # moment estimate brackets the maximum; then a bounded search on the log scale
    hi_k = max(float(np.sum(r2) / max(np.sum(h), 1e-300)) * 100.0, 1e-12)
    lo_k = hi_k * 1e-14
    res = optimize.minimize_scalar(
        lambda u: -ll(math.exp(u)),
        bounds=(math.log(lo_k), math.log(hi_k)),
        method="bounded",
        options={"xatol": 1e-10},
    )
    ks = math.exp(float(res.x))
    ll0 = ll(0.0)
    ll_hat = max(ll(ks), ll0)
    if ll0 >= ll_hat - 1e-9:
        ks = 0.0
    cut = ll_hat - 0.5 * chi2_ppf(0.95, 1)

    def above(k: float) -> float:
        return ll(k) - cut

    lo = 0.0 if ll0 >= cut else float(optimize.brentq(above, 0.0, max(ks, lo_k), xtol=1e-14))
    top = max(ks, lo_k) * 2.0
    while above(top) > 0:
        top *= 2.0
    hi = float(optimize.brentq(above, max(ks, lo_k), top, xtol=1e-14, rtol=1e-10))
    lr = max(0.0, 2.0 * (ll_hat - ll0))
    return ks, (lo, hi), 0.5 * chi2_sf(lr, 1)


def fit_separated_noise(records: list[NoiseRecord]) -> SeparatedNoise:
    """``k_left``, ``k_right`` from the straight runs, ``k_scrub`` from the turns (module doc).

    Never raises for lack of data: a constant no kind of motion identifies is returned unknown,
    with the reason (fewer than :data:`MIN_NOISE_TRIALS` straight runs leave all three unknown,
    as the turns alone cannot split their variance between the wheels and scrub)."""
    straight = [rec for rec in records if not rec.kind.turns_in_place]
    turns = [rec for rec in records if rec.kind.turns_in_place]
    s_ids = tuple(rec.trial_id for rec in straight)
    t_ids = tuple(rec.trial_id for rec in turns)
    if len(straight) < MIN_NOISE_TRIALS:
        why = (
            f"{len(straight)} measured straight runs (x or y fits), at least "
            f"{MIN_NOISE_TRIALS} needed"
        )
        wheel_l = NoiseConstant("k_left", None, None, s_ids, why)
        wheel_r = NoiseConstant("k_right", None, None, s_ids, why)
        scrub_why = (
            "without straight runs the turns' variance cannot be split between wheel noise and "
            "scrub"
            if len(turns) >= MIN_NOISE_TRIALS
            else f"{len(turns)} measured turns, at least {MIN_NOISE_TRIALS} needed"
        )
        scrub = NoiseConstant("k_scrub", None, None, t_ids, scrub_why)
        return SeparatedNoise(wheel_l, wheel_r, scrub, False, None)
    wheels = fit_wheel_noise(straight)
    src = f"{len(straight)} straight runs"
    wheel_l = NoiseConstant("k_left", wheels.k_left, wheels.k_left_ci95, s_ids, src)
    wheel_r = NoiseConstant("k_right", wheels.k_right, wheels.k_right_ci95, s_ids, src)
    if len(turns) < MIN_NOISE_TRIALS:
        why = f"{len(turns)} measured turns (rotations, pivots), at least {MIN_NOISE_TRIALS} needed"
        scrub = NoiseConstant("k_scrub", None, None, t_ids, why)
        return SeparatedNoise(wheel_l, wheel_r, scrub, wheels.identifiable, None)
    ks, ci, p = _scrub_fit(turns, wheels.k_right, wheels.k_left)
    scrub = NoiseConstant(
        "k_scrub",
        ks,
        ci,
        t_ids,
        f"{len(turns)} turns, beyond the straight runs' wheel noise",
    )
    return SeparatedNoise(wheel_l, wheel_r, scrub, wheels.identifiable, p)
