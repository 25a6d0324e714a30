"""CLI commands: ``odolab robot rotate|drive|pivot|square|explore|sim-server``.

Each motion command drives a robot by odometry (by default a virtual Jaguar started on loopback),
shows the pose and loop health live, and saves the run (encoder log, predicted trajectory, JSON)
so that the measured pose can be entered afterwards. ``explore`` drives commands sampled over the
robot's input space inside a geofence and keeps the run's ground truth
(:mod:`odolab.robot.explore`).
"""

from __future__ import annotations

import inspect
import math
import shlex
from collections.abc import Callable
from enum import StrEnum
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Annotated, Any, get_type_hints

import typer

from odolab.app.robot import FOXGLOVE_PORT
from odolab.cli._apps import robot_app
from odolab.cli._output import echo, term
from odolab.cli.options import NominalParamsOpt
from odolab.cli.wording import flag
from odolab.core.defaults import (
    DEFAULT_MAX_WHEEL_SPEED,
    DEFAULT_ROBOT,
    DEFAULT_SEED,
    DEFAULT_TERRAIN,
    DEFAULT_TRUTH,
)

if TYPE_CHECKING:
    from odolab.app.robot import RobotPlan
    from odolab.core.trials import Command
    from odolab.robot.config import RunConfig
    from odolab.robot.jaguar.board import VirtualJaguarServer
    from odolab.robot.jaguar2014.board import VirtualJaguar2014Server
    from odolab.robot.loop import CycleInfo
    from odolab.robot.session import AbortReport, RobotRun
    from odolab.store import Notebook

__all__ = ["measure_virtual_command"]


ModeChoice = StrEnum("ModeChoice", ["pwm", "velocity"])
LinkChoice = StrEnum("LinkChoice", ["jaguar", "jaguar2014"])
DirectionChoice = StrEnum("DirectionChoice", ["cw", "ccw"])
TrackChoice = StrEnum("TrackChoice", ["left", "right"])
DistributionChoice = StrEnum("DistributionChoice", ["uniform", "edges"])
GroundTruthChoice = StrEnum("GroundTruthChoice", ["virtual", "mocap", "track", "laser"])


RobotOpt = Annotated[
    str | None,
    typer.Option(
        "--robot",
        help="udp://HOST:PORT of a Jaguar board (binary), tcp://HOST:PORT[?variant=wheel|track] "
        "of a Jaguar 4x4 of 2014 or later (text), or sim:// (the default) for a virtual Jaguar "
        "on loopback.",
    ),
]
RateOpt = Annotated[float, typer.Option("--rate", help="Control loop rate, Hz (5..1000).")]
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
    float,
    typer.Option(
        "--watchdog", help="Stop when no sensor data has arrived for this many s (0.05..2)."
    ),
]
LinkTimeoutOpt = Annotated[
    float,
    typer.Option(
        "--link-timeout",
        help="Give up (robot stopped, exit 1, partial run saved) after no sensor data for this "
        "many s (>= --watchdog, <= 60).",
    ),
]
StallTimeoutOpt = Annotated[
    float,
    typer.Option(
        "--stall-timeout",
        help="Give up when the wheels are driven but the encoders do not move for this many s.",
    ),
]
CommandTimeoutOpt = Annotated[
    float,
    typer.Option(
        "--command-timeout",
        help="Virtual Jaguar (sim://) only: its motors stop when no motor command came for "
        "this many s (a real board has its own; refused on one).",
    ),
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
LeftMotorOpt = Annotated[
    int,
    typer.Option(
        "--left-motor-sign", help="-1 if a positive command drives the left track backward."
    ),
]
RightMotorOpt = Annotated[
    int,
    typer.Option(
        "--right-motor-sign", help="-1 if a positive command drives the right track backward."
    ),
]
MaxSpeedOpt = Annotated[
    float,
    typer.Option("--max-wheel-speed", help="m/s at full PWM, and the speed clip (0 < v <= 3)."),
]
QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No live view.")]
FoxgloveOpt = Annotated[
    bool,
    typer.Option(
        "--foxglove", help="Serve the run live to Foxglove (ws://127.0.0.1:PORT; loopback only)."
    ),
]
FoxglovePortOpt = Annotated[
    int, typer.Option("--foxglove-port", help="Foxglove server port (with --foxglove; 0: any).")
]
RealtimeOpt = Annotated[
    bool,
    typer.Option(
        "--realtime/--no-realtime",
        help="Run the loop thread in SCHED_FIFO where the OS allows it (else silently normal).",
    ),
]


class _LiveTable:
    """The live view of one cycle. Its imports happen when it is made, before the robot moves:
    a control cycle imports nothing."""

    def __init__(self, rate: float, target: str) -> None:
        from rich.table import Table

        from odolab.cli._output import markup_text

        self._table = Table
        self.rate = rate
        self.title = f"odolab robot: {markup_text(target)}"

    #: the latest cycle, set by the control loop (a plain assignment, no lock)
    latest: CycleInfo | None = None

    def __call__(self, info: CycleInfo) -> Any:
        return _live_table(self._table(title=self.title, show_header=False), info, self.rate)

    def render(self) -> Any:
        """The view of the latest cycle, for rich's refresh thread."""
        info = self.latest
        return self(info) if info is not None else self.title


class _EventPrinter:
    """Prints lines on stderr from its own thread, so that the control loop never waits on
    the terminal; :meth:`close` waits until every line given so far is out and ends the
    thread (a process that drives many runs keeps no thread per run)."""

    def __init__(self) -> None:
        import queue
        import threading

        self._lines: queue.Queue[str | None] = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="odolab-events", daemon=True)
        self._thread.start()

    def put(self, line: str) -> None:
        self._lines.put(line)

    def _work(self) -> None:
        while (line := self._lines.get()) is not None:
            echo(line, err=True)

    def close(self) -> None:
        """Every line given so far printed, then the thread ended."""
        self._lines.put(None)
        self._thread.join()


def measure_virtual_command(trial_id: str, db: Path | str | None) -> str:
    """The ``odolab trials measure ID --virtual [--db DB]`` line to copy into a shell (quoted)."""
    command = ["odolab", "trials", "measure", trial_id, flag("virtual")]
    command += [flag("db"), str(db)] if db is not None else []
    return shlex.join(command)


def _live_table(table: Any, info: CycleInfo, rate: float) -> Any:
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


class _FoxgloveView:
    """The live run in Foxglove: each cycle's pose, counters and (with ``[noise]``) covariance.

    The covariance comes from a second streaming odometry fed the very counters the loop's
    odometry gets (same compiled step, so the same poses)."""

    def __init__(self, params: Any, port: int) -> None:
        from odolab.core.odometry import Odometry
        from odolab.export.foxglove import FoxgloveLive

        self.live = FoxgloveLive(port=port)
        self.odo = Odometry(params, covariance=True) if params.noise is not None else None
        if self.odo is not None:
            self.odo.warm_up()  # its compiled steps load now, not in a control cycle
        echo(f"Foxglove: open ws://127.0.0.1:{self.live.port}", err=True)

    def publish(self, info: CycleInfo) -> None:
        ticks = (info.reading.left_ticks, info.reading.right_ticks)
        cov = None
        if self.odo is not None:
            self.odo.update(info.t, *ticks)
            cov = self.odo.covariance
        self.live.publish(info.pose, ticks=ticks, covariance=cov)

    def close(self) -> None:
        self.live.close()


def _confirm_line(confirmed: bool) -> str:
    if confirmed:
        return "robot stopped (its sensor data confirms it)"
    return (
        "stop commanded, but the robot's sensor data does not confirm that it stopped: "
        "CHECK THE ROBOT"
    )


_FOXGLOVE_PORT = FOXGLOVE_PORT


def _run(
    command: Command,
    config: RunConfig,
    *,
    robot: str | None,
    params: str,
    out: Path | None,
    db: Path | None,
    truth: str,
    terrain: str,
    seed: int,
    quiet: bool,
    realtime: bool,
    foxglove: bool = False,
    foxglove_port: int = _FOXGLOVE_PORT,
    ground_truth: GroundTruthChoice | None = None,
) -> None:
    """Validate everything (:func:`odolab.app.robot.plan_run`), then drive ``command`` with
    ``config``; nothing is sent before."""
    from odolab.app.robot import RobotRequest, default_folder, open_outputs, plan_run

    source = ground_truth.value if ground_truth is not None else None
    from odolab.cli.wording import CLI, said

    request = RobotRequest(
        command, config, robot, params, truth, terrain, seed, foxglove, foxglove_port, source, CLI
    )
    plan = plan_run(request, lambda line: echo(said(line), err=True))
    # every output precondition before the robot moves: the notebook opens and is one (create,
    # migrate), the run folder can be created and written and holds no earlier run
    folder = out if out is not None else default_folder(plan.command)
    notebook = open_outputs(folder, db)
    views = _Views(plan, quiet)  # (its printer thread ends with the run, however it ends)
    try:
        views.foxglove = _FoxgloveView(plan.nominal, foxglove_port) if foxglove else None
        _drive(plan, views, folder=folder, notebook=notebook, db=db, realtime=realtime)
    finally:
        views.stop()
        if notebook is not None:
            notebook.close()


class _Views:
    """What the user sees while the robot moves: the live table (drawn by rich's own thread
    from the latest cycle), the events (said at once by a printer thread with ``--quiet``, a
    lost link must not be silent; else after the run) and the Foxglove view. Nothing the
    control loop calls writes to the terminal: a terminal that stops reading (Ctrl-S, a
    stalled ssh session) blocked the loop with the motion in force."""

    def __init__(self, plan: RobotPlan, quiet: bool) -> None:
        from rich.console import Console
        from rich.live import Live

        self.quiet = quiet
        self.target = plan.command.describe()
        self.events: list[str] = []
        self.printer = _EventPrinter() if quiet else None
        self.table = _LiveTable(plan.config.rate, self.target)
        self.live: Any = (
            None
            if quiet
            else Live(
                console=Console(stderr=True),
                refresh_per_second=8,
                transient=False,
                get_renderable=self.table.render,
            )
        )
        self.foxglove: _FoxgloveView | None = None  # started once every check has passed

    def on_event(self, t: float, message: str) -> None:
        self.events.append(f"t={t:.2f} s: {message}")
        if self.printer is not None:
            self.printer.put(self.events[-1])

    def on_cycle(self, info: CycleInfo) -> None:
        self.table.latest = info  # one assignment: the drawing thread reads it
        if self.foxglove is not None:
            self.foxglove.publish(info)

    def stop(self) -> None:
        """The live view stopped and every event said (once)."""
        if self.printer is not None:
            self.printer.close()
            self.printer = None
        if self.live is not None:
            self.live.stop()
            self.live = None
            for line in self.events:
                echo(line, err=True)


def _record(notebook: Notebook | None, db: Path | None, run: RobotRun) -> str:
    """Record ``run`` in the notebook (:func:`odolab.app.robot.keep_in_notebook`) and say so;
    "" when done (or no notebook), else why not."""
    from odolab.app.robot import keep_in_notebook

    kept = keep_in_notebook(notebook, db, run)
    if kept.line:
        echo(kept.line, err=kept.err)
    return kept.problem


def _drive(
    plan: RobotPlan,
    views: _Views,
    *,
    folder: Path,
    notebook: Notebook | None,
    db: Path | None,
    realtime: bool,
) -> None:
    """Drive the checked run; keep it (folder, notebook) whatever fails after the robot moved."""
    from odolab.app.robot import check_kept, drive_run

    def on_abort(report: AbortReport) -> None:
        views.stop()
        if report.run is None and not report.stop_confirmed:
            # no cycle ran: no sensor data ever came, and no motion was commanded
            echo("nothing was driven (no sensor data came from the robot); the stop was sent "
                 "anyway", err=True)  # fmt: skip
        else:
            echo(_confirm_line(report.stop_confirmed), err=True)
        if report.save_note:
            echo(report.save_note, err=True)
        if report.saved_to is not None:
            echo(f"the partial run is saved to {report.saved_to}", err=True)
        if report.run is not None:
            problem = _record(notebook, db, report.run)
            if problem:
                echo(problem, err=True)

    if views.live is not None:
        views.live.start()
    try:
        run = drive_run(
            plan, folder=folder, on_cycle=views.on_cycle, on_event=views.on_event,
            on_abort=on_abort, realtime=realtime,
        )  # fmt: skip
    finally:
        views.stop()
        if views.foxglove is not None:
            views.foxglove.close()
    outcome, crossed = plan.explore.outcome(run) if plan.explore is not None else ([], None)
    _print_run(run, views.target, db, plan.explore is None, outcome)
    problem = _record(notebook, db, run)
    if problem:
        echo(problem, err=True)
    if run.stop_confirmed:
        echo(_confirm_line(True), err=True)
    check_kept(run, problem, crossed)


def _print_run(
    run: RobotRun, target: str, db: Path | None, say_saved: bool, outcome: list[str]
) -> None:
    """The predicted (and on the virtual robot the true) pose, the loop's health, the gyro's
    word where the link has one, where the run went and an exploration's outcome."""
    p = run.trial.predicted
    echo(
        f"{target} on {run.robot}: predicted x={p.x:.4f} m y={p.y:.4f} m "
        f"heading={p.heading:.4f} rad"
    )
    if run.trial.true is not None:
        q = run.trial.true
        echo(f"true (virtual): x={q.x:.4f} m y={q.y:.4f} m heading={q.heading:.4f} rad")
        shown = run.extra.get("virtual_instruments") if isinstance(run.extra, dict) else None
        if isinstance(shown, dict):
            suggested = measure_virtual_command(run.trial.trial_id, db)
            echo(term(f"the virtual instruments show: {shown['shows']} ({suggested} takes them)"))
    echo(run.stats.describe())
    if run.headings:  # a link with an IMU: the gyro's word on the track, and the drift monitor
        from odolab.app.imu import gyro_after_run

        for line in gyro_after_run(run):
            echo(line)
    if run.save_note:
        echo(run.save_note, err=True)
    if run.saved_to is not None and say_saved:
        echo(f"saved to {run.saved_to} (status: awaiting measurement)")
    for line in outcome:
        echo(line)


def _config(
    *,
    rate: float,
    mode: ModeChoice,
    max_wheel_speed: float,
    watchdog: float,
    link_timeout: float,
    stall_timeout: float,
    command_timeout: float,
    decel: float,
    left_channel: int,
    right_channel: int,
    left_encoder_sign: int,
    right_encoder_sign: int,
    left_motor_sign: int,
    right_motor_sign: int,
) -> RunConfig:
    """The validated run configuration of the shared options (refused here, before driving)."""
    from odolab.robot.config import CommandMode, RunConfig

    return RunConfig(
        rate=rate,
        mode=CommandMode(mode.value),
        max_wheel_speed=max_wheel_speed,
        watchdog=watchdog,
        link_timeout=link_timeout,
        stall_timeout=stall_timeout,
        command_timeout=command_timeout,
        decel=decel,
        left_channel=left_channel,
        right_channel=right_channel,
        left_encoder_sign=left_encoder_sign,
        right_encoder_sign=right_encoder_sign,
        left_motor_sign=left_motor_sign,
        right_motor_sign=right_motor_sign,
    )


#: The options every motion command takes after its own, in --help order: (name, type, default).
#: Those named in ``_config`` make the RunConfig; the rest go to ``_run``.
_SHARED_OPTIONS: tuple[tuple[str, Any, Any], ...] = (
    ("robot", RobotOpt, None),
    ("rate", RateOpt, 20.0),
    ("params", NominalParamsOpt, DEFAULT_ROBOT),
    ("mode", ModeOpt, ModeChoice.pwm),
    ("decel", DecelOpt, 0.0),
    ("watchdog", WatchdogOpt, 0.5),
    ("link_timeout", LinkTimeoutOpt, 5.0),
    ("stall_timeout", StallTimeoutOpt, 3.0),
    ("command_timeout", CommandTimeoutOpt, 0.5),
    ("out", OutOpt, None),
    ("db", DbOpt, None),
    ("truth", TruthOpt, DEFAULT_TRUTH),
    ("terrain", TerrainOpt, DEFAULT_TERRAIN),
    ("seed", SeedOpt, DEFAULT_SEED),
    ("left_channel", LeftChOpt, 0),
    ("right_channel", RightChOpt, 1),
    ("left_encoder_sign", LeftSignOpt, 1),
    ("right_encoder_sign", RightSignOpt, 1),
    ("left_motor_sign", LeftMotorOpt, 1),
    ("right_motor_sign", RightMotorOpt, 1),
    ("max_wheel_speed", MaxSpeedOpt, DEFAULT_MAX_WHEEL_SPEED),
    ("quiet", QuietOpt, False),
    ("realtime", RealtimeOpt, True),
    ("foxglove", FoxgloveOpt, False),
    ("foxglove_port", FoxglovePortOpt, _FOXGLOVE_PORT),
)
_CONFIG_KEYS = frozenset(inspect.signature(_config).parameters)


def _motion_command(
    name: str, run_options: tuple[tuple[str, Any, Any], ...] = ()
) -> Callable[[Callable[..., Command]], Callable[..., Command]]:
    """Register ``build`` (its own options -> the Command; its docstring is the help) as
    ``odolab robot NAME`` with the shared options after its own: validated, then driven.
    ``run_options`` (name, type, default): options of this command that go to ``_run`` (after
    the builder's in --help)."""

    def register(build: Callable[..., Command]) -> Callable[..., Command]:
        # the annotations are postponed strings; resolved here, the return type left out (it
        # is imported only for type checking)
        holder = SimpleNamespace(
            __annotations__={k: v for k, v in build.__annotations__.items() if k != "return"}
        )
        hints = get_type_hints(holder, globalns=build.__globals__, include_extras=True)
        own = [
            p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=hints[p.name])
            for p in inspect.signature(build).parameters.values()
        ]
        shared = [
            inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, annotation=a, default=d)
            for n, a, d in (*run_options, *_SHARED_OPTIONS)
        ]

        def command(**options: Any) -> None:
            cmd = build(**{p.name: options.pop(p.name) for p in own})
            config = _config(**{k: options.pop(k) for k in _CONFIG_KEYS})
            _run(cmd, config, **options)

        command.__signature__ = inspect.Signature([*own, *shared])  # type: ignore[attr-defined]
        command.__doc__ = build.__doc__
        command.__name__ = command.__qualname__ = f"{build.__name__}_cmd"
        robot_app.command(name)(command)
        return build

    return register


#: the turn rate of ``robot rotate`` and ``robot pivot``
TurnRateOpt = Annotated[float, typer.Option("--speed", help="Turn rate, rad/s.")]


@_motion_command("rotate")
def rotate(
    turns: Annotated[
        float, typer.Option("--turns", help="Full turns (negative = clockwise).")
    ] = 10.0,
    speed: TurnRateOpt = 0.5,
) -> Command:
    """Rotate in place by TURNS full turns (2*pi each), stopping when odometry says so."""
    from odolab.core.trials import Command, MotionKind

    return Command(MotionKind.ROTATION, angle=2.0 * math.pi * turns, speed=speed)


@_motion_command("drive")
def drive(
    distance: Annotated[
        float, typer.Option("--distance", help="Metres; negative = reverse.")
    ] = 1.0,
    speed: Annotated[float, typer.Option("--speed", help="Speed, m/s.")] = 0.3,
) -> Command:
    """Drive straight DISTANCE m (negative = reverse), stopping when odometry says so."""
    from odolab.core.trials import Command, MotionKind

    return Command(MotionKind.TRANSLATION, distance=distance, speed=speed)


@_motion_command("pivot")
def pivot(
    degrees: Annotated[
        float, typer.Option("--degrees", help="Turn, degrees (ccw positive).")
    ] = 90.0,
    held: Annotated[
        TrackChoice, typer.Option("--held", help="The track that stays still.")
    ] = TrackChoice.left,
    speed: TurnRateOpt = 0.5,
) -> Command:
    """Pivot on one track by DEGREES, stopping when odometry says so."""
    from odolab.core.trials import Command, MotionKind

    return Command(MotionKind.PIVOT, angle=math.radians(degrees), direction=held.value, speed=speed)


@_motion_command("square")
def square(
    side: Annotated[float, typer.Option("--side", help="Side of the square, m.")] = 4.0,
    direction: Annotated[
        DirectionChoice, typer.Option("--direction", help="cw or ccw.")
    ] = DirectionChoice.ccw,
    speed: Annotated[float, typer.Option("--speed", help="Straight speed, m/s.")] = 0.3,
) -> Command:
    """Drive the UMBmark square (four sides, four 90-degree turns in place) by odometry."""
    from odolab.core.trials import Command, MotionKind

    return Command(MotionKind.SQUARE, side=side, direction=direction.value, speed=speed)


def _hold(text: str) -> tuple[float, float]:
    """``--hold LOW,HIGH`` (or one number: both) in seconds; one sentence when it is not."""
    from odolab.robot.errors import RobotConfigError

    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (1, 2):
        raise RobotConfigError(
            f"--hold is {text!r}; expected LOW,HIGH seconds (e.g. 1,3) or one number of seconds"
        )
    return (values[0], values[-1])


GroundTruthOpt = Annotated[
    GroundTruthChoice | None,
    typer.Option(
        "--ground-truth",
        help="Where the run's ground truth comes from: virtual (sim://, recorded as "
        "encoders_gt.csv; the default there); on a real robot, required: mocap, track (a filmed "
        "marker, odolab track) or laser (odolab calibrate sensor --truth-out), attached "
        "afterwards as the output says.",
    ),
]


@_motion_command("explore", run_options=(("ground_truth", GroundTruthOpt, None),))
def explore(
    seconds: Annotated[
        float, typer.Option("--seconds", help="How long to explore, s (at most 600).")
    ] = 60.0,
    max_speed: Annotated[
        float | None,
        typer.Option(
            "--max-speed",
            help="Largest forward speed and track speed, m/s (default 0.5, at most "
            "--max-wheel-speed).",
        ),
    ] = None,
    max_turn_rate: Annotated[
        float | None,
        typer.Option(
            "--max-turn-rate",
            help="Largest turn rate, rad/s (default 1, at most a turn in place at --max-speed).",
        ),
    ] = None,
    hold: Annotated[
        str, typer.Option("--hold", help="Each command is held LOW,HIGH s (uniform between).")
    ] = "1,3",
    fence: Annotated[
        float,
        typer.Option(
            "--fence",
            help="Geofence radius about the start, m, by odometry: the robot turns back near "
            "it and is stopped (exit 1, run kept) beyond it.",
        ),
    ] = 3.0,
    distribution: Annotated[
        DistributionChoice,
        typer.Option(
            "--distribution",
            help="How commands are drawn: uniform over what the robot can do, or edges (three "
            "in four from the outer half of each range).",
        ),
    ] = DistributionChoice.uniform,
    explore_seed: Annotated[
        int, typer.Option("--explore-seed", min=0, help="Seed of the commands drawn (>= 0).")
    ] = 0,
) -> Command:
    """Explore: commands sampled over speed and turn rate, held a few seconds each, inside a
    geofence by odometry; one run kept with its ground truth (a slip model's data)."""
    from odolab.core.trials import Command, Exploration

    spec = Exploration(
        seconds=seconds,
        max_speed=max_speed,
        max_turn_rate=max_turn_rate,
        hold=_hold(hold),
        fence=fence,
        distribution=distribution.value,
        seed=explore_seed,
    )
    return Command.exploration(spec)


BoardHostOpt = Annotated[str, typer.Option("--host", help="Address to listen on.")]
BoardPortOpt = Annotated[
    int,
    typer.Option(
        "--port", min=0, max=65535, help="UDP (TCP for jaguar2014) port (0 = any free one)."
    ),
]
BoardReportRateOpt = Annotated[
    float, typer.Option("--report-rate", help="Sensor packets per second (0.5..1000).")
]
BoardCommandTimeoutOpt = Annotated[
    float,
    typer.Option(
        "--command-timeout",
        help="Motors stop when no valid motor command came for this many s (0.05..5).",
    ),
]
BoardDropOpt = Annotated[float, typer.Option("--drop", help="Probability of dropping a packet.")]
BoardJitterOpt = Annotated[
    float, typer.Option("--jitter", help="Random extra delay up to this many s.")
]
BoardSilentAfterOpt = Annotated[
    float | None,
    typer.Option(
        "--silent-after", help="Fault: send nothing from this many s after the first ACK."
    ),
]
BoardTraceOpt = Annotated[
    Path | None,
    typer.Option(
        "--trace",
        help="Append a line per wheel-speed change: host monotonic time (s), left and "
        "right speed (m/s), why.",
    ),
]
BoardLinkOpt = Annotated[
    LinkChoice,
    typer.Option(
        "--link",
        help="jaguar: the binary board over UDP; jaguar2014: the Jaguar 4x4 of 2014, text "
        "lines over TCP (--command-timeout is then its host-silence timeout, 0 = never).",
    ),
]
BoardVariantOpt = Annotated[
    str, typer.Option("--variant", help="jaguar2014 only: wheel (4x4) or track.")
]
BoardIdleExitOpt = Annotated[
    float | None,
    typer.Option(
        "--idle-exit",
        help="Exit after this many s in which nothing came from a host (default: run until "
        "Ctrl-C); for a board started in the background.",
    ),
]


@robot_app.command("sim-server")
def sim_server_cmd(
    host: BoardHostOpt = "127.0.0.1",
    port: BoardPortOpt = 10001,
    params: NominalParamsOpt = DEFAULT_ROBOT,
    truth: TruthOpt = DEFAULT_TRUTH,
    terrain: TerrainOpt = DEFAULT_TERRAIN,
    seed: SeedOpt = DEFAULT_SEED,
    report_rate: BoardReportRateOpt = 10.0,
    max_wheel_speed: MaxSpeedOpt = DEFAULT_MAX_WHEEL_SPEED,
    command_timeout: BoardCommandTimeoutOpt = 0.5,
    drop: BoardDropOpt = 0.0,
    jitter: BoardJitterOpt = 0.0,
    silent_after: BoardSilentAfterOpt = None,
    trace: BoardTraceOpt = None,
    link: BoardLinkOpt = LinkChoice.jaguar,
    variant: BoardVariantOpt = "wheel",
    idle_exit: BoardIdleExitOpt = None,
) -> None:
    """Run a virtual Jaguar board (UDP, or TCP for --link jaguar2014) until Ctrl-C (or SIGTERM)."""
    import signal

    from odolab.app.robot import BoardRequest, virtual_board

    request = BoardRequest(
        host, port, params, truth, terrain, seed, report_rate, max_wheel_speed, command_timeout,
        drop, jitter, silent_after, link.value, variant, idle_exit,
    )  # fmt: skip
    trace_file = trace.open("a", encoding="utf-8") if trace is not None else None

    def on_speeds(t: float, left: float, right: float, why: str) -> None:
        if trace_file is not None:
            trace_file.write(f"{t:.6f} {left:.6f} {right:.6f} {why.replace(' ', '-')}\n")
            trace_file.flush()

    board = virtual_board(request, on_speeds)
    echo(board.listening, err=True)

    def on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    try:
        _serve(board.server, board.activity, idle_exit)
    except KeyboardInterrupt:
        pass
    finally:
        board.server.close()
        if trace_file is not None:
            trace_file.write(board.counts())
            trace_file.close()
        pose = board.plant.true_pose
        echo(
            f"true pose: x={pose.x:.4f} m y={pose.y:.4f} m heading={pose.heading:.4f} rad", err=True
        )


def _serve(
    server: VirtualJaguarServer | VirtualJaguar2014Server,
    activity: Callable[[], int],
    idle_exit: float | None,
) -> None:
    """``server.serve_forever()``; with ``idle_exit``, served from its thread until nothing has
    come from a host (``activity()``, a count, unchanged) for that many seconds."""
    if idle_exit is None:
        server.serve_forever()
        return
    import time

    server.start()
    seen, since = activity(), time.monotonic()
    while server.error is None:
        time.sleep(0.2)
        now, count = time.monotonic(), activity()
        if count != seen:
            seen, since = count, now
        elif now - since >= idle_exit:
            echo(f"nothing came from a host for {idle_exit:g} s (--idle-exit): exiting", err=True)
            return
    from odolab.core.errors import RobotLinkError

    raise RobotLinkError(f"the virtual board stopped: {server.error!r}") from server.error
