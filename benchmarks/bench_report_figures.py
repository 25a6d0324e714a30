"""The report's figures: the margin fit of ``odolab.report.html`` against matplotlib's constrained
layout, on the same figures, in the same run.

Run:  PYTHONPATH=src MPLBACKEND=Agg python benchmarks/bench_report_figures.py [--db lab.db] [REPEATS]
Without ``--db`` it runs the demo once (about a minute) and uses its notebook.
Baseline: each figure drawn as before 2026-11-28 (``layout="constrained"``, which lays the
figure out twice and draws it once more at save time); the ratio is constrained / margin fit.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from odolab.app.report import report_content
from odolab.report import html
from odolab.store import Notebook


def _constrained(fig_dir: Path, plans: list[Any]) -> None:
    import matplotlib as mpl
    from matplotlib.figure import Figure

    with mpl.rc_context(html._RC):
        for p in plans:
            size = (p.size[0] * html._SCALE, p.size[1] * html._SCALE)
            fig = Figure(figsize=size, dpi=html._DPI, layout="constrained")
            ax = fig.add_subplot()
            p.draw(ax)
            html._legend_below(fig, ax, size)
            fig.savefig(fig_dir / f"{p.name}.png", format="png")


def main() -> None:
    args = sys.argv[1:]
    tmp = Path(tempfile.mkdtemp(prefix="bench-report-"))
    if "--db" in args:
        i = args.index("--db")
        db = Path(args[i + 1])
        del args[i : i + 2]
    else:
        from odolab.app.demo import run_lab

        db = run_lab(tmp / "demo").notebook
    repeats = int(args[0]) if args else 3
    with Notebook(db) as nb:
        c = report_content(nb)
    plans = html._figure_plan(c.analysis.analysis, c.calibrations, None)
    out = tmp / "figures"
    out.mkdir()
    times: dict[str, float] = {"constrained": float("inf"), "margin fit": float("inf")}
    for _ in range(repeats):  # interleaved: a noisy moment hits both
        for name, fn in (("constrained", _constrained), ("margin fit", html._render)):
            t0 = time.process_time()
            fn(out, plans)
            times[name] = min(times[name], time.process_time() - t0)
    n = len(plans)
    for name, t in times.items():
        print(f"{name:12s} {t:6.2f} s CPU for {n} figures ({1000 * t / n:.0f} ms a figure)")
    print(f"ratio constrained / margin fit: {times['constrained'] / times['margin fit']:.2f}x")


if __name__ == "__main__":
    main()
