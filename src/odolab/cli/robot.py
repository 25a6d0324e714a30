"""CLI commands: ``odolab robot rotate|drive|pivot|square|explore|sim-server``.

Each motion command drives a robot by odometry (by default a virtual Jaguar started on loopback),
shows the pose and loop health live, and saves the run (encoder log, predicted trajectory, JSON)
so that the measured pose can be entered afterwards. ``explore`` drives commands sampled over the
robot's input space inside a geofence and keeps the run's ground truth
(:mod:`odolab.robot.explore`).
"""

from __future__ import annotations

import contextlib
import inspect
import math
import shlex
from collections.abc import Callable
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Annotated, Any, get_type_hints

import typer

from odolab.cli._apps import robot_app
from odolab.cli._output import echo, term
from odolab.defaults import DEFAULT_TRUTH

if TYPE_CHECKING:
    from odolab.robot.config import RunConfig
    from odolab.robot.explore import ExplorePlan
    from odolab.robot.loop import CycleInfo
    from odolab.robot.session import AbortReport, RobotRun
    from odolab.store import Notebook
    from odolab.trials import Command

__all__: list[str] = []


class ModeChoice(StrEnum):
    pwm = "pwm"
    velocity = "velocity"


class LinkChoice(StrEnum):
    jaguar = "jaguar"
    jaguar2014 = "jaguar2014"


class DirectionChoice(StrEnum):
    cw = "cw"
    ccw = "ccw"


class TrackChoice(StrEnum):
    left = "left"
    right = "right"


class DistributionChoice(StrEnum):
    uniform = "uniform"
    edges = "edges"


class GroundTruthChoice(StrEnum):
    virtual = "virtual"
    mocap = "mocap"
    track = "track"
    laser = "laser"


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
    the terminal; :meth:`flush` waits until every line given so far is out."""

    def __init__(self) -> None:
        import queue
        import threading

        self._lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._work, name="odolab-events", daemon=True).start()

    def put(self, line: str) -> None:
        self._lines.put(line)

    def _work(self) -> None:
        while True:
            line = self._lines.get()
            try:
                echo(line, err=True)
            finally:
                self._lines.task_done()

    def flush(self) -> None:
        self._lines.join()


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
        from odolab.export.foxglove import FoxgloveLive
        from odolab.odometry import Odometry

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


#: The Foxglove server's port when --foxglove-port is not given.
_FOXGLOVE_PORT = 8765


def _check_foxglove(foxglove: bool, port: int) -> None:
    """The port is checked whether or not --foxglove is given, and one given without it (it
    would do nothing) is refused."""
    from odolab.export.foxglove import check_port
    from odolab.extras import require
    from odolab.robot.errors import RobotConfigError

    if foxglove:  # before the run's folder is made
        require("ros", "--foxglove")
    check_port(port)
    if not foxglove and port != _FOXGLOVE_PORT:
        raise RobotConfigError(
            f"--foxglove-port {port} without --foxglove does nothing; expected --foxglove with "
            "it (to serve the run to Foxglove), or neither"
        )


def _check_virtual_options(
    url: str, truth: str, terrain: str, seed: int, config: RunConfig
) -> None:
    """``--truth`` and ``--terrain`` name presets (typos are refused on any link); the virtual
    Jaguar's own options on a real link are refused (:func:`odolab.robot.registry.check_virtual_only`)."""
    from odolab.robot.errors import RobotConfigError
    from odolab.robot.registry import check_virtual_only
    from odolab.sim.presets import TRUTH_PRESETS
    from odolab.sim.terrains import TERRAINS

    if truth not in TRUTH_PRESETS:
        raise RobotConfigError(f"--truth is {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}")
    if terrain not in TERRAINS:
        raise RobotConfigError(f"--terrain is {terrain!r}; expected one of {', '.join(TERRAINS)}")
    given = {"truth": truth, "terrain": terrain, "seed": seed}
    check_virtual_only(url, {**given, "command_timeout": config.command_timeout})


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
    """Validate everything, then drive ``command`` with ``config``; nothing is sent before."""
    from rich.console import Console
    from rich.live import Live

    from odolab.params import load_params
    from odolab.robot.config import check_motion
    from odolab.robot.registry import check_robot_url
    from odolab.robot.session import check_run_folder

    url = check_robot_url(robot)
    _check_virtual_options(url, truth, terrain, seed, config)
    _check_foxglove(foxglove, foxglove_port)
    nominal = load_params(params)
    plan = _explore_plan(command, config, nominal, url, ground_truth, params)
    if plan is not None:
        command = plan.command
    check_motion(command, config, nominal)
    plant = None
    if url.startswith("sim:"):
        from odolab.sim.plants import make_plant

        def plant() -> Any:
            return make_plant(truth, nominal, terrain, seed=seed)

    console = Console(stderr=True)
    target = command.describe()
    events: list[str] = []
    # nothing the control loop calls writes to the terminal: a terminal that stops reading
    # (Ctrl-S, a stalled ssh session) blocked the loop with the motion in force; the live view
    # is drawn by rich's own thread from the latest cycle, and events by a printer thread
    printer = _EventPrinter() if quiet else None

    def on_event(t: float, message: str) -> None:
        events.append(f"t={t:.2f} s: {message}")
        if printer is not None:  # no live view: say it at once, a lost link must not be silent
            printer.put(events[-1])

    live_table = _LiveTable(config.rate, target)
    live = (
        Live(
            console=console,
            refresh_per_second=8,
            transient=False,
            get_renderable=live_table.render,
        )
        if not quiet
        else None
    )

    view: _FoxgloveView | None = None  # started once every check has passed

    def on_cycle(info: CycleInfo) -> None:
        live_table.latest = info  # one assignment: the drawing thread reads it
        if view is not None:
            view.publish(info)

    # every output precondition before the robot moves: the notebook opens and is one (create,
    # migrate), the run folder can be created and written and holds no earlier run
    folder = out if out is not None else _default_folder(command)
    new_folder = not folder.exists()
    check_run_folder(folder)
    notebook = None
    if db is not None:
        from odolab.store import Notebook

        try:
            notebook = Notebook(db)
        except BaseException:
            if new_folder:  # refused before driving: leave no empty run folder behind
                with contextlib.suppress(OSError):
                    folder.rmdir()
            raise
    try:
        view = _FoxgloveView(nominal, foxglove_port) if foxglove else None
        _drive(
            command, config, url=url, nominal=nominal, plant=plant, seed=seed, terrain=terrain,
            on_cycle=on_cycle, on_event=on_event, realtime=realtime, folder=folder,
            notebook=notebook, db=db, quiet=quiet, live=live, view=view, events=events,
            target=target, plan=plan, printer=printer,
        )  # fmt: skip
    finally:
        if notebook is not None:
            notebook.close()


def _explore_plan(
    command: Command,
    config: RunConfig,
    nominal: Any,
    url: str,
    ground_truth: GroundTruthChoice | None,
    params: str,
) -> ExplorePlan | None:
    """The checked plan of an exploration (its choices said), None for another motion."""
    if command.explore is None:
        return None
    from odolab.robot.explore import plan_exploration

    source = ground_truth.value if ground_truth is not None else None
    from odolab.cli.wording import CLI

    plan = plan_exploration(command, config, nominal, url, source, params_name=params, words=CLI)
    echo(plan.describe(), err=True)
    return plan


def _default_folder(command: Command) -> Path:
    """``runs/robot/<UTC time>-<motion>``, with ``-2``, ``-3``... when that is taken."""
    base = (
        Path("runs") / "robot" / (datetime.now(UTC).strftime("%Y%m%dT%H%M%S") + f"-{command.label}")
    )
    folder, n = base, 1
    while folder.exists() or folder.is_symlink():
        n += 1
        folder = base.with_name(f"{base.name}-{n}")
    return folder


def _record(notebook: Notebook | None, db: Path | None, run: RobotRun) -> str:
    """Record ``run`` in the notebook; "" when done (or no notebook), else why not."""
    if notebook is None or db is None:
        return ""
    from odolab.errors import OdolabError
    from odolab.robot.explore import notebook_trial

    trial = notebook_trial(run.trial)  # an exploration: an excluded free run
    try:
        notebook.add_trial(trial)
    except OdolabError as err:
        return f"the run could not be recorded in the notebook {db}: {err}"
    if trial is not run.trial:
        echo(f"recorded in {db} as {trial.trial_id} (excluded: {trial.exclusion_reason})")
    elif run.trial.status.value == "excluded":
        echo(f"recorded in {db} as {run.trial.trial_id} (excluded: the run failed)", err=True)
    else:
        echo(
            f"recorded in {db} as {run.trial.trial_id}; enter the measurement with "
            f"'odolab trials measure {run.trial.trial_id} --db {db}'"
        )
    return ""


def measure_virtual_command(trial_id: str, db: Path | str | None) -> str:
    """The ``odolab trials measure ID --virtual [--db DB]`` line to copy into a shell (quoted)."""
    command = ["odolab", "trials", "measure", trial_id, "--virtual"]
    command += ["--db", str(db)] if db is not None else []
    return " ".join(shlex.quote(part) for part in command)


def _virtual_instruments(run: RobotRun) -> RobotRun:
    """``run`` with what the lab's instruments would show after it (``run.json``
    ``"virtual_instruments"``), when a virtual board gave its true pose; else as it is."""
    import dataclasses

    from odolab.store.measure import describe_readings, virtual_readings

    readings = virtual_readings(run.trial)
    if readings is None:
        return run
    shown = {"readings": readings, "shows": describe_readings(readings)}
    return dataclasses.replace(run, extra={**run.extra, "virtual_instruments": shown})


def _drive(
    command: Command,
    config: RunConfig,
    *,
    url: str,
    nominal: Any,
    plant: Any,
    seed: int,
    terrain: str,
    on_cycle: Callable[[CycleInfo], None],
    on_event: Callable[[float, str], None],
    realtime: bool,
    folder: Path,
    notebook: Notebook | None,
    db: Path | None,
    quiet: bool,
    live: Any,
    view: _FoxgloveView | None,
    events: list[str],
    target: str,
    plan: ExplorePlan | None = None,
    printer: _EventPrinter | None = None,
) -> None:
    """Drive the checked run; keep it (folder, notebook) whatever fails after the robot moved."""
    from odolab.errors import RobotLinkError
    from odolab.robot.errors import RunNotSavedError
    from odolab.robot.session import run_motion

    def on_abort(report: AbortReport) -> None:
        nonlocal live
        if printer is not None:
            printer.flush()
        if live is not None:
            live.stop()
            live = None
        if not quiet:
            for line in events:
                echo(line, err=True)
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

    if live is not None:
        live.start()
    try:
        if plan is not None:
            run = plan.run(
                config=config, robot=url, params=nominal, plant=plant, seed=seed,
                terrain=terrain, on_cycle=on_cycle, on_event=on_event, realtime=realtime,
                save_to=folder, on_abort=on_abort,
            )  # fmt: skip
        else:
            run = run_motion(
                command,
                config=config,
                robot=url,
                params=nominal,
                plant=plant,
                seed=seed,
                terrain=terrain,
                on_cycle=on_cycle,
                on_event=on_event,
                realtime=realtime,
                save_to=folder,
                on_abort=on_abort,
                finish=_virtual_instruments,
            )
    finally:
        if printer is not None:
            printer.flush()
        if live is not None:
            live.stop()
        if view is not None:
            view.close()
    if not quiet:
        for line in events:
            echo(line, err=True)
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
    outcome, crossed = plan.outcome(run) if plan is not None else ([], None)
    if run.saved_to is not None and plan is None:
        echo(f"saved to {run.saved_to} (status: awaiting measurement)")
    for line in outcome:
        echo(line)
    problem = _record(notebook, db, run)
    if problem:
        echo(problem, err=True)
    if not run.stop_confirmed:
        raise RobotLinkError(
            "the run finished and stop was commanded, but the robot's sensor data does not "
            "confirm that it stopped; check the robot"
        )
    echo(_confirm_line(True), err=True)
    if run.saved_to is None:
        raise RunNotSavedError(run.save_note)
    if problem:
        raise RunNotSavedError(f"{problem}; the run is saved to {run.saved_to}")
    if crossed is not None:
        from odolab.robot.errors import FenceCrossedError

        raise FenceCrossedError(crossed)


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
    ("params", ParamsOpt, "jaguar-lite"),
    ("mode", ModeOpt, ModeChoice.pwm),
    ("decel", DecelOpt, 0.0),
    ("watchdog", WatchdogOpt, 0.5),
    ("link_timeout", LinkTimeoutOpt, 5.0),
    ("stall_timeout", StallTimeoutOpt, 3.0),
    ("command_timeout", CommandTimeoutOpt, 0.5),
    ("out", OutOpt, None),
    ("db", DbOpt, None),
    ("truth", TruthOpt, DEFAULT_TRUTH),
    ("terrain", TerrainOpt, "tile"),
    ("seed", SeedOpt, 0),
    ("left_channel", LeftChOpt, 0),
    ("right_channel", RightChOpt, 1),
    ("left_encoder_sign", LeftSignOpt, 1),
    ("right_encoder_sign", RightSignOpt, 1),
    ("left_motor_sign", LeftMotorOpt, 1),
    ("right_motor_sign", RightMotorOpt, 1),
    ("max_wheel_speed", MaxSpeedOpt, 1.0),
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


@_motion_command("rotate")
def rotate(
    turns: Annotated[
        float, typer.Option("--turns", help="Full turns (negative = clockwise).")
    ] = 10.0,
    speed: Annotated[float, typer.Option("--speed", help="Turn rate, rad/s.")] = 0.5,
) -> Command:
    """Rotate in place by TURNS full turns (2*pi each), stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

    return Command(MotionKind.ROTATION, angle=2.0 * math.pi * turns, speed=speed)


@_motion_command("drive")
def drive(
    distance: Annotated[
        float, typer.Option("--distance", help="Metres; negative = reverse.")
    ] = 1.0,
    speed: Annotated[float, typer.Option("--speed", help="Speed, m/s.")] = 0.3,
) -> Command:
    """Drive straight DISTANCE m (negative = reverse), stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

    return Command(MotionKind.TRANSLATION, distance=distance, speed=speed)


@_motion_command("pivot")
def pivot(
    degrees: Annotated[
        float, typer.Option("--degrees", help="Turn, degrees (ccw positive).")
    ] = 90.0,
    held: Annotated[
        TrackChoice, typer.Option("--held", help="The track that stays still.")
    ] = TrackChoice.left,
    speed: Annotated[float, typer.Option("--speed", help="Turn rate, rad/s.")] = 0.5,
) -> Command:
    """Pivot on one track by DEGREES, stopping when odometry says so."""
    from odolab.trials import Command, MotionKind

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
    from odolab.trials import Command, MotionKind

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
    from odolab.trials import Command, Exploration

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


@robot_app.command("sim-server")
def sim_server_cmd(
    host: Annotated[str, typer.Option("--host", help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[
        int,
        typer.Option(
            "--port", min=0, max=65535, help="UDP (TCP for jaguar2014) port (0 = any free one)."
        ),
    ] = 10001,
    params: ParamsOpt = "jaguar-lite",
    truth: TruthOpt = "jaguar-lab",
    terrain: TerrainOpt = "tile",
    seed: SeedOpt = 0,
    report_rate: Annotated[
        float, typer.Option("--report-rate", help="Sensor packets per second (0.5..1000).")
    ] = 10.0,
    max_wheel_speed: MaxSpeedOpt = 1.0,
    command_timeout: Annotated[
        float,
        typer.Option(
            "--command-timeout",
            help="Motors stop when no valid motor command came for this many s (0.05..5).",
        ),
    ] = 0.5,
    drop: Annotated[float, typer.Option("--drop", help="Probability of dropping a packet.")] = 0.0,
    jitter: Annotated[
        float, typer.Option("--jitter", help="Random extra delay up to this many s.")
    ] = 0.0,
    silent_after: Annotated[
        float | None,
        typer.Option(
            "--silent-after", help="Fault: send nothing from this many s after the first ACK."
        ),
    ] = None,
    trace: Annotated[
        Path | None,
        typer.Option(
            "--trace",
            help="Append a line per wheel-speed change: host monotonic time (s), left and "
            "right speed (m/s), why.",
        ),
    ] = None,
    link: Annotated[
        LinkChoice,
        typer.Option(
            "--link",
            help="jaguar: the binary board over UDP; jaguar2014: the Jaguar 4x4 of 2014, text "
            "lines over TCP (--command-timeout is then its host-silence timeout, 0 = never).",
        ),
    ] = LinkChoice.jaguar,
    variant: Annotated[
        str, typer.Option("--variant", help="jaguar2014 only: wheel (4x4) or track.")
    ] = "wheel",
    idle_exit: Annotated[
        float | None,
        typer.Option(
            "--idle-exit",
            help="Exit after this many s in which nothing came from a host (default: run until "
            "Ctrl-C); for a board started in the background.",
        ),
    ] = None,
) -> None:
    """Run a virtual Jaguar board (UDP, or TCP for --link jaguar2014) until Ctrl-C (or SIGTERM)."""
    import signal

    if idle_exit is not None and not (math.isfinite(idle_exit) and 1 <= idle_exit <= 3600):
        from odolab.robot.errors import RobotConfigError

        raise RobotConfigError(f"--idle-exit is {idle_exit!r}; expected 1 to 3600 s")
    if link is LinkChoice.jaguar2014:
        _serve_2014(
            host, port, params, truth, terrain, seed, report_rate, max_wheel_speed,
            command_timeout, trace, variant, silent_after, idle_exit,
        )  # fmt: skip
        return

    from odolab.params import load_params
    from odolab.robot.jaguar.board import (
        BoardConfig,
        Faults,
        VirtualJaguar,
        VirtualJaguarServer,
    )
    from odolab.sim.plants import make_plant

    nominal = load_params(params)
    board = BoardConfig.from_params(
        nominal,
        report_rate=report_rate,
        max_wheel_speed=max_wheel_speed,
        command_timeout=command_timeout,
    )
    faults = Faults(drop=drop, jitter=jitter, silent_after=silent_after)
    plant = make_plant(truth, nominal, terrain, seed=seed)
    trace_file = trace.open("a", encoding="utf-8") if trace is not None else None

    def on_speeds(t: float, left: float, right: float, why: str) -> None:
        if trace_file is not None:
            trace_file.write(f"{t:.6f} {left:.6f} {right:.6f} {why.replace(' ', '-')}\n")
            trace_file.flush()

    jaguar = VirtualJaguar(plant, board, faults=faults, seed=seed, on_speeds=on_speeds)
    server = VirtualJaguarServer(jaguar, host, port)
    h, p = server.address
    echo(f"virtual Jaguar ({truth}) listening on udp://{h}:{p}; Ctrl-C to stop", err=True)

    def on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    try:
        _serve(server, lambda: server.call(lambda b: b.stats.received), idle_exit)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        if trace_file is not None:
            st = jaguar.stats
            trace_file.write(
                f"# received {st.received} commands {st.commands} ignored {st.ignored_commands} "
                f"rejected_acks {st.rejected_acks} takeovers {st.takeovers} "
                f"command_timeouts {st.command_timeouts}\n"
            )
            trace_file.close()
        pose = plant.true_pose
        echo(
            f"true pose: x={pose.x:.4f} m y={pose.y:.4f} m heading={pose.heading:.4f} rad", err=True
        )


def _serve(server: Any, activity: Callable[[], int], idle_exit: float | None) -> None:
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
    from odolab.errors import RobotLinkError

    raise RobotLinkError(f"the virtual board stopped: {server.error!r}") from server.error


def _serve_2014(
    host: str,
    port: int,
    params: str,
    truth: str,
    terrain: str,
    seed: int,
    report_rate: float,
    max_wheel_speed: float,
    silence_timeout: float,
    trace: Path | None,
    variant: str,
    silent_after: float | None = None,
    idle_exit: float | None = None,
) -> None:
    """The virtual Jaguar 4x4 of 2014 over TCP until Ctrl-C or SIGTERM."""
    import signal

    from odolab.params import load_params
    from odolab.robot.jaguar2014.board import (
        Board2014Config,
        VirtualJaguar2014,
        VirtualJaguar2014Server,
    )
    from odolab.sim.plants import make_plant

    nominal = load_params(params)
    config = Board2014Config.from_params(
        nominal,
        report_rate=report_rate,
        max_wheel_speed=max_wheel_speed,
        silence_timeout=silence_timeout,
        variant=variant,
        silent_after=silent_after,
    )
    plant = make_plant(truth, nominal, terrain, seed=seed)
    trace_file = trace.open("a", encoding="utf-8") if trace is not None else None

    def on_speeds(t: float, left: float, right: float, why: str) -> None:
        if trace_file is not None:
            trace_file.write(f"{t:.6f} {left:.6f} {right:.6f} {why.replace(' ', '-')}\n")
            trace_file.flush()

    board = VirtualJaguar2014(plant, config, on_speeds=on_speeds)
    server = VirtualJaguar2014Server(board, host, port)
    h, p = server.address
    echo(
        f"virtual Jaguar 4x4 2014 ({truth}, {variant}) listening on tcp://{h}:{p}; Ctrl-C to stop",
        err=True,
    )

    def on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    try:
        _serve(server, lambda: server.call(lambda b: b.stats.lines), idle_exit)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        st = board.stats
        if trace_file is not None:
            trace_file.write(
                f"# lines {st.lines} pings {st.pings} commands {st.commands} rejected "
                f"{st.rejected} silence_stops {st.silence_stops} disconnect_stops "
                f"{st.disconnect_stops} refused_peers {st.refused_peers}\n"
            )
            trace_file.close()
        pose = plant.true_pose
        echo(
            f"true pose: x={pose.x:.4f} m y={pose.y:.4f} m heading={pose.heading:.4f} rad", err=True
        )
