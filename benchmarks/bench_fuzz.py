"""The long fuzz: every reader fed seeded byte mutations of valid files for N minutes.

The CI suite (tests/hostile/test_fuzz_readers.py) reads 60 mutations per reader; this reads as
many as fit in ``--minutes``, the readers in turn, case numbers counting up from ``--start`` (so
two runs with different starts try different files). Every outcome is counted: read, refused
with an OdolabError (one sentence), or anything else by signature (type and odolab's innermost
frame). The address space is capped (``--memory-gib``, default 6) so a reader that allocates
what a damaged length field says fails with a MemoryError here instead of swapping, and a case
that takes longer than ``--case-timeout`` seconds is counted as a hang. The goal: 0 foreign.

Usage: nice python benchmarks/bench_fuzz.py --minutes 10 [--json fuzz.json]
"""

from __future__ import annotations

import argparse
import collections
import json
import resource
import signal
import sys
import tempfile
import time
import warnings
from pathlib import Path
from types import FrameType

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from hostile.fuzzing import TARGETS, prepare, try_case


class _Hang(Exception):
    pass


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise _Hang


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--start", type=int, default=1000, help="first case number of each reader")
    ap.add_argument("--memory-gib", type=float, default=6.0)
    ap.add_argument("--case-timeout", type=int, default=30)
    ap.add_argument("--targets", nargs="*", default=sorted(TARGETS))
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    warnings.simplefilter("ignore")  # (pandas' ParserWarning is not an exception)
    limit = int(args.memory_gib * (1 << 30))
    resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))
    signal.signal(signal.SIGALRM, _alarm)
    tried: collections.Counter[str] = collections.Counter()
    outcomes: dict[str, collections.Counter[str]] = {}
    examples: dict[str, tuple[str, int]] = {}
    with tempfile.TemporaryDirectory() as d:
        seeds = {name: prepare(TARGETS[name], Path(d)) for name in args.targets}
        t0 = time.perf_counter()
        end = t0 + 60.0 * args.minutes
        case = args.start
        while time.perf_counter() < end:
            for name in args.targets:
                seed, mutable, read_path = seeds[name]
                signal.alarm(args.case_timeout)
                try:
                    outcome = try_case(TARGETS[name], seed, mutable, read_path, case)
                except _Hang:
                    outcome = "hang (over --case-timeout)"
                finally:
                    signal.alarm(0)
                tried[name] += 1
                outcomes.setdefault(name, collections.Counter())[outcome] += 1
                if outcome not in ("read", "refused"):
                    examples.setdefault(outcome, (name, case))
                if time.perf_counter() >= end:
                    break
            case += 1
        elapsed = time.perf_counter() - t0
    total = sum(tried.values())
    foreign = collections.Counter(
        {
            (n, o): k
            for n, c in outcomes.items()
            for o, k in c.items()
            if o not in ("read", "refused")
        }
    )
    print(f"fuzz: {total:,} files in {elapsed / 60:.1f} min ({total / elapsed:.0f}/s), "
          f"{len(args.targets)} readers, cases {args.start}..{case}")  # fmt: skip
    print(f"{'reader':28s} {'files':>8s} {'read':>8s} {'refused':>8s} {'foreign':>8s}")
    for name in args.targets:
        c = outcomes.get(name, collections.Counter())
        bad = sum(k for o, k in c.items() if o not in ("read", "refused"))
        print(f"{name:28s} {tried[name]:8,d} {c['read']:8,d} {c['refused']:8,d} {bad:8,d}")
    print(f"foreign exceptions: {sum(foreign.values())} ({len(foreign)} signatures)")
    for (name, sig), k in foreign.most_common():
        print(f"  {k:6d}  {name}: {sig} (first case {examples[sig][1]})")
    if args.json:
        args.json.write_text(
            json.dumps(
                {
                    "minutes": elapsed / 60,
                    "files": total,
                    "per_reader": {n: dict(c) for n, c in outcomes.items()},
                    "foreign": sum(foreign.values()),
                },
                indent=1,
            )
        )


if __name__ == "__main__":
    main()
