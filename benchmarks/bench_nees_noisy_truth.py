"""The slip model's NEES against a noisy ground truth at 1 s and 3 s (issue 37: a covariance
whose growth with the horizon is right). Numbers, not times.

Per seed: icr-speed's 60 s exploration and four held-out runs (tests/models/independent_sims),
the truth at 10 Hz with ``--sigma-xy`` / ``--sigma-h`` of white noise resampled to the odometry's
20 Hz (benchmarks/bench_noisy_truth.py's); the slip model fitted with `calibrate lsq --model
slip` (the truth's noise a known term of each piece, so its variance terms are the model's
own); the mean NEES of the held-out runs' pieces as `odolab evaluate --nees` gives it (the
truth's noise, estimated from its updates, added at each piece's two ends), and the same with
the truth taken as exact (``--truth-sigma 0,0``); pooled, against the chi-square 95 % bounds.

    PYTHONPATH=src:tests python benchmarks/bench_nees_noisy_truth.py --seeds 1 2 3 4 5
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

from bench_noisy_truth import noisy  # noqa: E402

from odolab.calibration.lsq import LsqOptions, calibrate_lsq  # noqa: E402
from odolab.calibration.slipfit import nees_bounds, nees_pieces  # noqa: E402
from odolab.core.params import PRESETS  # noqa: E402
from odolab.io.registry import read_run  # noqa: E402
from odolab.metrics.truthnoise import TruthNoise  # noqa: E402

PIECES = (1.0, 3.0)
EXACT = TruthNoise(0.0, 0.0, given=True)


def main() -> None:
    from tests.models.independent_sims import IcrSpeedSim, exploration, held_out_runs, write_run

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--sigma-xy", type=float, default=0.05)
    ap.add_argument("--sigma-h", type=float, default=0.1)
    a = ap.parse_args()
    pooled: dict[tuple[float, bool], list[np.ndarray]] = {}
    for seed in a.seeds:
        runs = [exploration(IcrSpeedSim(), seed), *held_out_runs(IcrSpeedSim(), seed)]
        if a.sigma_xy > 0 or a.sigma_h > 0:
            runs = [noisy(r, a.sigma_xy, a.sigma_h, 7919 * seed + k) for k, r in enumerate(runs)]
        with tempfile.TemporaryDirectory() as d:
            read = [read_run(write_run(Path(d), r), "csv") for r in runs]
            fit = calibrate_lsq(read[:1], PRESETS["jaguar-lite"], LsqOptions(model="slip"))
            line = []
            for piece in PIECES:
                with_truth = nees_pieces(read[1:], fit.params, piece)
                exact = nees_pieces(read[1:], fit.params, piece, EXACT)
                pooled.setdefault((piece, True), []).append(with_truth)
                pooled.setdefault((piece, False), []).append(exact)
                line.append(
                    f"{piece:g} s {with_truth.mean():.2f} (truth as exact {exact.mean():.2f}; "
                    f"{with_truth.size} pieces)"
                )
        print(f"seed {seed}: " + "; ".join(line), flush=True)
    for piece in PIECES:
        v = np.concatenate(pooled[(piece, True)])
        v0 = np.concatenate(pooled[(piece, False)])
        lo, hi = nees_bounds(v.size)
        print(
            f"pooled {piece:g} s: mean NEES {v.mean():.2f} over {v.size} pieces, 95 % bounds "
            f"[{lo:.2f}, {hi:.2f}]; the truth taken as exact {v0.mean():.2f}"
        )


if __name__ == "__main__":
    main()
