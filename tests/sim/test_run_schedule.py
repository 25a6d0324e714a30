"""A schedule of wheel speeds run in one compiled loop (VirtualRobot.run_schedule, which
sim.drives.drive and record_drive use) gives the numbers of set_wheel_speeds and advance called
report by report: the same draws in the same order, the abrupt stops' slides, the stalls."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core.errors import SimError
from odolab.core.params import PRESETS
from odolab.sim.drives import Leg, drive, random_legs
from odolab.sim.physics import VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]


def _one_by_one(
    robot: VirtualRobot, left: np.ndarray, right: np.ndarray, period: float
) -> np.ndarray:
    rows = []
    for vl, vr in zip(left, right, strict=True):
        robot.set_wheel_speeds(vl, vr)
        robot.advance(period)
        p = robot.true_pose
        rows.append((robot.time, *robot.wheel_ticks(), p.x, p.y, p.heading))
    return np.array(rows)


def _speeds(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Random speeds with stops (both 0), turns in place (opposite signs) and repeats."""
    rng = np.random.default_rng(seed)
    left = rng.choice([-0.4, -0.1, 0.0, 0.2, 0.5], n)
    right = rng.choice([-0.3, 0.0, 0.1, 0.4], n)
    left[rng.random(n) < 0.15] = 0.0
    right[left == 0.0] = 0.0  # some abrupt stops
    return left, right


@pytest.mark.parametrize("truth", ["jaguar-lab", "jaguar-lab-tracked", "ideal"])
@pytest.mark.parametrize("terrain", ["tile", "grass"])
@pytest.mark.parametrize(("period", "dt"), [(0.05, 0.005), (0.05, 0.001), (0.033, 0.005)])
def test_a_schedule_equals_the_calls_one_by_one(
    truth: str, terrain: str, period: float, dt: float
) -> None:
    left, right = _speeds(7, 120)
    a = VirtualRobot(TRUTH_PRESETS[truth], NOMINAL, terrain, seed=3, dt=dt)
    b = VirtualRobot(TRUTH_PRESETS[truth], NOMINAL, terrain, seed=3, dt=dt)
    want = _one_by_one(a, left, right, period)
    got = b.run_schedule(left, right, period)
    np.testing.assert_array_equal(got, want)  # to the bit
    # and the robot goes on from the same state: time, speeds, stall, generator
    assert (b.time, b.wheel_speeds, b.stalled) == (a.time, a.wheel_speeds, a.stalled)
    np.testing.assert_array_equal(
        b.run_schedule(left[:9], right[:9], period), _one_by_one(a, left[:9], right[:9], period)
    )


def _drive_one_by_one(truth: str, legs: list[Leg], terrain: str, seed: int) -> list[np.ndarray]:
    """sim.drives.drive as it was written before run_schedule: a Python loop of reports."""
    robot = VirtualRobot(TRUTH_PRESETS[truth], NOMINAL, terrain, seed=seed, dt=0.005)
    robot.reset(misalign=False)
    period = 0.05
    p = robot.true_pose
    rows = [(robot.time, *robot.wheel_ticks(), p.x, p.y, p.heading)]
    stalled = False
    vl0, vr0 = 0.0, 0.0
    for leg in [*legs, Leg(0.0, 0.0, 0.5)]:
        for k in range(max(1, round(leg.duration / period))):
            if leg.ramp > 0 and (k + 0.5) * period < leg.ramp:
                f = (k + 0.5) * period / leg.ramp
                vl, vr = vl0 + f * (leg.left - vl0), vr0 + f * (leg.right - vr0)
            else:
                vl, vr = leg.left, leg.right
            robot.set_wheel_speeds(vl, vr)
            robot.advance(period)
            stalled = stalled or robot.stalled
            p = robot.true_pose
            rows.append((robot.time, *robot.wheel_ticks(), p.x, p.y, p.heading))
        vl0, vr0 = leg.left, leg.right
    a = np.array(rows)
    ticks = np.floor(a[:, 1:3] + 0.5)
    d = np.diff(ticks, axis=0, prepend=ticks[:1])
    return [a[:, 0], d[:, 0], d[:, 1], a[:, 3], a[:, 4], a[:, 5], np.array([stalled])]


@pytest.mark.parametrize("terrain", ["tile", "grass"])
def test_a_drive_equals_its_reports_one_by_one(terrain: str) -> None:
    """Ramped legs ease in from the previous leg's speeds; on grass a turn in place stalls (no
    draw, no motion) and the drive says so."""
    legs = [*random_legs(np.random.default_rng(2), 8), Leg(0.3, 0.3, 1.0, ramp=0.4),
            Leg(-0.2, 0.2, 0.7, ramp=0.3)]  # fmt: skip
    d = drive(TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL, legs, terrain=terrain, seed=5)
    want = _drive_one_by_one("jaguar-lab-tracked", legs, terrain, 5)
    got = [d.t, d.dticks_left, d.dticks_right, d.x, d.y, d.heading, np.array([d.stalled])]
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
    assert d.stalled == (terrain == "grass")


def test_a_bad_schedule_is_refused_in_one_sentence() -> None:
    robot = VirtualRobot(TRUTH_PRESETS["ideal"], NOMINAL, "tile", seed=0)
    with pytest.raises(SimError, match="as many left as right"):
        robot.run_schedule(np.zeros(3), np.zeros(4), 0.05)
    with pytest.raises(SimError, match="finite"):
        robot.run_schedule(np.array([0.1, np.nan]), np.zeros(2), 0.05)
    with pytest.raises(SimError, match="finite number >= 0"):
        robot.run_schedule(np.zeros(2), np.zeros(2), -1.0)
    assert robot.run_schedule(np.zeros(0), np.zeros(0), 0.05).shape == (0, 6)
