"""``analyze_trials``: every statistic of the lab from a list of trials, in one result object."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from odolab.analysis.growth import GrowthFit, fit_growth
from odolab.analysis.noise import (
    NoiseRecord,
    SeparatedNoise,
    WheelNoise,
    fit_separated_noise,
    fit_wheel_noise,
    noise_record,
)
from odolab.analysis.outliers import Outlier, miscounted_turns
from odolab.analysis.random import GroupSpread, RandomError, group_spreads, random_error
from odolab.analysis.systematic import MIN_FIT_POINTS, LinearFit, fit_line
from odolab.analysis.terrain import TerrainComparison, compare_terrains
from odolab.core.errors import InsufficientDataError
from odolab.core.motion import Motion
from odolab.core.numfmt import count
from odolab.core.params import RobotParams
from odolab.core.progress import Progress, steps
from odolab.core.trials import MotionKind, Trial, TrialStatus

__all__ = ["MOTIONS", "LabAnalysis", "MotionAnalysis", "Progress", "analyze_trials"]


#: The motions the lab fits, in report order, with what is regressed on what (from
#: :class:`odolab.core.motion.Motion`, which holds these rules).
MOTIONS: dict[str, dict[str, str]] = {
    m.value: {"x": m.x_label, "y": m.y_label, "unit": m.unit, "ratio_unit": m.ratio_unit}
    for m in Motion
}


@dataclass(frozen=True, eq=False)
class MotionAnalysis:
    """The analysis of one motion on one terrain: fit, random error, spreads, growth."""

    motion: Motion
    terrain: str
    fit: LinearFit
    random: RandomError
    groups: list[GroupSpread]
    growth: GrowthFit | None
    growth_note: str | None
    outliers: list[Outlier]
    commanded: np.ndarray
    #: rotation, pivot and x: the proportional fit ``actual = ratio * predicted`` (a scale
    #: error moves nothing when nothing is commanded); None for the y rows
    ratio_fit: LinearFit | None = None

    @property
    def _ratio_source(self) -> LinearFit:
        return self.ratio_fit if self.ratio_fit is not None else self.fit

    @property
    def ratio(self) -> float:
        """actual/predicted for rotation and x (proportional fit); error per metre travelled
        for y rows (slope of the line with an intercept, as the lab fitted it)."""
        slope = self._ratio_source.slope
        return self.motion.ratio_sign * slope

    @property
    def ratio_se(self) -> float:
        return self._ratio_source.slope_se

    @property
    def ratio_ci95(self) -> tuple[float, float]:
        lo, hi = self._ratio_source.slope_ci95
        return (-hi, -lo) if self.motion.ratio_sign < 0 else (lo, hi)

    def to_dict(self) -> dict[str, object]:
        return {
            "motion": self.motion.value,
            "terrain": self.terrain,
            "regression": {"x": self.motion.x_label, "y": self.motion.y_label},
            "fit": self.fit.to_dict(),
            "ratio_fit": None if self.ratio_fit is None else self.ratio_fit.to_dict(arrays=False),
            "ratio": self.ratio,
            "ratio_ci95": list(self.ratio_ci95),
            "random": self.random.to_dict(),
            "groups": [g.to_dict() for g in self.groups],
            "growth": None if self.growth is None else self.growth.to_dict(),
            "growth_note": self.growth_note,
            "outliers": [o.to_dict() for o in self.outliers],
        }


@dataclass(frozen=True, eq=False)
class LabAnalysis:
    """Everything :func:`analyze_trials` found. ``to_dict()`` is JSON-able."""

    motions: list[MotionAnalysis]
    terrain_tests: list[TerrainComparison]
    noise: WheelNoise | None
    noise_note: str | None
    noise_by_kind: dict[str, WheelNoise]
    outliers: list[Outlier]
    excluded: list[dict[str, str]]
    skipped: list[str]
    n_trials: int
    n_measured: int
    campaigns: list[str]
    terrains: list[str]
    params: RobotParams | None
    square_trials: list[Trial] = field(default_factory=list)
    #: k_left, k_right from straight runs and k_scrub from turns, kept apart (analysis.noise)
    noise_split: SeparatedNoise | None = None

    def get(self, motion: str, terrain: str | None = None) -> MotionAnalysis | None:
        """The analysis of ``motion`` on ``terrain`` (or the first terrain that has it)."""
        for m in self.motions:
            if m.motion == motion and (terrain is None or m.terrain == terrain):
                return m
        return None

    def to_dict(self) -> dict[str, object]:
        return {
            "n_trials": self.n_trials,
            "n_measured": self.n_measured,
            "campaigns": list(self.campaigns),
            "terrains": list(self.terrains),
            "params": None if self.params is None else self.params.to_dict(),
            "motions": [m.to_dict() for m in self.motions],
            "terrain_tests": [t.to_dict() for t in self.terrain_tests],
            "wheel_noise": None if self.noise is None else self.noise.to_dict(),
            "wheel_noise_note": self.noise_note,
            "wheel_noise_by_kind": {k: v.to_dict() for k, v in self.noise_by_kind.items()},
            "noise_split": None if self.noise_split is None else self.noise_split.to_dict(),
            "outliers": [o.to_dict() for o in self.outliers],
            "excluded_trials": list(self.excluded),
            "skipped": list(self.skipped),
        }


@dataclass
class _Series:
    ids: list[str] = field(default_factory=list)
    predicted: list[float] = field(default_factory=list)
    actual: list[float] = field(default_factory=list)
    commanded: list[float] = field(default_factory=list)
    trials: list[Trial] = field(default_factory=list)


def _collect(trials: Sequence[Trial]) -> dict[tuple[Motion, str], _Series]:
    series: dict[tuple[Motion, str], _Series] = {}

    def add(motion: Motion, tr: Trial, pred: float, act: float, cmd: float) -> None:
        s = series.setdefault((motion, tr.terrain), _Series())
        s.ids.append(tr.trial_id)
        s.predicted.append(pred)
        s.actual.append(act)
        s.commanded.append(cmd)
        s.trials.append(tr)

    for tr in trials:
        meas, cmd = tr.measured, tr.command
        if meas is None:
            continue
        if cmd.kind.turns_in_place and meas.rotation is not None:
            angle = cmd.angle if cmd.angle is not None else tr.predicted.heading
            (turn,) = cmd.kind.fits
            add(turn, tr, tr.predicted.heading, meas.rotation, angle)
        elif cmd.kind is MotionKind.TRANSLATION:
            dist = cmd.distance if cmd.distance is not None else tr.predicted.x
            if meas.x is not None:
                add(Motion.X, tr, tr.predicted.x, meas.x, dist)
            if meas.y is not None:
                # the lab's y fit: error (predicted - actual) against predicted x
                add(Motion.of_y(dist), tr, tr.predicted.x, tr.predicted.y - meas.y, dist)
    return series


def _analyse_series(
    motion: Motion, terrain: str, s: _Series, skipped: list[str]
) -> MotionAnalysis | None:
    pred = np.asarray(s.predicted, dtype=np.float64)
    act = np.asarray(s.actual, dtype=np.float64)
    cmd = np.asarray(s.commanded, dtype=np.float64)
    ids = list(s.ids)
    outliers: list[Outlier] = []
    # a turn's whole turns are counted by hand, and can be miscounted
    turns = miscounted_turns(pred, act) if motion.angular else np.zeros(pred.size, dtype=bool)
    flags = turns
    if flags.any() and int((~flags).sum()) >= MIN_FIT_POINTS:
        keep = ~flags
        probe = fit_line(pred[keep], act[keep], name=f"{motion} ({terrain})")
        for i in np.flatnonzero(flags):
            r = float(act[i] - probe.predict(pred[i]))
            n_turns = round(r / (2 * math.pi))
            reason = (
                f"residual {r:+.2f} rad is about {n_turns:+d} x 2 pi, far outside the "
                "scatter of the other trials: likely a miscounted turn"
            )
            outliers.append(
                Outlier(
                    trial_id=ids[i],
                    motion=motion.value,
                    terrain=terrain,
                    predicted=float(pred[i]),
                    actual=float(act[i]),
                    residual=r,
                    reason=reason,
                )
            )
        pred, act, cmd = pred[keep], act[keep], cmd[keep]
        ids = [i for i, k in zip(ids, keep, strict=True) if k]
    label = f"{motion} ({terrain})"
    try:
        fit = fit_line(pred, act, name=label, trial_ids=ids)
        rnd = random_error(fit.residuals, fit.df_resid)
        ratio_fit = (
            fit_line(
                pred, act, name=f"{label}, through the origin", trial_ids=ids, through_origin=True
            )
            if motion.ideal_line
            else None
        )
    except InsufficientDataError as err:
        skipped.append(str(err))
        return None
    errors = motion.errors(pred, act)
    groups = group_spreads(cmd, pred, errors)
    growth: GrowthFit | None = None
    note: str | None = None
    try:
        growth = fit_growth(pred, fit.residuals, name=label)
    except InsufficientDataError as err:
        note = str(err)
    return MotionAnalysis(
        motion=motion,
        terrain=terrain,
        fit=fit,
        random=rnd,
        groups=groups,
        growth=growth,
        growth_note=note,
        outliers=outliers,
        commanded=cmd,
        ratio_fit=ratio_fit,
    )


def _noise_records(motions: list[MotionAnalysis], by_id: dict[str, Trial]) -> list[NoiseRecord]:
    # each trial's residuals, on the actual side, by the noise record's residual they are
    residuals: dict[str, dict[str, float]] = {}
    for m in motions:
        for tid, r in zip(m.fit.trial_ids, m.fit.residuals, strict=True):
            residuals.setdefault(tid, {})[m.motion.noise_residual] = m.motion.actual_side(float(r))
    # the turns in fit order, then the straight runs by id
    turns = [tid for tid in residuals if by_id[tid].command.kind.turns_in_place]
    straight = sorted(set(residuals) - set(turns))
    records: list[NoiseRecord] = []
    for tid in [*turns, *straight]:
        tr = by_id[tid]
        kind = tr.command.kind
        p, meas = tr.predicted, tr.measured
        sig = (meas.sigma_rotation if kind.turns_in_place else meas.sigma_xy) if meas else None
        records.append(
            noise_record(
                kind,
                p.heading if kind.turns_in_place else p.x,
                tr.params.track_width,
                residuals[tid],
                held=tr.command.direction,
                sigma=sig or 0.0,
                trial_id=tid,
            )
        )
    return records


def _noise_fits(
    records: list[NoiseRecord],
) -> tuple[WheelNoise | None, str | None, dict[str, WheelNoise]]:
    """The wheel-noise constants pooled over every motion, a note when they cannot be fitted or
    one pair does not explain every kind of motion, and the constants of each kind alone."""
    noise: WheelNoise | None = None
    noise_note: str | None = None
    try:
        noise = fit_wheel_noise(records)
    except InsufficientDataError as err:
        noise_note = str(err)
    by_kind: dict[str, WheelNoise] = {}
    for kind in sorted({rec.kind for rec in records}):
        try:
            by_kind[kind] = fit_wheel_noise([rec for rec in records if rec.kind == kind])
        except InsufficientDataError:
            continue
    if noise is not None and noise.same_k_pvalue is not None and noise.same_k_pvalue < 0.05:
        sums = ", ".join(f"{k}: {v:.3g} m" for k, v in noise.k_sum_by_kind.items())
        noise_note = (
            "one pair (k_r, k_l) does not explain every kind of motion (likelihood-ratio "
            f"p = {noise.same_k_pvalue:.2g}; k_r + k_l by motion: {sums}); use the constants "
            "of the motion you need (e.g. in-place turns of a tracked robot skid far more)"
        )
    return noise, noise_note, by_kind


def analyze_trials(trials: Sequence[Trial], *, progress: Progress | None = None) -> LabAnalysis:
    """Fit every motion on every terrain and characterise its systematic and random error.

    Uses MEASURED trials only; EXCLUDED ones are listed with their reasons. Fits that lack data
    are listed in ``skipped`` (one sentence each, saying how many trials are needed). Raises
    :class:`InsufficientDataError` when not a single fit is possible.
    """
    say = steps(progress)
    trials = list(trials)
    measured = [t for t in trials if t.status is TrialStatus.MEASURED and t.measured is not None]
    excluded = [
        {"trial_id": t.trial_id, "reason": t.exclusion_reason or "excluded"}
        for t in trials
        if t.status is TrialStatus.EXCLUDED
    ]
    by_id = {t.trial_id: t for t in measured}
    say(f"{count(len(measured), 'measured trial')} of {len(trials)}")
    series = _collect(measured)
    order = list(Motion)
    motions: list[MotionAnalysis] = []
    skipped: list[str] = []
    for motion, terrain in sorted(series, key=lambda k: (order.index(k[0]), k[1])):
        say(f"fitting {motion} on {terrain}")
        m = _analyse_series(motion, terrain, series[(motion, terrain)], skipped)
        if m is not None:
            motions.append(m)
    squares = [t for t in measured if t.command.kind is MotionKind.SQUARE]
    if not motions and not squares:
        detail = f" ({'; '.join(skipped)})" if skipped else ""
        raise InsufficientDataError(
            f"no fit possible from {count(len(measured), 'measured trial')}: each motion and "
            f"terrain needs at least {MIN_FIT_POINTS} measured trials at two or more distances "
            f"or angles{detail}; a protocol on the virtual Jaguar (`odolab sim run rotation "
            "{{db}} NOTEBOOK`) records enough in seconds"
        )
    tests: list[TerrainComparison] = []
    for motion in order:
        fits = {m.terrain: m.fit for m in motions if m.motion == motion}
        if len(fits) < 2:
            continue
        say(f"comparing terrains for {motion}")
        try:
            tests.append(compare_terrains(motion.value, {t: (f.x, f.y) for t, f in fits.items()}))
        except InsufficientDataError as err:
            skipped.append(str(err))
    records = _noise_records(motions, by_id)
    say("fitting wheel noise constants")
    noise, noise_note, by_kind = _noise_fits(records)
    params = Counter(t.params for t in measured).most_common(1)
    return LabAnalysis(
        motions=motions,
        terrain_tests=tests,
        noise=noise,
        noise_note=noise_note,
        noise_by_kind=by_kind,
        outliers=[o for m in motions for o in m.outliers],
        excluded=excluded,
        skipped=skipped,
        n_trials=len(trials),
        n_measured=len(measured),
        campaigns=sorted({t.campaign for t in trials}),
        terrains=sorted({t.terrain for t in measured}),
        params=params[0][0] if params else None,
        square_trials=squares,
        noise_split=fit_separated_noise(records),
    )
