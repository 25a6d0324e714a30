"""CLI command: ``odolab demo``, the whole lab on the virtual Jaguar (what ``make demo`` runs)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from odolab.cli._apps import app
from odolab.defaults import DEFAULT_TRUTH

__all__: list[str] = []


@app.command("demo")
def demo_cmd(
    out: Annotated[
        Path, typer.Option("--out", help="Folder for the results (a new run folder inside).")
    ] = Path("odolab-out"),
    seed: Annotated[
        int | None,
        typer.Option(min=0, help="Random seed (default: the documented lab-report seed)."),
    ] = None,
    truth: Annotated[str, typer.Option(help="True robot preset.")] = DEFAULT_TRUTH,
) -> None:
    """Run the lab end to end: campaigns, notebook, analysis, calibration, validation, report."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from odolab.lab import STEPS, run_lab

    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description:<12}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=console,
        transient=False,
    ) as bar:
        tasks = {name: bar.add_task(name, total=None, start=False) for name in STEPS}

        def progress(step: str, done: int, total: int) -> None:
            task = tasks[step]
            bar.start_task(task)
            bar.update(task, completed=done, total=total)

        result = run_lab(out, seed=seed, truth=truth, progress=progress)

    out_console = Console()
    out_console.print(_compact_table1(result.table1))
    after = ", ".join(f"{k} {v:.4f}" for k, v in result.after_calibration.items())
    old_rms, new_rms = result.validation_rms
    out_console.print(f"after calibration (ratios), actual/predicted: {after}")
    out_console.print(f"IMU validation: heading RMS error {old_rms:.3f} rad -> {new_rms:.3f} rad")
    for name, path in result.params_files.items():
        out_console.print(f"calibrated parameters ({name}): {path}")
    out_console.print(f"lab notebook: {result.notebook}")
    out_console.print(f"report: {result.report}")


def _compact_table1(rows: list[dict[str, Any]]) -> Any:
    """Table I as measured in this run, beside the lab report's own numbers."""
    from rich.table import Table

    from odolab.lab import LAB_REPORT_TABLE1, LAB_REPORT_Y_SIGMA, pooled_y_sigmas

    table = Table(title="Table I: this run (virtual Jaguar) vs the lab report")
    for name in ("motion", "terrain", "n", "ratio [95% CI]", "lab", "sigma @", "lab sigma"):
        table.add_column(name, justify="left" if name in ("motion", "terrain") else "right")
    for r in rows:
        ref = LAB_REPORT_TABLE1.get((r["motion"], r["terrain"]))
        lo, hi = r["ratio_ci95"]
        sig = "\n".join(f"{s['sigma']:.3g} @ {s['commanded']:+.3g}" for s in r.get("sigmas", []))
        table.add_row(
            r["motion"],
            r["terrain"],
            str(r["n"]),
            f"{r['ratio']:.4f} [{lo:.3f}, {hi:.3f}]",
            f"{ref[0]:g} ± {ref[1]:g}" if ref else "-",
            sig or "-",
            "\n".join(f"{s:g} @ {at:.3g}" for s, at, _ in ref[2]) if ref and ref[2] else "-",
        )
    pooled = pooled_y_sigmas(rows)
    if pooled:
        table.add_row(
            "y (both)",
            "tile",
            "",
            "",
            "",
            "\n".join(f"{s:.3g} @ {d:g}" for d, s in pooled.items()),
            "\n".join(f"{s:g} @ {at:g}" for s, at, _ in LAB_REPORT_Y_SIGMA),
        )
    return table
