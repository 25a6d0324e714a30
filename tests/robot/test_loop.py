"""The control loop in simulated time: consistency with batch odometry, drift, watchdog, safety."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.core.errors import RobotLinkError
from odolab.core.odometry import Odometry, integrate
from odolab.core.params import PRESETS, RobotParams
from odolab.robot.clock import SimClock
from odolab.robot.jaguar.board import BoardConfig, Faults, InProcessLink, VirtualJaguar
from odolab.robot.jaguar.driver import JaguarDriver, driver_config_for
from odolab.robot.loop import ControlLoop, CycleInfo, LoopResult, Watchdog, timing_stats
from odolab.robot.motions import Rotate, Straight
from odolab.robot.plant import IdealPlant

NOMINAL = PRESETS["jaguar-lite"]


def rig(
    truth: RobotParams = NOMINAL, clock: SimClock | None = None, **faults: float
) -> tuple[ControlLoop, VirtualJaguar, SimClock]:
    clock = clock or SimClock()
    board = VirtualJaguar(
        IdealPlant(truth), BoardConfig.from_params(NOMINAL), faults=Faults(**faults), seed=3
    )
    driver = JaguarDriver(InProcessLink(board, clock.now), clock, driver_config_for(NOMINAL))
    return ControlLoop(driver, Odometry(NOMINAL), clock, rate=20.0), board, clock


def batch_final(result: LoopResult) -> tuple[float, float, float]:
    log = result.log
    traj = integrate(log.t, log.left_ticks, log.right_ticks, NOMINAL)
    return traj.x[-1], traj.y[-1], traj.heading[-1]


def test_rotation_pose_equals_batch_and_truth_as_implied() -> None:
    truth = NOMINAL.with_(track_width=0.60, left_wheel_radius=0.0850, right_wheel_radius=0.0850)
    loop, board, _ = rig(truth)
    res = loop.run(Rotate(2 * math.pi, speed=1.0))
    assert res.completed
    bx, by, bh = batch_final(res)
    assert (res.final.x, res.final.y, res.final.heading) == pytest.approx((bx, by, bh), abs=1e-9)
    assert res.final.heading >= 2 * math.pi  # stops once odometry reaches the target
    # the ideal plant's counters: ticks = true distance / true metres per tick, so the true
    # heading is the predicted one times (r_true / r_nominal) * (track_nominal / track_true)
    implied = res.final.heading * (0.0850 / 0.0835) * (0.56 / 0.60)
    tick_angle = truth.left_metres_per_tick / truth.track_width  # one count of quantisation
    assert board.plant.true_pose.heading == pytest.approx(implied, abs=2 * tick_angle)
    assert len(res.log) == res.stats.cycles


def test_straight_reverse_and_cycle_times() -> None:
    loop, board, _ = rig()
    res = loop.run(Straight(-0.5, speed=0.25))
    assert res.final.x <= -0.5
    assert res.final.x == pytest.approx(batch_final(res)[0], abs=1e-9)
    assert board.plant.true_pose.x == pytest.approx(
        res.final.x, abs=2 * NOMINAL.left_metres_per_tick
    )
    np.testing.assert_allclose(np.diff(res.log.t), 0.05, atol=1e-9)
    assert res.stats.period_error_max == pytest.approx(0.0, abs=1e-9)
    # one sensor packet every other cycle (10 Hz board, 20 Hz loop)
    assert sum(res.log.fresh) == pytest.approx(len(res.log) / 2, abs=2)


class JitterClock(SimClock):
    """Wakes late by 0..3 ms, and now and then 80 ms (an overrun) - like a loaded machine."""

    def __init__(self) -> None:
        super().__init__()
        self.rng = np.random.default_rng(11)

    def sleep_until(self, t: float) -> None:
        late = 0.08 if self.rng.random() < 0.01 else float(self.rng.uniform(0, 0.003))
        super().sleep_until(max(t, self.now()) + late)


def test_absolute_deadlines_do_not_drift() -> None:
    clock = JitterClock()
    loop, _, _ = rig(clock=clock)
    res = loop.run(None, max_duration=600.0)
    # 10 minutes at 20 Hz: 12,000 periods (12,001 wake-ups counting the first), despite jitter
    assert abs((res.stats.cycles - 1) - 12000) <= 1
    assert res.stats.overruns > 50
    # |U1 - U2| for U ~ uniform(0, 3 ms) has median 3 ms * (1 - 1/sqrt(2)) = 0.88 ms
    assert 0.0008 < res.stats.period_error_p50 < 0.00096
    assert res.stats.period_error_max >= 0.05


def test_timing_stats_by_hand() -> None:
    p50, p99, pmax = timing_stats(np.array([0.0, 0.05, 0.101, 0.15, 0.2]), 20.0)
    # |periods - 0.05| = 0, 0.001, 0.001, 0
    assert (p50, pmax) == pytest.approx((0.0005, 0.001))
    assert p99 == pytest.approx(0.001, abs=1e-5)


def test_watchdog_stops_within_timeout_plus_one_cycle() -> None:
    loop, board, _clock = rig()
    cycles: list[CycleInfo] = []

    def on_cycle(info: CycleInfo) -> None:
        cycles.append(info)
        if info.t >= 1.0 and not board.silent:
            board.silent = True  # the robot goes quiet mid-motion
        if info.t >= 3.0:
            raise KeyboardInterrupt  # Ctrl-C after a while

    loop.on_cycle = on_cycle
    with pytest.raises(KeyboardInterrupt):
        loop.run(Straight(5.0, speed=0.5))
    last_data = max(c.t for c in cycles if c.fresh)
    first_lost = next(c for c in cycles if not c.link_ok)
    assert first_lost.phase == "link-lost"
    # timed from the arrival of the last packet (t = 1.0 here, a report and a cycle coincide);
    # the bound is inclusive: the cycle exactly 0.5 s later already stops
    assert first_lost.t - last_data == pytest.approx(0.5)
    assert first_lost.data_age == pytest.approx(0.5)
    # from then on every cycle commands stop, and the board has stopped the plant
    assert all(c.command == (0.0, 0.0) for c in cycles if c.t >= first_lost.t)
    assert board.wheel_speeds == (0.0, 0.0)
    assert loop.driver.stats.stops_sent >= sum(1 for c in cycles if not c.link_ok)


def test_link_comes_back_and_motion_finishes() -> None:
    loop, board, _ = rig()
    events: list[str] = []

    def on_cycle(info: CycleInfo) -> None:
        board.silent = 1.0 <= info.t < 2.0

    loop.on_cycle = on_cycle
    loop.on_event = lambda t, m: events.append(m)
    res = loop.run(Straight(1.0, speed=0.5))
    assert res.completed and res.final.x >= 1.0
    assert res.stats.link_lost_events == 1
    assert events[0].startswith("link lost") and events[1] == "link back"
    assert res.final.x == pytest.approx(batch_final(res)[0], abs=1e-9)


def test_exception_commands_stop_before_leaving() -> None:
    loop, board, _ = rig()

    def boom(info: CycleInfo) -> None:
        if info.index == 10:
            raise RuntimeError("bug in a callback")

    loop.on_cycle = boom
    with pytest.raises(RuntimeError):
        loop.run(Straight(2.0, speed=0.5))
    assert board.wheel_speeds == (0.0, 0.0)


def test_loss_and_reordering_keep_the_loop_consistent() -> None:
    loop, board, _ = rig(drop=0.2, jitter=0.25)
    res = loop.run(Rotate(4 * math.pi, speed=1.0))
    assert res.completed
    assert board.stats.dropped > 20
    left = np.array(res.log.left_ticks)
    assert (np.diff(left) > 0).any() and (np.diff(left) < 0).any()  # reordering seen
    bx, by, bh = batch_final(res)
    assert (res.final.x, res.final.y, res.final.heading) == pytest.approx((bx, by, bh), abs=1e-9)
    assert res.final.heading >= 4 * math.pi


def test_watchdog_unit() -> None:
    w = Watchdog(0.5)
    assert w.expired(0.0)
    w.feed(1.0)
    assert not w.expired(1.4999) and w.expired(1.5)
    w.feed(0.7)  # an older arrival (reordered) does not rejuvenate the link
    assert w.expired(1.5)


class StuckPlant(IdealPlant):
    """A robot that does not move whatever it is told (lifted off, or wheels blocked)."""

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        super().set_wheel_speeds(0.0, 0.0)


def test_stalled_robot_is_stopped_and_reported() -> None:
    clock = SimClock()
    board = VirtualJaguar(StuckPlant(NOMINAL), BoardConfig.from_params(NOMINAL))
    driver = JaguarDriver(InProcessLink(board, clock.now), clock, driver_config_for(NOMINAL))
    loop = ControlLoop(driver, Odometry(NOMINAL), clock)
    with pytest.raises(RobotLinkError, match="have not moved for 3 s"):
        loop.run(Straight(1.0))
    assert 3.0 < clock.now() < 3.3
    assert driver.last_command == (0.0, 0.0)


def test_velocity_mode_drives_the_same() -> None:
    from odolab.robot.jaguar.driver import CommandMode

    clock = SimClock()
    board = VirtualJaguar(IdealPlant(NOMINAL), BoardConfig.from_params(NOMINAL))
    cfg = driver_config_for(NOMINAL, mode=CommandMode.VELOCITY)
    driver = JaguarDriver(InProcessLink(board, clock.now), clock, cfg)
    loop = ControlLoop(driver, Odometry(NOMINAL), clock)
    speeds: list[tuple[float, float]] = []
    loop.on_cycle = lambda info: speeds.append(board.wheel_speeds)
    res = loop.run(Straight(1.0, speed=0.5))
    assert res.final.x >= 1.0
    # 0.5 m/s is round(0.5 / metres per tick) = 362 counts/s on the wire
    expected = 362 * NOMINAL.left_metres_per_tick
    assert max(s[0] for s in speeds) == pytest.approx(expected, rel=1e-12)
    assert board.plant.true_pose.x == pytest.approx(
        res.final.x, abs=2 * NOMINAL.left_metres_per_tick
    )
