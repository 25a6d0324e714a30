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
from odolab.sim.terrains import Terrain

__all__ = ["Drive", "Leg", "drive", "random_legs"]


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
