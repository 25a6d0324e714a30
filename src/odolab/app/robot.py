"""Driving a robot by odometry: ``odolab robot rotate|drive|pivot|square|explore`` plan a run
(:func:`plan_run`: every check before anything is sent), drive it (:func:`drive_run`) and keep
it (:func:`keep_in_notebook`, :func:`check_kept`); ``odolab robot sim-server`` serves a virtual
board (:func:`virtual_board`).

The rules live here once: which options a link accepts (the virtual Jaguar's own are refused on
a real one), the run folder's default name, how a run is recorded in the notebook (an
exploration as an excluded free run, a failed run as excluded, else awaiting measurement), and
which failure after driving the command ends with.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.core.defaults import (
    DEFAULT_MAX_WHEEL_SPEED,
    DEFAULT_ROBOT,
    DEFAULT_SEED,
    DEFAULT_TERRAIN,
    DEFAULT_TRUTH,
)
from odolab.core.errors import NEUTRAL, Wording, opt

if TYPE_CHECKING:
    from odolab.core.params import RobotParams
    from odolab.core.trials import Command
    from odolab.robot.config import RunConfig
    from odolab.robot.explore import ExplorePlan
    from odolab.robot.jaguar.board import VirtualJaguarServer
    from odolab.robot.jaguar2014.board import VirtualJaguar2014Server
    from odolab.robot.loop import CycleInfo
    from odolab.robot.session import AbortReport, RobotRun
    from odolab.sim.physics import VirtualRobot
    from odolab.store import Notebook

__all__ = [
    "FOXGLOVE_PORT",
    "BoardRequest",
    "KeptRun",
    "RobotPlan",
    "RobotRequest",
    "check_kept",
    "default_folder",
    "drive_run",
    "keep_in_notebook",
    "open_outputs",
    "plan_run",
    "virtual_board",
]

#: The Foxglove server's port when --foxglove-port is not given.
FOXGLOVE_PORT = 8765


@dataclass(frozen=True)
class RobotRequest:
    """A motion command and the options of the run (``robot`` None: the virtual Jaguar)."""

    command: Command
    config: RunConfig
    robot: str | None
    params: str
    truth: str
    terrain: str
    seed: int
    foxglove: bool = False
    foxglove_port: int = FOXGLOVE_PORT
    ground_truth: str | None = None  #: an exploration's ground-truth source
    #: how the run's written record names the settings (the face's words)
    words: Wording = NEUTRAL


@dataclass(frozen=True)
class RobotPlan:
    """A checked run: nothing has been sent yet."""

    command: Command
    config: RunConfig
    url: str
    nominal: RobotParams
    seed: int
    terrain: str
    plant: Callable[[], VirtualRobot] | None = None  #: the virtual Jaguar's plant (sim://)
    explore: ExplorePlan | None = None


def _check_foxglove(foxglove: bool, port: int) -> None:
    """The port is checked whether or not --foxglove is given, and one given without it (it
    would do nothing) is refused."""
    from odolab.core.extras import require
    from odolab.export.foxglove import check_port
    from odolab.robot.errors import RobotConfigError

    if foxglove:  # before the run's folder is made
        require("ros", opt("foxglove"))
    check_port(port)
    if not foxglove and port != FOXGLOVE_PORT:
        raise RobotConfigError(
            f"{opt('foxglove_port')} {port} without {opt('foxglove')} does nothing; expected {opt('foxglove')} with "
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
        raise RobotConfigError(
            f"{opt('truth')} is {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
        )
    if terrain not in TERRAINS:
        raise RobotConfigError(
            f"{opt('terrain')} is {terrain!r}; expected one of {', '.join(TERRAINS)}"
        )
    given = {"truth": truth, "terrain": terrain, "seed": seed}
    check_virtual_only(url, {**given, "command_timeout": config.command_timeout})


def plan_run(req: RobotRequest, say: Callable[[str], None]) -> RobotPlan:
    """Check everything about the run before anything is sent: the link, the options it
    accepts, Foxglove, the parameters, an exploration's plan (``say`` hears its choices) and
    the motion against the configuration.

    Raises:
        RobotConfigError: an option the link or the motion does not accept.
        ParamsError: parameters that cannot be read.
    """
    from odolab.core.params import load_params
    from odolab.robot.config import check_motion
    from odolab.robot.registry import check_robot_url

    url = check_robot_url(req.robot)
    _check_virtual_options(url, req.truth, req.terrain, req.seed, req.config)
    _check_foxglove(req.foxglove, req.foxglove_port)
    nominal = load_params(req.params)
    command, plan = req.command, None
    if command.explore is not None:
        from odolab.robot.explore import plan_exploration

        plan = plan_exploration(
            command, req.config, nominal, url, req.ground_truth, params_name=req.params,
            words=req.words,
        )  # fmt: skip
        say(plan.describe())
        command = plan.command
    check_motion(command, req.config, nominal)
    plant = None
    if url.startswith("sim:"):
        from odolab.sim.plants import make_plant

        truth, terrain, seed = req.truth, req.terrain, req.seed

        def plant() -> VirtualRobot:
            return make_plant(truth, nominal, terrain, seed=seed)

    return RobotPlan(command, req.config, url, nominal, req.seed, req.terrain, plant, plan)


def default_folder(command: Command) -> Path:
    """``runs/robot/<UTC time>-<motion>``, with ``-2``, ``-3``... when that is taken."""
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S")
    base = Path("runs") / "robot" / f"{stamp}-{command.label}"
    folder, n = base, 1
    while folder.exists() or folder.is_symlink():
        n += 1
        folder = base.with_name(f"{base.name}-{n}")
    return folder


def open_outputs(folder: Path, db: Path | None) -> Notebook | None:
    """Every output precondition before the robot moves: the run folder can be created and
    written and holds no earlier run, the notebook opens and is one (create, migrate); a
    notebook refused leaves no empty run folder behind. The caller closes the notebook.

    Raises:
        RobotConfigError: a run folder that cannot be used.
        StoreError: a notebook that cannot be opened.
    """
    from odolab.robot.session import check_run_folder

    new_folder = not folder.exists()
    check_run_folder(folder)
    if db is None:
        return None
    from odolab.store import Notebook

    try:
        return Notebook(db)
    except BaseException:
        if new_folder:  # refused before driving: leave no empty run folder behind
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise


def _virtual_instruments(run: RobotRun) -> RobotRun:
    """``run`` with what the lab's instruments would show after it (``run.json``
    ``"virtual_instruments"``), when a virtual board gave its true pose; else as it is."""
    from odolab.store.measure import describe_readings, virtual_readings

    readings = virtual_readings(run.trial)
    if readings is None:
        return run
    shown = {"readings": readings, "shows": describe_readings(readings)}
    return replace(run, extra={**run.extra, "virtual_instruments": shown})


def drive_run(
    plan: RobotPlan,
    *,
    folder: Path,
    on_cycle: Callable[[CycleInfo], None],
    on_event: Callable[[float, str], None],
    on_abort: Callable[[AbortReport], object],
    realtime: bool,
) -> RobotRun:
    """Drive the checked run and save it to ``folder`` (whatever fails after the robot moved,
    ``on_abort`` hears where the partial run went)."""
    from odolab.robot.session import run_motion

    common: dict[str, Any] = {
        "config": plan.config, "robot": plan.url, "params": plan.nominal, "plant": plan.plant,
        "seed": plan.seed, "terrain": plan.terrain, "on_cycle": on_cycle, "on_event": on_event,
        "realtime": realtime, "save_to": folder, "on_abort": on_abort,
    }  # fmt: skip
    if plan.explore is not None:
        return plan.explore.run(**common)
    return run_motion(plan.command, **common, finish=_virtual_instruments)


@dataclass(frozen=True)
class KeptRun:
    """How a run went into the notebook: what to say (``line``, on stderr when ``err``), or
    why it could not (``problem``)."""

    line: str = ""
    err: bool = False
    problem: str = ""


def keep_in_notebook(notebook: Notebook | None, db: Path | None, run: RobotRun) -> KeptRun:
    """Record ``run`` in the notebook: an exploration as an excluded free run, a failed run as
    excluded, else awaiting its measurement."""
    if notebook is None or db is None:
        return KeptRun()
    from odolab.core.errors import OdolabError
    from odolab.robot.explore import notebook_trial

    trial = notebook_trial(run.trial)  # an exploration: an excluded free run
    try:
        notebook.add_trial(trial)
    except OdolabError as err:
        return KeptRun(problem=f"the run could not be recorded in the notebook {db}: {err}")
    if trial is not run.trial:
        return KeptRun(f"recorded in {db} as {trial.trial_id} (excluded: {trial.exclusion_reason})")
    if run.trial.status.value == "excluded":
        return KeptRun(f"recorded in {db} as {run.trial.trial_id} (excluded: the run failed)", True)
    return KeptRun(
        f"recorded in {db} as {run.trial.trial_id}; enter the measurement with "
        f"'odolab trials measure {run.trial.trial_id} {opt('db')} {db}'"
    )


def check_kept(run: RobotRun, problem: str, crossed: str | None) -> None:
    """The failure a finished run ends with, if any: the stop not confirmed, the run not saved
    or not recorded, the fence crossed.

    Raises:
        RobotLinkError: the robot's data does not confirm that it stopped.
        RunNotSavedError: the run could not be saved, or not recorded in the notebook.
        FenceCrossedError: an exploration went beyond its fence.
    """
    from odolab.core.errors import RobotLinkError
    from odolab.robot.errors import FenceCrossedError, RunNotSavedError

    if not run.stop_confirmed:
        raise RobotLinkError(
            "the run finished and stop was commanded, but the robot's sensor data does not "
            "confirm that it stopped; check the robot"
        )
    if run.saved_to is None:
        raise RunNotSavedError(run.save_note)
    if problem:
        raise RunNotSavedError(f"{problem}; the run is saved to {run.saved_to}")
    if crossed is not None:
        raise FenceCrossedError(crossed)


# -- sim-server -----------------------------------------------------------------------------


@dataclass(frozen=True)
class BoardRequest:
    """What ``odolab robot sim-server`` was asked: the board, its plant, its faults."""

    host: str = "127.0.0.1"
    port: int = 10001
    params: str = DEFAULT_ROBOT
    truth: str = DEFAULT_TRUTH
    terrain: str = DEFAULT_TERRAIN
    seed: int = DEFAULT_SEED
    report_rate: float = 10.0
    max_wheel_speed: float = DEFAULT_MAX_WHEEL_SPEED
    command_timeout: float = 0.5
    drop: float = 0.0
    jitter: float = 0.0
    silent_after: float | None = None
    link: str = "jaguar"
    variant: str = "wheel"
    idle_exit: float | None = None


@dataclass
class VirtualBoard:
    """A virtual board serving on its address: the server, the board, its plant, what it says
    when it starts, and its counts (the trace's last line when it stops)."""

    server: VirtualJaguarServer | VirtualJaguar2014Server
    board: Any
    plant: VirtualRobot
    listening: str
    #: the board's count of what came from a host (unchanged: nothing came)
    activity_count: str
    #: (label, stats attribute) of the trace's last line
    trace_counts: tuple[tuple[str, str], ...]

    def activity(self) -> int:
        """How much has come from a host so far (read in the server's thread)."""
        return int(self.server.call(lambda b: getattr(b.stats, self.activity_count)))

    def counts(self) -> str:
        """The trace's last line: the board's counts, and the most its thread woke late (ms;
        :attr:`odolab.robot.virtual_board.BoardServer.late_max`)."""
        st = self.board.stats
        counts = " ".join(f"{k} {getattr(st, a)}" for k, a in self.trace_counts)
        return f"# {counts} late_ms {round(self.server.late_max * 1000)}\n"


_UDP_COUNTS = (
    ("received", "received"), ("commands", "commands"), ("ignored", "ignored_commands"),
    ("rejected_acks", "rejected_acks"), ("takeovers", "takeovers"),
    ("command_timeouts", "command_timeouts"),
)  # fmt: skip
_TCP_COUNTS = tuple(
    (name, name)
    for name in ("lines", "pings", "commands", "rejected", "silence_stops", "disconnect_stops",
                 "refused_peers")
)  # fmt: skip


def virtual_board(
    req: BoardRequest, on_speeds: Callable[[float, float, float, str], None]
) -> VirtualBoard:
    """The virtual Jaguar board (UDP) or Jaguar 4x4 of 2014 (TCP, ``req.link == "jaguar2014"``)
    bound to its address; ``on_speeds(t, left, right, why)`` hears each wheel-speed change.

    Raises:
        RobotConfigError: an option out of its range (--idle-exit, the board's own).
    """
    from odolab.core.params import load_params
    from odolab.sim.plants import make_plant

    if req.idle_exit is not None and not (
        math.isfinite(req.idle_exit) and 1 <= req.idle_exit <= 3600
    ):
        from odolab.robot.errors import RobotConfigError

        raise RobotConfigError(f"{opt('idle_exit')} is {req.idle_exit!r}; expected 1 to 3600 s")
    nominal = load_params(req.params)
    if req.link == "jaguar2014":
        return _board_2014(req, nominal, on_speeds)
    from odolab.robot.jaguar.board import BoardConfig, Faults, VirtualJaguar, VirtualJaguarServer

    board = BoardConfig.from_params(
        nominal,
        report_rate=req.report_rate,
        max_wheel_speed=req.max_wheel_speed,
        command_timeout=req.command_timeout,
    )
    faults = Faults(drop=req.drop, jitter=req.jitter, silent_after=req.silent_after)
    plant = make_plant(req.truth, nominal, req.terrain, seed=req.seed, compiled=False)  # real time
    jaguar = VirtualJaguar(plant, board, faults=faults, seed=req.seed, on_speeds=on_speeds)
    server = VirtualJaguarServer(jaguar, req.host, req.port)
    h, p = server.address
    listening = f"virtual Jaguar ({req.truth}) listening on udp://{h}:{p}; Ctrl-C to stop"
    return VirtualBoard(server, jaguar, plant, listening, "received", _UDP_COUNTS)


def _board_2014(
    req: BoardRequest,
    nominal: RobotParams,
    on_speeds: Callable[[float, float, float, str], None],
) -> VirtualBoard:
    """The virtual Jaguar 4x4 of 2014 over TCP (its --command-timeout: the host-silence one)."""
    from odolab.robot.jaguar2014.board import (
        Board2014Config,
        VirtualJaguar2014,
        VirtualJaguar2014Server,
    )
    from odolab.sim.plants import make_plant

    config = Board2014Config.from_params(
        nominal,
        report_rate=req.report_rate,
        max_wheel_speed=req.max_wheel_speed,
        silence_timeout=req.command_timeout,
        variant=req.variant,
        silent_after=req.silent_after,
    )
    plant = make_plant(req.truth, nominal, req.terrain, seed=req.seed, compiled=False)  # real time
    board = VirtualJaguar2014(plant, config, on_speeds=on_speeds)
    server = VirtualJaguar2014Server(board, req.host, req.port)
    h, p = server.address
    listening = (
        f"virtual Jaguar 4x4 2014 ({req.truth}, {req.variant}) listening on tcp://{h}:{p}; "
        "Ctrl-C to stop"
    )
    return VirtualBoard(server, board, plant, listening, "lines", _TCP_COUNTS)
