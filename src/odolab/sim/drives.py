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


def drive(
    truth: TrueParams,
    nominal: RobotParams,
    legs: Sequence[Leg],
    *,
    terrain: str | Terrain = "tile",
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
    rows: list[tuple[float, float, float, float, float, float]] = []
    stalled = False

    def record() -> None:
        p = robot.true_pose
        wl, wr = robot.wheel_ticks()
        rows.append((robot.time, wl, wr, p.x, p.y, p.heading))

    record()
    vl0, vr0 = 0.0, 0.0
    plan = [*legs, Leg(0.0, 0.0, max(settle, period))]
    for leg in plan:
        n = max(1, round(leg.duration / period))
        for k in range(n):
            if leg.ramp > 0 and (k + 0.5) * period < leg.ramp:
                f = (k + 0.5) * period / leg.ramp
                vl, vr = vl0 + f * (leg.left - vl0), vr0 + f * (leg.right - vr0)
            else:
                vl, vr = leg.left, leg.right
            robot.set_wheel_speeds(vl, vr)
            robot.advance(period)
            stalled = stalled or robot.stalled
            record()
        vl0, vr0 = leg.left, leg.right
    a = np.array(rows)
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
    terrain: str = "tile",
) -> RecordedDrive:
    """Drive ``legs`` (:class:`Leg` or ``(left, right, seconds)``) with the virtual robot; sample
    the counts and true poses at ``rate`` Hz. A leg's ``ramp`` eases in as in :func:`drive`."""
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
    vl0, vr0 = 0.0, 0.0
    for item in legs:
        leg = item if isinstance(item, Leg) else Leg(*item)
        for k in range(round(leg.duration * rate)):
            if leg.ramp > 0 and (k + 0.5) * period < leg.ramp:
                f = (k + 0.5) * period / leg.ramp
                robot.set_wheel_speeds(vl0 + f * (leg.left - vl0), vr0 + f * (leg.right - vr0))
            elif k == 0 or leg.ramp > 0:
                robot.set_wheel_speeds(leg.left, leg.right)
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
        vl0, vr0 = leg.left, leg.right
    robot.set_wheel_speeds(0.0, 0.0)
    tt = np.array(t)
    return RecordedDrive(tt, np.array(tl), np.array(tr), Trajectory.from_xyh(tt, x, y, h))
