"""What the benchmarks share: the best of several timings (these machines are noisy; the
fastest run is the one least disturbed)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Mapping, Sequence


def best(fn: Callable[[], object], repeats: int) -> float:
    """The shortest of ``repeats`` timings of ``fn()`` (s)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def alternated(
    names: Sequence[str], measure: Callable[[str, str], float], rounds: int
) -> dict[str, list[float]]:
    """``measure(name, tag)`` once for each name first (a warm-up: numba's cache filled, the
    bytecode written, not counted), then ``rounds`` rounds of every name in turn, so that the
    machine's changing load falls on all of them alike; the measures by name."""
    for name in names:
        measure(name, "warm")
    got: dict[str, list[float]] = {name: [] for name in names}
    for k in range(rounds):
        for name in names:
            got[name].append(measure(name, str(k)))
    return got


def print_ratio(cpu: Mapping[str, list[float]], now: str, before: str, width: int = 42) -> None:
    """The median of each name's measures and of the rounds' ratios before / now."""
    for name, values in cpu.items():
        print(f"{name:{width}s} {statistics.median(values):.3f} s CPU (median of {len(values)})")
    ratios = [b / a for a, b in zip(cpu[now], cpu[before], strict=True)]
    print(
        f"ratio before / now: {statistics.median(ratios):.2f}x "
        f"(rounds {min(ratios):.2f}-{max(ratios):.2f})"
    )
