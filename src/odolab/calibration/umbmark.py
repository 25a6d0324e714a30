"""UMBmark (Borenstein & Feng, 1996): square runs clockwise and counter-clockwise.

The robot drives a square of side ``L`` by odometry, ``n`` times each way, and the return
position is measured. Errors are ``measured - odometry`` (x, y) in the start frame, x along the
first leg, y to the left (a ccw square turns left). Two systematic errors dominate:

* Type A, the track width: each 90 deg turn comes out short by ``alpha``
  (``E_b = b_actual / b_nominal = (pi/2) / (pi/2 - alpha)``);
* Type B, unequal wheel diameters: each straight leg curves by ``beta`` (left positive), a
  circle of radius ``R = (L/2) / sin(beta/2)``, so ``E_d = D_R / D_L = (R + b/2) / (R - b/2)``.

To first order the return errors' centres of gravity are ``x_cw = y_cw = -2L(alpha + beta)``
and ``x_ccw = -y_ccw = 2L(beta - alpha)``, so, as in the paper,
``alpha = (x_cw + x_ccw) / (-4L)``, ``beta = (x_cw - x_ccw) / (-4L)``, and from y
``alpha = (y_cw - y_ccw) / (-4L)``, ``beta = (y_cw + y_ccw) / (-4L)``. Here both are used: alpha
and beta are the least-squares solution of all four equations (the mean of the x and y
estimates; each is also reported).

Corrections: ``b_new = E_b b``; left and right radii multiplied by ``c_L = 2 / (E_d + 1)`` and
``c_R = 2 / (1/E_d + 1)`` (their mean is kept). The benchmark is
``E_max,syst = max(|cg_cw|, |cg_ccw|)``, the larger distance of the two centres of gravity from
the origin.

Those formulas linearize around small errors. When the errors are large (a robot whose turns
come out 10 deg short ends its 4 m squares metres from the start) one step corrects only part
of them. :func:`umbmark_iterated` repeats the step on the same runs: re-integrate the square
trials' encoder logs with the current parameters, take one UMBmark step relative to them, and
stop when the step no longer changes them. Each step multiplies the track width by its ``E_b``
and the right/left diameter ratio by its ``E_d`` (``c_R / c_L = E_d``), so the cumulative
``E_b`` and ``E_d`` are the products of the steps'. The iteration's fixed point is where the
re-integrated runs' centres of gravity show no alpha and no beta, which no linearization error
can move: for a robot the model can describe, its true parameters, provided the starting mean
wheel radius is the true one. Like one step, it leaves the mean wheel radius (the scale, which
UMBmark does not calibrate) where it was, up to second order; the track it finds is the one that
makes the turns right with that radius.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.calibration.ratios import (
    CalibrationResult,
    _now,
    check_track_model,
    with_noise,
)
from odolab.core.distributions import Z95
from odolab.core.errors import CalibrationError, LogFormatError
from odolab.core.params import RobotParams
from odolab.core.text import quote_input
from odolab.core.trials import MotionKind, Trial, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis

__all__ = [
    "UmbmarkResult",
    "e_max_syst",
    "read_umbmark_errors_csv",
    "scale_sd_from",
    "umbmark",
    "umbmark_errors_from_trials",
    "umbmark_iterated",
]


def read_umbmark_errors_csv(
    path: str | Path,
) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """(cw, ccw) return errors (x, y in m) from a CSV with the header ``direction,x,y``.

    Every refusal is one :class:`~odolab.core.errors.LogFormatError` sentence naming the file and
    the line: not UTF-8, a line over 1 MB, a column twice, a missing column, a non-number, a
    direction other than cw or ccw, no run at all.
    """
    import csv

    from odolab.io.limits import check_columns_unique, check_text_file

    p = Path(path)
    if not p.is_file():
        raise LogFormatError(f"{p}: no such file; expected a CSV with header direction,x,y")
    check_text_file(p, expected="a CSV with header direction,x,y")
    cw: list[tuple[float, float]] = []
    ccw: list[tuple[float, float]] = []
    try:
        with p.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            check_columns_unique(p, header)
            missing = [c for c in ("direction", "x", "y") if c not in header]
            if missing:
                raise LogFormatError(
                    f"{p}: line 1 has no column {missing[0]!r}; expected a header with direction,x,y"
                )
            col = {name: header.index(name) for name in ("direction", "x", "y")}
            for cells in reader:
                line = reader.line_num
                if not any(c.strip() for c in cells):
                    continue
                cell = {k: cells[j].strip() if j < len(cells) else "" for k, j in col.items()}
                try:
                    xy = (float(cell["x"]), float(cell["y"]))
                except ValueError:
                    xy = (math.nan, math.nan)
                if not all(math.isfinite(v) for v in xy):
                    raise LogFormatError(
                        f"{p}: line {line}: x and y must be finite numbers (m), got "
                        f"{quote_input(cell['x'])} and {quote_input(cell['y'])}"
                    )
                d = cell["direction"].lower()
                if d not in ("cw", "ccw"):
                    raise LogFormatError(
                        f"{p}: line {line}: direction must be cw or ccw, got {quote_input(d)}"
                    )
                (cw if d == "cw" else ccw).append(xy)
    except csv.Error as err:
        raise LogFormatError(f"{p}: not readable as CSV ({err})") from err
    except OSError as err:
        raise LogFormatError(f"{p}: cannot read ({err.strerror or err})") from err
    return cw, ccw


def _errors(name: str, errors: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(errors, dtype=np.float64)
    if arr.size == 0:
        raise CalibrationError(f"{name}: UMBmark needs at least one run in each direction, got 0")
    if arr.ndim == 1 and arr.size == 2:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise CalibrationError(
            f"{name} must be an (n, 2) array of (x, y) return errors in m, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(f"{name} contains NaN or infinite values")
    return arr


def e_max_syst(cw_errors: ArrayLike, ccw_errors: ArrayLike) -> float:
    """UMBmark's measure of systematic odometry error (m): the larger |centre of gravity|."""
    cw = _errors("cw_errors", cw_errors).mean(axis=0)
    ccw = _errors("ccw_errors", ccw_errors).mean(axis=0)
    return float(max(math.hypot(*cw), math.hypot(*ccw)))


@dataclass(frozen=True, eq=False)
class UmbmarkResult:
    """UMBmark's errors, the corrected parameters and the benchmark figure."""

    params: RobotParams
    e_d: float
    e_b: float
    alpha: float
    beta: float
    alpha_from_x: float
    alpha_from_y: float
    beta_from_x: float
    beta_from_y: float
    cg_cw: tuple[float, float]
    cg_ccw: tuple[float, float]
    e_max_syst: float
    side: float
    n_cw: int
    n_ccw: int
    calibration: CalibrationResult
    cw_errors: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    ccw_errors: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    #: return errors of the same runs re-integrated with the corrected parameters, if known
    after: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    @property
    def e_max_syst_after(self) -> float | None:
        """E_max,syst of the runs re-integrated with the corrected parameters (None: unknown)."""
        return None if self.after is None else e_max_syst(*self.after)

    def with_after(self, cw_errors: ArrayLike, ccw_errors: ArrayLike) -> UmbmarkResult:
        """A copy that knows the return errors after correction (same runs, new parameters)."""
        after = (_errors("cw_errors", cw_errors), _errors("ccw_errors", ccw_errors))
        prov = dict(self.calibration.provenance)
        prov["e_max_syst_after"] = e_max_syst(*after)
        cal = CalibrationResult("umbmark", self.params, self.calibration.old_params, prov)
        return replace(self, after=after, calibration=cal)

    def with_noise(self, analysis: LabAnalysis) -> UmbmarkResult:
        """A copy whose parameters carry the analysis' separated ``[noise]`` (k_left, k_right
        from its straight runs, k_scrub from its turns; :func:`odolab.calibration.ratios.
        with_noise`), scaled to the corrected geometry; unchanged without a noise fit."""
        cal = with_noise(self.calibration, analysis)
        return replace(self, params=cal.params, calibration=cal)

    def intervals_sentence(self) -> str | None:
        """The new parameters' 95 % intervals and what they hold (the squares' scatter, with
        or without the ratios' scale), in one sentence; None without intervals."""
        prov = self.calibration.provenance
        cis = [prov.get(f"{k}_ci95") for k in ("left_wheel_radius", "right_wheel_radius")]
        track = prov.get("track_width_ci95")
        if not all(isinstance(c, list) and len(c) == 2 for c in (*cis, track)):
            return None
        (l0, l1), (r0, r1), (b0, b1) = cis[0], cis[1], track  # type: ignore[misc]
        return (
            f"95 % intervals ({prov.get('ci95_includes', 'the squares scatter')}): left radius "
            f"[{l0:.5g}, {l1:.5g}] m, right radius [{r0:.5g}, {r1:.5g}] m, track width "
            f"[{b0:.5g}, {b1:.5g}] m"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "params": self.params.to_dict(),
            "e_d": self.e_d,
            "e_b": self.e_b,
            "alpha": self.alpha,
            "beta": self.beta,
            "alpha_from_x": self.alpha_from_x,
            "alpha_from_y": self.alpha_from_y,
            "beta_from_x": self.beta_from_x,
            "beta_from_y": self.beta_from_y,
            "cg_cw": list(self.cg_cw),
            "cg_ccw": list(self.cg_ccw),
            "e_max_syst": self.e_max_syst,
            "side": self.side,
            "n_cw": self.n_cw,
            "n_ccw": self.n_ccw,
            "cw_errors": self.cw_errors.tolist(),
            "ccw_errors": self.ccw_errors.tolist(),
            "e_max_syst_after": self.e_max_syst_after,
            "cw_errors_after": None if self.after is None else self.after[0].tolist(),
            "ccw_errors_after": None if self.after is None else self.after[1].tolist(),
            "provenance": dict(self.calibration.provenance),
        }


def _corrected(
    params: RobotParams, alpha: float, beta: float, side: float
) -> tuple[float, float, float, float, float]:
    """UMBmark's corrections for errors ``alpha`` (per turn) and ``beta`` (per leg):
    ``(E_b, E_d, left radius, right radius, track width)``."""
    b = params.track_width
    e_b = (math.pi / 2) / (math.pi / 2 - alpha)
    if abs(beta) < 1e-12:
        e_d = 1.0
    else:
        radius = (side / 2) / math.sin(beta / 2)
        e_d = (radius + b / 2) / (radius - b / 2)
    c_l = 2.0 / (e_d + 1.0) if e_d > 0 else math.nan
    c_r = 2.0 / (1.0 / e_d + 1.0) if e_d > 0 else math.nan
    return e_b, e_d, params.left_wheel_radius * c_l, params.right_wheel_radius * c_r, b * e_b


def _alpha_beta(
    cw: NDArray[np.float64], ccw: NDArray[np.float64], side: float
) -> tuple[float, float, float, float, float, float]:
    """UMBmark's errors from the return errors' centres of gravity, the one place of the
    formula: ``(alpha, beta, alpha_from_x, alpha_from_y, beta_from_x, beta_from_y)``, with
    ``alpha = -(x_cw + y_cw + x_ccw - y_ccw) / (8 L)`` and ``beta = -(x_cw + y_cw - x_ccw +
    y_ccw) / (8 L)`` the means of the estimates from x and from y."""
    xcw, ycw = (float(v) for v in cw.mean(axis=0))
    xccw, yccw = (float(v) for v in ccw.mean(axis=0))
    L = float(side)
    a_x = (xcw + xccw) / (-4 * L)
    b_x = (xcw - xccw) / (-4 * L)
    a_y = (ycw - yccw) / (-4 * L)
    b_y = (ycw + yccw) / (-4 * L)
    return 0.5 * (a_x + a_y), 0.5 * (b_x + b_y), a_x, a_y, b_x, b_y


def scale_sd_from(result: CalibrationResult) -> float | None:
    """The relative standard error of the wheel-radius scale a ratios calibration fixed (from
    its ``wheel_radius_ci95``, a log-normal interval), or None when it carries none."""
    ci = result.provenance.get("wheel_radius_ci95")
    if not (isinstance(ci, list | tuple) and len(ci) == 2):
        return None
    lo, hi = float(ci[0]), float(ci[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        return None
    return math.log(hi / lo) / (2 * Z95)


def umbmark_intervals(
    cw: NDArray[np.float64],
    ccw: NDArray[np.float64],
    side: float,
    params: RobotParams,
    scale_sd: float | None = None,
) -> dict[str, object]:
    """95 % intervals of UMBmark's new parameters from the scatter of the return errors:
    ``alpha`` and ``beta`` (:func:`_alpha_beta`) are means of the errors, so their standard
    errors come from each direction's sample variance (x and y of one run together) over its
    number of runs, with Student's t on the smaller direction's degrees of freedom; the track
    width follows ``alpha`` alone and the wheel radii ``beta`` alone, monotonically, so their
    intervals are the corrections at the ends of those of ``alpha`` and ``beta``.

    UMBmark cannot see the scale: a square closes whatever the wheels' common size, so the
    radii keep the scale of ``params`` and the track width follows it (the turns are right for
    the track over the radii). When ``params`` come from a ratios calibration, ``scale_sd`` is
    the relative standard error of its scale (:func:`scale_sd_from`) and each interval adds it
    in quadrature, on the log scale (``ci95_includes`` says so); without it the interval is the
    squares' scatter only, the scale of ``params`` taken as exact, and ``ci95_includes`` says
    that. Empty with fewer than 2 runs in a direction (no scatter to go by) or an end past the
    small-error model. Keys: ``left_wheel_radius_ci95``, ``right_wheel_radius_ci95``,
    ``track_width_ci95``, ``ci95_includes``."""
    from odolab.core.distributions import t_ppf

    n1, n2 = int(cw.shape[0]), int(ccw.shape[0])
    if min(n1, n2) < 2:
        return {"ci95_note": f"no interval: {n1} + {n2} squares, none to tell their scatter by"}
    L = float(side)
    s_cw = float(np.var(cw[:, 0] + cw[:, 1], ddof=1)) / n1
    alpha, beta = _alpha_beta(cw, ccw, L)[:2]
    se_a = math.sqrt(s_cw + float(np.var(ccw[:, 0] - ccw[:, 1], ddof=1)) / n2) / (8 * L)
    se_b = math.sqrt(s_cw + float(np.var(ccw[:, 1] - ccw[:, 0], ddof=1)) / n2) / (8 * L)
    t = t_ppf(0.975, min(n1, n2) - 1)
    ends = [(float(alpha) + k * t * se_a, float(beta) + k * t * se_b) for k in (-1.0, 1.0)]
    values = [_corrected(params, a, bb, L) for a, bb in ends]
    centre = _corrected(params, alpha, beta, L)
    wide: dict[str, object] = {
        "ci95_note": f"no interval: the {n1} + {n2} squares' return errors scatter too much "
        f"(alpha {alpha:.3f} ± {t * se_a:.3f} rad, beta {beta:.3f} ± {t * se_b:.3f} rad at 95 %) "
        "for UMBmark's small-error model"
    }
    if any(abs(a) >= math.pi / 4 or abs(bb) >= math.pi / 4 for a, bb in ends):
        return wide
    sd = scale_sd if scale_sd is not None and math.isfinite(scale_sd) and scale_sd > 0 else None
    out: dict[str, object] = {
        "ci95_includes": (
            "the squares' scatter only, the starting parameters' scale taken as exact"
            if sd is None
            else f"the squares' scatter and the ratios calibration's scale (±{100 * Z95 * sd:.2g}"
            " % at 95 %), in quadrature"
        )
    }
    for key, i in (("left_wheel_radius", 2), ("right_wheel_radius", 3), ("track_width", 4)):
        lo, hi = sorted(float(v[i]) for v in values)
        mid = float(centre[i])
        if not (math.isfinite(lo) and math.isfinite(hi) and lo > 0 and lo <= mid <= hi):
            return wide
        if sd is not None:  # log half-widths, each side, with the scale's added
            lo = mid * math.exp(-math.hypot(math.log(mid / lo), Z95 * sd))
            hi = mid * math.exp(math.hypot(math.log(hi / mid), Z95 * sd))
        out[f"{key}_ci95"] = [lo, hi]
    return out


def umbmark(
    cw_errors: ArrayLike,
    ccw_errors: ArrayLike,
    side: float,
    params: RobotParams,
    *,
    scale_sd: float | None = None,
) -> UmbmarkResult:
    """UMBmark from return errors (measured - odometry), each shape (n, 2), square ``side`` m.
    ``scale_sd``: the relative standard error of the scale of ``params`` when a ratios
    calibration fixed it (:func:`scale_sd_from`), carried into the intervals
    (:func:`umbmark_intervals`)."""
    check_track_model(params, "UMBmark")
    cw = _errors("cw_errors", cw_errors)
    ccw = _errors("ccw_errors", ccw_errors)
    L = float(side)
    if not math.isfinite(L) or L <= 0:
        raise CalibrationError(f"square side must be a positive length in m, got {side!r}")
    xcw, ycw = (float(v) for v in cw.mean(axis=0))
    xccw, yccw = (float(v) for v in ccw.mean(axis=0))
    alpha, beta, a_x, a_y, b_x, b_y = _alpha_beta(cw, ccw, L)
    if abs(alpha) >= math.pi / 4 or abs(beta) >= math.pi / 4:
        raise CalibrationError(
            f"UMBmark errors are too large for its small-error model (alpha = {alpha:.3f} rad, "
            f"beta = {beta:.3f} rad per 90 deg turn / leg); check the side ({L} m) and the sign "
            "convention (measured - odometry, x along the first leg)"
        )
    e_b, e_d, left, right, track = _corrected(params, alpha, beta, L)
    if e_d <= 0:
        raise CalibrationError(f"UMBmark gives a negative diameter ratio (beta = {beta:.3f})")
    new = params.with_(
        left_wheel_radius=left,
        right_wheel_radius=right,
        track_width=track,
        name=f"{params.name}-umbmark",
    )
    emax = e_max_syst(cw, ccw)
    prov: dict[str, object] = {
        "method": "umbmark",
        "created": _now(),
        "reference": "Borenstein & Feng 1996, UMBmark",
        "from_params": params.name,
        "side": L,
        "n_cw": int(cw.shape[0]),
        "n_ccw": int(ccw.shape[0]),
        "cg_cw": [xcw, ycw],
        "cg_ccw": [xccw, yccw],
        "alpha": alpha,
        "beta": beta,
        "e_b": e_b,
        "e_d": e_d,
        "e_max_syst_before": emax,
        "convention": (
            "errors = measured - odometry in the start frame (x along the first leg, y left); "
            "track_width_new = E_b * track_width; left radius *= 2/(E_d+1); "
            "right radius *= 2/(1/E_d+1)"
        ),
        "old": params.to_dict(),
        **umbmark_intervals(cw, ccw, L, params, scale_sd),
    }
    return UmbmarkResult(
        params=new,
        e_d=e_d,
        e_b=e_b,
        alpha=alpha,
        beta=beta,
        alpha_from_x=a_x,
        alpha_from_y=a_y,
        beta_from_x=b_x,
        beta_from_y=b_y,
        cg_cw=(xcw, ycw),
        cg_ccw=(xccw, yccw),
        e_max_syst=emax,
        side=L,
        n_cw=int(cw.shape[0]),
        n_ccw=int(ccw.shape[0]),
        calibration=CalibrationResult("umbmark", new, params, prov),
        cw_errors=cw,
        ccw_errors=ccw,
    )


def _iteration_entry(k: int, p: RobotParams, emax: float) -> dict[str, object]:
    return {
        "iteration": k,
        "left_wheel_radius": p.left_wheel_radius,
        "right_wheel_radius": p.right_wheel_radius,
        "track_width": p.track_width,
        "e_max_syst": emax,
    }


def _square_trials(trials: Sequence[Trial]) -> list[Trial]:
    """The measured square trials, each with its encoder log (else a CalibrationError)."""
    squares = [
        tr
        for tr in trials
        if tr.command.kind is MotionKind.SQUARE
        and tr.status is TrialStatus.MEASURED
        and tr.measured is not None
        and tr.measured.x is not None
        and tr.measured.y is not None
    ]
    missing = [tr.trial_id for tr in squares if tr.encoder_log is None]
    if missing:
        raise CalibrationError(
            f"iterated UMBmark re-integrates each square trial's encoder log, but "
            f"{len(missing)} of {len(squares)} measured square trials have none (first: "
            f"{missing[0]}); with return errors alone use the single step, umbmark()"
        )
    return squares


@dataclass(frozen=True)
class _Iterated:
    """Where the iteration ended: the first step, the final parameters and their errors, each
    iterate, the cumulative E_d and E_b."""

    first: UmbmarkResult
    current: RobotParams
    cw: NDArray[np.float64]
    ccw: NDArray[np.float64]
    side: float
    iterations: list[dict[str, object]]
    e_d: float
    e_b: float


def _iterate(
    squares: list[Trial], params: RobotParams, max_iter: int, tol: float, scale_sd: float | None
) -> _Iterated:
    """UMBmark steps from ``params`` until no parameter changes by more than ``tol``."""
    base = params
    current = params
    cw, ccw, side = umbmark_errors_from_trials(squares, current)
    first: UmbmarkResult | None = None
    iterations: list[dict[str, object]] = []
    e_d = e_b = 1.0
    change = math.inf
    for k in range(max_iter):
        step = umbmark(cw, ccw, side, current, scale_sd=scale_sd)
        if first is None:
            first = step
        entry = _iteration_entry(k, current, step.e_max_syst)
        entry.update(alpha=step.alpha, beta=step.beta, step_e_d=step.e_d, step_e_b=step.e_b)
        iterations.append(entry)
        e_d *= step.e_d
        e_b *= step.e_b
        new = step.params.with_(name=base.name)
        change = max(
            abs(new.left_wheel_radius / current.left_wheel_radius - 1.0),
            abs(new.right_wheel_radius / current.right_wheel_radius - 1.0),
            abs(new.track_width / current.track_width - 1.0),
        )
        current = new
        cw, ccw, _ = umbmark_errors_from_trials(squares, current)
        if change <= tol:
            break
    assert first is not None
    iterations.append(_iteration_entry(len(iterations), current, e_max_syst(cw, ccw)))
    if change > tol:
        raise CalibrationError(
            f"iterated UMBmark did not converge in {max_iter} steps (last relative parameter "
            f"change {change:.3g}, tolerance {tol:.3g}; E_max,syst {iterations[0]['e_max_syst']:.4g}"
            f" m -> {iterations[-1]['e_max_syst']:.4g} m); check the runs or raise max_iter"
        )
    return _Iterated(first, current, cw, ccw, side, iterations, e_d, e_b)


def _implied_errors(base: RobotParams, e_d: float, e_b: float, side: float) -> tuple[float, float]:
    """The per-turn and per-leg errors (alpha, beta) that the cumulative E_b and E_d stand for."""
    alpha = (math.pi / 2) * (1.0 - 1.0 / e_b)
    half_b = base.track_width / 2
    beta = 0.0
    if e_d != 1.0:
        radius = half_b * (e_d + 1.0) / (e_d - 1.0)
        beta = 2.0 * math.asin(max(-1.0, min(1.0, (side / 2) / radius)))
    return alpha, beta


def umbmark_iterated(
    trials: Sequence[Trial],
    params: RobotParams,
    *,
    max_iter: int = 50,
    tol: float = 1e-9,
    scale_sd: float | None = None,
) -> UmbmarkResult:
    """UMBmark iterated to convergence on square trials that carry their encoder logs.

    Starting from ``params``: re-integrate each measured square trial's encoder log with the
    current parameters, take the return errors (measured - odometry), take one :func:`umbmark`
    step relative to the current parameters; repeat until the step changes no parameter by more
    than ``tol`` (relative), at most ``max_iter`` steps.

    The result's ``params`` are the final parameters; ``e_d`` and ``e_b`` are cumulative,
    relative to ``params`` (the products of the steps'; ``alpha`` and ``beta`` are the per-turn
    and per-leg errors they imply with ``params``' track width); ``cg_cw``, ``cg_ccw``,
    ``e_max_syst``, ``cw_errors``, ``ccw_errors`` and ``alpha_from_x`` ... ``beta_from_y`` are
    those of the runs re-integrated with ``params`` (the first step's); ``after`` holds the
    errors with the final parameters. ``calibration.provenance["iterations"]`` lists each
    iterate (radii, track width, E_max,syst; the step taken from it).

    Raises :class:`~odolab.core.errors.CalibrationError` when a square trial has no encoder log
    (return errors typed in by hand allow only the single step, :func:`umbmark`), or when the
    iteration does not converge in ``max_iter`` steps.
    """
    if isinstance(max_iter, bool) or not isinstance(max_iter, int) or max_iter < 1:
        raise CalibrationError(f"max_iter must be a positive whole number, got {max_iter!r}")
    if not math.isfinite(tol) or tol <= 0:
        raise CalibrationError(f"tol must be a positive relative change, got {tol!r}")
    squares = _square_trials(trials)
    it = _iterate(squares, params, max_iter, tol, scale_sd)
    base, first, current, cw, ccw, side = params, it.first, it.current, it.cw, it.ccw, it.side
    iterations, e_d, e_b = it.iterations, it.e_d, it.e_b
    final = current.with_(name=f"{base.name}-umbmark")
    alpha, beta = _implied_errors(base, e_d, e_b, side)
    prov = dict(first.calibration.provenance)
    for key in ("left_wheel_radius_ci95", "right_wheel_radius_ci95", "track_width_ci95",
                "ci95_note", "ci95_includes"):  # fmt: skip
        prov.pop(key, None)  # the first step's: about its own start, not the result
    # about the result: the step from the final parameters with their errors (it moves them by
    # less than tol), its scatter the runs'
    prov.update(umbmark_intervals(cw, ccw, side, current, scale_sd))
    prov.update(
        method="umbmark-iterated",
        alpha=alpha,
        beta=beta,
        e_b=e_b,
        e_d=e_d,
        n_iterations=len(iterations) - 1,
        tol=tol,
        max_iter=max_iter,
        first_step={
            "alpha": first.alpha,
            "beta": first.beta,
            "e_d": first.e_d,
            "e_b": first.e_b,
            "params": first.params.to_dict(),
        },
        iterations=iterations,
        convention=(
            str(prov["convention"])
            + "; iterated: each step re-integrates the encoder logs with the current parameters "
            "and corrects them; cumulative E_b and E_d are the products of the steps"
        ),
    )
    result = replace(
        first,
        params=final,
        e_d=e_d,
        e_b=e_b,
        alpha=alpha,
        beta=beta,
        calibration=CalibrationResult("umbmark", final, base, prov),
    )
    return result.with_after(cw, ccw)


def _predicted_xy(tr: Trial, params: RobotParams | None) -> tuple[float, float]:
    if params is None:
        return tr.predicted.x, tr.predicted.y
    log = tr.encoder_log
    if log is None:
        raise CalibrationError(
            f"trial {tr.trial_id}: re-predicting with new parameters needs its encoder log"
        )
    from odolab.core.odometry import integrate

    modulus = log.modulus if log.modulus is not None else params.encoder_modulus
    end = integrate(
        log.t, log.left_ticks, log.right_ticks, params.with_(encoder_modulus=modulus)
    ).final
    return end.x, end.y


def umbmark_errors_from_trials(
    trials: Sequence[Trial], params: RobotParams | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """(cw_errors, ccw_errors, side) from measured square trials (measured - predicted).

    With ``params``, each trial's encoder log is re-integrated with them and the errors are
    measured minus that new prediction (the check after a calibration).
    """
    cw: list[tuple[float, float]] = []
    ccw: list[tuple[float, float]] = []
    sides: set[float] = set()
    for tr in trials:
        if tr.command.kind is not MotionKind.SQUARE or tr.status is not TrialStatus.MEASURED:
            continue
        m = tr.measured
        if m is None or m.x is None or m.y is None:
            continue
        px, py = _predicted_xy(tr, params)
        err = (m.x - px, m.y - py)
        direction = (tr.command.direction or "").lower()
        if direction == "cw":
            cw.append(err)
        elif direction == "ccw":
            ccw.append(err)
        else:
            raise CalibrationError(
                f"trial {tr.trial_id}: a square needs direction 'cw' or 'ccw', got {direction!r}"
            )
        if tr.command.side is not None:
            sides.add(round(float(tr.command.side), 6))
    if not cw or not ccw:
        raise CalibrationError(
            "UMBmark needs measured square trials in both directions (at least 1 cw and 1 ccw; "
            f"the method asks for 5 each), got {len(cw)} cw and {len(ccw)} ccw"
        )
    if len(sides) != 1:
        raise CalibrationError(
            f"UMBmark needs square trials of one side length, got {sorted(sides) or 'none'}"
        )
    return np.array(cw), np.array(ccw), sides.pop()
