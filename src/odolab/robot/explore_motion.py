"""An exploration motion for the live stack: commands over the input space, a hard geofence.

The control loop's :class:`~odolab.robot.motions.Motion` for issue 29's exploration (the live
twin of :func:`odolab.sim.explore.explore`, which the robot layer may not import): every
``hold`` seconds (uniform between its two values) it draws a forward speed and turn rate
uniformly within ``|v| <= max_speed``, ``|w| <= max_turn_rate`` and both wheel speeds
``v -+ w b/2`` within ``max_speed``; beyond ``return_fraction`` of the fence radius and moving
outward it turns in place toward the centre, then drives a drawn command forward. The fence
(a circle of ``fence_radius`` m about the start pose, by odometry) is a hard limit: the cycle
that finds the robot outside it answers None (stop) and sets :attr:`Explore.fence_crossed`;
after ``seconds`` it answers None too. Every other safety rule is the loop's own.

Not yet registered as ``odolab robot explore``: the live commands are built from a
:class:`odolab.trials.Command`, which has no exploration kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from odolab.params import RobotParams
from odolab.robot.errors import MotionError
from odolab.trajectory import Pose

__all__ = ["Explore"]


@dataclass
class Explore:
    """Exploration by odometry inside a hard geofence (see the module)."""

    seconds: float = 60.0
    max_speed: float = 0.5
    max_turn_rate: float = 1.0
    hold: tuple[float, float] = (1.0, 3.0)
    fence_radius: float = 3.0
    return_fraction: float = 0.6
    seed: int = 0
    #: True once a cycle found the robot outside the fence (the motion then stopped)
    fence_crossed: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        for key in ("seconds", "max_speed", "max_turn_rate", "fence_radius"):
            value = getattr(self, key)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise MotionError(f"exploration {key} is {value!r}, expected a positive number")
        lo, hi = self.hold
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
            raise MotionError(f"exploration hold is {self.hold!r} s, expected 0 < low <= high")
        if not 0 < self.return_fraction < 1:
            raise MotionError(
                f"exploration return_fraction is {self.return_fraction!r}, expected 0 to 1"
            )
        self._rng = np.random.default_rng(self.seed)
        self._centre = (0.0, 0.0)
        self._t0 = math.nan
        self._until = -math.inf
        self._half = 0.0
        self._cmd = (0.0, 0.0)
        self._returning = False

    def start(self, pose: Pose, params: RobotParams) -> None:
        self._centre = (pose.x, pose.y)
        self._t0 = pose.t
        self._half = 0.5 * params.track_width
        self._until = -math.inf
        self._returning = False
        self.fence_crossed = False

    def _draw(self, t: float, forward: bool = False) -> None:
        for _ in range(1000):
            v = float(self._rng.uniform(-self.max_speed, self.max_speed))
            w = float(self._rng.uniform(-self.max_turn_rate, self.max_turn_rate))
            if forward:
                v = abs(v)
            if abs(v) + abs(w) * self._half <= self.max_speed:
                self._cmd = (v, w)
                self._until = t + float(self._rng.uniform(*self.hold))
                return
        raise MotionError("no exploration command within the wheel speed limit")

    def step(self, pose: Pose) -> tuple[float, float] | None:
        t = pose.t if math.isfinite(pose.t) else self._t0
        if not t - self._t0 < self.seconds:
            return None
        dx, dy = pose.x - self._centre[0], pose.y - self._centre[1]
        r = math.hypot(dx, dy)
        if r > self.fence_radius:
            self.fence_crossed = True
            return None
        v, w = self._cmd
        outward = v * (dx * math.cos(pose.heading) + dy * math.sin(pose.heading)) > 0
        if self._returning:
            err = math.atan2(-dy, -dx) - pose.heading
            err = math.atan2(math.sin(err), math.cos(err))
            if abs(err) < 0.2:
                self._returning = False
                self._draw(t, forward=True)
            else:
                rate = min(self.max_turn_rate, self.max_speed / self._half)
                self._cmd = (0.0, math.copysign(rate, err))
        elif r > self.return_fraction * self.fence_radius and (outward or t >= self._until):
            self._returning = True
            return self.step(pose)
        elif t >= self._until:
            self._draw(t)
        v, w = self._cmd
        return (v - w * self._half, v + w * self._half)
