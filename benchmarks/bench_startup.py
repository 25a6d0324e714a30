"""Whole-process time of the commands a user waits on, against baselines run in the same rounds.

1. ``odolab evaluate GT.tum EST.tum`` on two 100,000-pose TUM files (APE, RPE, drift) against
   ``evo_ape tum GT EST`` + ``evo_rpe tum GT EST`` on the same files (issue 28's goal: >= 10x).
2. ``odolab odometry tiny.csv -p jaguar-lite -o out.csv`` on a 3-row log against
   ``python -c "import numpy, polars"`` (goal: <= 1.5x); also ``odolab params list`` and
   ``odolab --help``.

Each command runs in a fresh process, as a user runs it; the rounds interleave every command
once, and the medians and the median of each round's ratio are printed. Before timing, odolab's
modules are compiled to bytecode and one run of each command fills numba's cache, as an
installed odolab has them.

``--before SRC`` (another odolab tree's ``src/``) adds its ``odolab evaluate`` to the rounds, for
a before/after; ``--only-evaluate`` leaves out section 2.

Usage: python benchmarks/bench_startup.py [--rounds 7] [--poses 100000] [--before SRC]
       [--only-evaluate]
"""

from __future__ import annotations

import argparse
import compileall
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BIN = Path(sys.executable).parent


def _write_inputs(d: Path, n: int) -> tuple[Path, Path, Path]:
    from odolab.core.trajectory import Trajectory
    from odolab.core.trials import EncoderLog
    from odolab.io import write_encoder_csv, write_tum

    rng = np.random.default_rng(0)
    t = 0.01 * np.arange(n)
    h = np.cumsum(rng.normal(0.0, 0.01, n))
    x, y = np.cumsum(0.01 * np.cos(h)), np.cumsum(0.01 * np.sin(h))
    gt = write_tum(d / "gt.tum", Trajectory.from_xytheta(t, x, y, h))
    noisy = Trajectory.from_xytheta(
        t, x + rng.normal(0, 0.01, n), y + rng.normal(0, 0.01, n), h + rng.normal(0, 0.01, n)
    )
    est = write_tum(d / "est.tum", noisy)
    tiny = write_encoder_csv(
        d / "tiny.csv",
        EncoderLog(np.array([0.0, 0.05, 0.1]), np.array([0, 10, 20]), np.array([0, 11, 22]), None),
    )
    return gt, est, tiny


def _run(cmd: list[str]) -> float:
    env = None
    if cmd and cmd[0].startswith("PYTHONPATH="):  # another tree first on the path
        env = {**os.environ, "PYTHONPATH": cmd[0].partition("=")[2]}
        cmd = cmd[1:]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--poses", type=int, default=100_000)
    ap.add_argument("--before", type=Path, default=None)
    ap.add_argument("--only-evaluate", action="store_true")
    args = ap.parse_args()
    odolab = str(BIN / "odolab")
    evo_ape, evo_rpe = (
        shutil.which("evo_ape", path=str(BIN)),
        shutil.which("evo_rpe", path=str(BIN)),
    )
    if evo_ape is None or evo_rpe is None:
        sys.exit("evo is not installed in this environment (pip install evo)")
    import odolab as pkg

    compileall.compile_dir(str(Path(pkg.__file__).parent), quiet=1)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        gt, est, tiny = _write_inputs(d, args.poses)
        out = str(d / "out.csv")
        commands = {
            "odolab evaluate": [odolab, "evaluate", str(gt), str(est)],
            "evo_ape + evo_rpe": [],  # two processes, timed together
            **(
                {
                    "odolab evaluate BEFORE": [
                        f"PYTHONPATH={args.before}",
                        odolab,
                        "evaluate",
                        str(gt),
                        str(est),
                    ]
                }
                if args.before is not None
                else {}
            ),
            "odolab odometry (3 rows)": [
                odolab,
                "odometry",
                str(tiny),
                "-p",
                "jaguar-lite",
                "-o",
                out,
            ],
            "python -c 'import numpy, polars'": [sys.executable, "-c", "import numpy, polars"],
            "odolab params list": [odolab, "params", "list"],
            "odolab --help": [odolab, "--help"],
        }
        if args.only_evaluate:
            commands = {k: v for k, v in commands.items() if "evaluate" in k or "evo" in k}
        if args.before is not None:
            compileall.compile_dir(str(args.before / "odolab"), quiet=1)
        for cmd in commands.values():  # warm: bytecode, numba's cache, the disk cache
            if cmd:
                _run(cmd)
        _run([evo_ape, "tum", str(gt), str(est)])
        times: dict[str, list[float]] = {k: [] for k in commands}
        for _ in range(args.rounds):
            for name, cmd in commands.items():
                if name == "evo_ape + evo_rpe":
                    times[name].append(
                        _run([evo_ape, "tum", str(gt), str(est)])
                        + _run([evo_rpe, "tum", str(gt), str(est)])
                    )
                else:
                    times[name].append(_run(cmd))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"{args.rounds} interleaved rounds; seconds, median (min-max)")
    for name, v in times.items():
        print(f"  {name:34s} {med[name]:6.3f}  ({min(v):.3f}-{max(v):.3f})")

    def ratio(a: str, b: str) -> str:
        per_round = [x / y for x, y in zip(times[a], times[b], strict=True)]
        return (
            f"{statistics.median(per_round):.2f} (rounds {min(per_round):.2f}-{max(per_round):.2f})"
        )

    print(f"evo / odolab evaluate ({args.poses:,} poses): {ratio('evo_ape + evo_rpe', 'odolab evaluate')}"
          "  [goal >= 20]")  # fmt: skip
    best = {k: min(v) for k, v in times.items()}
    print(f"  best of the rounds: evo {best['evo_ape + evo_rpe']:.3f} s / odolab evaluate "
          f"{best['odolab evaluate']:.3f} s = {best['evo_ape + evo_rpe'] / best['odolab evaluate']:.1f}x")  # fmt: skip
    if args.before is not None:
        print(f"evo / odolab evaluate BEFORE: {ratio('evo_ape + evo_rpe', 'odolab evaluate BEFORE')}"
              f"; best of the rounds {best['evo_ape + evo_rpe'] / best['odolab evaluate BEFORE']:.1f}x")  # fmt: skip
    if args.only_evaluate:
        return
    base = "python -c 'import numpy, polars'"
    print(f"odometry (3 rows) / import numpy, polars: {ratio('odolab odometry (3 rows)', base)}"
          "  [goal <= 1.5]")  # fmt: skip
    print(f"params list / import numpy, polars: {ratio('odolab params list', base)}")
    print(f"--help / import numpy, polars: {ratio('odolab --help', base)}")


if __name__ == "__main__":
    main()
