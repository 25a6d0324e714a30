"""Motions by odometry: wheel speeds from poses, and when they stop."""

from __future__ import annotations

import math

import pytest

from odolab.core.errors import SimError
from odolab.core.params import PRESETS
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, MotionKind
from odolab.robot.motions import Pivot, Rotate, Straight, motion_from_command, square
from odolab.robot.session import run_motion_simulated

NOMINAL = PRESETS["jaguar-lite"]


def pose(x: float = 0.0, y: float = 0.0, h: float = 0.0) -> Pose:
    return Pose(0.0, x, y, math.atan2(math.sin(h), math.cos(h)), h)


def test_rotate_speeds_and_stop() -> None:
    m = Rotate(-3 * math.pi, speed=0.5)
    m.start(pose(h=1.0), NOMINAL)
    # clockwise: left forward, right backward, 0.5 rad/s * 0.28 m = 0.14 m/s
    assert m.step(pose(h=1.0)) == pytest.approx((0.14, -0.14))
    assert m.step(pose(h=1.0 - 3 * math.pi + 1e-6)) is not None
    assert m.step(pose(h=1.0 - 3 * math.pi)) is None


def test_rotate_decelerates_linearly() -> None:
    m = Rotate(math.pi, speed=1.0, decel=0.5, min_fraction=0.2)
    m.start(pose(), NOMINAL)
    assert m.step(pose(h=math.pi - 0.25)) == pytest.approx((-0.14, 0.14))  # half of 0.28
    assert m.step(pose(h=math.pi - 0.01)) == pytest.approx((-0.056, 0.056))  # floor 20 %


def test_straight_projects_on_start_heading() -> None:
    m = Straight(-2.0, speed=0.4)
    m.start(pose(1.0, 1.0, math.pi / 2), NOMINAL)  # facing +y; reverse goes to -y
    assert m.step(pose(1.0, 1.0, math.pi / 2)) == (-0.4, -0.4)
    assert m.step(pose(1.3, -0.99, math.pi / 2)) is not None  # 1.99 m back along -y
    assert m.step(pose(1.3, -1.0, math.pi / 2)) is None


def test_pivot_moves_one_track() -> None:
    m = Pivot(math.pi / 2, held="left", speed=0.5)
    m.start(pose(), NOMINAL)
    assert m.step(pose()) == pytest.approx((0.0, 0.28))  # 0.5 rad/s * 0.56 m
    m = Pivot(math.pi / 2, held="right", speed=0.5)
    m.start(pose(), NOMINAL)
    assert m.step(pose()) == pytest.approx((-0.28, 0.0))
    with pytest.raises(SimError):
        Pivot(1.0, held="middle")


def test_square_in_simulation_closes_on_ideal_robot() -> None:
    trial, stats = run_motion_simulated(
        Command(MotionKind.SQUARE, side=1.0, direction="cw", speed=0.5), NOMINAL, NOMINAL
    )
    p = trial.predicted
    # four sides and four -90 degree turns; each turn overshoots by at most the turn rate times
    # the data latency (one 10 Hz report period plus one 20 Hz cycle): 0.5 * 0.15 = 0.075 rad
    assert -2 * math.pi - 4 * 0.075 <= p.heading <= -2 * math.pi
    assert math.hypot(p.x, p.y) < 0.3
    assert trial.true is not None
    assert math.hypot(trial.true.x - p.x, trial.true.y - p.y) < 0.01
    assert stats.cycles > 4 * 40


def test_motion_from_command() -> None:
    assert isinstance(motion_from_command(Command(MotionKind.ROTATION, angle=1.0)), Rotate)
    m = motion_from_command(Command(MotionKind.TRANSLATION, distance=2.0, speed=0.7))
    assert isinstance(m, Straight) and m.speed == 0.7
    with pytest.raises(SimError, match="cannot drive"):
        motion_from_command(Command(MotionKind.FREE))
    with pytest.raises(SimError):
        square(1.0, "sideways")
