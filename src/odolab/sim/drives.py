"""Recorded drives of the virtual robot: encoder counts and the true poses at a fixed rate.

A drive is a list of legs ``(left speed, right speed, seconds)`` (wheel surface speeds in m/s as
the nominal model understands them). :func:`record_drive` steps a :class:`VirtualRobot` through
them and samples the raw (unwrapped) encoder counts and the true pose ``rate`` times a second:
the ground truth that sensor and camera simulations start from.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.errors import SimError
from odolab.params import RobotParams
from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.trajectory import Trajectory

__all__ = ["CALIBRATION_DRIVE", "RecordedDrive", "calibration_drive", "record_drive"]

Leg = tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class RecordedDrive:
    """``t`` (s), continuous wheel counts ``ticks_left``/``ticks_right`` (shape (n,), from 0;
    ``counts_*`` the same rounded to integers as an encoder reports them) and the true poses."""

    t: NDArray[np.float64]
    ticks_left: NDArray[np.float64]
    ticks_right: NDArray[np.float64]
    truth: Trajectory

    @property
    def counts_left(self) -> NDArray[np.int64]:
        """Integer encoder counts (left)."""
        return np.floor(self.ticks_left + 0.5).astype(np.int64)

    @property
    def counts_right(self) -> NDArray[np.int64]:
        """Integer encoder counts (right)."""
        return np.floor(self.ticks_right + 0.5).astype(np.int64)


def calibration_drive(speed: float = 0.4, track: float = 0.56, repeats: int = 1) -> list[Leg]:
    """Straight lines, turns in place and arcs of both signs, forward and back (~55 s a repeat).

    The kind of drive the Censi et al. calibration needs: every wheel-speed ratio it separates
    (straight: radii; in place: track; arcs: both), turns of both signs (the sensor's offset)."""
    w = speed / (track / 2.0)  # turn rate in place with wheels at +-speed
    quarter = (math.pi / 2.0) / w
    legs: list[Leg] = [
        (speed, speed, 4.0),
        (-speed, speed, quarter),
        (speed, speed, 3.0),
        (speed, -speed, 2.0 * quarter),
        (0.5 * speed, speed, 6.0),
        (speed, 0.5 * speed, 6.0),
        (-speed, -speed, 3.0),
        (-speed, speed, 3.0 * quarter),
        (speed, 0.2 * speed, 4.0),
        (0.2 * speed, speed, 4.0),
        (speed, -speed, quarter),
        (speed, speed, 4.0),
        (-0.5 * speed, -speed, 4.0),
        (-speed, speed, 2.0 * quarter),
    ]
    return legs * repeats


CALIBRATION_DRIVE = calibration_drive()


def record_drive(
    truth: TrueParams,
    nominal: RobotParams,
    legs: Sequence[Leg],
    *,
    rate: float = 20.0,
    seed: int = 0,
    dt: float = 0.001,
    terrain: str = "tile",
) -> RecordedDrive:
    """Drive ``legs`` with the virtual robot; sample counts and true poses at ``rate`` Hz."""
    if not (math.isfinite(rate) and rate > 0):
        raise SimError(f"sample rate is {rate!r} Hz; expected a positive number")
    robot = VirtualRobot(truth, nominal, terrain, seed=seed, dt=dt)
    robot.reset(misalign=False)
    period = 1.0 / rate
    t, tl, tr = [0.0], [0.0], [0.0]
    pose = robot.true_pose
    x, y, h = [pose.x], [pose.y], [pose.heading]
    l0, r0 = robot.wheel_ticks()
    clock = 0.0
    for vl, vr, seconds in legs:
        if not (math.isfinite(seconds) and seconds >= 0):
            raise SimError(f"a leg lasts {seconds!r} s; expected a number of seconds >= 0")
        robot.set_wheel_speeds(vl, vr)
        for _ in range(round(seconds * rate)):
            robot.advance(period)
            clock += period
            wl, wr = robot.wheel_ticks()
            pose = robot.true_pose
            t.append(clock)
            tl.append(wl - l0)
            tr.append(wr - r0)
            x.append(pose.x)
            y.append(pose.y)
            h.append(pose.heading)
    robot.set_wheel_speeds(0.0, 0.0)
    tt = np.array(t)
    return RecordedDrive(tt, np.array(tl), np.array(tr), Trajectory.from_xyh(tt, x, y, h))
