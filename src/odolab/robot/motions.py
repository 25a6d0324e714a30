"""Motions "by odometry": each turns the current odometry pose into wheel speeds until done.

A motion is started with the pose at its start and the nominal parameters, then asked once per
control cycle for wheel speeds; it answers None when the odometry says the target is reached.
With ``decel`` set, the speed falls linearly over the last ``decel`` metres (or radians) of the
motion, to ``min_fraction`` of the cruise speed, so the robot does not stop abruptly.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from odolab.core.odometry import Odometry
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, MotionKind
from odolab.robot.errors import MotionError
from odolab.robot.explore_motion import Explore

__all__ = [
    "Motion",
    "MotionSequence",
    "OwnsOdometry",
    "Pivot",
    "Rotate",
    "Straight",
    "motion_from_command",
    "odometry_for",
    "square",
]


class Motion(Protocol):
    """What the control loop asks of a motion."""

    def start(self, pose: Pose, params: RobotParams) -> None:
        """Begin at ``pose`` (odometry frame) with the nominal parameters."""
        ...

    def step(self, pose: Pose) -> tuple[float, float] | None:
        """Wheel speeds (left, right) in m/s for this cycle, or None when the target is reached."""
        ...


@runtime_checkable
class OwnsOdometry(Protocol):
    """A motion that needs more of the loop's odometry than its pose (the exploration's fence
    reads the propagated covariance): it makes the loop's :class:`~odolab.core.odometry.Odometry`."""

    def odometry(self, params: RobotParams) -> Odometry:
        """The odometry the loop runs with ``params`` (it keeps it to read each cycle)."""
        ...


def odometry_for(motion: Motion | None, params: RobotParams) -> Odometry:
    """The loop's odometry for ``motion``: its own (:class:`OwnsOdometry`), else the plain one."""
    if isinstance(motion, OwnsOdometry):
        return motion.odometry(params)
    return Odometry(params)


def _scale(remaining: float, decel: float, min_fraction: float) -> float:
    if decel <= 0 or remaining >= decel:
        return 1.0
    return max(min_fraction, remaining / decel)


def _check_positive(name: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise MotionError(f"motion {name} is {value!r}, expected a positive number")
    return v


class _Turn(ABC):
    """A turn by ``angle`` rad measured on the odometry heading (:class:`Rotate`,
    :class:`Pivot`): the moving track(s) run at ``speed`` (rad/s of heading) times a lever (m
    per rad: :meth:`_lever_arm`), slowing down over the last ``decel`` radians; :meth:`_wheels`
    says which track runs which way."""

    angle: float
    speed: float
    decel: float
    min_fraction: float
    _target = 0.0  #: heading at which the turn ends (odometry frame)
    _lever = 0.0  #: m of the moving track's travel per rad of heading
    _sign = 1.0  #: +1 ccw, -1 cw

    @abstractmethod
    def _lever_arm(self, params: RobotParams) -> float:
        """m of the moving track's travel per rad of heading."""

    @abstractmethod
    def _wheels(self, v: float) -> tuple[float, float]:
        """The (left, right) speeds when the moving track(s) run at ``v`` m/s (unsigned)."""

    def start(self, pose: Pose, params: RobotParams) -> None:
        self._target = pose.heading + self.angle
        self._lever = self._lever_arm(params)
        self._sign = 1.0 if self.angle >= 0 else -1.0

    def step(self, pose: Pose) -> tuple[float, float] | None:
        remaining = self._sign * (self._target - pose.heading)
        if remaining <= 0:
            return None
        return self._wheels(
            self.speed * self._lever * _scale(remaining, self.decel, self.min_fraction)
        )


@dataclass
class Rotate(_Turn):
    """Turn in place by ``angle`` rad (ccw positive; e.g. 20*pi), tracks in opposite directions.

    ``speed``: heading rate, rad/s. ``decel``: the last radians over which to slow down.
    """

    angle: float
    speed: float = 0.5
    decel: float = 0.0
    min_fraction: float = 0.2

    def __post_init__(self) -> None:
        if not math.isfinite(self.angle):
            raise MotionError(f"rotation angle is {self.angle!r}, expected a finite number")
        _check_positive("speed", self.speed)

    def _lever_arm(self, params: RobotParams) -> float:
        return 0.5 * params.track_width  # both tracks, opposite ways

    def _wheels(self, v: float) -> tuple[float, float]:
        return (-self._sign * v, self._sign * v)


@dataclass
class Straight:
    """Drive ``distance`` m along the start heading (negative = reverse), both tracks equal.

    Progress is the odometry displacement projected on the start heading. ``speed`` in m/s.
    """

    distance: float
    speed: float = 0.3
    decel: float = 0.0
    min_fraction: float = 0.2

    def __post_init__(self) -> None:
        if not math.isfinite(self.distance):
            raise MotionError(f"distance is {self.distance!r}, expected a finite number")
        _check_positive("speed", self.speed)
        self._origin = (0.0, 0.0)
        self._dir = (1.0, 0.0)

    def start(self, pose: Pose, params: RobotParams) -> None:
        self._origin = (pose.x, pose.y)
        self._dir = (math.cos(pose.heading), math.sin(pose.heading))

    def step(self, pose: Pose) -> tuple[float, float] | None:
        along = (pose.x - self._origin[0]) * self._dir[0] + (pose.y - self._origin[1]) * self._dir[
            1
        ]
        sign = 1.0 if self.distance >= 0 else -1.0
        remaining = abs(self.distance) - sign * along
        if remaining <= 0:
            return None
        v = sign * self.speed * _scale(remaining, self.decel, self.min_fraction)
        return (v, v)


@dataclass
class Pivot(_Turn):
    """Turn by ``angle`` rad on one track: ``held`` ("left" or "right") stays still.

    ``speed``: heading rate, rad/s; the moving track runs at ``speed * track_width``.
    """

    angle: float
    held: str = "left"
    speed: float = 0.5
    decel: float = 0.0
    min_fraction: float = 0.2

    def __post_init__(self) -> None:
        if self.held not in ("left", "right"):
            raise MotionError(f"pivot held track is {self.held!r}, expected 'left' or 'right'")
        if not math.isfinite(self.angle):
            raise MotionError(f"pivot angle is {self.angle!r}, expected a finite number")
        _check_positive("speed", self.speed)

    def _lever_arm(self, params: RobotParams) -> float:
        return params.track_width  # one track, about the other

    def _wheels(self, v: float) -> tuple[float, float]:
        # ccw (sign +): right forward with left held, or left backward with right held
        if self.held == "left":
            return (0.0, self._sign * v)
        return (-self._sign * v, 0.0)


class MotionSequence:
    """Motions one after another; each starts from the odometry pose where the last stopped."""

    def __init__(self, motions: Sequence[Motion]) -> None:
        if not motions:
            raise MotionError("a motion sequence needs at least one motion")
        self.motions = list(motions)
        self._i = 0
        self._params: RobotParams | None = None

    def start(self, pose: Pose, params: RobotParams) -> None:
        self._i = 0
        self._params = params
        self.motions[0].start(pose, params)

    def step(self, pose: Pose) -> tuple[float, float] | None:
        while self._i < len(self.motions):
            out = self.motions[self._i].step(pose)
            if out is not None:
                return out
            self._i += 1
            if self._i < len(self.motions):
                assert self._params is not None
                self.motions[self._i].start(pose, self._params)
        return None


def square(
    side: float,
    direction: str = "ccw",
    *,
    speed: float = 0.3,
    turn_speed: float = 0.5,
    decel: float = 0.0,
    turn_decel: float = 0.0,
) -> MotionSequence:
    """The UMBmark square: four times (straight ``side`` m, turn 90 degrees in place)."""
    if direction not in ("cw", "ccw"):
        raise MotionError(f"square direction is {direction!r}, expected 'cw' or 'ccw'")
    _check_positive("side", side)
    quarter = 0.5 * math.pi if direction == "ccw" else -0.5 * math.pi
    steps: list[Motion] = []
    for _ in range(4):
        steps.append(Straight(side, speed, decel))
        steps.append(Rotate(quarter, turn_speed, turn_decel))
    return MotionSequence(steps)


def motion_from_command(
    command: Command,
    *,
    speed: float | None = None,
    turn_speed: float | None = None,
    decel: float = 0.0,
    turn_decel: float = 0.0,
) -> Motion:
    """The motion that executes ``command`` (speed m/s, turn_speed rad/s; defaults as above).

    ``command.speed`` is used when ``speed``/``turn_speed`` are not given. An exploration is
    :class:`~odolab.robot.explore_motion.Explore` (its own speeds; no deceleration).
    """
    if command.explore is not None:
        return Explore.from_exploration(command)
    lin = (
        speed
        if speed is not None
        else (
            command.speed
            if command.kind in (MotionKind.TRANSLATION, MotionKind.SQUARE)
            and command.speed is not None
            else 0.3
        )
    )
    ang = (
        turn_speed
        if turn_speed is not None
        else (
            command.speed
            if command.kind in (MotionKind.ROTATION, MotionKind.PIVOT) and command.speed is not None
            else 0.5
        )
    )
    if command.kind is MotionKind.ROTATION and command.angle is not None:
        return Rotate(command.angle, ang, turn_decel)
    if command.kind is MotionKind.TRANSLATION and command.distance is not None:
        return Straight(command.distance, lin, decel)
    if command.kind is MotionKind.PIVOT and command.angle is not None:
        return Pivot(command.angle, command.direction or "left", ang, turn_decel)
    if command.kind is MotionKind.SQUARE and command.side is not None:
        return square(
            command.side,
            command.direction or "ccw",
            speed=lin,
            turn_speed=ang,
            decel=decel,
            turn_decel=turn_decel,
        )
    raise MotionError(f"cannot drive a {command.describe()!r} command by odometry")
