"""What a fresh clone's test run spends before its first test: xdist's workers collecting the
suite, with the controller's one rewrite of the test modules' asserts (tests/rewrite_warmup.py)
against without it (``-p no:rewrite_warmup``: every worker rewrites every module itself).

Each round copies the repository's committed files (``git archive HEAD``: no ``__pycache__``,
what a fresh clone has) to an empty folder, then runs ``pytest -n WORKERS -k <nothing>`` there, which starts the workers, makes
them collect every test and runs none; the two ways alternate round by round, and the CPU of
the whole process tree is compared (the wall time is printed too: on 2 cores the workers'
collections run two at a time).

Run:  PYTHONPATH=src python benchmarks/bench_collection.py [--rounds 3] [--workers 4]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import alternated, print_ratio

ROOT = Path(__file__).resolve().parents[1]
WAYS = {"warm-up (one rewrite)": [], "every worker rewrites": ["-p", "no:rewrite_warmup"]}


def _collect(way: str, workers: int, walls: dict[str, list[float]]) -> float:
    """CPU seconds of one fresh collection by ``workers`` workers."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        tar = subprocess.run(
            ["git", "-C", str(ROOT), "archive", "HEAD"], capture_output=True, check=True
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(root)], input=tar, check=True)
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "", "MPLBACKEND": "Agg"}
        env["PYTHONPATH"] = str(root / "src")
        cmd = [sys.executable, "-m", "pytest", "-n", str(workers), "-q", "-p", "no:cacheprovider"]
        cmd += [*WAYS[way], "-k", "no_test_has_this_name"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
        walls.setdefault(way, []).append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if proc.returncode not in (0, 5):  # 5: no test ran, as asked
            raise SystemExit(f"pytest failed ({proc.returncode}):\n{proc.stdout[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--workers", type=int, default=4)
    args = ap.parse_args()
    walls: dict[str, list[float]] = {}
    cpu = alternated(list(WAYS), lambda way, _tag: _collect(way, args.workers, walls), args.rounds)
    for way in WAYS:
        rounds = walls[way][1:]  # (the first was the warm-up)
        print(f"{way:42s} wall {min(rounds):.1f}-{max(rounds):.1f} s")
    print_ratio(cpu, "warm-up (one rewrite)", "every worker rewrites")


if __name__ == "__main__":
    main()
