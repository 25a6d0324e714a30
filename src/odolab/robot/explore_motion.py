"""An exploration motion for the live stack: commands over the input space, a hard geofence.

The control loop's :class:`~odolab.robot.motions.Motion` for issue 29's exploration (the live
twin of :func:`odolab.sim.explore.explore`, which the robot layer may not import), driven by
``odolab robot explore`` (:mod:`odolab.robot.explore`; built from the
:class:`odolab.core.trials.Command` of an exploration by :meth:`Explore.from_exploration`): every
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

The fence under uncertainty: odometry drifts, so the true robot can leave a fence that the
odometry never left (issue 39: 2 of 4 explorations of a tracked Jaguar inside a 0.5 m fence).
The motion makes the loop's odometry itself (:meth:`Explore.odometry`), with the covariance
propagated (the parameters' ``[noise]`` table, a slip model's own variance, else
:data:`FENCE_NOISE`), and shrinks the fence each cycle by the margin ``k * sqrt(largest
eigenvalue of the position covariance)``, ``k`` the radius of the 2-D normal's ``confidence``
region (2.45 at 95 %): it turns back where the odometry's position plus the margin passes the
return radius, stops where it passes the fence, and ends the exploration when the margin
leaves no room inside the return radius (:attr:`Explore.uncertainty_stop`). The largest margin
is kept in :attr:`Explore.largest_margin`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from odolab.core.kinematics import wrap_angle
from odolab.core.models import own_covariance
from odolab.core.params import NoiseParams, RobotParams
from odolab.core.trajectory import Pose
from odolab.core.trials import EXPLORE_DISTRIBUTIONS, Command, draw_exploration_value
from odolab.robot.errors import MotionError

if TYPE_CHECKING:
    from odolab.core.odometry import Odometry

__all__ = ["FENCE_CONFIDENCE", "FENCE_NOISE", "Explore", "fence_margin"]

#: The confidence at which the fence is kept under the odometry's uncertainty.
FENCE_CONFIDENCE = 0.95
#: The odometry's random error assumed for the fence when the parameters have no ``[noise]``
#: table (nor a slip model); a stated default, not a measurement: per-wheel variance 2e-3 m per
#: metre rolled (100 times the tracked virtual Jaguar's 2e-5 m, to stand for an uncalibrated
#: robot's systematic error too) and 0.05 rad of heading variance per radian turned. With it
#: the tracked virtual Jaguar stays inside a 0.5 m fence in 4 of 4 seeds (it left it in 3 by
#: odometry alone; ``tests/robot/test_fence_uncertainty.py``).
FENCE_NOISE = NoiseParams(k_left=2e-3, k_right=2e-3, k_scrub=0.05)


def fence_margin(terms: tuple[float, ...], confidence: float = FENCE_CONFIDENCE) -> float:
    """The radius (m) of the circle about the odometry's position that holds the true position
    with probability ``confidence`` or more: ``k * sqrt(largest eigenvalue)`` of the position
    covariance (``terms`` in :data:`odolab.core.uncertainty.COV_COLUMNS`), ``k = sqrt(-2 ln(1 -
    confidence))`` the radius of a 2-D standard normal's region (2.45 at 95 %)."""
    a, b, c = float(terms[0]), float(terms[1]), float(terms[3])
    largest = 0.5 * (a + c) + math.hypot(0.5 * (a - c), b)
    if not (math.isfinite(largest) and largest > 0):
        return 0.0 if largest == 0 else math.inf
    return math.sqrt(-2.0 * math.log(1.0 - confidence)) * math.sqrt(largest)


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
    #: the confidence the fence is kept at under the odometry's uncertainty (0: the fence by
    #: odometry alone, as before issue 39)
    confidence: float = FENCE_CONFIDENCE
    #: the odometry's random error for the fence when the parameters have none
    noise: NoiseParams = FENCE_NOISE
    #: where the fence's covariance comes from (set by :meth:`odometry`; "" without it)
    noise_source: str = field(default="", init=False)
    #: the largest margin the fence was shrunk by (m)
    largest_margin: float = field(default=0.0, init=False)
    #: (t, distance from the centre m, margin m) of the cycle that ended the exploration for
    #: its uncertainty (at the fence, or no room left inside the return radius)
    uncertainty_stop: tuple[float, float, float] | None = field(default=None, init=False)
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
        if not (isinstance(self.confidence, int | float) and 0 <= self.confidence < 1):
            raise MotionError(
                f"exploration confidence is {self.confidence!r}, expected 0 up to 1 (0.95: 95 %)"
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
        self._odometry: Odometry | None = None

    def odometry(self, params: RobotParams) -> Odometry:
        """The loop's odometry, with the covariance the fence reads (see the module)."""
        from odolab.core.odometry import Odometry

        if own_covariance(params.model) is not None:
            self.noise_source = "the slip model's own predictive variance"
        elif params.noise is not None:
            self.noise_source = "the parameters' [noise] table"
        else:
            n = self.noise
            self.noise_source = (
                f"odolab's default for the fence (k_left {n.k_left:g} m, k_right {n.k_right:g} "
                f"m, k_scrub {n.k_scrub:g} rad; the parameters have no [noise] table)"
            )
            params = params.with_(noise=n)
        self._odometry = Odometry(params, covariance=self.confidence > 0)
        return self._odometry

    def margin(self) -> float:
        """The fence's margin now (m): 0 without a covariance (see the module)."""
        odo = self._odometry
        if odo is None or self.confidence <= 0:
            return 0.0
        return fence_margin(odo.covariance, self.confidence)

    def start(self, pose: Pose, params: RobotParams) -> None:
        self._centre = (pose.x, pose.y)
        self._t0 = pose.t
        self._half = 0.5 * params.track_width
        self._until = -math.inf
        self._returning = False
        self.fence_crossed = False
        self.crossed_at = None
        self.uncertainty_stop = None
        self.largest_margin = 0.0
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
        margin = self.margin()
        self.largest_margin = max(self.largest_margin, margin)
        inner = self.return_fraction * self.fence_radius
        if r + margin > self.fence_radius or margin >= inner:
            # the true robot may be outside the fence (or soon will be, wherever it turns)
            self.uncertainty_stop = (t, r, margin)
            return None
        v, w = self._cmd
        outward = v * (dx * math.cos(pose.heading) + dy * math.sin(pose.heading)) > 0
        if self._returning:
            err = math.atan2(-dy, -dx) - pose.heading
            err = wrap_angle(err)
            if abs(err) < 0.2:
                self._returning = False
                self._draw(t, forward=True)
            else:
                rate = min(self.max_turn_rate, self.max_speed / self._half)
                self._set(t, 0.0, math.copysign(rate, err))
        elif r + margin > inner and (outward or t >= self._until):
            self._returning = True
            return self.step(pose)
        elif t >= self._until:
            self._draw(t)
        v, w = self._cmd
        return (v - w * self._half, v + w * self._half)
