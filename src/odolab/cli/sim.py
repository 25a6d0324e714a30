"""CLI commands: ``odolab sim run`` and ``odolab sim list`` (the virtual Jaguar)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import sim_app
from odolab.cli._output import echo
from odolab.cli.options import NominalParamsOpt, RandomSeedOpt, VirtualTruthOpt
from odolab.core.defaults import DEFAULT_ROBOT, DEFAULT_TERRAIN, DEFAULT_TRUTH

__all__: list[str] = []


def _builtin_names() -> list[str]:
    folder = resources.files("odolab").joinpath("data/protocols")
    try:
        return sorted(e.name[:-5] for e in folder.iterdir() if e.name.endswith(".toml"))
    except (FileNotFoundError, NotADirectoryError):  # pragma: no cover - broken install
        return []


#: == odolab.sim.presets.LAB_REPORT_SEED (tested); a literal so that --help stays instant
_LAB_REPORT_SEED = 4314  # = odolab.sim.presets.LAB_REPORT_SEED (tests guard it)

_PROTOCOL_HELP = "Protocol TOML file or built-in protocol: " + ", ".join(_builtin_names()) + "."


RunProtocolOpt = Annotated[str, typer.Argument(help=_PROTOCOL_HELP)]
RunTerrainOpt = Annotated[
    str | None,
    typer.Option(help="Override the protocol's terrain: tile, concrete or grass."),
]
RunSeedOpt = Annotated[
    int,
    typer.Option(
        min=0,
        help="Random seed (the same seed gives the same trials); the default is the "
        "documented seed whose lab-report campaign reproduces the lab's Table I.",
    ),
]
RunOutputOpt = Annotated[
    Path, typer.Option("--output", "-o", help="Trials CSV to write (one row per trial).")
]
RunTruthOpt = Annotated[
    str,
    typer.Option(
        help="True-behaviour preset of the virtual robot: "
        "jaguar-lab, jaguar-lab-track, jaguar-lab-tracked (an ICR vehicle) or ideal."
    ),
]
RunEncoderDirOpt = Annotated[
    Path | None,
    typer.Option(help="Also write each trial's encoder log as DIR/<trial_id>.csv."),
]
RunDbOpt = Annotated[
    Path | None,
    typer.Option("--db", help="Also record the trials in this lab notebook.", envvar="ODOLAB_DB"),
]


@sim_app.command("run")
def sim_run(
    protocol: RunProtocolOpt,
    terrain: RunTerrainOpt = None,
    seed: RunSeedOpt = _LAB_REPORT_SEED,
    output: RunOutputOpt = Path("trials.csv"),
    truth: RunTruthOpt = DEFAULT_TRUTH,
    params: NominalParamsOpt = DEFAULT_ROBOT,
    encoder_dir: RunEncoderDirOpt = None,
    db: RunDbOpt = None,
) -> None:
    """Run an experiment protocol on the virtual Jaguar and write the trials."""
    from rich.console import Console
    from rich.progress import Progress, TaskID

    from odolab.app.sim import SimRunRequest, simulate_protocol
    from odolab.cli._output import markup_text, term
    from odolab.core.numfmt import count

    request = SimRunRequest(protocol, output, seed, terrain, truth, params, encoder_dir, db)
    console = Console(stderr=True)
    with Progress(transient=True, console=console, disable=not console.is_terminal) as bar:
        tasks: dict[str, TaskID] = {}

        def progress(name: str, done: int, total: int) -> None:
            if name not in tasks:
                tasks[name] = bar.add_task(markup_text(name), total=total)
            bar.update(tasks[name], completed=done)

        done = simulate_protocol(request, progress)
    stalled = done.stalled
    echo(
        f"{count(len(done.trials), 'trial')} of {term(done.protocol)} ({truth}, seed {seed}) -> "
        f"{output}"
        + (f"; {stalled} stalled (excluded)" if stalled else "")
        + (f"; recorded in {db}" if db is not None else "")
    )


@sim_app.command("list")
def sim_list() -> None:
    """List the built-in protocols, terrains and true-behaviour presets."""
    from odolab.sim.presets import TRUTH_PRESETS
    from odolab.sim.protocols import builtin_protocols
    from odolab.sim.terrains import TERRAINS

    echo("protocols:")
    for name, desc in builtin_protocols().items():
        echo(f"  {name}: {desc}")
    echo("terrains:")
    for name, t in TERRAINS.items():
        echo(f"  {name}: {t.description}")
    echo("truths: " + ", ".join(TRUTH_PRESETS))


@sim_app.command("explore")
def sim_explore(
    output: Annotated[
        Path,
        typer.Option("--output", "-o", help="Folder for the run: explore.csv and explore_gt.csv."),
    ],
    seconds: Annotated[float, typer.Option(help="How long to explore (s).")] = 60.0,
    max_speed: Annotated[float, typer.Option(help="Largest wheel speed (m/s).")] = 1.0,
    max_turn_rate: Annotated[
        float | None,
        typer.Option(
            help="Largest turn rate (rad/s). [default: 2, or a turn in place at --max-speed "
            "when that is less]"
        ),
    ] = None,
    fence: Annotated[float, typer.Option(help="Geofence radius about the start (m).")] = 4.0,
    distribution: Annotated[
        str, typer.Option(help="How commands are drawn: uniform, or edges (mostly fast).")
    ] = "uniform",
    terrain: Annotated[str, typer.Option(help="tile, concrete or grass.")] = DEFAULT_TERRAIN,
    truth: VirtualTruthOpt = "jaguar-lab-tracked",
    params: NominalParamsOpt = DEFAULT_ROBOT,
    seed: RandomSeedOpt = 0,
    name: Annotated[str, typer.Option(help="File name stem of the run.")] = "explore",
) -> None:
    """Drive commands sampled over speed and turn rate inside a geofence; record with truth."""
    from odolab.app.sim import ExploreRequest, simulate_exploration

    request = ExploreRequest(
        output, seconds, max_speed, max_turn_rate, fence, distribution, terrain, truth, params,
        seed, name,
    )  # fmt: skip
    done = simulate_exploration(request)
    if done.chosen:
        echo(done.chosen)
    echo(
        f"explored {done.settings.seconds:.1f} s ({truth}, seed {seed}) -> {done.log}, "
        f"{done.ground_truth}"
        + ("; the robot stalled (turns in place on this terrain)" if done.run.stalled else "")
    )
    reach = done.reach
    if reach > fence:  # the simulator's fence turns the robot back; it does not stop it
        echo(
            f"note: the robot went {reach:.3g} m from its start, beyond the {fence:g} m fence "
            "(odometry turns it back near the edge; a fence smaller than one held command's "
            "travel cannot hold it)"
        )
