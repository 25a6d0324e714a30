"""CLI command: ``odolab demo``, the whole lab on the virtual Jaguar (what ``make demo`` runs)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import app
from odolab.core.defaults import DEFAULT_TRUTH

if TYPE_CHECKING:
    from odolab.app.demo import LabResult

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

    from odolab.app.demo import STEPS, run_lab
    from odolab.cli.wording import flag

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

        result = run_lab(out, seed=seed, truth=truth, progress=progress, flag=flag)

    _print_result(result)


def _print_result(result: LabResult) -> None:
    """Table I against the lab report, the headline numbers and where the files went."""
    from odolab.cli._console import console as make_console
    from odolab.cli._console import print_table
    from odolab.core import numfmt
    from odolab.report.table import table1_compare_rich

    out_console = make_console()
    print_table(
        out_console, table1_compare_rich(result.table1, title="Table I: this run vs the lab report")
    )
    after = ", ".join(f"{k} {numfmt.plain(v)}" for k, v in result.after_calibration.items())
    old_rms, new_rms = result.validation_rms
    out_console.print(f"after calibration (ratios), actual/predicted: {after}")
    out_console.print(
        f"IMU validation: heading RMS error {numfmt.plain(old_rms, 3)} rad -> "
        f"{numfmt.plain(new_rms, 3)} rad"
    )
    if result.phone_runs is not None:
        for sentence in result.phone_runs.verdict():
            out_console.print(f"  {sentence}", markup=False)
    ev = result.evidence
    if ev is not None and ev.comparison is not None:
        cmp = ev.comparison
        out_console.print(
            f"kinematic model: {cmp.recommended} ({cmp.reason})", markup=False, highlight=False
        )
    if ev is not None and ev.slip:
        _print_slip(out_console, ev.slip)
    elif ev is not None and ev.slip_note:
        out_console.print(ev.slip_note, markup=False, highlight=False)
    if ev is not None and ev.nees:
        from odolab.cli.wording import said
        from odolab.metrics.consistency import first_order_note, nees_summary

        s = nees_summary(ev.nees)
        lo, hi = s.mean_bounds95
        piece = ev.nees[0].segment_s
        out_console.print(
            f"covariance (NEES over {s.n} pieces of {piece:g} s): mean "
            f"{numfmt.plain(s.mean, 3)}, "
            f"95 % bounds [{numfmt.plain(lo, 3)}, {numfmt.plain(hi, 3)}], "
            f"{100 * s.fraction_inside:.0f} % of pieces inside their own bounds: {s.verdict}",
            markup=False,
            highlight=False,
        )
        _, note = first_order_note(ev.nees)
        if note:  # why the verdict is on these pieces (issue 38), in the CLI's words
            out_console.print(
                said(f"note: {note}; {ev.about_nees.rsplit('. ', 1)[-1]}"),
                markup=False,
                highlight=False,
            )
    for name, path in result.params_files.items():
        out_console.print(f"calibrated parameters ({name}): {path}", markup=False)
    out_console.print(f"lab notebook: {result.notebook}", markup=False)
    out_console.print(f"report: {result.report}", markup=False)


def _print_slip(console: Any, slip: Mapping[str, Any]) -> None:
    """The slip comparison in three lines: what was explored, what compare recommends, the
    learning curve, and the speed question from the slip model's coefficients."""
    from odolab.core import numfmt

    ex = slip["exploration"]
    cmp = slip["comparison"]
    say = {"markup": False, "highlight": False}
    console.print(
        f"exploration: {ex['seconds']:g} s on {ex['terrain']}, seed {ex['seed']}, commands "
        f"{ex['distribution']} over |v| <= {ex['max_speed']:g} m/s, |w| <= "
        f"{ex['max_turn_rate']:g} rad/s, fence {ex['fence_radius']:g} m",
        **say,
    )
    console.print(f"slip vs kinematic models: {cmp['recommended']} ({cmp['reason']})", **say)
    curve = cmp.get("learning_curve") or []
    for name in dict.fromkeys(str(r["model"]) for r in curve):
        cells = [
            f"{r['seconds']:g} s "
            + (
                "not fitted"
                if r["endpoint_error"] is None
                else numfmt.plain(r["endpoint_error"], 3)
            )
            for r in curve
            if r["model"] == name
        ]
        console.print(f"  learning curve, {name} (held-out end-point error, m): "
                      + ", ".join(cells), **say)  # fmt: skip
    answer = slip["speed_question"].get("answer") or slip["speed_question"].get("problem")
    if answer:
        console.print(f"speed question: {answer}", **say)
    from odolab.report.models_section import slip_nees_sentence

    nees = slip_nees_sentence(slip.get("nees") or {})
    if nees:
        console.print(f"slip model's covariance: {nees}", **say)
