"""The fixed-rate control loop (the lab's Figs. 6-8), on absolute deadlines, with a watchdog.

Cycle ``k`` is due at ``t0 + k / rate``: the loop sleeps until that deadline (never "period after
the last wake-up"), so it does not drift; a late cycle runs at once and counts as an overrun. One
cycle is: read what the board sent (update the encoder measurements), :meth:`Odometry.update`
(predict the motion, update the global pose), log, then command the wheels. If no sensor packet
has ARRIVED (receive timestamp, not the time the loop read it) for ``watchdog_timeout`` seconds
the link is declared lost and the loop commands stop every cycle until data returns: the first
stop goes out within ``watchdog_timeout`` + one cycle of the last packet's arrival. Any
exception, Ctrl-C included, commands stop before it leaves. A cycle that wakes (or is about to
command the wheels) more than ``watchdog_timeout`` past its deadline - the host was frozen,
swapped out or starved - sends stop and fails the run (:class:`LateCycleError`): it never
resumes a motion from stale state. Everything a cycle calls is loaded before the first command
(:meth:`ControlLoop.prepare`: the odometry's compiled step), so no cycle compiles or imports. The
loop knows robots only through :class:`odolab.robot.interface.Driver`.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import opt
from odolab.core.odometry import Odometry
from odolab.core.trajectory import Pose, Trajectory
from odolab.core.trials import EncoderLog
from odolab.robot.clock import Clock
from odolab.robot.errors import (
    CommandsIgnoredError,
    LateCycleError,
    LinkLostError,
    RobotConfigError,
)
from odolab.robot.interface import Driver, EncoderReading
from odolab.robot.motions import Motion

__all__ = [
    "ControlLoop",
    "CycleInfo",
    "CycleLog",
    "LoopResult",
    "LoopStats",
    "Watchdog",
    "timing_stats",
]


def _check_positive(option: str, value: float, unit: str) -> None:
    """Refuse a setting that is not a positive number (of ``unit``) with
    :class:`RobotConfigError`."""
    if not (math.isfinite(value) and value > 0):
        allowed = f"a positive number of {unit}"
        raise RobotConfigError(option=option, value=value, allowed=allowed)


class Watchdog:
    """Declares the link lost when nothing arrived for ``timeout`` seconds.

    Fed with arrival times; expired at ``now >= last arrival + timeout`` (not ``>``: a cycle
    that lands exactly on the bound already stops).
    """

    def __init__(self, timeout: float = 0.5) -> None:
        _check_positive("watchdog", timeout, "s")
        self.timeout = float(timeout)
        self.last_feed: float | None = None

    def feed(self, t: float) -> None:
        """Data arrived at ``t`` (an older arrival than the last one changes nothing)."""
        if self.last_feed is None or t > self.last_feed:
            self.last_feed = t

    def expired(self, now: float) -> bool:
        """True when nothing arrived in the last ``timeout`` seconds (or ever)."""
        return self.last_feed is None or now - self.last_feed >= self.timeout


@dataclass(frozen=True)
class CycleInfo:
    """What one cycle saw and did, for a live view."""

    index: int
    t: float
    pose: Pose
    reading: EncoderReading
    fresh: bool  #: a new sensor packet arrived this cycle
    link_ok: bool
    command: tuple[float, float]
    phase: str  #: "moving", "settling", "holding" or "link-lost"
    lateness: float  #: s past the deadline when the cycle woke
    data_age: float = 0.0  #: s since the newest sensor packet ARRIVED, at this cycle's wake-up


@dataclass
class CycleLog:
    """Per-cycle log: counters exactly as fed to the odometry, and the pose it returned."""

    t: list[float] = field(default_factory=list)
    left_ticks: list[int] = field(default_factory=list)
    right_ticks: list[int] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    theta: list[float] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    fresh: list[bool] = field(default_factory=list)
    lateness: list[float] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.t)

    def append(self, pose: Pose, reading: EncoderReading, fresh: bool, lateness: float) -> None:
        self.t.append(pose.t)
        self.left_ticks.append(reading.left_ticks)
        self.right_ticks.append(reading.right_ticks)
        self.x.append(pose.x)
        self.y.append(pose.y)
        self.theta.append(pose.theta)
        self.heading.append(pose.heading)
        self.fresh.append(fresh)
        self.lateness.append(lateness)

    def encoder_log(self, modulus: int | None) -> EncoderLog:
        """The counters as an :class:`EncoderLog` (shape (n,) arrays)."""
        return EncoderLog(
            np.asarray(self.t, dtype=np.float64),
            np.asarray(self.left_ticks, dtype=np.int64),
            np.asarray(self.right_ticks, dtype=np.int64),
            modulus,
        )

    def trajectory(self) -> Trajectory:
        """The loop's poses, one per cycle."""
        return Trajectory(
            np.asarray(self.t, dtype=np.float64),
            np.asarray(self.x, dtype=np.float64),
            np.asarray(self.y, dtype=np.float64),
            np.asarray(self.theta, dtype=np.float64),
            np.asarray(self.heading, dtype=np.float64),
        )


@dataclass(frozen=True)
class LoopStats:
    """Timing and link health of one loop run. Times in seconds.

    ``period_error_*`` are statistics of |actual period - nominal period| between consecutive
    wake-ups; ``lateness_*`` of (wake-up time - deadline). An overrun is a cycle whose work
    ended after the next cycle's deadline.
    """

    rate: float
    cycles: int
    duration: float
    period_error_p50: float
    period_error_p99: float
    period_error_max: float
    lateness_p50: float
    lateness_p99: float
    lateness_max: float
    overruns: int
    sensor_packets: int
    link_lost_events: int
    stops_sent: int
    commands_sent: int
    decode_errors: int
    keepalives: int  #: keep-alive messages the link exchanged (answered or sent)

    def describe(self) -> str:
        """One line for people."""
        return (
            f"{self.cycles} cycles at {self.rate:g} Hz in {self.duration:.2f} s; period error "
            f"p50 {self.period_error_p50 * 1e3:.3f} ms, p99 {self.period_error_p99 * 1e3:.3f} ms, "
            f"max {self.period_error_max * 1e3:.3f} ms; {self.overruns} overruns; "
            f"{self.sensor_packets} sensor packets, {self.decode_errors} bad, "
            f"{self.link_lost_events} link losses"
        )


def timing_stats(t_wake: NDArray[np.float64], rate: float) -> tuple[float, float, float]:
    """(p50, p99, max) of |diff(t_wake) - 1/rate|; ``t_wake`` shape (n,). Zeros when n < 2."""
    if t_wake.size < 2:
        return 0.0, 0.0, 0.0
    err = np.abs(np.diff(t_wake) - 1.0 / rate)
    p50, p99 = np.percentile(err, [50, 99])
    return float(p50), float(p99), float(err.max())


@dataclass(frozen=True, eq=False)
class LoopResult:
    """What a loop run produced."""

    log: CycleLog
    stats: LoopStats
    completed: bool  #: the motion reached its target (False: stopped by max_duration)
    final: Pose
    events: tuple[tuple[float, str], ...]
    aborted: str = ""  #: why the run ended early ("" when it did not)


def _noop_cycle(info: CycleInfo) -> None:
    return None


def _noop_event(t: float, message: str) -> None:
    return None


@dataclass
class _RunState:
    """What :meth:`ControlLoop._run` keeps across cycles."""

    pose: Pose
    log: CycleLog = field(default_factory=CycleLog)
    events: list[tuple[float, str]] = field(default_factory=list)
    wakes: list[float] = field(default_factory=list)
    overruns: int = 0
    lost_events: int = 0
    completed: bool = False
    phase: str = "holding"
    lost_since: float | None = None
    settle_start: float = math.nan
    last_counts: tuple[int, int] = (0, 0)
    last_change: float = 0.0


class ControlLoop:
    """Runs motions at a fixed rate over a :class:`Driver` with a streaming odometry.

    ``on_cycle`` is called after every cycle; ``on_event(t, message)`` on link loss/return.
    """

    def __init__(
        self,
        driver: Driver,
        odometry: Odometry,
        clock: Clock,
        *,
        rate: float = 20.0,
        watchdog_timeout: float = 0.5,
        on_cycle: Callable[[CycleInfo], None] | None = None,
        on_event: Callable[[float, str], None] | None = None,
    ) -> None:
        _check_positive("rate", rate, "Hz")
        self.driver = driver
        self.odometry = odometry
        self.clock = clock
        self.rate = float(rate)
        self.watchdog = Watchdog(watchdog_timeout)
        self.on_cycle = on_cycle or _noop_cycle
        self.on_event = on_event or _noop_event
        #: what the last run had recorded when it failed (None after a run that ended normally)
        self.partial: LoopResult | None = None
        #: the clock time the last run's cycle times count from (log ``t`` = clock time - this)
        self.started_at: float | None = None

    def _safe_stop(self) -> None:
        for _ in range(3):  # UDP may lose one; a stop is idempotent
            try:
                self.driver.stop()
            except Exception:
                continue

    def prepare(self) -> None:
        """Load everything a cycle calls before anything is sent: the odometry's compiled step
        (numba loads or compiles it on its first call, 0.3 s to seconds, which used to fall in
        the cycle after the first wheel command). :meth:`run` calls it before connecting."""
        self.odometry.warm_up()

    def _check_on_time(self, late: float, k: int) -> None:
        """Stop and fail the run when cycle ``k`` is ``late`` s past its deadline, more than the
        watchdog bound: whatever the robot did meanwhile, the loop's state is stale."""
        bound = self.watchdog.timeout
        if late > bound:
            self._safe_stop()
            raise LateCycleError(
                f"control cycle {k} ran {late:.3f} s late, more than the watchdog bound {bound:g} s "
                "(the host was frozen, swapped out or starved); stop sent and the run failed "
                "instead of resuming the motion"
            )

    def run(
        self,
        motion: Motion | None = None,
        *,
        settle: float = 0.5,
        max_duration: float | None = None,
        max_cycles: int | None = None,
        link_abort: float | None = None,
        stall_timeout: float | None = 3.0,
    ) -> LoopResult:
        """Drive ``motion`` to its end, then hold still for ``settle`` s while the odometry runs.

        Without a motion the loop holds the robot still (commanding stop every cycle) for
        ``max_duration`` s or ``max_cycles`` cycles. ``link_abort``: raise
        :class:`LinkLostError` (after commanding stop) when the link stays lost that long.
        ``stall_timeout``: raise :class:`CommandsIgnoredError` (after commanding stop) when the motion
        commands the wheels but, with sensor data arriving, the counters have not changed for
        that long (a stalled or lifted-off robot, or a board that ignores the commands).
        """
        if motion is None and max_duration is None and max_cycles is None:
            raise RobotConfigError("a loop without a motion needs max_duration or max_cycles")
        self.partial = None
        self.prepare()  # before connecting: nothing has been sent yet
        # a full collection of the cyclic GC scans the whole heap: 0.4 s for the CLI's 120,000
        # objects on a loaded 2-CPU machine, inside whichever cycle triggers it. Frozen, the heap
        # the run starts with is never scanned; a collection sees only what the run made
        # (0.1 ms). Left alone when someone else froze it (unfreezing would undo theirs).
        frozen = gc.get_freeze_count() == 0
        if frozen:
            gc.freeze()
        try:
            return self._run(motion, settle, max_duration, max_cycles, link_abort, stall_timeout)
        finally:
            if frozen:
                gc.unfreeze()

    def _run(
        self,
        motion: Motion | None,
        settle: float,
        max_duration: float | None,
        max_cycles: int | None,
        link_abort: float | None,
        stall_timeout: float | None,
    ) -> LoopResult:
        driver = self.driver
        clock = self.clock
        odo = self.odometry
        st = _RunState(pose=odo.pose)
        try:
            reading = driver.latest if driver.latest is not None else driver.connect()
            self.watchdog.feed(reading.t)
            period = 1.0 / self.rate
            t0 = clock.now()
            self.started_at = t0
            k = 0
            st.phase = "holding" if motion is None else "moving"
            st.last_counts = (reading.left_ticks, reading.right_ticks)
            st.last_change = clock.now()
            while True:
                deadline = t0 + k * period
                clock.sleep_until(deadline)
                now = clock.now()
                st.wakes.append(now)
                fresh = driver.poll() > 0
                assert driver.latest is not None
                reading = driver.latest
                if fresh:
                    self.watchdog.feed(reading.t)
                    counts = (reading.left_ticks, reading.right_ticks)
                    if counts != st.last_counts or st.phase != "moving":
                        st.last_counts = counts
                        st.last_change = now
                pose = st.pose = odo.update(now - t0, reading.left_ticks, reading.right_ticks)
                st.log.append(pose, reading, fresh, now - deadline)
                self._check_on_time(now - deadline, k)  # before any command of this cycle
                if k == 0 and motion is not None:
                    motion.start(pose, odo.params)
                command = (0.0, 0.0)
                if self.watchdog.expired(now):
                    self._link_lost(st, now, t0, link_abort)
                    shown = "link-lost"
                else:
                    command = self._link_up(st, motion, now, t0, deadline, k, stall_timeout)
                    shown = st.phase
                last_feed = self.watchdog.last_feed
                self.on_cycle(
                    CycleInfo(
                        k, now - t0, pose, reading, fresh, st.lost_since is None, command, shown,
                        now - deadline, now - (last_feed if last_feed is not None else t0),
                    )
                )  # fmt: skip
                k += 1
                if st.phase == "settling" and now - st.settle_start >= settle:
                    st.completed = True
                    break
                if max_cycles is not None and k >= max_cycles:
                    break
                if max_duration is not None and now - t0 >= max_duration:
                    break
                if clock.now() > t0 + k * period:
                    st.overruns += 1
        except BaseException as err:
            self._safe_stop()
            self.partial = self._result(
                st.log, st.wakes, st.overruns, st.lost_events, False, st.pose, st.events,
                f"aborted: {err!r}",
            )  # fmt: skip
            raise
        self._safe_stop()
        if motion is None:
            st.completed = True
        return self._result(
            st.log, st.wakes, st.overruns, st.lost_events, st.completed, st.pose, st.events, ""
        )

    def _link_lost(self, st: _RunState, now: float, t0: float, link_abort: float | None) -> None:
        """A cycle without the link: say so once, command stop, give up after ``link_abort`` s."""
        if st.lost_since is None:
            st.lost_since = now
            st.lost_events += 1
            msg = f"link lost: no sensor data for {self.watchdog.timeout:g} s; stopping"
            st.events.append((now - t0, msg))
            self.on_event(now - t0, msg)
        self.driver.stop()
        last = self.watchdog.last_feed
        silent = now - last if last is not None else now - t0
        if link_abort is not None and silent >= link_abort:
            raise LinkLostError(
                f"no sensor data from the robot for {silent:.2f} s ({opt('link_timeout')} "
                f"{link_abort:g} s); stop commanded, gave up"
            )

    def _link_up(
        self,
        st: _RunState,
        motion: Motion | None,
        now: float,
        t0: float,
        deadline: float,
        k: int,
        stall_timeout: float | None,
    ) -> tuple[float, float]:
        """A cycle with the link: the motion's next command sent (or stop); the command."""
        if st.lost_since is not None:
            st.lost_since = None
            st.last_change = now
            st.events.append((now - t0, "link back"))
            self.on_event(now - t0, "link back")
        if st.phase != "moving":
            self.driver.stop()
            return (0.0, 0.0)
        assert motion is not None
        if stall_timeout is not None and now - st.last_change > stall_timeout:
            raise CommandsIgnoredError(
                f"the robot's encoders have not moved for {stall_timeout:g} s "
                "while driving (stalled, or the board ignores the commands); "
                "stopped"
            )
        step = motion.step(st.pose)
        if step is None:
            st.phase = "settling"
            st.settle_start = now
            self.driver.stop()
            return (0.0, 0.0)
        self._check_on_time(self.clock.now() - deadline, k)
        # and again by the driver, just before the bytes go out: a freeze
        # between this check and the send must not send a stale command
        send_by = deadline + self.watchdog.timeout
        self.driver.set_wheel_speeds(*step, send_by=send_by)
        return step

    def _result(
        self,
        log: CycleLog,
        wakes: list[float],
        overruns: int,
        lost_events: int,
        completed: bool,
        pose: Pose,
        events: list[tuple[float, str]],
        aborted: str,
    ) -> LoopResult:
        p50, p99, pmax = timing_stats(np.asarray(wakes), self.rate)
        late = np.asarray(log.lateness) if log.lateness else np.zeros(1)
        lp50, lp99 = np.percentile(late, [50, 99])
        driver = self.driver
        ds = driver.stats
        stats = LoopStats(
            rate=self.rate,
            cycles=len(log),
            duration=(wakes[-1] - wakes[0]) if wakes else 0.0,
            period_error_p50=p50,
            period_error_p99=p99,
            period_error_max=pmax,
            lateness_p50=float(lp50),
            lateness_p99=float(lp99),
            lateness_max=float(late.max()),
            overruns=overruns,
            sensor_packets=ds.sensor_packets,
            link_lost_events=lost_events,
            stops_sent=ds.stops_sent,
            commands_sent=ds.commands_sent,
            decode_errors=driver.decode_errors,
            keepalives=ds.keepalives,
        )
        return LoopResult(log, stats, completed, pose, tuple(events), aborted)
