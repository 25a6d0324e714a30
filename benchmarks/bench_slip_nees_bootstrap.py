"""The slip model's NEES at 1 s and 3 s on the independent simulator, against chi-square bounds
widened for the covariance's own estimation uncertainty (issue 37). Ratios, not times.

Per seed: icr-speed's 60 s exploration (truth at 10 Hz with ``--sigma-xy`` / ``--sigma-h`` of
noise, 0 by default) fitted with `calibrate lsq --model slip`; mean NEES of the 1 s and 3 s
pieces of the four held-out runs (`odolab evaluate --nees`'s numbers, against the same kind of
truth). The fit's own uncertainty: the exploration cut into six 10 s blocks, resampled with
replacement ``--boots`` times and refitted (a block bootstrap); each refit's mean NEES over the
fit's is a ratio, and the bounds are widened by the 2.5-97.5 % range of those ratios pooled
over the seeds (as benchmarks/bench_husky_nees_bootstrap.py does on the Husky).

    PYTHONPATH=src:tests python benchmarks/bench_slip_nees_bootstrap.py --seeds 1 2 3 --boots 4
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from itertools import pairwise
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from odolab.calibration.lsq import LsqOptions, calibrate_lsq, prepare_run  # noqa: E402
from odolab.calibration.slipfit import nees_bounds, nees_pieces  # noqa: E402
from odolab.core.params import PRESETS  # noqa: E402
from odolab.io.registry import read_run  # noqa: E402

PIECES = (1.0, 3.0)


def blocks(run: object, count: int) -> list[object]:
    """``run`` (an :class:`odolab.io.run.OdometryRun`) cut into ``count`` runs of equal
    duration, each prepared on its own."""
    from dataclasses import replace

    from odolab.core.trajectory import Trajectory

    t = np.asarray(run.t)  # type: ignore[attr-defined]
    gt = run.require_ground_truth()  # type: ignore[attr-defined]
    cuts = t[0] + (t[-1] - t[0]) * np.arange(count + 1) / count
    out = []
    for a, b in pairwise(cuts):
        keep = (t >= a) & (t <= b)
        g = (gt.t >= a) & (gt.t <= b)
        part = replace(
            run,  # type: ignore[type-var]
            t=t[keep],
            dticks_left=np.asarray(run.dticks_left)[keep],  # type: ignore[attr-defined]
            dticks_right=np.asarray(run.dticks_right)[keep],  # type: ignore[attr-defined]
            ground_truth=Trajectory.from_xyh(gt.t[g], gt.x[g], gt.y[g], gt.heading[g]),
        )
        out.append(prepare_run(part))  # type: ignore[arg-type]
    return out


def main() -> None:
    from bench_noisy_truth import noisy
    from tests.models.independent_sims import IcrSpeedSim, exploration, held_out_runs, write_run

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--boots", type=int, default=4)
    ap.add_argument("--sigma-xy", type=float, default=0.0)
    ap.add_argument("--sigma-h", type=float, default=0.0)
    a = ap.parse_args()
    nominal = PRESETS["jaguar-lite"]
    sim = IcrSpeedSim()
    values: dict[float, list[np.ndarray]] = {p: [] for p in PIECES}
    ratios: dict[float, list[float]] = {p: [] for p in PIECES}
    for seed in a.seeds:
        runs = [exploration(sim, seed), *held_out_runs(sim, seed)]
        runs = [noisy(r, a.sigma_xy, a.sigma_h, 7919 * seed + k) for k, r in enumerate(runs)]
        with tempfile.TemporaryDirectory() as tmp:
            read = [read_run(write_run(Path(tmp), r), "csv") for r in runs]
            fit = calibrate_lsq(read[:1], nominal, LsqOptions(model="slip"))
            own = {p: nees_pieces(read[1:], fit.params, p) for p in PIECES}
            parts = blocks(read[0], 6)
            rng = np.random.default_rng(seed)
            for _ in range(a.boots):
                pick = [parts[k] for k in rng.integers(0, len(parts), len(parts))]
                refit = calibrate_lsq(pick, nominal, LsqOptions(model="slip"))  # type: ignore[arg-type]
                for p in PIECES:
                    ratios[p].append(
                        float(np.mean(nees_pieces(read[1:], refit.params, p)) / np.mean(own[p]))
                    )
        for p in PIECES:
            values[p].append(own[p])
        cells = ", ".join(f"{p:g} s {np.mean(own[p]):.2f} ({own[p].size})" for p in PIECES)
        print(f"seed {seed}: mean NEES {cells}")
    for p in PIECES:
        pooled = np.concatenate(values[p])
        lo, hi = nees_bounds(pooled.size)
        r_lo, r_hi = np.percentile(ratios[p], [2.5, 97.5])
        wide = (lo * min(r_lo, 1.0), hi * max(r_hi, 1.0))
        mean = float(np.mean(pooled))
        inside = wide[0] <= mean <= wide[1]
        print(
            f"{p:g} s pieces: pooled mean NEES {mean:.2f} over {pooled.size}; bounds "
            f"[{lo:.2f}, {hi:.2f}]; refits {r_lo:.2f}x to {r_hi:.2f}x; widened "
            f"[{wide[0]:.2f}, {wide[1]:.2f}]: {'inside' if inside else 'outside'}"
        )


if __name__ == "__main__":
    main()
