"""Measure how far each asserted number sits from its bound, over seeds (docs/testing.md).

    .venv/bin/python tests/bounds.py --shifts 0 1 2 3 4 tests/models tests/calibration

runs the given tests once per seed shift K (``ODOLAB_TEST_SEED_SHIFT=K``: every integer seed
given to ``numpy.random.default_rng``, in the tests and in odolab, becomes ``seed + K``; K = 0 is
the suite as it is) with pytest's assertion-pass hook on (tests/suite_plugin.py logs each
assertion's values), then prints one row per assertion that compares numbers: the measured
values over the shifts and the smallest margin, the distance from the value to its bound as a
fraction of the bound. A margin under 10 % is a bound that a machine or a seed can cross.

A shift also moves the numbers that a test pins exactly (a regression value for seed 7), so
a failure under K > 0 is expected there; the table marks failures and keeps the value the
failed assertion printed.
"""

from __future__ import annotations

import argparse
import ast
import json
import operator
import os
import re
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OPS = {">=": operator.ge, "<=": operator.le, ">": operator.gt, "<": operator.lt}
_NUM = re.compile(r"^[-+*/()\s.0-9eE]+$")


def _value(text: str) -> float | None:
    text = text.strip()
    if not text or not _NUM.match(text):
        return None
    try:
        return float(eval(compile(ast.parse(text, mode="eval"), "<bound>", "eval"), {}, {}))
    except (SyntaxError, ValueError, ZeroDivisionError, TypeError):
        return None


def comparison(expl: str) -> tuple[float, str, float] | None:
    """(value, op, bound) of an explanation's first line when both sides are numbers; for a
    chain ``lo <= value <= hi`` the side of the interval nearer the value, with the interval's
    width standing for the bound's size (see :func:`margin`)."""
    first = expl.splitlines()[0] if expl else ""
    first = re.sub(r"^(assert|AssertionError:)\s+", "", first.strip())
    first = re.sub(r"^assert\s+", "", first)
    approx = re.match(r"^(\S+) == (\S+) \u00b1 (\S+)", first)
    if approx:
        got, want, tol = (_value(approx.group(i)) for i in (1, 2, 3))
        if got is not None and want is not None and tol is not None:
            return got, "approx", (want, tol)  # type: ignore[return-value]
    parts = re.split(r" (>=|<=|>|<) ", first)
    if len(parts) == 3:
        lv, rv = _value(parts[0]), _value(parts[2])
        if lv is not None and rv is not None:
            return lv, parts[1], rv
        return None
    if len(parts) == 5 and parts[1] in ("<", "<=") and parts[3] in ("<", "<="):
        lo, x, hi = (_value(parts[i]) for i in (0, 2, 4))
        if lo is None or x is None or hi is None:
            return None
        return (x, "in", (lo, hi))  # type: ignore[return-value]
    return None


def margin(left: float, op: str, right: float) -> float:
    """How far ``left`` is inside its bound ``right``, as a fraction of the bound (negative:
    outside); inside an interval (op "in"), as a fraction of the interval's width."""
    if op == "approx":
        want, tol = right  # type: ignore[misc]
        return (tol - abs(left - want)) / tol if tol else 0.0
    if op == "in":
        lo, hi = right  # type: ignore[misc]
        width = hi - lo if hi != lo else max(abs(hi), 1e-300)
        return min(left - lo, hi - left) / width
    scale = abs(right) if right != 0 else max(abs(left), 1e-300)
    inside = left - right if op in (">", ">=") else right - left
    return inside / scale


def run(
    paths: list[str],
    shift: int,
    log: Path,
    workers: str,
    *,
    env: dict[str, str] | None = None,
    args: tuple[str, ...] = ("-p", "no:randomly"),
) -> int:
    """pytest on ``paths`` with the assertion log ``log`` and seed shift ``shift``; its exit."""
    for pyc in (ROOT / "tests").rglob("*pytest*.pyc"):
        pyc.unlink()  # (rewritten without the pass hook; rewritten again below, not written)
    full = {
        **os.environ,
        "ODOLAB_TEST_SEED_SHIFT": str(shift),
        "ODOLAB_ASSERT_LOG": str(log),
        "PYTHONDONTWRITEBYTECODE": "1",
        "MPLBACKEND": "Agg",
        **(env or {}),
    }
    full.pop("CI", None)
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args]
    cmd += ["-o", "enable_assertion_pass_hook=true", "-n", workers, *paths]
    return subprocess.run(cmd, cwd=ROOT, env=full, check=False).returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--shifts", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("-n", "--workers", default="2")
    ap.add_argument("--keep", type=Path, help="folder for the raw logs (default: temporary)")
    ap.add_argument("--only-low", type=float, default=None, help="rows with a margin below this")
    args = ap.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="odolab-bounds-"))
    folder.mkdir(parents=True, exist_ok=True)
    for shift in args.shifts:
        code = run(args.paths, shift, folder / f"shift{shift}", args.workers)
        print(f"shift {shift}: pytest exit {code}", file=sys.stderr)
    rows: dict[tuple[str, int], dict[int, list[tuple[float, str, float, bool]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    origs: dict[tuple[str, int], str] = {}
    for path in folder.glob("shift*.*"):
        for line in path.read_text(encoding="utf-8").splitlines():
            rec = json.loads(line)
            cmp_ = comparison(rec["expl"])
            if cmp_ is None:
                continue
            key = (rec["file"], rec["line"])
            origs[key] = rec["orig"]
            rows[key][rec["shift"]].append((*cmp_, bool(rec.get("failed"))))
    print(f"{'assertion':60} {'measured (over shifts)':30} {'bound':>10} {'min margin':>10}")
    for key in sorted(rows):
        values = [v for vs in rows[key].values() for v in vs]
        lows = [margin(lv, op, rv) for lv, op, rv, _ in values]
        worst = min(lows)
        if args.only_low is not None and worst >= args.only_low:
            continue
        lefts = [lv for lv, *_ in values]
        rights = [rv if not isinstance(rv, tuple) else rv[1] for _, _, rv, _ in values]
        failed = any(f for *_, f in values)
        where = f"{key[0]}:{key[1]}"
        rng = f"{min(lefts):.4g}-{max(lefts):.4g}"
        bound = f"{min(rights):.4g}" if min(rights) == max(rights) else "varies"
        flag = " FAILED" if failed else ""
        print(f"{where:60} {rng:30} {bound:>10} {worst:>10.1%}{flag}")
        print(f"    {origs[key][:110]}")


if __name__ == "__main__":
    main()
