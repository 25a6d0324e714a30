"""One robot run end to end: connect, drive a command by odometry, return a trial; save it.

:func:`run_motion` drives a robot over UDP (by default a virtual Jaguar started on loopback);
:func:`run_motion_simulated` drives the same driver and loop in simulated time, in-process,
so a 20*pi rotation takes a fraction of its real duration.
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from odolab.errors import OdolabError
from odolab.odometry import Odometry
from odolab.params import PRESETS, RobotParams
from odolab.robot.clock import Clock, RealClock, SimClock, set_realtime
from odolab.robot.driver import DriverConfig, JaguarDriver, Transport, UdpTransport, parse_robot_url
from odolab.robot.loop import ControlLoop, CycleInfo, LoopResult, LoopStats
from odolab.robot.motions import Motion, motion_from_command
from odolab.robot.plant import Plant, make_plant
from odolab.robot.server import (
    BoardConfig,
    Faults,
    InProcessLink,
    VirtualJaguar,
    VirtualJaguarServer,
)
from odolab.trajectory import Pose
from odolab.trials import Command, Trial, TrialStatus

__all__ = [
    "RobotRun",
    "driver_config_for",
    "run_motion",
    "run_motion_simulated",
    "save_run",
]


@dataclass(frozen=True, eq=False)
class RobotRun:
    """A finished run: the trial (AWAITING its measurement), the loop's log and statistics."""

    trial: Trial
    loop: LoopResult
    robot: str  #: "udp://HOST:PORT", "virtual (udp://...)" or "simulated"

    @property
    def stats(self) -> LoopStats:
        return self.loop.stats


def driver_config_for(params: RobotParams, **changes: Any) -> DriverConfig:
    """Driver settings whose velocity unit and counter modulus follow ``params``."""
    base: dict[str, Any] = {
        "left_metres_per_tick": params.left_metres_per_tick,
        "right_metres_per_tick": params.right_metres_per_tick,
        "modulus": min(params.encoder_modulus or 65536, 65536),
    }
    base.update(changes)
    return DriverConfig(**base)


def _trial(
    command: Command,
    result: LoopResult,
    params: RobotParams,
    terrain: str,
    true_pose: Pose | None,
    campaign: str,
) -> Trial:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S%fZ")
    if result.aborted:
        status = f"run {result.aborted}; the motion did not finish"
    elif not result.completed:
        status = "motion stopped before its target (max duration)"
    else:
        status = ""
    return Trial(
        trial_id=f"robot-{command.kind.value}-{stamp}",
        campaign=campaign,
        terrain=terrain,
        command=command,
        predicted=result.final,
        params=params,
        true=true_pose,
        encoder_log=result.log.encoder_log(params.encoder_modulus),
        status=TrialStatus.AWAITING,
        notes=status,
    )


def _drive(
    transport: Transport,
    clock: Clock,
    command: Command,
    motion: Motion | None,
    params: RobotParams,
    config: DriverConfig,
    rate: float,
    watchdog_timeout: float,
    settle: float,
    max_duration: float | None,
    on_cycle: Callable[[CycleInfo], None] | None,
    on_event: Callable[[float, str], None] | None,
    realtime: bool = False,
    on_abort: Callable[[LoopResult], object] | None = None,
) -> LoopResult:
    driver = JaguarDriver(transport, clock, config)
    rt = realtime and set_realtime(True)
    loop: ControlLoop | None = None
    try:
        loop = ControlLoop(
            driver,
            Odometry(params),
            clock,
            rate=rate,
            watchdog_timeout=watchdog_timeout,
            on_cycle=on_cycle,
            on_event=on_event,
        )
        return loop.run(
            motion or motion_from_command(command), settle=settle, max_duration=max_duration
        )
    except BaseException:
        if loop is not None and loop.partial is not None and on_abort is not None:
            # keep what was recorded before the failure; a failure to save must not hide it
            with contextlib.suppress(OSError, OdolabError):
                on_abort(loop.partial)
        raise
    finally:
        driver.close()
        if rt:
            set_realtime(False)


def run_motion(
    command: Command,
    *,
    robot: str | None = None,
    params: RobotParams | None = None,
    rate: float = 20.0,
    motion: Motion | None = None,
    driver_config: DriverConfig | None = None,
    watchdog_timeout: float = 0.5,
    settle: float = 0.5,
    max_duration: float | None = None,
    truth: Any = "jaguar-lab",
    terrain: str = "tile",
    seed: int = 0,
    board: BoardConfig | None = None,
    faults: Faults | None = None,
    campaign: str = "robot",
    clock: Clock | None = None,
    on_cycle: Callable[[CycleInfo], None] | None = None,
    on_event: Callable[[float, str], None] | None = None,
    realtime: bool = False,
    save_to: str | Path | None = None,
) -> RobotRun:
    """Drive ``command`` by odometry over UDP in real time; return the run.

    ``robot``: "udp://HOST:PORT" of a board; None starts a virtual Jaguar on 127.0.0.1 (an
    OS-assigned port) whose plant is ``truth`` on ``terrain`` (see
    :func:`odolab.robot.plant.make_plant`), and the trial then carries the true pose.
    ``realtime``: run the loop thread in SCHED_FIFO where the OS allows it. ``save_to``: save the
    run there (:func:`save_run`), also when it fails part way (Ctrl-C, lost link, stall): what
    was recorded up to the failure is kept.
    """
    params = params or PRESETS["jaguar-lite"]
    config = driver_config or driver_config_for(params)
    clock = clock or RealClock()

    def finish(result: LoopResult, url: str, true_pose: Pose | None) -> RobotRun:
        run = RobotRun(_trial(command, result, params, terrain, true_pose, campaign), result, url)
        if save_to is not None:
            save_run(run, save_to)
        return run

    if robot is not None:
        host, port = parse_robot_url(robot)
        result = _drive(
            UdpTransport(host, port), clock, command, motion, params, config, rate,
            watchdog_timeout, settle, max_duration, on_cycle, on_event, realtime,
            lambda partial: finish(partial, robot, None),
        )  # fmt: skip
        return finish(result, robot, None)
    plant = make_plant(truth, params, terrain, seed=seed)
    jaguar = VirtualJaguar(
        plant, board or BoardConfig.from_params(params), faults=faults, seed=seed
    )
    with VirtualJaguarServer(jaguar) as server:
        host, port = server.address
        url = f"virtual (udp://{host}:{port})"

        def abort(partial: LoopResult) -> None:
            time.sleep(0.05)  # let the board take the stop before reading the truth
            finish(partial, url, server.call(lambda b: b.plant.true_pose))

        result = _drive(
            UdpTransport(host, port), clock, command, motion, params, config, rate,
            watchdog_timeout, settle, max_duration, on_cycle, on_event, realtime, abort,
        )  # fmt: skip
        time.sleep(0.05)  # let the board take the final stop before reading the truth
        true_pose = server.call(lambda b: b.plant.true_pose)
    return finish(result, url, true_pose)


def run_motion_simulated(
    motion: Command | Motion,
    truth: Any = "jaguar-lab",
    nominal: RobotParams | None = None,
    terrain: str = "tile",
    seed: int = 0,
    rate: float = 20.0,
    *,
    command: Command | None = None,
    plant: Plant | None = None,
    driver_config: DriverConfig | None = None,
    board: BoardConfig | None = None,
    faults: Faults | None = None,
    watchdog_timeout: float = 0.5,
    settle: float = 0.5,
    max_duration: float | None = 3600.0,
    campaign: str = "sim",
    on_cycle: Callable[[CycleInfo], None] | None = None,
) -> tuple[Trial, LoopStats]:
    """Drive a command (or a motion) through the same driver and loop, in simulated time.

    The virtual Jaguar board (over ``plant``, or ``make_plant(truth, nominal, terrain, seed)``)
    is wired to the driver in-process; a :class:`SimClock` jumps from deadline to deadline.
    Returns the trial (predicted pose from the loop, true pose from the plant) and the loop
    statistics (whose timing errors are zero: simulated time is exact).
    """
    nominal = nominal or PRESETS["jaguar-lite"]
    if isinstance(motion, Command):
        command = motion
        mot: Motion = motion_from_command(command)
    else:
        mot = motion
        if command is None:
            from odolab.trials import MotionKind

            command = Command(MotionKind.FREE)
    plant = plant or make_plant(truth, nominal, terrain, seed=seed)
    jaguar = VirtualJaguar(
        plant, board or BoardConfig.from_params(nominal), faults=faults, seed=seed
    )
    clock = SimClock(plant.time)
    link = InProcessLink(jaguar, clock.now)
    config = driver_config or driver_config_for(nominal)
    result = _drive(
        link, clock, command, mot, nominal, config, rate, watchdog_timeout, settle, max_duration,
        on_cycle, None,
    )  # fmt: skip
    trial = _trial(command, result, nominal, terrain, plant.true_pose, campaign)
    return trial, result.stats


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def save_run(run: RobotRun, folder: str | Path) -> Path:
    """Write ``encoders.csv``, ``predicted.csv`` (one pose per cycle) and ``run.json``."""
    from odolab.io import write_encoder_csv, write_trajectory_csv

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    trial = run.trial
    assert trial.encoder_log is not None
    write_encoder_csv(trial.encoder_log, out / "encoders.csv")
    write_trajectory_csv(run.loop.log.trajectory(), out / "predicted.csv")
    cmd = {k: _jsonable(v) for k, v in asdict(trial.command).items() if v is not None}
    cmd["kind"] = trial.command.kind.value
    doc = {
        "trial_id": trial.trial_id,
        "campaign": trial.campaign,
        "terrain": trial.terrain,
        "robot": run.robot,
        "command": cmd,
        "describe": trial.command.describe(),
        "params": trial.params.to_dict(),
        "completed": run.loop.completed,
        "aborted": run.loop.aborted or None,
        "predicted": trial.predicted._asdict(),
        "true": trial.true._asdict() if trial.true is not None else None,
        "status": trial.status.value,
        "stats": {k: _jsonable(v) for k, v in asdict(run.stats).items()},
        "events": [list(e) for e in run.loop.events],
        "measured": None,
    }
    (out / "run.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return out
