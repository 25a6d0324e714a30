"""The statistical tests give the same numbers whatever the order, hash seed and worker (issue 36).

    .venv/bin/python tests/determinism.py            # (make test-determinism)

runs the statistical tests (tests/models, tests/metrics, tests/calibration, tests/analysis) twice:

- A: ``PYTHONHASHSEED=1``, pytest-randomly's order 1, ``--dist load``, the fixture cache on, in a
  fresh folder (a cache left by an earlier ``make test`` would skip the fixtures' own assertions:
  CI's first run with this check failed on exactly that, "ran in one run only");
- B: ``PYTHONHASHSEED=2``, order 2, ``--dist worksteal``, the fixture cache off (every process
  builds its own fixtures: a build that depends on what ran before shows),

with every passing assertion's values logged (tests/suite_plugin.py), and fails unless both runs
pass and every asserted number is the same in both (relative 1e-9: a test's seed fixes its
numbers; a difference means state leaking between tests, a dict or set order, or a result that
depends on the worker). Temporary paths and object addresses are not numbers of the test's.

A hypothesis test must pass in both runs, but its numbers are not compared: even derandomized,
hypothesis draws examples from a pool of constants it collects from the project's modules loaded
so far (hypothesis.internal.conjecture.providers._get_local_constants), so which examples a
test sees depends on what ran before it in the same process. The first runs found exactly that
(an example 1.175494351e-38 in one order, -0.0 in the other).
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bounds import run

PATHS = ["tests/models", "tests/metrics", "tests/calibration", "tests/analysis"]
_NOISE = [
    re.compile(r"0x[0-9a-fA-F]+"),  # object addresses
    re.compile(r"/tmp/\S*|/var/folders/\S*|pytest-of-\S*"),  # temporary paths
    re.compile(r"\bat \d+\b"),
    re.compile(r"\d{4}-\d\d-\d\d[T ]\d\d:\d\d:\d\d(\.\d+)?Z?|\d{8}[-T_]?\d{6,}"),  # stamps
]
_FLOAT = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?|nan|inf")


def _numbers(expl: str) -> list[float]:
    """The numbers of the explanation's first line, the comparison itself (the lines under it
    are reprs of the objects, with their addresses, paths and times of day)."""
    first = expl.splitlines()[0] if expl else ""
    for pat in _NOISE:
        first = pat.sub("", first)
    return [float(x) for x in _FLOAT.findall(first)]


def load(log: Path) -> dict[tuple[str, str, int, int], list[float]]:
    """(test, file, line, occurrence) -> the numbers its explanation printed. An assert in a
    fixture is logged against whichever test first asked for the fixture, which the order
    decides: those are keyed by their place alone, as a sorted multiset."""
    out: dict[tuple[str, str, int, int], list[float]] = {}
    seen: dict[tuple[str, str, int], int] = defaultdict(int)
    setup: dict[tuple[str, int], list[list[float]]] = defaultdict(list)
    for path in sorted(log.parent.glob(log.name + ".*")):
        for line in path.read_text(encoding="utf-8").splitlines():
            rec = json.loads(line)
            if rec.get("hypothesis"):  # its examples, not a statistic: see the module's docstring
                continue
            if rec.get("phase") == "setup":
                setup[(rec["file"], rec["line"])].append(_numbers(rec["expl"]))
                continue
            key = (rec["test"], rec["file"], rec["line"])
            out[(*key, seen[key])] = _numbers(rec["expl"])
            seen[key] += 1
    for (file, line), values in setup.items():  # (built once or once a worker: distinct)
        for k, v in enumerate(sorted({tuple(v) for v in values})):
            out[("(a fixture)", file, line, k)] = list(v)
    return out


def differences(
    a: dict[tuple[str, str, int, int], list[float]],
    b: dict[tuple[str, str, int, int], list[float]],
) -> list[str]:
    found = []
    for key in sorted(set(a) & set(b)):
        x, y = a[key], b[key]
        same = len(x) == len(y) and all(
            (u == v) or (u != u and v != v) or abs(u - v) <= 1e-9 * max(abs(u), abs(v))
            for u, v in zip(x, y, strict=True)
        )
        if not same:
            found.append(f"{key[1]}:{key[2]} in {key[0]}: {x[:6]} against {y[:6]}")
    for key in sorted(set(a) ^ set(b)):
        found.append(f"{key[1]}:{key[2]} in {key[0]} (occurrence {key[3]}) ran in one run only")
    return found


def main() -> int:
    folder = Path(tempfile.mkdtemp(prefix="odolab-determinism-"))
    fixed = {"HYPOTHESIS_PROFILE": "ci"}  # hypothesis' derandomized examples, as in CI
    runs = {
        "A": (
            {**fixed, "PYTHONHASHSEED": "1", "ODOLAB_TEST_CACHE_DIR": str(folder / "cache")},
            ("--randomly-seed=1", "--dist", "load"),
        ),
        "B": (
            {**fixed, "PYTHONHASHSEED": "2", "ODOLAB_TEST_CACHE": "0"},
            ("--randomly-seed=2", "--dist", "worksteal"),
        ),
    }
    codes = {}
    for name, (env, args) in runs.items():
        codes[name] = run(PATHS, 0, folder / name, "2", env=env, args=args)
        print(f"determinism: run {name} ({' '.join(args)}, {env}): pytest exit {codes[name]}")
    found = differences(load(folder / "A"), load(folder / "B"))
    for line in found[:50]:
        print(f"determinism: differs: {line}")
    if any(codes.values()) or found:
        print(f"determinism: FAILED ({len(found)} differences; exits {codes}; logs in {folder})")
        return 1
    print(f"determinism: the same numbers in both runs ({len(load(folder / 'A'))} assertions)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
