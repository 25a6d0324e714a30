"""Real UDP on loopback (127.0.0.1, OS-assigned ports) against the virtual Jaguar server.

Each test runs a few seconds of real time; sockets are closed by context managers.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from odolab.core.odometry import Odometry, integrate
from odolab.core.params import PRESETS
from odolab.robot.clock import RealClock
from odolab.robot.jaguar.board import BoardConfig, Faults, VirtualJaguar, VirtualJaguarServer
from odolab.robot.jaguar.driver import JaguarDriver, UdpTransport, driver_config_for
from odolab.robot.loop import ControlLoop, CycleInfo, LoopResult
from odolab.robot.motions import Rotate, Straight
from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]
LAB = TRUTH_PRESETS["jaguar-lab"].noiseless  # the lab's biases without the random part
MPT = NOMINAL.left_metres_per_tick


@contextmanager
def udp_rig(
    truth: TrueParams, faults: Faults | None = None, seed: int = 0
) -> Iterator[tuple[ControlLoop, VirtualJaguarServer, VirtualRobot]]:
    plant = VirtualRobot(truth, NOMINAL, "tile", seed=seed)
    board = VirtualJaguar(plant, BoardConfig.from_params(NOMINAL), faults=faults, seed=seed)
    with VirtualJaguarServer(board, "127.0.0.1", 0) as server:
        host, port = server.address
        clock = RealClock()
        driver = JaguarDriver(UdpTransport(host, port), clock, driver_config_for(NOMINAL))
        try:
            yield ControlLoop(driver, Odometry(NOMINAL), clock, rate=20.0), server, plant
        finally:
            driver.close()


def assert_loop_equals_batch(res: LoopResult) -> None:
    log = res.log
    traj = integrate(log.t, log.left_ticks, log.right_ticks, NOMINAL)
    got = (res.final.x, res.final.y, res.final.heading)
    assert got == pytest.approx((traj.x[-1], traj.y[-1], traj.heading[-1]), abs=1e-9)


def total_dticks(res: LoopResult) -> tuple[int, int]:
    m = NOMINAL.encoder_modulus
    assert m is not None
    d = [
        (b - a + m // 2) % m - m // 2
        for a, b in zip(res.log.left_ticks, res.log.left_ticks[1:], strict=False)
    ]
    e = [
        (b - a + m // 2) % m - m // 2
        for a, b in zip(res.log.right_ticks, res.log.right_ticks[1:], strict=False)
    ]
    return sum(d), sum(e)


def test_rotate_two_pi_over_udp_jaguar_lab() -> None:
    with udp_rig(LAB) as (loop, server, plant):
        h0 = server.call(lambda b: plant.true_pose.heading)
        res = loop.run(Rotate(2 * math.pi, speed=2.0), settle=0.3)
        true = server.call(lambda b: plant.true_pose)
    assert res.completed and res.final.heading >= 2 * math.pi
    assert_loop_equals_batch(res)
    # counter-clockwise: left track in reverse, right forward. True heading change per count
    # follows the true radii over the nominal, and the true track:
    dl, dr = total_dticks(res)
    assert dl < 0 < dr
    rho_lr = LAB.left_radius_reverse / NOMINAL.left_wheel_radius
    rho_rf = LAB.right_radius_forward / NOMINAL.right_wheel_radius
    implied = (dr * MPT * rho_rf - dl * MPT * rho_lr) / LAB.track_width
    assert true.heading - h0 == pytest.approx(implied, abs=2 * MPT / LAB.track_width)
    # about the lab's 0.875 actual/predicted
    assert (true.heading - h0) / res.final.heading == pytest.approx(0.875, abs=0.01)


def test_drive_one_metre_over_udp_jaguar_lab() -> None:
    with udp_rig(LAB) as (loop, server, plant):
        res = loop.run(Straight(1.0, speed=0.8), settle=0.3)
        true = server.call(lambda b: plant.true_pose)
    assert res.completed and res.final.x >= 1.0
    assert_loop_equals_batch(res)
    dl, dr = total_dticks(res)
    sl = dl * MPT * LAB.left_radius_forward / NOMINAL.left_wheel_radius
    sr = dr * MPT * LAB.right_radius_forward / NOMINAL.right_wheel_radius
    # the true path is an arc: length (sl + sr) / 2, heading change (sr - sl) / track
    assert math.hypot(true.x, true.y) == pytest.approx(0.5 * (sl + sr), abs=2 * MPT)
    assert true.heading == pytest.approx((sr - sl) / LAB.track_width, abs=4 * MPT / LAB.track_width)
    assert true.x / res.final.x == pytest.approx(0.905, abs=0.01)


def test_ideal_truth_matches_prediction_over_udp() -> None:
    with udp_rig(TRUTH_PRESETS["ideal"]) as (loop, server, plant):
        res = loop.run(Straight(-0.4, speed=0.8), settle=0.3)
        true = server.call(lambda b: plant.true_pose)
    assert_loop_equals_batch(res)
    assert true.x == pytest.approx(res.final.x, abs=MPT)


def test_loss_and_reordering_over_udp() -> None:
    faults = Faults(drop=0.2, jitter=0.15, duplicate=0.1, corrupt=0.1)
    with udp_rig(TRUTH_PRESETS["ideal"], faults, seed=4) as (loop, server, _plant):
        res = loop.run(Straight(1.2, speed=0.6), settle=0.3)
        stats = server.board.stats
    assert res.completed and res.final.x >= 1.2
    assert_loop_equals_batch(res)
    assert stats.reports >= 20 and stats.dropped + stats.corrupted > 0
    # corrupted packets are discarded (those with a damaged STX count as garbage instead)
    assert res.stats.decode_errors <= stats.corrupted
    assert res.stats.sensor_packets <= stats.sent


def test_silent_robot_is_stopped_within_watchdog_plus_cycle() -> None:
    cycles: list[CycleInfo] = []
    with udp_rig(TRUTH_PRESETS["ideal"]) as (loop, server, _plant):

        def on_cycle(info: CycleInfo) -> None:
            cycles.append(info)
            if info.t >= 0.5 and not server.board.silent:
                server.set_silent(True)
            if not info.link_ok and info.t - first_lost(cycles) > 0.3:
                raise KeyboardInterrupt

        loop.on_cycle = on_cycle
        with pytest.raises(KeyboardInterrupt):
            loop.run(Straight(3.0, speed=0.5))
        speeds = server.call(lambda b: b.wheel_speeds)
    lost = first_lost(cycles)
    first = next(c for c in cycles if not c.link_ok)
    # timed from the kernel's arrival timestamp: >= the watchdog, within one cycle plus slack
    # plus however late the OS woke that cycle (0 on an idle machine; a loaded one starves it)
    assert 0.5 <= first.data_age <= 0.5 + 0.05 + first.lateness + 0.02, first
    assert all(c.command == (0.0, 0.0) for c in cycles if c.t >= lost)
    assert speeds == (0.0, 0.0)  # the board received the stop


def first_lost(cycles: list[CycleInfo]) -> float:
    return next((c.t for c in cycles if not c.link_ok), math.inf)
