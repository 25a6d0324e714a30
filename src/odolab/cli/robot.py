"""CLI commands: ``odolab robot rotate|drive|pivot|square|sim-server``.

Each motion command drives a robot by odometry (by default a virtual Jaguar started on loopback),
shows the pose and loop health live, and saves the run (encoder log, predicted trajectory, JSON)
so that the measured pose can be entered afterwards.
"""

from __future__ import annotations

import inspect
import math
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from odolab.cli._apps import robot_app

if TYPE_CHECKING:
    from odolab.robot.loop import CycleInfo
    from odolab.trials import Command

__all__: list[str] = []


class ModeChoice(StrEnum):
    pwm = "pwm"
    velocity = "velocity"


class DirectionChoice(StrEnum):
    cw = "cw"
    ccw = "ccw"


class TrackChoice(StrEnum):
    left = "left"
    right = "right"


RobotOpt = Annotated[
    str | None,
    typer.Option(
        "--robot", help="udp://HOST:PORT of the board; default: a virtual Jaguar on loopback."
    ),
]
RateOpt = Annotated[float, typer.Option("--rate", help="Control loop rate, Hz.")]
ParamsOpt = Annotated[
    str, typer.Option("--params", "-p", help="Nominal parameters: TOML file or preset name.")
]
ModeOpt = Annotated[
    ModeChoice, typer.Option("--mode", help="Drive commands: PWM (type 6) or velocity (type 27).")
]
DecelOpt = Annotated[
    float,
    typer.Option(
        "--decel",
        help="Slow down over the last DECEL m (straight) or rad (turns); 0 = abrupt stop.",
    ),
]
WatchdogOpt = Annotated[
    float, typer.Option("--watchdog", help="Stop when no sensor data arrives for this many s.")
]
OutOpt = Annotated[
    Path | None,
    typer.Option("--out", "-o", help="Folder for the run (default runs/robot/<time>-<motion>)."),
]
DbOpt = Annotated[
    Path | None,
    typer.Option(
        "--db",
        help="Also record the run in this lab notebook (status: awaiting measurement).",
        envvar="ODOLAB_DB",
    ),
]
TruthOpt = Annotated[
    str, typer.Option("--truth", help="Virtual Jaguar only: true-parameter preset of the plant.")
]
TerrainOpt = Annotated[str, typer.Option("--terrain", help="Virtual Jaguar only: terrain.")]
SeedOpt = Annotated[
    int, typer.Option("--seed", min=0, help="Virtual Jaguar only: random seed (>= 0).")
]
LeftChOpt = Annotated[int, typer.Option("--left-channel", help="Board channel of the left track.")]
RightChOpt = Annotated[
    int, typer.Option("--right-channel", help="Board channel of the right track.")
]
LeftSignOpt = Annotated[
    int, typer.Option("--left-encoder-sign", help="-1 if the left counter counts down forward.")
]
RightSignOpt = Annotated[
    int, typer.Option("--right-encoder-sign", help="-1 if the right counter counts down forward.")
]
MaxSpeedOpt = Annotated[
    float, typer.Option("--max-wheel-speed", help="m/s at full PWM (and the speed clip).")
]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No live view.")]
RealtimeOpt = Annotated[
    bool,
    typer.Option(
        "--realtime/--no-realtime",
        help="Run the loop thread in SCHED_FIFO where the OS allows it (else silently normal).",
    ),
]


def _live_table(info: CycleInfo, rate: float, target: str) -> Any:
    from rich.table import Table

    table = Table(title=f"odolab robot: {target}", show_header=False)
    p = info.pose
    table.add_row("cycle", f"{info.index}  t={info.t:.2f} s  ({rate:g} Hz)")
    table.add_row(
        "pose",
        f"x={p.x:+.4f} m  y={p.y:+.4f} m  heading={p.heading:+.4f} rad "
        f"({math.degrees(p.heading):+.1f} deg)",
    )
    table.add_row("ticks", f"left={info.reading.left_ticks}  right={info.reading.right_ticks}")
    table.add_row("command", f"left={info.command[0]:+.3f} m/s  right={info.command[1]:+.3f} m/s")
    link = "[green]ok[/green]" if info.link_ok else "[bold red]LOST - stopping[/bold red]"
    table.add_row("loop", f"{info.phase}; link {link}; late {info.lateness * 1e3:.2f} ms")
    return table


def _run(
    command: Command,
    *,
    robot: str | None,
    rate: float,
    params: str,
    mode: ModeChoice,
    decel: float,
    watchdog: float,
    out: Path | None,
    db: Path | None,
    truth: str,
    terrain: str,
    seed: int,
    left_channel: int,
    right_channel: int,
    left_encoder_sign: int,
    right_encoder_sign: int,
    max_wheel_speed: float,
    quiet: bool,
    realtime: bool,
) -> None:
    from rich.console import Console
    from rich.live import Live

    from odolab.params import load_params
    from odolab.robot.driver import ChannelMap, CommandMode
    from odolab.robot.motions import motion_from_command
    from odolab.robot.session import driver_config_for, run_motion

    if not (math.isfinite(rate) and rate > 0):
        from odolab.errors import SimError

        raise SimError(f"--rate is {rate:g}; expected a positive number of Hz")
    nominal = load_params(params)
    config = driver_config_for(
        nominal,
        channels=ChannelMap(
            left=left_channel,
            right=right_channel,
            left_encoder_sign=left_encoder_sign,
            right_encoder_sign=right_encoder_sign,
        ),
        mode=CommandMode(mode.value),
        max_wheel_speed=max_wheel_speed,
    )
    motion = motion_from_command(command, decel=decel, turn_decel=decel)
    console = Console(stderr=True)
    target = command.describe()
    events: list[str] = []

    def on_event(t: float, message: str) -> None:
        events.append(f"t={t:.2f} s: {message}")

    live = Live(console=console, refresh_per_second=8, transient=False) if not quiet else None
    every = max(1, round(rate / 8))

    def on_cycle(info: CycleInfo) -> None:
        if live is not None and (info.index % every == 0 or not info.link_ok):
            live.update(_live_table(info, rate, target))

    notebook = None
    if db is not None:  # open (create, migrate) the notebook before driving: refuse a bad one now
        from odolab.store import Notebook

        notebook = Notebook(db)
    folder = out or Path("runs") / "robot" / (
        datetime.now(UTC).strftime("%Y%m%dT%H%M%S") + f"-{command.kind.value}"
    )
    if folder.exists() and not folder.is_dir():
        from odolab.errors import SimError

        # refuse before driving: a run that cannot be saved would be lost
        raise SimError(f"{folder}: is a file; expected a folder for the run (--out)")
    if live is not None:
        live.start()
    try:
        run = run_motion(
            command,
            robot=robot,
            params=nominal,
            rate=rate,
            motion=motion,
            driver_config=config,
            watchdog_timeout=watchdog,
            truth=truth,
            terrain=terrain,
            seed=seed,
            on_cycle=on_cycle,
            on_event=on_event,
            realtime=realtime,
            save_to=folder,
        )
    except BaseException:
        if live is not None:
            live.stop()
            live = None
        for line in events:
            typer.echo(line, err=True)
        if (folder / "run.json").exists():
            typer.echo(f"robot stopped; the partial run is saved to {folder}", err=True)
        raise
    finally:
        if live is not None:
            live.stop()
    for line in events:
        typer.echo(line, err=True)
    p = run.trial.predicted
    typer.echo(
        f"{target} on {run.robot}: predicted x={p.x:.4f} m y={p.y:.4f} m "
        f"heading={p.heading:.4f} rad"
    )
    if run.trial.true is not None:
        q = run.trial.true
        typer.echo(f"true (virtual): x={q.x:.4f} m y={q.y:.4f} m heading={q.heading:.4f} rad")
    typer.echo(run.stats.describe())
    typer.echo(f"saved to {folder} (status: awaiting measurement)")
    if notebook is not None:
        with notebook as nb:
            nb.add_trial(run.trial)
        typer.echo(
            f"recorded in {db} as {run.trial.trial_id}; enter the measurement with "
            f"'odolab trials measure {run.trial.trial_id} --db {db}'"
        )


def _run_options(values: dict[str, Any]) -> dict[str, Any]:
    """The options every motion command passes on to :func:`_run`, taken from its arguments."""
    names = list(inspect.signature(_run).parameters)[1:]  # all but the command
    return {name: values[name] for name in names}


def _check_nonzero(option: str, value: float) -> None:
    """A zero (or non-finite) motion would record an empty trial: refuse it before connecting."""
    from odolab.errors import SimError

    if not math.isfinite(value) or value == 0:
        raise SimError(f"{option} is {value:g}; expected a finite number other than 0")


@robot_app.command("rotate")
def rotate_cmd(
    turns: Annotated[
        float, typer.Option("--turns", help="Full turns (negative = clockwise).")
    ] = 10.0,
    speed: Annotated[float, typer.Option("--speed", help="Turn rate, rad/s.")] = 0.5,
    robot: RobotOpt = None,
    rate: RateOpt = 20.0,
    params: ParamsOpt = "jaguar-lite",
    mode: ModeOpt = ModeChoice.pwm,
    decel: DecelOpt = 0.0,
    watchdog: WatchdogOpt = 0.5,
    out: OutOpt = None,
    db: DbOpt = None,
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    left_channel: LeftChOpt = 0,
    right_channel: RightChOpt = 1,
    left_encoder_sign: LeftSignOpt = 1,
    right_encoder_sign: RightSignOpt = 1,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    quiet: QuietOpt = False,
    realtime: RealtimeOpt = True,
) -> None:
    """Rotate in place by TURNS full turns (2*pi each), stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

    _check_nonzero("--turns", turns)
    cmd = Command(MotionKind.ROTATION, angle=2.0 * math.pi * turns, speed=speed)
    _run(cmd, **_run_options(locals()))


@robot_app.command("drive")
def drive_cmd(
    distance: Annotated[
        float, typer.Option("--distance", help="Metres; negative = reverse.")
    ] = 1.0,
    speed: Annotated[float, typer.Option("--speed", help="Speed, m/s.")] = 0.3,
    robot: RobotOpt = None,
    rate: RateOpt = 20.0,
    params: ParamsOpt = "jaguar-lite",
    mode: ModeOpt = ModeChoice.pwm,
    decel: DecelOpt = 0.0,
    watchdog: WatchdogOpt = 0.5,
    out: OutOpt = None,
    db: DbOpt = None,
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    left_channel: LeftChOpt = 0,
    right_channel: RightChOpt = 1,
    left_encoder_sign: LeftSignOpt = 1,
    right_encoder_sign: RightSignOpt = 1,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    quiet: QuietOpt = False,
    realtime: RealtimeOpt = True,
) -> None:
    """Drive straight DISTANCE m (negative = reverse), stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

    _check_nonzero("--distance", distance)
    cmd = Command(MotionKind.TRANSLATION, distance=distance, speed=speed)
    _run(cmd, **_run_options(locals()))


@robot_app.command("pivot")
def pivot_cmd(
    degrees: Annotated[
        float, typer.Option("--degrees", help="Turn, degrees (ccw positive).")
    ] = 90.0,
    held: Annotated[
        TrackChoice, typer.Option("--held", help="The track that stays still.")
    ] = TrackChoice.left,
    speed: Annotated[float, typer.Option("--speed", help="Turn rate, rad/s.")] = 0.5,
    robot: RobotOpt = None,
    rate: RateOpt = 20.0,
    params: ParamsOpt = "jaguar-lite",
    mode: ModeOpt = ModeChoice.pwm,
    decel: DecelOpt = 0.0,
    watchdog: WatchdogOpt = 0.5,
    out: OutOpt = None,
    db: DbOpt = None,
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    left_channel: LeftChOpt = 0,
    right_channel: RightChOpt = 1,
    left_encoder_sign: LeftSignOpt = 1,
    right_encoder_sign: RightSignOpt = 1,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    quiet: QuietOpt = False,
    realtime: RealtimeOpt = True,
) -> None:
    """Pivot on one track by DEGREES, stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

    _check_nonzero("--degrees", degrees)
    cmd = Command(MotionKind.PIVOT, angle=math.radians(degrees), direction=held.value, speed=speed)
    _run(cmd, **_run_options(locals()))


@robot_app.command("square")
def square_cmd(
    side: Annotated[float, typer.Option("--side", help="Side of the square, m.")] = 4.0,
    direction: Annotated[
        DirectionChoice, typer.Option("--direction", help="cw or ccw.")
    ] = DirectionChoice.ccw,
    speed: Annotated[float, typer.Option("--speed", help="Straight speed, m/s.")] = 0.3,
    robot: RobotOpt = None,
    rate: RateOpt = 20.0,
    params: ParamsOpt = "jaguar-lite",
    mode: ModeOpt = ModeChoice.pwm,
    decel: DecelOpt = 0.0,
    watchdog: WatchdogOpt = 0.5,
    out: OutOpt = None,
    db: DbOpt = None,
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    left_channel: LeftChOpt = 0,
    right_channel: RightChOpt = 1,
    left_encoder_sign: LeftSignOpt = 1,
    right_encoder_sign: RightSignOpt = 1,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    quiet: QuietOpt = False,
    realtime: RealtimeOpt = True,
) -> None:
    """Drive the UMBmark square (four sides, four 90-degree turns in place) by odometry."""
    from odolab.trials import Command, MotionKind

    cmd = Command(MotionKind.SQUARE, side=side, direction=direction.value, speed=speed)
    _run(cmd, **_run_options(locals()))


@robot_app.command("sim-server")
def sim_server_cmd(
    host: Annotated[str, typer.Option("--host", help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[
        int, typer.Option("--port", min=0, max=65535, help="UDP port (0 = any free one).")
    ] = 10001,
    params: ParamsOpt = "jaguar-lite",
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    report_rate: Annotated[
        float, typer.Option("--report-rate", help="Sensor packets per second.")
    ] = 10.0,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    drop: Annotated[float, typer.Option("--drop", help="Probability of dropping a packet.")] = 0.0,
    jitter: Annotated[
        float, typer.Option("--jitter", help="Random extra delay up to this many s.")
    ] = 0.0,
) -> None:
    """Run a virtual Jaguar board (UDP) until Ctrl-C."""
    from odolab.params import load_params
    from odolab.robot.plant import make_plant
    from odolab.robot.server import BoardConfig, Faults, VirtualJaguar, VirtualJaguarServer

    nominal = load_params(params)
    plant = make_plant(truth, nominal, terrain, seed=seed)
    board = BoardConfig.from_params(
        nominal, report_rate=report_rate, max_wheel_speed=max_wheel_speed
    )
    jaguar = VirtualJaguar(plant, board, faults=Faults(drop=drop, jitter=jitter), seed=seed)
    server = VirtualJaguarServer(jaguar, host, port)
    h, p = server.address
    typer.echo(f"virtual Jaguar ({truth}) listening on udp://{h}:{p}; Ctrl-C to stop", err=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        pose = plant.true_pose
        typer.echo(
            f"true pose: x={pose.x:.4f} m y={pose.y:.4f} m heading={pose.heading:.4f} rad", err=True
        )
