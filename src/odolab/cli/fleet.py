"""CLI commands: ``odolab fleet simulate`` (a fleet's logs) and ``odolab fleet report``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import fleet_app
from odolab.cli._output import echo

__all__: list[str] = []


@fleet_app.command("simulate")
def fleet_simulate(
    output: Annotated[Path, typer.Argument(help="Folder for <robot>/<date>/run-NNN.csv runs.")],
    robots: Annotated[int, typer.Option(help="Robots in the fleet.")] = 4,
    days: Annotated[int, typer.Option(help="Days of logs.")] = 5,
    runs_per_day: Annotated[int, typer.Option(help="Runs per robot and day.")] = 3,
    seconds: Annotated[float, typer.Option(help="Length of each run (s).")] = 40.0,
    wearing: Annotated[int, typer.Option(help="How many robots wear (drift grows).")] = 1,
    wear_per_day: Annotated[
        float, typer.Option(help="Wear: fraction of the left wheel radius lost per day.")
    ] = 0.003,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Simulate a fleet's logs with the virtual Jaguar: each robot its own truth and wear."""
    from odolab.cli._progress import progress_bar
    from odolab.fleet import FleetSpec, simulate_fleet

    spec = FleetSpec(
        robots=robots,
        days=days,
        runs_per_day=runs_per_day,
        run_seconds=seconds,
        wearing=wearing,
        wear_per_day=wear_per_day,
        seed=seed,
    )
    with progress_bar("simulate", unit="runs") as report:
        paths = simulate_fleet(output, spec, progress=report)
    echo(
        f"{len(paths)} runs of {robots} robots over {days} days -> {output} "
        f"(truth in {output / 'fleet.json'}); evaluate with: odolab evaluate {output} "
        "--format csv -p jaguar-lite --results fleet.parquet"
    )


@fleet_app.command("report")
def fleet_report(
    table: Annotated[Path, typer.Argument(help="Fleet table from odolab evaluate --results.")],
    output: Annotated[
        Path, typer.Option("--output", "-o", help="Folder for fleet.html and its figures.")
    ] = Path("fleet-report"),
) -> None:
    """Which robot needs recalibration, with the evidence: an HTML section and a figure."""
    from rich.console import Console

    from odolab.cli._output import term
    from odolab.fleet.section import fleet_section
    from odolab.fleet.table import read_fleet_table

    section = fleet_section(read_fleet_table(table))
    page = section.save(output)
    console = Console()
    for v in section.verdicts:
        mark = "RECALIBRATE" if v.recalibrate else "ok"
        console.print(f"{term(v.robot)}: {mark}: {term(v.reason())}", markup=False)
    console.print(f"fleet section -> {term(str(page))}", markup=False)
