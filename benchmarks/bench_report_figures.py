"""The report's figures: the margin fit of ``odolab.report.html`` against matplotlib's constrained
layout, and its PNG writer (``odolab.core.writing.write_png``: opaque RGB, zlib level 1) against
``savefig``'s PNG (RGBA, level 6), on the same figures, in the same run.

Run:  PYTHONPATH=src MPLBACKEND=Agg python benchmarks/bench_report_figures.py [--db lab.db] [REPEATS]
Without ``--db`` it runs the demo once (about a minute) and uses its notebook.
Baselines: each figure drawn as before 2026-11-28 (``layout="constrained"``, which lays the
figure out twice and draws it once more at save time), and as before 2026-11-29's writer (the
margin fit, then ``savefig``); the ratios are constrained / margin fit and savefig / write_png,
with the bytes each PNG writer wrote. Last, the whole report of the notebook
(``write_notebook_report``) with its figures against ``--no-figures`` (``ReportRequest(figures=
False)``), interleaved in the same run: the ratio is what leaving the figures out saves.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from odolab.app.report import ReportRequest, report_content, write_notebook_report
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


def _savefig(fig_dir: Path, plans: list[Any]) -> None:
    """``html._render`` as it was before ``write_png``: the margin fit, then ``savefig``."""
    import matplotlib as mpl
    from matplotlib.figure import Figure

    with mpl.rc_context(html._RC):
        for p in plans:
            size = (p.size[0] * html._SCALE, p.size[1] * html._SCALE)
            fig = Figure(figsize=size, dpi=html._DPI)
            ax = fig.add_subplot()
            p.draw(ax)
            html._legend_below(fig, ax, size)
            html._fit_margins(fig, ax)
            fig.savefig(fig_dir / f"{p.name}.png", format="png")


def _bytes(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.glob("*.png"))


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
    variants = {"constrained": _constrained, "savefig": _savefig, "margin fit": html._render}
    times = dict.fromkeys(variants, float("inf"))
    written: dict[str, int] = {}
    for _ in range(repeats):  # interleaved: a noisy moment hits every variant
        for name, fn in variants.items():
            out = tmp / name.replace(" ", "-")
            out.mkdir(exist_ok=True)
            t0 = time.process_time()
            fn(out, plans)
            times[name] = min(times[name], time.process_time() - t0)
            written[name] = _bytes(out)
    n = len(plans)
    for name, t in times.items():
        print(f"{name:12s} {t:6.2f} s CPU for {n} figures ({1000 * t / n:.0f} ms a figure)")
    print(f"ratio constrained / margin fit: {times['constrained'] / times['margin fit']:.2f}x")
    print(
        f"ratio savefig / write_png: {times['savefig'] / times['margin fit']:.2f}x "
        f"(PNG bytes {written['savefig']:,} against {written['margin fit']:,})"
    )
    whole = {"with figures": True, "--no-figures": False}
    spent = dict.fromkeys(whole, float("inf"))
    for _ in range(repeats):
        for name, figures in whole.items():
            t0 = time.process_time()
            with Notebook(db) as nb:
                write_notebook_report(nb, tmp / name, ReportRequest(figures=figures))
            spent[name] = min(spent[name], time.process_time() - t0)
    for name, t in spent.items():
        print(f"whole report, {name:13s} {t:6.2f} s CPU")
    print(
        f"ratio with figures / --no-figures: {spent['with figures'] / spent['--no-figures']:.2f}x"
    )


if __name__ == "__main__":
    main()
