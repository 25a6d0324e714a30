"""The slip fit that knows its ground truth is noisy (issue 37), against the fit that does not.

Two parts, ratios not times:

* ``--husky``: the DRIVE Husky (fitted on even command steps, held out on odd ones), the
  held-out mean end-point error of the slip fit over the ICR model's (the best kinematic model
  on end points): plain (``LsqOptions(truth_noise=False)``), with the truth's noise estimated
  from its own updates (the default), and with Student-t rows as well (against scan-matcher
  glitches, ``slipfit.ROBUST_NU``).
* ``--outliers 0.02``: icr-speed's 60 s exploration with 2 cm / 0.02 rad of truth noise and a
  share of updates off by 0.5 m / 0.2 rad (scan-matcher glitches), held out on the true path:
  the kinematic fits with plain least squares and with the Huber loss, the slip fit with
  Gaussian and Student-t rows.
* ``--sims``: the independent simulators of ``tests/models/independent_sims.py`` (icr-speed, its
  constant-slip twin and skid-dynamic, whose body lags its tracks), a 60 s exploration, the truth at 10 Hz with ``--sigma-xy`` /
  ``--sigma-h`` of white noise, per seed and pooled: slip over the best kinematic model, plain
  and with the truth's noise (the default: the Kalman filter where the truth's noise is larger
  than the model's, :func:`odolab.calibration.slipfit.filtered`, as it is here), and what
  `calibrate compare` recommends with the default fit;
  ``--shrink`` adds the fit shrunk toward the kinematic model by grouped cross-validation
  (``slipfit.SHRINK_GRID_MEASURED``, off by default).

    PYTHONPATH=src:tests ODOLAB_TEST_DATA=../shared/data python benchmarks/bench_truth_noise.py --husky
    PYTHONPATH=src:tests python benchmarks/bench_truth_noise.py --sims --seeds 1 2 3 4 5
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from odolab.calibration import slipfit  # noqa: E402
from odolab.calibration.lsq import LsqOptions, calibrate_lsq  # noqa: E402
from odolab.calibration.slipfit import endpoint_error  # noqa: E402
from odolab.core.params import PRESETS  # noqa: E402
from odolab.io.registry import read_run  # noqa: E402

KINEMATIC = ("diff", "extended", "icr")


def husky() -> None:
    from _husky import HUSKY, held_out_error, husky_split

    _train, held, prep = husky_split()

    def end(params: object) -> float:
        return held_out_error(held, params)

    icr = end(calibrate_lsq(prep, HUSKY, LsqOptions(model="icr")).params)
    print(f"icr (best kinematic on end points): {icr:.4f} m")
    for label, opts, nu in (
        ("plain", LsqOptions(model="slip", truth_noise=False), None),
        ("truth noise estimated", LsqOptions(model="slip"), None),
        ("truth noise estimated, Student-t rows nu 4", LsqOptions(model="slip"), 4.0),
    ):
        slipfit.ROBUST_NU = nu
        fit = calibrate_lsq(prep, HUSKY, opts)
        e = end(fit.params)
        print(f"slip, {label}: {e:.4f} m, {e / icr:.3f}x icr")
        if opts.truth_noise:
            print(f"  {fit.notes[-1]}")
    slipfit.ROBUST_NU = None
    e = end(_fit_slip(prep, HUSKY, True, True))
    print(f"slip, truth noise estimated + CV shrinkage: {e:.4f} m, {e / icr:.3f}x icr")


def noisy(run: object, sigma_xy: float, sigma_h: float, seed: int) -> object:
    from bench_noisy_truth import noisy as add

    return add(run, sigma_xy, sigma_h, seed)  # type: ignore[arg-type]


def _fit_slip(read: list[object], nominal: object, flag: bool, shrink: bool) -> object:
    """The slip fit of ``read``, with the truth's noise (``flag``) and the cross-validated
    shrinkage toward the kinematic model (``shrink``: ``slipfit.SHRINK_GRID_MEASURED``)."""
    slipfit.SHRINK_GRID = slipfit.SHRINK_GRID_MEASURED if shrink else None
    try:
        return calibrate_lsq(read, nominal, LsqOptions(model="slip", truth_noise=flag)).params  # type: ignore[arg-type]
    finally:
        slipfit.SHRINK_GRID = None


def sims(seeds: list[int], sigma_xy: float, sigma_h: float, shrink: bool = False) -> None:
    from tests.models.independent_sims import (
        IcrSpeedSim,
        SkidDynamicSim,
        constant_slip,
        exploration,
        held_out_runs,
        write_run,
    )

    from odolab.calibration.compare import compare_models

    nominal = PRESETS["jaguar-lite"]
    sims_ = (
        ("icr-speed", IcrSpeedSim()),
        ("constant", constant_slip(IcrSpeedSim())),
        ("skid-dyn", SkidDynamicSim()),
    )
    for name, sim in sims_:
        ends: dict[str, list[float]] = {}
        picks = []
        for seed in seeds:
            runs = [exploration(sim, seed), *held_out_runs(sim, seed)]
            runs = [noisy(r, sigma_xy, sigma_h, 7919 * seed + k) for k, r in enumerate(runs)]
            with tempfile.TemporaryDirectory() as tmp:
                read = [read_run(write_run(Path(tmp), r), "csv") for r in runs]  # type: ignore[arg-type]
                row: dict[str, float] = {}
                for m in KINEMATIC:
                    fit = calibrate_lsq(read[:1], nominal, LsqOptions(model=m))
                    row[m] = float(np.mean([endpoint_error(r, fit.params) for r in read[1:]]))
                alts = [("slip plain", False, False), ("slip truth noise", True, False)]
                if shrink:
                    alts.append(("slip truth noise + CV shrinkage", True, True))
                for label, flag, sh in alts:
                    params = _fit_slip(read[:1], nominal, flag, sh)
                    row[label] = float(np.mean([endpoint_error(r, params) for r in read[1:]]))
                c = compare_models(read[:1], read[1:], nominal, models=(*KINEMATIC, "slip"))
            best = min(row[m] for m in KINEMATIC)
            picks.append(c.recommended)
            print(
                f"{name:9s} seed {seed}: best kinematic {best:.3f} m; "
                + ", ".join(f"{k} {v / best:.2f}x" for k, v in row.items() if k not in KINEMATIC)
                + f"; compare -> {c.recommended}"
            )
            for k, v in row.items():
                ends.setdefault(k, []).append(v)
        best = min(float(np.mean(ends[m])) for m in KINEMATIC)
        print(
            f"{name:9s} pooled: "
            + ", ".join(
                f"{k} {np.mean(v) / best:.2f}x" for k, v in ends.items() if k not in KINEMATIC
            )
            + f"; slip recommended on {picks.count('slip')} of {len(seeds)} seeds"
        )


def glitched(run: object, share: float, seed: int) -> object:
    """``run`` with its truth at 10 Hz, 2 cm / 0.02 rad of white noise, and ``share`` of the
    updates off by 0.5 m and 0.2 rad in a random direction (a scan matcher's misregistration)."""
    from tests.models.independent_sims import SimRun

    r: SimRun = run  # type: ignore[assignment]
    rng = np.random.default_rng(seed)
    keep = np.arange(0, r.t.size, 2)
    n = keep.size
    bad = rng.random(n) < share
    ang = rng.uniform(0, 2 * np.pi, n)
    x = r.x[keep] + 0.02 * rng.standard_normal(n) + bad * 0.5 * np.cos(ang)
    y = r.y[keep] + 0.02 * rng.standard_normal(n) + bad * 0.5 * np.sin(ang)
    h = r.heading[keep] + 0.02 * rng.standard_normal(n) + bad * 0.2 * rng.choice([-1, 1], n)
    tk = r.t[keep]
    return SimRun(
        r.name, r.t, r.dticks_left, r.dticks_right,
        np.interp(r.t, tk, x), np.interp(r.t, tk, y), np.interp(r.t, tk, h),
    )  # fmt: skip


def outliers(seeds: list[int], share: float) -> None:
    """Plain against robust fits with scan-matcher glitches in the fitted run's truth (the
    held-out runs are scored against the true path)."""
    from tests.models.independent_sims import IcrSpeedSim, exploration, held_out_runs, write_run

    nominal = PRESETS["jaguar-lite"]
    sim = IcrSpeedSim()
    ends: dict[str, list[float]] = {}
    for seed in seeds:
        explore = glitched(exploration(sim, seed), share, 7919 * seed)
        with tempfile.TemporaryDirectory() as tmp:
            fit_run = read_run(write_run(Path(tmp) / "fit", explore), "csv")  # type: ignore[arg-type]
            held = [read_run(write_run(Path(tmp), r), "csv") for r in held_out_runs(sim, seed)]
            row: dict[str, float] = {}
            for m in ("diff", "icr"):
                for loss in ("linear", "huber"):
                    fit = calibrate_lsq([fit_run], nominal, LsqOptions(model=m, loss=loss))
                    row[f"{m} {loss}"] = float(
                        np.mean([endpoint_error(r, fit.params) for r in held])
                    )
            for nu in (None, 4.0):
                slipfit.ROBUST_NU = nu
                fit = calibrate_lsq([fit_run], nominal, LsqOptions(model="slip"))
                label = "slip Gaussian rows" if nu is None else f"slip Student-t rows nu {nu:g}"
                row[label] = float(np.mean([endpoint_error(r, fit.params) for r in held]))
            slipfit.ROBUST_NU = None
        print(f"seed {seed}: " + ", ".join(f"{k} {v:.3f} m" for k, v in row.items()))
        for k, v in row.items():
            ends.setdefault(k, []).append(v)
    print(
        f"pooled ({share:.0%} glitches): "
        + ", ".join(f"{k} {np.mean(v):.3f} m" for k, v in ends.items())
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--husky", action="store_true")
    ap.add_argument("--sims", action="store_true")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--sigma-xy", type=float, default=0.05)
    ap.add_argument("--sigma-h", type=float, default=0.1)
    ap.add_argument("--outliers", type=float, default=None, help="share of glitched updates")
    ap.add_argument("--shrink", action="store_true", help="also the CV shrinkage alternative")
    a = ap.parse_args()
    if a.outliers is not None:
        outliers(a.seeds, a.outliers)
    if a.husky:
        husky()
    if a.sims:
        sims(a.seeds, a.sigma_xy, a.sigma_h, a.shrink)


if __name__ == "__main__":
    main()
