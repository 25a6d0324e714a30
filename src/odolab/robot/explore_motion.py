"""An exploration motion for the live stack: commands over the input space, a hard geofence.

The control loop's :class:`~odolab.robot.motions.Motion` for issue 29's exploration (the live
twin of :func:`odolab.sim.explore.explore`, which the robot layer may not import), driven by
``odolab robot explore`` (:mod:`odolab.robot.explore`; built from the
:class:`odolab.trials.Command` of an exploration by :meth:`Explore.from_exploration`): every
``hold`` seconds (uniform between its two values) it draws a forward speed and turn rate within
``|v| <= max_speed``, ``|w| <= max_turn_rate`` and both wheel speeds ``v -+ w b/2`` within
``max_speed`` - uniformly, or with ``distribution = "edges"`` three in four of each from the
outer half of its range, as the simulator's twin does. A draw whose faster track would run
below ``min_fraction`` of ``max_speed`` is drawn again: a motor's dead band would hold the
robot still and the loop's stall rule would end the run. Beyond ``return_fraction`` of the fence
radius and moving outward (or at the end of a hold there) it turns in place toward the centre,
then drives a drawn command forward. The fence (a circle of ``fence_radius`` m about the start
pose, by odometry) is a hard limit: the cycle that finds the robot outside it answers None (the
loop stops the robot) and sets :attr:`Explore.fence_crossed`; after ``seconds`` it answers None
too. Every command it starts is kept in :attr:`Explore.commands`. Every other safety rule is the
loop's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from odolab.params import RobotParams
from odolab.robot.errors import MotionError
from odolab.trajectory import Pose
from odolab.trials import EXPLORE_DISTRIBUTIONS, Command, draw_exploration_value

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
    distribution: str = "uniform"
    min_fraction: float = 0.1
    #: True once a cycle found the robot outside the fence (the motion then stopped)
    fence_crossed: bool = field(default=False, init=False)
    #: (t, distance from the centre m) of the cycle that found the fence crossed
    crossed_at: tuple[float, float] | None = field(default=None, init=False)
    #: every command started: (t s, forward speed m/s, turn rate rad/s), t on the loop's clock
    commands: list[tuple[float, float, float]] = field(default_factory=list, init=False)

    @classmethod
    def from_exploration(cls, command: Command) -> Explore:
        """The motion of an exploration's command (its limits chosen; see check_motion)."""
        e = command.explore
        if e is None:
            raise MotionError(f"cannot explore with a {command.describe()!r} command")
        if e.max_speed is None or e.max_turn_rate is None:
            raise MotionError("exploration speed limits are not chosen; expected numbers")
        return cls(
            seconds=e.seconds,
            max_speed=e.max_speed,
            max_turn_rate=e.max_turn_rate,
            hold=(float(e.hold[0]), float(e.hold[1])),
            fence_radius=e.fence,
            seed=e.seed,
            distribution=e.distribution,
        )

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
        if not 0 <= self.min_fraction < 0.5:
            raise MotionError(
                f"exploration min_fraction is {self.min_fraction!r}, expected 0 up to 0.5"
            )
        if self.distribution not in EXPLORE_DISTRIBUTIONS:
            raise MotionError(
                f"exploration distribution is {self.distribution!r}; expected one of "
                f"{', '.join(EXPLORE_DISTRIBUTIONS)}"
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
        self.crossed_at = None
        self.commands = []

    def _set(self, t: float, v: float, w: float) -> None:
        if (v, w) != self._cmd or not self.commands:
            self.commands.append((t, v, w))
        self._cmd = (v, w)

    def _draw(self, t: float, forward: bool = False) -> None:
        floor = self.min_fraction * self.max_speed
        for _ in range(1000):
            v = draw_exploration_value(self._rng, self.max_speed, self.distribution)
            w = draw_exploration_value(self._rng, self.max_turn_rate, self.distribution)
            if forward:
                v = abs(v)
            fastest = abs(v) + abs(w) * self._half
            if floor <= fastest <= self.max_speed:
                self._set(t, v, w)
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
            self.crossed_at = (t, r)
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
                self._set(t, 0.0, math.copysign(rate, err))
        elif r > self.return_fraction * self.fence_radius and (outward or t >= self._until):
            self._returning = True
            return self.step(pose)
        elif t >= self._until:
            self._draw(t)
        v, w = self._cmd
        return (v - w * self._half, v + w * self._half)
