"""Free drives of the virtual robot: wheel-speed legs in time, recorded with the true pose.

A protocol (:mod:`odolab.sim.protocols`) drives the lab's motions by odometry and measures only
their end; a *drive* is what a motion-capture run records: the wheels follow a list of
:class:`Leg` (left and right wheel surface speeds as the nominal model understands them, for a
duration, optionally easing to the next leg's speeds), and every report period the encoder counts
and the true pose are written down. Calibration of a kinematic model needs such runs: curves of
several radii and turns of both signs.

The physics is :class:`~odolab.sim.physics.VirtualRobot` (the live loop's): a stop (both speeds
0 after motion) is abrupt and slides by the truth's ``stop_slide``; a leg with ``ramp`` > 0 eases
the speeds linearly from the previous leg's over its first ``ramp`` seconds (a gradual stop is a
leg to speeds 0 with a ramp).

:func:`record_drive` is the same walk sampled for the ground-truth simulations (camera, laser,
odometry + sensor calibration): continuous (unrounded) wheel counts from 0 and the true poses as a
:class:`~odolab.core.trajectory.Trajectory`, without the final stop; :func:`calibration_drive` is the
kind of drive the Censi et al. calibration needs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.params import RobotParams
from odolab.core.trajectory import Trajectory
from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.sim.terrains import Terrain

__all__ = [
    "CALIBRATION_DRIVE",
    "Drive",
    "Leg",
    "RecordedDrive",
    "calibration_drive",
    "drive",
    "random_legs",
    "record_drive",
]


@dataclass(frozen=True)
class Leg:
    """Wheel surface speeds (m/s, nominal) held for ``duration`` s, eased in over ``ramp`` s."""

    left: float
    right: float
    duration: float
    ramp: float = 0.0

    def __post_init__(self) -> None:
        for key in ("left", "right", "duration", "ramp"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise SimError(f"leg {key} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise SimError(f"leg {key} must be finite, got {value!r}")
        if self.duration <= 0 or self.ramp < 0 or self.ramp > self.duration:
            raise SimError(
                f"leg duration {self.duration!r} s must be > 0 and its ramp {self.ramp!r} s "
                "between 0 and the duration"
            )


@dataclass(frozen=True, eq=False)
class Drive:
    """A recorded drive: report stamps, per-report tick increments, true poses (tape frame)."""

    t: NDArray[np.float64]
    dticks_left: NDArray[np.float64]
    dticks_right: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    heading: NDArray[np.float64]
    stalled: bool


def _schedule(
    legs: Sequence[Leg], reports: Sequence[int], period: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The wheel speeds (left, right) commanded at each report: ``reports[i]`` reports of
    ``period`` seconds for leg ``i``, whose ``ramp`` eases in from the previous leg's speeds
    (from rest before the first), at each report's middle."""
    left: list[NDArray[np.float64]] = [np.empty(0)]
    right: list[NDArray[np.float64]] = [np.empty(0)]
    vl0, vr0 = 0.0, 0.0
    for leg, n in zip(legs, reports, strict=True):
        vl = np.full(n, float(leg.left))
        vr = np.full(n, float(leg.right))
        if leg.ramp > 0:
            mid = (np.arange(n) + 0.5) * period  # each report's middle, as a float per report
            easing = mid < leg.ramp
            f = mid[easing] / leg.ramp
            vl[easing] = vl0 + f * (leg.left - vl0)
            vr[easing] = vr0 + f * (leg.right - vr0)
        left.append(vl)
        right.append(vr)
        vl0, vr0 = leg.left, leg.right
    return np.concatenate(left), np.concatenate(right)


def drive(
    truth: TrueParams,
    nominal: RobotParams,
    legs: Sequence[Leg],
    *,
    terrain: str | Terrain = DEFAULT_TERRAIN,
    report_rate: float = 20.0,
    dt: float = 0.005,
    seed: int = 0,
    settle: float = 0.5,
) -> Drive:
    """Drive the legs one after the other and record them (see the module); then stop and wait
    ``settle`` seconds. The start pose is the origin, without misalignment."""
    if not legs:
        raise SimError("a drive needs at least one leg")
    if not (math.isfinite(report_rate) and report_rate > 0):
        raise SimError(f"report rate must be a positive number of Hz, got {report_rate!r}")
    robot = VirtualRobot(truth, nominal, terrain, seed=seed, dt=dt)
    robot.reset(misalign=False)
    period = 1.0 / report_rate
    plan = [*legs, Leg(0.0, 0.0, max(settle, period))]
    left, right = _schedule(plan, [max(1, round(leg.duration / period)) for leg in plan], period)
    p = robot.true_pose
    a = np.vstack([[(p.t, *robot.wheel_ticks(), p.x, p.y, p.heading)],
                   robot.run_schedule(left, right, period)])  # fmt: skip
    # stalled at some report: robot.stalled's rule (a turn in place where none can be made)
    stalled = not robot.terrain.can_turn_in_place and bool(np.any(left * right < 0.0))
    ticks_l = np.floor(a[:, 1] + 0.5)
    ticks_r = np.floor(a[:, 2] + 0.5)
    dl = np.diff(ticks_l, prepend=ticks_l[0])
    dr = np.diff(ticks_r, prepend=ticks_r[0])
    return Drive(a[:, 0], dl, dr, a[:, 3], a[:, 4], a[:, 5], stalled)


def random_legs(
    rng: np.random.Generator,
    n: int,
    *,
    speed: float = 0.4,
    track_width: float = 0.56,
    min_duration: float = 1.0,
    max_duration: float = 3.0,
) -> list[Leg]:
    """``n`` legs of random motion for calibration runs: straight, curves of radius 0.3 m to
    5 m, pivots on either track and turns in place, both directions and both turn signs, at
    wheel speeds up to ``speed`` (m/s)."""
    legs = []
    half = track_width / 2.0
    for _ in range(n):
        kind = rng.integers(0, 4)
        v = float(rng.uniform(0.3, 1.0)) * speed
        sign = 1.0 if rng.random() < 0.5 else -1.0
        if kind == 0:  # straight, forward or reverse
            left = right = v * (1.0 if rng.random() < 0.8 else -1.0)
        elif kind == 1:  # a curve of radius R: wheel speeds omega * (R -+ half)
            radius = float(np.exp(rng.uniform(math.log(0.3), math.log(5.0))))
            omega = v / (radius + half)
            left, right = omega * (radius - sign * half), omega * (radius + sign * half)
        elif kind == 2:  # pivot on one track
            left, right = (0.0, sign * v) if rng.random() < 0.5 else (-sign * v, 0.0)
        else:  # turn in place
            left, right = -sign * v, sign * v
        legs.append(Leg(left, right, float(rng.uniform(min_duration, max_duration))))
    return legs


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
    table = [
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
    return [Leg(left, right, seconds) for left, right, seconds in table] * repeats


CALIBRATION_DRIVE = calibration_drive()


def record_drive(
    truth: TrueParams,
    nominal: RobotParams,
    legs: Sequence[Leg | tuple[float, float, float]],
    *,
    rate: float = 20.0,
    seed: int = 0,
    dt: float = 0.001,
    terrain: str = DEFAULT_TERRAIN,
) -> RecordedDrive:
    """Drive ``legs`` (:class:`Leg` or ``(left, right, seconds)``) with the virtual robot; sample
    the counts and true poses at ``rate`` Hz. A leg's ``ramp`` eases in as in :func:`drive`."""
    if not (math.isfinite(rate) and rate > 0):
        raise SimError(f"sample rate is {rate!r} Hz; expected a positive number")
    robot = VirtualRobot(truth, nominal, terrain, seed=seed, dt=dt)
    robot.reset(misalign=False)
    period = 1.0 / rate
    plan = [item if isinstance(item, Leg) else Leg(*item) for item in legs]
    left, right = _schedule(plan, [round(leg.duration * rate) for leg in plan], period)
    p = robot.true_pose
    l0, r0 = robot.wheel_ticks()
    rows = robot.run_schedule(left, right, period)
    # the robot's clock: from 0 at its construction, a period added at each report
    tt = np.concatenate([[0.0], rows[:, 0]])
    tl = np.concatenate([[0.0], rows[:, 1] - l0])
    tr = np.concatenate([[0.0], rows[:, 2] - r0])
    x = np.concatenate([[p.x], rows[:, 3]])
    y = np.concatenate([[p.y], rows[:, 4]])
    h = np.concatenate([[p.heading], rows[:, 5]])
    return RecordedDrive(tt, tl, tr, Trajectory.from_xyh(tt, x, y, h))
