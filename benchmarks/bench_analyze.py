"""`odolab analyze` of the demo's notebook, whole process, against another odolab tree in the same
rounds (docs/architecture.md: scipy.stats is no longer imported, about a second of every
analysis).

The notebook is made once by ``odolab demo`` (about 20 s); then each round runs ``odolab analyze
--db`` with this tree and with ``--before SRC`` (another tree's ``src/``), interleaved, and the
ratio of the medians is printed (these machines are noisy: compare within one run only).

Usage: python benchmarks/bench_analyze.py --before OLD/src [--rounds N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def _analyze(src: Path, db: Path) -> float:
    env = {**os.environ, "PYTHONPATH": str(src), "MPLBACKEND": "Agg"}
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "odolab.cli", "analyze", "--db", str(db)],
        check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
    )  # fmt: skip
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="another odolab tree's src/")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
        subprocess.run(
            [sys.executable, "-m", "odolab.cli", "demo", "--out", tmp],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
        )  # fmt: skip
        db = next(Path(tmp).glob("*/odolab.db"))
        for src in (SRC, args.before):  # warm both trees' bytecode and numba caches
            _analyze(src, db)
        now, before = [], []
        for _ in range(args.rounds):
            now.append(_analyze(SRC, db))
            before.append(_analyze(args.before, db))
    m_now, m_before = statistics.median(now), statistics.median(before)
    print(f"{args.rounds} interleaved rounds; seconds, median (min-max)")
    print(f"  odolab analyze          {m_now:.3f}  ({min(now):.3f}-{max(now):.3f})")
    print(f"  odolab analyze BEFORE   {m_before:.3f}  ({min(before):.3f}-{max(before):.3f})")
    print(f"before / now: {m_before / m_now:.2f}x (best rounds {min(before) / min(now):.2f}x)")


if __name__ == "__main__":
    main()
