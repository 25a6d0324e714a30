"""Which kinematic model does my robot need? Fit every model, score it on held-out runs.

:func:`compare_models` fits each model of :data:`odolab.calibration.lsq.FIT_MODELS` on training
runs (:func:`~odolab.calibration.lsq.calibrate_lsq`) and evaluates the fit on runs it did not
see: end-point error, RPE (over 1 m of path) and drift per metre, each a mean over the held-out
runs with a 95 % percentile-bootstrap confidence interval (runs resampled). Without separate
held-out runs every run is held out once (k-fold cross-validation over runs, at most 5 folds).

On the training residuals it also gives an information criterion, BIC
``n ln(RSS / n) + k ln(n)`` (n residuals, k fitted parameters including the ground truth's yaw
offsets), and its difference to the differential drive with a bootstrap CI over training runs
(the fit is not repeated per resample: the CI shows how much the runs disagree, not the whole
uncertainty).

The recommendation is the simplest model (diff < extended < icr) that is *not worse* than the
best one on held-out end-point error: the paired bootstrap CI of the ratio of its mean error to
the best model's reaches down to 1, or the ratio is within 5 %. A more complex model is chosen
only with a held-out gain.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.calibration.lsq import (
    FIT_MODELS,
    LsqCalibration,
    LsqOptions,
    PreparedRun,
    calibrate_lsq,
    find_fit_and_held_out,
    fit_model,
    prepare_run,
)
from odolab.errors import CalibrationError, InsufficientDataError
from odolab.io.registry import LogFormat, read_run
from odolab.io.run import OdometryRun, ReadOptions
from odolab.metrics.runs import RUN_OPTIONS, Progress, evaluate_run, parallel_map
from odolab.params import RobotParams

__all__ = [
    "MODEL_ORDER",
    "Estimate",
    "ModelComparison",
    "ModelScore",
    "compare_model_files",
    "compare_models",
]

#: Models from the simplest to the most complex (the recommendation prefers the left).
MODEL_ORDER = ("diff", "extended", "icr")
#: A model within this fraction of the best model's held-out error is "not worse".
NOT_WORSE = 0.05
_METRICS = ("endpoint_error", "rpe_rmse", "drift_pct", "drift_deg_per_m")


@dataclass(frozen=True)
class Estimate:
    """A mean with its 95 % confidence interval."""

    value: float
    low: float
    high: float

    def to_dict(self) -> dict[str, float]:
        return {"value": self.value, "ci95": [self.low, self.high]}  # type: ignore[dict-item]


@dataclass(frozen=True)
class ModelScore:
    """One model: its fit on the training runs and its scores on the held-out runs."""

    model: str
    n_params: int
    fit: LsqCalibration | None
    #: why the model could not be fitted (not identifiable from these runs), else None
    problem: str | None = None
    #: per held-out run: metric name -> value (runs in ModelComparison.held_out order)
    per_run: dict[str, list[float]] = field(default_factory=dict)
    held_out: dict[str, Estimate] = field(default_factory=dict)
    bic: float = math.nan
    delta_bic: Estimate | None = None  #: BIC minus the differential drive's (negative: better)
    #: paired bootstrap of mean end-point error / the best model's (1 for the best)
    ratio_to_best: Estimate | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "n_params": self.n_params,
            "problem": self.problem,
            "values": self.fit.values if self.fit else None,
            "stderr": self.fit.stderr if self.fit else None,
            "held_out": {k: v.to_dict() for k, v in self.held_out.items()},
            "per_run": self.per_run,
            "bic": self.bic,
            "delta_bic": self.delta_bic.to_dict() if self.delta_bic else None,
            "ratio_to_best": self.ratio_to_best.to_dict() if self.ratio_to_best else None,
        }


@dataclass(frozen=True)
class ModelComparison:
    """Result of :func:`compare_models`."""

    scores: list[ModelScore]
    recommended: str
    reason: str
    train: list[str]
    held_out: list[str]
    cross_validated: bool

    def score(self, model: str) -> ModelScore:
        """The score of one model."""
        for s in self.scores:
            if s.model == model:
                return s
        raise KeyError(model)

    def to_dict(self) -> dict[str, Any]:
        return {
            "recommended": self.recommended,
            "reason": self.reason,
            "train": self.train,
            "held_out": self.held_out,
            "cross_validated": self.cross_validated,
            "models": [s.to_dict() for s in self.scores],
        }


def _bootstrap_mean(values: NDArray[np.float64], rng: np.random.Generator, n: int) -> Estimate:
    mean = float(values.mean())
    if values.size < 2:
        return Estimate(mean, math.nan, math.nan)
    idx = rng.integers(0, values.size, size=(n, values.size))
    boot = values[idx].mean(axis=1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return Estimate(mean, float(lo), float(hi))


def _bootstrap_ratio(
    a: NDArray[np.float64], b: NDArray[np.float64], rng: np.random.Generator, n: int
) -> Estimate:
    """Mean of a / mean of b, runs resampled in pairs."""
    value = float(a.mean() / b.mean()) if b.mean() > 0 else math.nan
    if a.size < 2:
        return Estimate(value, math.nan, math.nan)
    idx = rng.integers(0, a.size, size=(n, a.size))
    with np.errstate(divide="ignore", invalid="ignore"):
        boot = a[idx].mean(axis=1) / b[idx].mean(axis=1)
    lo, hi = np.nanpercentile(boot, [2.5, 97.5])
    return Estimate(value, float(lo), float(hi))


#: Residual variance floor of the BIC (m^2, 1 um RMS): below any ground truth's resolution. A
#: noiseless (simulated) fit would otherwise score -inf; at the floor, fits that are all exact
#: tie on the residuals and the parameter count decides.
BIC_VARIANCE_FLOOR = 1e-12


def _bic(rss: NDArray[np.float64], sizes: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """BIC over axis -1 sums (works on bootstrap matrices)."""
    n = sizes.sum(axis=-1)
    variance = np.maximum(rss.sum(axis=-1) / n, BIC_VARIANCE_FLOOR)
    return np.asarray(n * np.log(variance) + k * np.log(n), dtype=np.float64)


def _fit(
    runs: Sequence[PreparedRun], nominal: RobotParams, options: LsqOptions, model: str
) -> tuple[LsqCalibration | None, str | None]:
    try:
        return calibrate_lsq(runs, nominal, replace(options, model=model)), None
    except (CalibrationError, InsufficientDataError) as err:
        return None, str(err)


def _metrics(run: OdometryRun, params: RobotParams) -> dict[str, float]:
    ev = evaluate_run(run, params, RUN_OPTIONS).evaluation
    return {
        "endpoint_error": ev.drift.endpoint_error,
        "rpe_rmse": ev.rpe.rmse,
        "drift_pct": ev.drift.translation_pct,
        "drift_deg_per_m": ev.drift.rotation_deg_per_m,
    }


def _check_seed(seed: int) -> None:
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CalibrationError(f"seed is {seed!r}; expected an integer >= 0")


def compare_models(
    train: Sequence[OdometryRun],
    held_out: Sequence[OdometryRun] = (),
    nominal: RobotParams | None = None,
    *,
    models: Sequence[str] = MODEL_ORDER,
    options: LsqOptions | None = None,
    folds: int = 5,
    n_boot: int = 2000,
    seed: int = 0,
) -> ModelComparison:
    """Fit every model on ``train`` and score it on ``held_out`` (see the module).

    Without ``held_out`` the runs of ``train`` are split into ``min(folds, len(train))`` folds
    (run i in fold i mod k); each fold is held out once from a fit on the others."""
    o = options or LsqOptions()
    _check_seed(seed)
    if not train:
        raise InsufficientDataError("no runs to compare the models on; expected at least one")
    for m in models:
        fit_model(m)
    order = [m for m in MODEL_ORDER if m in models] + [m for m in models if m not in MODEL_ORDER]
    base = nominal or train[0].params
    if base is None:
        raise CalibrationError(f"{train[0].source}: the run has no nominal parameters")
    prepared = [prepare_run(r, o.segment_s) for r in train]
    rng = np.random.default_rng(seed)
    cv = not held_out
    if cv:
        k = min(folds, len(train))
        if k < 2:
            raise InsufficientDataError(
                "one run cannot be both fitted and held out; expected at least two runs or "
                "held-out runs (--validate)"
            )
        test_runs = list(train)
        fold_of = [i % k for i in range(len(train))]
    else:
        test_runs = list(held_out)
        names = {r.source for r in train} & {r.source for r in held_out}
        if names:
            raise CalibrationError(
                f"{sorted(names)[0]} is both a training and a held-out run; expected held-out runs"
            )
    scores: list[ModelScore] = []
    for model in order:
        fit, problem = _fit(prepared, base, o, model)
        if fit is None:
            scores.append(ModelScore(model, len(FIT_MODELS[model].names), None, problem))
            continue
        rows: list[dict[str, float]] = []
        if cv:
            fold_params: dict[int, RobotParams] = {}
            for f in sorted(set(fold_of)):
                part = [p for p, g in zip(prepared, fold_of, strict=True) if g != f]
                fold_fit, fold_problem = _fit(part, base, o, model)
                if fold_fit is None:
                    problem = f"fold {f + 1}: {fold_problem}"
                    break
                fold_params[f] = fold_fit.params
            if problem is None:
                rows = [
                    _metrics(r, fold_params[g]) for r, g in zip(test_runs, fold_of, strict=True)
                ]
        else:
            rows = [_metrics(r, fit.params) for r in test_runs]
        if problem is not None:
            scores.append(ModelScore(model, len(fit.stderr), fit, problem))
            continue
        per_run = {m: [row[m] for row in rows] for m in _METRICS}
        held = {m: _bootstrap_mean(np.array(v), rng, n_boot) for m, v in per_run.items()}
        bic = float(_bic(np.array(fit.run_rss), np.array(fit.run_sizes, float), fit.n_params))
        scores.append(ModelScore(model, len(fit.stderr), fit, None, per_run, held, bic))
    return _recommend(scores, train, test_runs, cv, rng, n_boot)


def _recommend(
    scores: list[ModelScore],
    train: Sequence[OdometryRun],
    test_runs: Sequence[OdometryRun],
    cv: bool,
    rng: np.random.Generator,
    n_boot: int,
) -> ModelComparison:
    ok = [s for s in scores if s.problem is None]
    if not ok:
        raise CalibrationError(
            "no model could be fitted to these runs: " + "; ".join(str(s.problem) for s in scores)
        )
    errors = {s.model: np.array(s.per_run["endpoint_error"]) for s in ok}
    best = min(ok, key=lambda s: errors[s.model].mean())
    diff = next((s for s in ok if s.model == "diff"), None)
    train_idx = rng.integers(0, len(train), size=(n_boot, len(train)))
    out: list[ModelScore] = []
    for s in scores:
        if s.problem is not None or s.fit is None:
            out.append(s)
            continue
        ratio = _bootstrap_ratio(errors[s.model], errors[best.model], rng, n_boot)
        dbic = None
        if diff is not None and diff.fit is not None:
            rss_m, size_m = np.array(s.fit.run_rss), np.array(s.fit.run_sizes, float)
            rss_d, size_d = np.array(diff.fit.run_rss), np.array(diff.fit.run_sizes, float)
            boot = _bic(rss_m[train_idx], size_m[train_idx], s.fit.n_params) - _bic(
                rss_d[train_idx], size_d[train_idx], diff.fit.n_params
            )
            lo, hi = np.percentile(boot, [2.5, 97.5])
            dbic = Estimate(s.bic - diff.bic, float(lo), float(hi))
        out.append(
            ModelScore(s.model, s.n_params, s.fit, None, s.per_run, s.held_out, s.bic, dbic, ratio)
        )
    chosen = best
    for s in out:
        r = s.ratio_to_best
        if s.problem is not None or r is None:
            continue
        if r.value <= 1.0 + NOT_WORSE or (math.isfinite(r.low) and r.low <= 1.0):
            chosen = s
            break
    simpler = [s.model for s in out[: out.index(chosen)] if s.problem is None]
    if chosen.model == best.model:
        reason = f"{best.model} has the smallest held-out end-point error"
        if simpler:
            reason += (
                f" and {', '.join(simpler)} is worse by more than {NOT_WORSE:.0%} "
                "(95 % CI of the error ratio above 1)"
            )
    else:
        r = chosen.ratio_to_best
        assert r is not None
        reason = (
            f"{chosen.model} is not worse than {best.model} on held-out runs (mean end-point "
            f"error ratio {r.value:.3f}, 95 % CI [{r.low:.3f}, {r.high:.3f}]) and is simpler"
        )
    return ModelComparison(
        out,
        chosen.model,
        reason,
        [r.name for r in train],
        [r.name for r in test_runs],
        cv,
    )


@dataclass(frozen=True)
class _ReadJob:
    path: Path
    fmt: LogFormat
    options: ReadOptions


def _read(job: _ReadJob) -> OdometryRun:
    return read_run(job.path, job.fmt, job.options)


def compare_model_files(
    paths: Sequence[str | Path],
    fmt: LogFormat | str,
    *,
    validate: Sequence[str | Path] = (),
    nominal: RobotParams | None = None,
    models: Sequence[str] = MODEL_ORDER,
    options: LsqOptions | None = None,
    read_options: ReadOptions | None = None,
    workers: int = 2,
    progress: Progress | None = None,
    seed: int = 0,
) -> ModelComparison:
    """:func:`compare_models` on every run found under ``paths`` (and ``validate``)."""
    _check_seed(seed)  # before any file is read
    f = LogFormat(fmt)
    ro = read_options or ReadOptions()
    train_paths, held_paths = find_fit_and_held_out(paths, validate, f)
    jobs = [_ReadJob(p, f, ro) for p in [*train_paths, *held_paths]]
    runs = parallel_map(
        _read, jobs, workers=workers, progress=progress, label=lambda j: str(j.path)
    )
    train, held = runs[: len(train_paths)], runs[len(train_paths) :]
    return compare_models(train, held, nominal, models=models, options=options, seed=seed)
