"""CLI commands: ``odolab sim run`` and ``odolab sim list`` (the virtual Jaguar)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import sim_app
from odolab.cli._output import echo
from odolab.defaults import DEFAULT_ROBOT, DEFAULT_TRUTH

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


@sim_app.command("run")
def sim_run(
    protocol: Annotated[str, typer.Argument(help=_PROTOCOL_HELP)],
    terrain: Annotated[
        str | None,
        typer.Option(help="Override the protocol's terrain: tile, concrete or grass."),
    ] = None,
    seed: Annotated[
        int,
        typer.Option(
            min=0,
            help="Random seed (the same seed gives the same trials); the default is the "
            "documented seed whose lab-report campaign reproduces the lab's Table I.",
        ),
    ] = _LAB_REPORT_SEED,
    output: Annotated[
        Path, typer.Option("--output", "-o", help="Trials CSV to write (one row per trial).")
    ] = Path("trials.csv"),
    truth: Annotated[
        str,
        typer.Option(
            help="True-behaviour preset of the virtual robot: "
            "jaguar-lab, jaguar-lab-track, jaguar-lab-tracked (an ICR vehicle) or ideal."
        ),
    ] = DEFAULT_TRUTH,
    params: Annotated[
        str, typer.Option("--params", "-p", help="Nominal parameters (TOML file or preset).")
    ] = DEFAULT_ROBOT,
    encoder_dir: Annotated[
        Path | None,
        typer.Option(help="Also write each trial's encoder log as DIR/<trial_id>.csv."),
    ] = None,
    db: Annotated[
        Path | None,
        typer.Option(
            "--db", help="Also record the trials in this lab notebook.", envvar="ODOLAB_DB"
        ),
    ] = None,
) -> None:
    """Run an experiment protocol on the virtual Jaguar and write the trials."""
    from rich.console import Console
    from rich.progress import Progress

    from odolab.cli._output import markup_text, term
    from odolab.errors import SimError
    from odolab.numfmt import count
    from odolab.params import load_params
    from odolab.sim.export import write_encoder_logs
    from odolab.sim.presets import TRUTH_PRESETS
    from odolab.sim.protocols import load_protocol, run_protocol

    if truth not in TRUTH_PRESETS:
        raise SimError(
            f"--truth: unknown preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    proto = load_protocol(protocol)
    nominal = load_params(params)
    if encoder_dir is not None and encoder_dir.exists() and not encoder_dir.is_dir():
        raise SimError(f"{encoder_dir}: is a file; expected a folder for --encoder-dir")
    console = Console(stderr=True)
    with Progress(transient=True, console=console, disable=not console.is_terminal) as bar:
        task = bar.add_task(markup_text(proto.name), total=len(proto))
        trials = run_protocol(
            proto,
            TRUTH_PRESETS[truth],
            nominal,
            terrain=terrain,
            seed=seed,
            progress=lambda done, total, what: bar.update(task, completed=done),
        )
    from odolab.store.csvio import write_trials_csv

    write_trials_csv(output, [(t, None) for t in trials])
    if encoder_dir is not None:
        write_encoder_logs(encoder_dir, trials)
    if db is not None:
        from odolab.store import Notebook

        with Notebook(db) as nb:
            nb.add_trials(trials)
    stalled = sum(t.exclusion_reason is not None for t in trials)
    echo(
        f"{count(len(trials), 'trial')} of {term(proto.name)} ({truth}, seed {seed}) -> {output}"
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
    terrain: Annotated[str, typer.Option(help="tile, concrete or grass.")] = "tile",
    truth: Annotated[
        str, typer.Option(help="True-behaviour preset of the virtual robot.")
    ] = "jaguar-lab-tracked",
    params: Annotated[
        str, typer.Option("--params", "-p", help="Nominal parameters (TOML file or preset).")
    ] = DEFAULT_ROBOT,
    seed: Annotated[int, typer.Option(min=0, help="Random seed.")] = 0,
    name: Annotated[str, typer.Option(help="File name stem of the run.")] = "explore",
) -> None:
    """Drive commands sampled over speed and turn rate inside a geofence; record with truth."""
    import math

    import numpy as np

    from odolab.errors import SimError
    from odolab.params import load_params
    from odolab.robot.config import BOUNDS, check_exploration
    from odolab.sim.explore import ExploreSettings, explore, write_exploration
    from odolab.sim.presets import TRUTH_PRESETS
    from odolab.text import safe_file_name
    from odolab.trials import Exploration

    if truth not in TRUTH_PRESETS:
        raise SimError(
            f"--truth: unknown preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    stem = safe_file_name(name, what="run name", suffix=".csv")[: -len(".csv")]
    nominal = load_params(params)
    chosen = ""
    if max_turn_rate is None:
        in_place = max_speed / (0.5 * nominal.track_width) if max_speed > 0 else 0.0
        max_turn_rate = min(2.0, in_place) if math.isfinite(in_place) and in_place > 0 else 2.0
        if max_turn_rate < 2.0:
            chosen = (
                f"--max-turn-rate not given: {max_turn_rate:.3g} rad/s, a turn in place at "
                f"--max-speed {max_speed:g} m/s (the default 2 rad/s is beyond it)"
            )
    # the bounds robot explore has (odolab.robot.config), up to the fastest wheel odolab drives
    check_exploration(
        Exploration(seconds, max_speed, max_turn_rate, fence=fence, distribution=distribution),
        nominal,
        BOUNDS["max_wheel_speed"].hi,
        "the largest wheel speed odolab drives,",
    )
    settings = ExploreSettings(
        seconds=seconds,
        max_speed=max_speed,
        max_turn_rate=max_turn_rate,
        fence_radius=fence,
        distribution=distribution,
    )
    if chosen:
        echo(chosen)
    run = explore(TRUTH_PRESETS[truth], nominal, settings, terrain=terrain, seed=seed)
    log, gt = write_exploration(output, run, stem)
    echo(
        f"explored {settings.seconds:.1f} s ({truth}, seed {seed}) -> {log}, {gt}"
        + ("; the robot stalled (turns in place on this terrain)" if run.stalled else "")
    )
    reach = float(np.max(np.hypot(run.x - run.x[0], run.y - run.y[0])))
    if reach > fence:  # the simulator's fence turns the robot back; it does not stop it
        echo(
            f"note: the robot went {reach:.3g} m from its start, beyond the {fence:g} m fence "
            "(odometry turns it back near the edge; a fence smaller than one held command's "
            "travel cannot hold it)"
        )
