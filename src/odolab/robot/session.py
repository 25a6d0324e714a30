"""One robot run end to end: connect, drive a command by odometry, return a trial; save it.

:func:`run_motion` drives the robot the ``--robot`` URL names (:mod:`odolab.robot.registry`;
by default a virtual Jaguar started on loopback) in real time; :func:`run_motion_simulated`
drives the same driver and loop in simulated time, in-process, so a 20*pi rotation takes a
fraction of its real duration. Both take one validated :class:`RunConfig`; the motion is checked
(:func:`check_motion`) before anything is sent. After every run, finished or not, the driver
commands stop until the robot's own sensor data confirms it (:attr:`RobotRun.stop_confirmed`).

Runs are never lost and never overwrite one another: :func:`check_run_folder` refuses, before
the robot moves, a folder that cannot take the run (not a folder, not writable, or holding a
run's file already); :func:`keep_run` saves a run that has driven where asked or, when that
fails after all, to a new sibling folder or to the rescue folder (:func:`rescue_folder`), and
says where. A run that failed part way is saved too, its trial EXCLUDED with the reason.

A run may carry more than its log: ``finish`` (of :func:`run_motion` and :func:`run_simulated`)
turns the run into the one that is saved, before it is saved, e.g. with the virtual robot's true
path (:attr:`RobotRun.truth`, written as ``encoders_gt.csv`` beside ``encoders.csv``, where
``odolab calibrate lsq -f csv`` looks for ground truth) and keys of its own in ``run.json``
(:attr:`RobotRun.extra`); :mod:`odolab.robot.explore` does both.
"""

from __future__ import annotations

import bisect
import contextlib
import functools
import inspect
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, ParamSpec

from odolab.core.defaults import DEFAULT_SEED, DEFAULT_TERRAIN
from odolab.core.errors import OdolabError, opt
from odolab.core.params import PRESETS, RobotParams
from odolab.core.trajectory import Pose, Trajectory
from odolab.core.trials import Command, MotionKind, Trial, TrialStatus
from odolab.core.writing import strict_json, write_text_file
from odolab.robot.clock import Clock, RealClock, SimClock, set_realtime
from odolab.robot.config import RunConfig, check_motion
from odolab.robot.errors import RobotConfigError, RunFolderError
from odolab.robot.interface import Driver, RobotLink, VirtualSpec
from odolab.robot.loop import ControlLoop, CycleInfo, LoopResult, LoopStats
from odolab.robot.motions import Motion, motion_from_command, odometry_for
from odolab.robot.plant import IdealPlant, Plant, PlantFactory
from odolab.robot.registry import open_in_process, open_link

__all__ = [
    "OPTIONAL_RUN_FILES",
    "RUN_FILES",
    "TRUTH_FILE",
    "AbortReport",
    "RobotRun",
    "check_run_folder",
    "keep_run",
    "rescue_folder",
    "run_motion",
    "run_motion_simulated",
    "run_simulated",
    "save_run",
]

#: The files a run folder gets, in the order they are written (run.json last).
RUN_FILES = ("encoders.csv", "predicted.csv", "run.json")
#: The true path of a run that has one (an exploration of the virtual robot), beside the encoder
#: log under the name the CSV run reader looks for (``<stem>_gt.csv``).
TRUTH_FILE = "encoders_gt.csv"
#: Files a run writes when it has them (the 2014 Jaguar's gyro, a true path), guarded the same way.
OPTIONAL_RUN_FILES = ("imu.csv", TRUTH_FILE)

_P = ParamSpec("_P")


@dataclass(frozen=True, eq=False)
class RobotRun:
    """A finished run: the trial (AWAITING its measurement), the loop's log and statistics."""

    trial: Trial
    loop: LoopResult
    robot: str  #: "udp://HOST:PORT", "virtual (udp://...)" or "simulated"
    stop_confirmed: bool = True  #: the robot's sensor data showed it still after the run
    config: RunConfig = field(default_factory=RunConfig)
    saved_to: Path | None = None  #: where the run was saved (None: not asked, or nowhere)
    save_note: str = ""  #: why it is not where it was asked to go ("" when it is)
    #: the robot's own heading sensor during the run (a link that has one): (t in the encoder
    #: log's time, yaw rad or None, yaw rate rad/s or None); saved as imu.csv
    headings: tuple[tuple[float, float | None, float | None], ...] = ()
    #: the true path on the encoder log's clock, in the start frame (an exploration of the
    #: virtual robot); saved as :data:`TRUTH_FILE`
    truth: Trajectory | None = None
    #: keys of the run's own added to ``run.json`` (never one of the keys every run has)
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def stats(self) -> LoopStats:
        return self.loop.stats


#: A run's own change of the run it is about to save (see the module); it should not raise.
Finish = Callable[[RobotRun], RobotRun]


@dataclass(frozen=True, eq=False)
class AbortReport:
    """A run that failed part way: why, where the partial run went, whether the stop is known."""

    error: BaseException
    saved_to: Path | None
    stop_confirmed: bool
    run: RobotRun | None = None  #: the partial run (None when the loop never ran a cycle)
    save_note: str = ""  #: why it is not where it was asked to go ("" when it is)


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
    failed = bool(result.aborted)  # kept, but out of the analysis until someone includes it
    return Trial(
        trial_id=f"robot-{command.label}-{stamp}",
        campaign=campaign,
        terrain=terrain,
        command=command,
        predicted=result.final,
        params=params,
        true=true_pose,
        encoder_log=result.log.encoder_log(params.encoder_modulus),
        status=TrialStatus.EXCLUDED if failed else TrialStatus.AWAITING,
        exclusion_reason=status if failed else None,
        notes=status,
    )


def _true_pose(link: RobotLink) -> Pose | None:
    """The virtual robot's true pose; None when unknown (a real robot, or a board that died)."""
    try:
        return link.true_pose()
    except Exception:
        return None


class RunSignal(KeyboardInterrupt):
    """SIGTERM or SIGHUP during a run (a ``kill``, a closed ssh session): handled as Ctrl-C
    is, the robot stopped, the stop confirmed and what was driven saved."""

    def __init__(self, signum: int) -> None:
        import signal

        self.signum = signum
        super().__init__(signal.Signals(signum).name)


@dataclass
class _Signals:
    """While a run drives: whether the stop and the saving that follow an interrupt are under
    way (a second signal then waits for them: it cut them short and lost the run), and the
    signal that arrived meanwhile."""

    deferring: bool = False
    pending: int | None = None


@contextmanager
def _run_signals() -> Iterator[_Signals]:
    """Ctrl-C, SIGTERM and SIGHUP stop the run the same way: the first raises in the control
    loop (the loop's stop, :meth:`Driver.confirm_stopped`, the partial run kept); any further
    one while that is under way is held until it is done. SIGTERM and SIGHUP killed the
    process at once before: no stop sent, the run lost. A signal the process ignores (``nohup``,
    a background job's SIGINT) stays ignored; off the main thread nothing changes."""
    import signal
    import threading

    state = _Signals()
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def handler(signum: int, frame: object) -> None:
        if state.deferring:
            state.pending = signum
            return
        state.deferring = True  # the stop and the saving that follow are not cut short
        raise KeyboardInterrupt if signum == signal.SIGINT else RunSignal(signum)

    wanted = {
        signal.SIGINT: signal.default_int_handler,
        signal.SIGTERM: signal.SIG_DFL,
        signal.SIGHUP: signal.SIG_DFL,
    }
    old = {s: signal.getsignal(s) for s in wanted}
    for sig, default in wanted.items():
        if old[sig] is default:  # only where the signal would end the process
            signal.signal(sig, handler)
    try:
        yield state
    finally:
        for sig, previous in old.items():
            signal.signal(sig, previous)


def confirm_timeout(config: RunConfig) -> float:
    """How long to wait for the robot's data to confirm a stop: 2 watchdog times, >= 1 s."""
    return max(1.0, 2.0 * config.watchdog)


def _kept(
    link: RobotLink,
    command: Command,
    result: LoopResult,
    params: RobotParams,
    config: RunConfig,
    confirmed: bool,
    started_at: float | None,
    drift: _DriftHook | None,
    finish: Finish | None,
    save_to: str | Path | None,
    *,
    terrain: str,
    campaign: str,
) -> RobotRun:
    """The run of what the loop recorded (all of it, or up to an abort), finished and saved."""
    run = RobotRun(
        _trial(command, result, params, terrain, _true_pose(link), campaign),
        result,
        link.description,
        confirmed,
        config,
        headings=_headings(link, started_at),
        extra=drift.extra() if drift is not None else {},
    )
    run = _finished(run, finish)
    if save_to is not None:
        saved, note = keep_run(run, save_to)
        run = replace(run, saved_to=saved, save_note=note)
    return run


def _drive_link(
    link: RobotLink,
    command: Command,
    motion: Motion,
    params: RobotParams,
    config: RunConfig,
    clock: Clock,
    *,
    terrain: str,
    campaign: str,
    max_duration: float | None,
    on_cycle: Callable[[CycleInfo], None] | None,
    on_event: Callable[[float, str], None] | None,
    realtime: bool,
    save_to: str | Path | None,
    on_abort: Callable[[AbortReport], object] | None,
    finish: Finish | None = None,
) -> RobotRun:
    driver: Driver = link.driver
    rt = realtime and set_realtime(True)
    loop: ControlLoop | None = None
    drift = _DriftHook(link, on_event) if link.headings is not None else None
    if drift is not None:
        on_cycle = drift.around(on_cycle)
    signals = contextlib.ExitStack()
    state = signals.enter_context(_run_signals())
    try:
        try:
            loop = ControlLoop(
                driver,
                odometry_for(motion, params),
                clock,
                rate=config.rate,
                watchdog_timeout=config.watchdog,
                on_cycle=on_cycle,
                on_event=on_event,
            )
            if drift is not None:
                drift.loop = loop
            result = loop.run(
                motion,
                settle=config.settle,
                max_duration=max_duration,
                link_abort=config.link_timeout,
                stall_timeout=config.stall_timeout,
            )
        except BaseException as err:
            state.deferring = True  # a second Ctrl-C must not cut the stop and the saving short
            confirmed = driver.confirm_stopped(confirm_timeout(config))
            partial: RobotRun | None = None
            if loop is not None and loop.partial is not None and len(loop.partial.log) > 0:
                # it has driven: keep what was recorded; a failure to save must not hide `err`
                partial = _kept(
                    link, command, loop.partial, params, config, confirmed, loop.started_at,
                    drift, finish, save_to, terrain=terrain, campaign=campaign,
                )  # fmt: skip
            if on_abort is not None:
                on_abort(
                    AbortReport(
                        err,
                        partial.saved_to if partial is not None else None,
                        confirmed,
                        partial,
                        partial.save_note if partial is not None else "",
                    )
                )
            raise
        state.deferring = True  # the motion is done: a Ctrl-C now must not lose the run
        confirmed = driver.confirm_stopped(confirm_timeout(config))
        return _kept(
            link, command, result, params, config, confirmed, loop.started_at, drift, finish,
            save_to, terrain=terrain, campaign=campaign,
        )  # fmt: skip
    finally:
        try:
            link.close()
            if rt:
                set_realtime(False)
        finally:
            signals.close()


class _DriftHook:
    """Feeds the drift monitor (:mod:`odolab.robot.drift`) from the control loop's cycles and
    the link's gyro; its flags go to ``on_event`` as they are raised and into ``run.json``
    (``"drift"``). It never stops the robot."""

    #: read the link's gyro every this many cycles
    EVERY = 5

    def __init__(self, link: RobotLink, on_event: Callable[[float, str], None] | None) -> None:
        from odolab.robot.drift import DriftMonitor

        self.link = link
        self.on_event = on_event
        self.monitor = DriftMonitor()
        self.loop: ControlLoop | None = None
        self.seen = 0
        self.events: list[tuple[float, str]] = []
        self._odo_t: list[float] = []  # every cycle's odometry heading, for the sense check
        self._odo_h: list[float] = []

    def around(self, on_cycle: Callable[[CycleInfo], None] | None) -> Callable[[CycleInfo], None]:
        def cycle(info: CycleInfo) -> None:
            self.cycle(info)
            if on_cycle is not None:
                on_cycle(info)

        return cycle

    def cycle(self, info: CycleInfo) -> None:
        self.monitor.odometry(info.t, info.pose.heading)
        self._odo_t.append(info.t)
        self._odo_h.append(info.pose.heading)
        loop, headings = self.loop, self.link.headings
        if info.index % self.EVERY or loop is None or loop.started_at is None or headings is None:
            return
        samples = headings()
        new = samples[self.seen :]
        self.seen = len(samples)
        t0 = loop.started_at
        for flag in self.monitor.gyro((t - t0, r) for t, _, r in new if r is not None):
            message = flag.message()
            self.events.append((flag.t, message))
            if self.on_event is not None:
                self.on_event(flag.t, message)
        problem = self.sense()
        if problem is not None:  # raised in the cycle: the loop stops the robot, keeps the run
            from odolab.robot.drift import SenseCheckError

            raise SenseCheckError(
                f"sense check at t={info.t:.1f} s, the run was stopped: {problem}"
            )

    def sense(self) -> str | None:
        """:func:`odolab.robot.drift.sense_check` on the turns so far, in the robot's words
        (None: they agree)."""
        from odolab.robot.drift import robot_sense_sentence, sense_check

        span = self.monitor.gyro_span()
        if span is None or not self._odo_t:
            return None
        t0, t1 = span[0], min(span[1], self._odo_t[-1])
        if t1 <= t0:
            return None
        turn = self._odo_at(t1) - self._odo_at(t0)
        found = sense_check(turn, self.monitor.gyro_turn(t0, t1), t1 - t0, self.monitor.expected)
        return None if found is None else robot_sense_sentence(found)

    def _odo_at(self, t: float) -> float:
        """The odometry's heading at ``t``, linear between cycles (a bisection: the check runs
        in the cycle, and a long run at a high rate has many cycles)."""
        ts, hs = self._odo_t, self._odo_h
        i = bisect.bisect_left(ts, t)
        if i <= 0:
            return hs[0]
        if i >= len(ts):
            return hs[-1]
        w = (t - ts[i - 1]) / (ts[i] - ts[i - 1]) if ts[i] > ts[i - 1] else 1.0
        return hs[i - 1] + w * (hs[i] - hs[i - 1])

    def extra(self) -> dict[str, object]:
        state = self.monitor.state

        def num(v: float) -> float | None:
            return v if math.isfinite(v) else None

        return {
            "drift": {
                "flags": [[t, m] for t, m in self.events],
                "expected_ratio": list(self.monitor.expected),
                "last_ratio": None if state is None else num(state.ratio),
                "last_ratio_ci95": None if state is None else [num(v) for v in state.ci95],
            },
            # odometry against the gyro over the whole run (None: they agree, or too little turn)
            "sense_check": _neutral(self.sense()),  # (a file: the library's words)
        }


def _finished(run: RobotRun, finish: Finish | None) -> RobotRun:
    """``finish(run)``; a failure there keeps the run as it was (it has driven: never lost),
    with why in ``run.json`` (``"finish_error"``)."""
    if finish is None:
        return run
    try:
        return finish(run)
    except Exception as err:
        return replace(run, extra={**run.extra, "finish_error": f"{err!r}"})


def _headings(
    link: RobotLink, started_at: float | None
) -> tuple[tuple[float, float | None, float | None], ...]:
    """The link's heading samples from the loop's start on, in the encoder log's time."""
    if link.headings is None or started_at is None:
        return ()
    return tuple((t - started_at, y, r) for t, y, r in link.headings() if t >= started_at)


def run_motion(
    command: Command,
    *,
    config: RunConfig | None = None,
    robot: str | None = None,
    params: RobotParams | None = None,
    motion: Motion | None = None,
    plant: PlantFactory | None = None,
    faults: object | None = None,
    seed: int = DEFAULT_SEED,
    report_rate: float = 10.0,
    terrain: str = DEFAULT_TERRAIN,
    campaign: str = "robot",
    max_duration: float | None = None,
    clock: Clock | None = None,
    on_cycle: Callable[[CycleInfo], None] | None = None,
    on_event: Callable[[float, str], None] | None = None,
    realtime: bool = False,
    save_to: str | Path | None = None,
    on_abort: Callable[[AbortReport], object] | None = None,
    finish: Finish | None = None,
) -> RobotRun:
    """Drive ``command`` by odometry in real time over the link ``robot`` names; return the run.

    ``robot``: "udp://HOST:PORT" of a Jaguar board, or None / "sim://" for a virtual Jaguar on
    127.0.0.1 whose plant ``plant()`` builds (default: an ideal robot with ``params``); the
    trial then carries the true pose. ``config`` (default :class:`RunConfig()`) and the motion
    are validated before anything is sent. ``save_to``: checked (:func:`check_run_folder`) and
    created before anything is sent; the run is saved there (:func:`keep_run`: to a sibling or
    the rescue folder if that fails after driving; :attr:`RobotRun.saved_to` says where), also
    when it fails part way (Ctrl-C, lost link, stall, a late cycle); ``on_abort`` then hears
    where it went and whether the robot's data confirmed the stop. ``finish``: see the module.
    ``motion``: drive this instead of the command's own motion (the caller checks it).
    """
    if save_to is not None:
        check_run_folder(save_to)
    config = config or RunConfig()
    params = params or PRESETS["jaguar-lite"]
    if motion is None:
        check_motion(command, config, params)
        motion = motion_from_command(command, decel=config.decel, turn_decel=config.decel)
    clock = clock or RealClock()
    link = open_link(robot, config, params, clock, VirtualSpec(plant, faults, seed, report_rate))
    return _drive_link(
        link, command, motion, params, config, clock,
        terrain=terrain, campaign=campaign, max_duration=max_duration, on_cycle=on_cycle,
        on_event=on_event, realtime=realtime, save_to=save_to, on_abort=on_abort, finish=finish,
    )  # fmt: skip


def run_simulated(
    motion: Command | Motion,
    truth: object = None,
    nominal: RobotParams | None = None,
    terrain: str = DEFAULT_TERRAIN,
    seed: int = DEFAULT_SEED,
    rate: float = 20.0,
    *,
    command: Command | None = None,
    plant: Plant | None = None,
    config: RunConfig | None = None,
    faults: object | None = None,
    report_rate: float = 10.0,
    max_duration: float | None = 3600.0,
    campaign: str = "sim",
    on_cycle: Callable[[CycleInfo], None] | None = None,
    link: str = "jaguar",
    save_to: str | Path | None = None,
    finish: Finish | None = None,
) -> RobotRun:
    """Drive a command (or a motion) through the same driver and loop, in simulated time.

    The virtual board of ``link`` (``"jaguar"``: the UDP Jaguar's, ``"jaguar2014"``: the 2014
    Jaguar's; :data:`odolab.robot.registry.IN_PROCESS`) over ``plant`` is wired to its driver
    in-process; a :class:`SimClock`
    jumps from deadline to deadline. Without a plant, ``truth`` must be a :class:`RobotParams`
    (an :class:`IdealPlant` with those true parameters) or None (ideal, nominal); build a
    simulator plant with ``odolab.sim.plants.make_plant``. ``rate`` is used when ``config`` is
    not given. Returns the whole :class:`RobotRun`: the trial (predicted pose from the loop, true
    pose from the plant), the log, the loop statistics (whose timing errors are zero: simulated
    time is exact) and ``finish``'s additions; with ``save_to``, saved there as
    :func:`run_motion` saves. :func:`run_motion_simulated` returns its trial and statistics.
    """
    if save_to is not None:
        check_run_folder(save_to)
    nominal = nominal or PRESETS["jaguar-lite"]
    config = config or RunConfig(rate=rate)
    if isinstance(motion, Command):
        command = motion
        mot: Motion = motion_from_command(command, decel=config.decel, turn_decel=config.decel)
    else:
        mot = motion
        if command is None:
            command = Command(MotionKind.FREE)
    if plant is None:
        if truth is None or isinstance(truth, RobotParams):
            plant = IdealPlant(truth or nominal)
        else:
            raise RobotConfigError(
                f"run_motion_simulated got truth {truth!r} without a plant; pass plant= "
                "(odolab.sim.plants.make_plant(...)) or truth as RobotParams"
            )
    clock = SimClock(plant.time)
    opened = open_in_process(
        link, config, nominal, clock, plant, VirtualSpec(None, faults, seed, report_rate)
    )
    return _drive_link(
        opened, command, mot, nominal, config, clock,
        terrain=terrain, campaign=campaign, max_duration=max_duration, on_cycle=on_cycle,
        on_event=None, realtime=False, save_to=save_to, on_abort=None, finish=finish,
    )  # fmt: skip


def _trial_and_stats(
    run: Callable[_P, RobotRun], name: str, doc: str
) -> Callable[_P, tuple[Trial, LoopStats]]:
    """``run`` (same arguments) returning only its run's trial and loop statistics."""

    @functools.wraps(run)
    def trial_and_stats(*args: _P.args, **kwargs: _P.kwargs) -> tuple[Trial, LoopStats]:
        done = run(*args, **kwargs)
        return done.trial, done.stats

    trial_and_stats.__name__ = trial_and_stats.__qualname__ = name
    trial_and_stats.__doc__ = doc
    # run's parameters, this function's return (wraps alone would show run's RobotRun)
    trial_and_stats.__dict__["__signature__"] = inspect.signature(run).replace(
        return_annotation="tuple[Trial, LoopStats]"
    )
    return trial_and_stats


run_motion_simulated = _trial_and_stats(
    run_simulated,
    "run_motion_simulated",
    """:func:`run_simulated` (the same arguments), returning ``(trial, stats)``: the trial
    (predicted pose from the loop, true pose from the plant) and the loop statistics (whose
    timing errors are zero: simulated time is exact).""",
)


def _first_existing(path: Path) -> Path:
    """``path`` or the nearest of its parents that exists (something always does)."""
    for p in (path, *path.parents):
        if os.path.lexists(p):
            return p
    return Path()


def check_run_folder(folder: str | Path) -> Path:
    """Make sure ``folder`` can take a new run, and create it; call it before the robot moves.

    Refused with one sentence (:class:`RunFolderError`): a path that is a file, or below a
    file; a folder that holds any of :data:`RUN_FILES` already, as a file or as a folder (an
    earlier run is never overwritten); a folder that cannot be created or written in (a
    temporary file is created there and removed).
    """
    out = Path(folder)
    base = _first_existing(out)
    if not base.is_dir():
        where = "is a file" if base == out else f"is below {base}, a file"
        raise RunFolderError(f"{out}: {where}; expected a folder for the run ({opt('out')})")
    in_the_way = [n for n in (*RUN_FILES, *OPTIONAL_RUN_FILES) if os.path.lexists(out / n)]
    if (out / "run.json").is_file():
        raise RunFolderError(
            f"{out}: holds an earlier run (run.json); a run folder is never overwritten, "
            "expected a new or empty folder ({{out}})"
        )
    if in_the_way:
        name = in_the_way[0]
        kind = "a folder" if (out / name).is_dir() else "a file"
        raise RunFolderError(
            f"{out}: has {kind} named {name} where the run writes its {name}; expected a new "
            "or empty folder ({{out}})"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".odolab-probe-", dir=out)
        os.close(fd)
        Path(probe).unlink()
    except OSError as err:
        raise RunFolderError(
            f"{out}: cannot create or write in the run folder ({err.strerror or err}); "
            "expected a folder odolab can write ({{out}})"
        ) from err
    return out


def rescue_folder() -> Path:
    """Where a run goes when neither its folder nor a sibling can take it:
    ``$ODOLAB_RESCUE_DIR``, else ``odolab-rescued-runs`` in the temporary folder."""
    env = os.environ.get("ODOLAB_RESCUE_DIR")
    return Path(env) if env else Path(tempfile.gettempdir()) / "odolab-rescued-runs"


def _fallbacks(out: Path, trial_id: str) -> Iterator[Path]:
    yield out
    if out.name:  # not "." or "/"
        n = 2
        while os.path.lexists(out.with_name(f"{out.name}-{n}")) and n < 1000:
            n += 1
        yield out.with_name(f"{out.name}-{n}")
    try:
        root = rescue_folder()
        root.mkdir(parents=True, exist_ok=True)
        yield Path(tempfile.mkdtemp(prefix=f"{trial_id}-", dir=root))
    except OSError:
        return


def keep_run(run: RobotRun, folder: str | Path) -> tuple[Path | None, str]:
    """Save ``run`` (:func:`save_run`) to ``folder``; when that fails (the folder was replaced,
    a full disk, a file in the way), to a new sibling folder ``FOLDER-N``, else to a new folder
    in :func:`rescue_folder`. Returns (where it went, why not where asked: "" when it went
    there); (None, why) when nowhere could take it. Never raises for a write failure: the
    caller still holds the run (for the notebook) and must say where it is."""
    out = Path(folder)
    problems: list[str] = []
    for target in _fallbacks(out, run.trial.trial_id):
        try:
            saved = save_run(run, target)
        except (OSError, OdolabError) as err:
            problems.append(str(err))
            continue
        if target == out:
            return saved, ""
        return saved, (
            f"the run could not be saved to {out}: {'; '.join(problems)}; it is saved to "
            f"{saved} instead"
        )
    return None, f"the run could not be saved anywhere: {'; '.join(problems)}"


def save_run(run: RobotRun, folder: str | Path) -> Path:
    """Write ``encoders.csv``, ``predicted.csv`` (one pose per cycle), ``imu.csv`` (when the
    robot has its own heading sensor: the 2014 Jaguar's IMU lines), ``encoders_gt.csv`` (when
    the run has its true path, :attr:`RobotRun.truth`) and ``run.json`` (with
    :attr:`RobotRun.extra`'s keys).

    The folder is checked first (:func:`check_run_folder`): one that already holds a run is
    refused (:class:`RunFolderError`), never overwritten. Each file is written through a
    temporary file and renamed into place (never through a link)."""
    from odolab.io import write_encoder_csv, write_trajectory_csv

    out = check_run_folder(folder)
    trial = run.trial
    assert trial.encoder_log is not None
    write_encoder_csv(out / "encoders.csv", trial.encoder_log)
    write_trajectory_csv(out / "predicted.csv", run.loop.log.trajectory())
    if run.headings:  # the robot's own gyro, in the SensorLog columns odolab validate reads
        rows = ["motionTimestamp_sinceReboot(s),motionYaw(rad),motionRotationRateZ(rad/s)"]
        rows += [
            f"{t:.6f},{'' if y is None else f'{y:.6f}'},{'' if r is None else f'{r:.6f}'}"
            for t, y, r in run.headings
        ]
        write_text_file(out / "imu.csv", "\n".join(rows) + "\n", what="robot IMU log")
    if run.truth is not None:  # the true path, where the CSV run reader looks for it
        write_trajectory_csv(out / TRUTH_FILE, run.truth)
    cmd = {k: v for k, v in asdict(trial.command).items() if v is not None}
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
        "stop_confirmed": run.stop_confirmed,
        "config": run.config.to_dict(),
        "aborted": run.loop.aborted or None,
        "predicted": trial.predicted._asdict(),
        "true": trial.true._asdict() if trial.true is not None else None,
        "status": trial.status.value,
        "exclusion_reason": trial.exclusion_reason,
        "stats": asdict(run.stats),  # a non-finite stat is null (strict_json)
        "events": [list(e) for e in run.loop.events],
        "measured": None,
    }
    doc.update({k: v for k, v in run.extra.items() if k not in doc})
    write_text_file(out / "run.json", strict_json(doc) + "\n", what="run record")
    return out


def _neutral(text: str | None) -> str | None:
    """``text`` with its settings' marks in the library's words (for a file the run writes)."""
    from odolab.core.errors import NEUTRAL

    return None if text is None else NEUTRAL.say(text)
