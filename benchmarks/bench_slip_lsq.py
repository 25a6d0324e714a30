"""``odolab calibrate lsq RUN --model slip`` on a simulated exploration (``odolab sim explore``),
whole process, this tree against another (``--before OLD/src``), alternated round by round so
that both meet the same load; the CPU of each process is compared.

The slip model's fit spends most of its time fitting its noise terms to how far it is off at the
end of 1 s and 3 s pieces (``odolab.calibration.slipfit.fit_noise``, which evaluates
``odolab.core.models.slip_covariance.end_second_order`` some hundred times); a 20 Hz
exploration gives pieces of 21 and 61 steps.

Run:  PYTHONPATH=src python benchmarks/bench_slip_lsq.py --before OLD/src [--rounds 3]
      [--seconds 60]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

from _timing import alternated, print_ratio

HERE = Path(__file__).resolve().parent
FIT = "import sys; from odolab.cli import main; sys.exit(main(sys.argv[1:]))"


def _cpu(src: Path, args: list[str], cwd: Path) -> float:
    """CPU seconds of ``odolab ARGS`` run with the odolab of ``src``."""
    env = {**os.environ, "PYTHONPATH": str(src), "OPENBLAS_NUM_THREADS": "1"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(
        [sys.executable, "-c", FIT, *args], cwd=cwd, env=env, capture_output=True, text=True
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"odolab {' '.join(args)} failed:\n{proc.stderr[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="another odolab tree's src/")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    now = HERE.parent / "src"
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        explore = ["sim", "explore", "--seconds", f"{args.seconds:g}", "-o", "run", "--seed", "1"]
        _cpu(now, explore, work)
        fit = ["calibrate", "lsq", "run/explore.csv", "--model", "slip", "-p", "jaguar-lite"]
        trees = {"this tree": now, "before": args.before}
        cpu = alternated(
            list(trees),
            lambda name, tag: _cpu(trees[name], [*fit, "-o", f"{tag}-{name[0]}.toml"], work),
            args.rounds,
        )
    print(f"calibrate lsq --model slip, a {args.seconds:g} s exploration, whole process:")
    print_ratio(cpu, "this tree", "before", width=12)


if __name__ == "__main__":
    main()
