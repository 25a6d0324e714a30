"""Time of the slip model's fit (``calibrate lsq --model slip``) on the DRIVE Husky's training
windows, as a ratio to the ICR model's fit on the same runs, both measured in the same rounds;
with ``--before SRC`` (another odolab tree's ``src/``) the same fits of that tree, each in its own
process, alternated with this tree's, so that the before/after ratio is measured under the same
load.

    PYTHONPATH=src ODOLAB_TEST_DATA=../shared/data python benchmarks/bench_slip_fit.py \\
        [--rounds 3] [--before OLD/src]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _fits(rounds: int) -> dict[str, list[float]]:
    """Seconds of each fit, ``rounds`` times each, in this process."""
    from _husky import HUSKY, husky_split

    from odolab.calibration.lsq import LsqOptions, calibrate_lsq

    _train, _held, prep = husky_split()
    calibrate_lsq(prep, HUSKY, LsqOptions(model="slip"))  # load and compile what it uses
    out: dict[str, list[float]] = {"icr": [], "slip": []}
    for _ in range(rounds):
        for model in out:
            t0 = time.perf_counter()
            calibrate_lsq(prep, HUSKY, LsqOptions(model=model))
            out[model].append(time.perf_counter() - t0)
    return out


def _in_tree(src: Path, rounds: int) -> dict[str, list[float]]:
    env = {**os.environ, "PYTHONPATH": f"{src}{os.pathsep}{HERE}", "OPENBLAS_NUM_THREADS": "1"}
    code = f"import json, bench_slip_fit as b; print(json.dumps(b._fits({rounds})))"
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True
    )
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--before", type=Path, default=None)
    args = ap.parse_args()
    here = Path(__file__).resolve().parents[1] / "src"
    trees = {"this tree": here, **({"before": args.before} if args.before else {})}
    times: dict[str, dict[str, list[float]]] = {k: {"icr": [], "slip": []} for k in trees}
    for _ in range(args.rounds):  # each round runs every tree once, alternated
        for name, src in trees.items():
            for model, secs in _in_tree(src, 1).items():
                times[name][model] += secs
    print(f"DRIVE Husky, training windows (even command steps); {args.rounds} rounds, median s")
    for name, fits in times.items():
        icr, slip = statistics.median(fits["icr"]), statistics.median(fits["slip"])
        print(
            f"  {name:10s} icr fit {icr:.3f} s, slip fit {slip:.3f} s = {slip / icr:.1f}x the icr fit"
        )
    if args.before:
        new, old = (statistics.median(times[k]["slip"]) for k in ("this tree", "before"))
        print(f"slip fit before / now: {old / new:.2f}x")


if __name__ == "__main__":
    main()
