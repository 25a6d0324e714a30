"""What the virtual Jaguar board drives: a plant (the robot's physics), and a small ideal one.

The board is written against :class:`Plant`, an interface that the simulator's
``odolab.sim.physics.VirtualRobot`` satisfies structurally; the robot stack never imports the
simulator: a plant comes in from outside as a :data:`PlantFactory` (the CLI wires
``odolab.sim.plants.make_plant`` in). :class:`IdealPlant` is an exact, slip-free, noise-free
differential drive with wrapping encoders and arbitrary true parameters: a plant whose motion
tests can compute by hand.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from odolab.core._step_kernels import body_motion, step_pose
from odolab.core.kinematics import wrap_angle
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose
from odolab.robot.errors import PlantError

__all__ = ["IdealPlant", "Plant", "PlantFactory"]


class Plant(Protocol):
    """The members of the virtual robot that the virtual Jaguar board uses."""

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        ...

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        """Command the left and right wheel (track) speeds, m/s."""
        ...

    def advance(self, duration: float) -> None:
        """Run the physics for ``duration`` seconds."""
        ...

    def encoder_counts(self) -> tuple[int, int]:
        """Raw (wrapped) encoder counters, left and right."""
        ...

    @property
    def true_pose(self) -> Pose:
        """Where the robot really is."""
        ...

    @property
    def stalled(self) -> bool:
        """Whether a track is stalled."""
        ...

    def reset(self, start: Any = None) -> None:
        """Back to the start (counters to 0)."""
        ...


#: Builds the plant of a virtual board (called once per run, in the board's thread or process).
PlantFactory = Callable[[], Plant]


class IdealPlant:
    """Exact differential drive with the given (true) parameters: no slip, no noise, no lag.

    A wheel commanded at ``v`` m/s rolls ``v * dt`` metres; its counter advances by that distance
    over the wheel's metres per tick (floored) and wraps at ``encoder_modulus``. The pose follows
    the exact arc for the true track width.
    """

    def __init__(self, truth: RobotParams) -> None:
        self.truth = truth
        self._modulus = truth.encoder_modulus
        self.reset()

    def reset(self, start: Pose | Sequence[float] | None = None) -> None:
        x, y, h = (0.0, 0.0, 0.0) if start is None else (float(v) for v in tuple(start)[-3:])
        if start is not None and isinstance(start, Pose):
            x, y, h = start.x, start.y, start.heading
        self._t = 0.0
        self._x, self._y, self._h = x, y, h
        self._sl = 0.0
        self._sr = 0.0
        self._vl = 0.0
        self._vr = 0.0

    @property
    def time(self) -> float:
        return self._t

    @property
    def stalled(self) -> bool:
        return False

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        if not (math.isfinite(left_mps) and math.isfinite(right_mps)):
            raise PlantError(f"wheel speeds must be finite, got {left_mps!r}, {right_mps!r}")
        self._vl = float(left_mps)
        self._vr = float(right_mps)

    def advance(self, duration: float) -> None:
        if duration < 0:
            raise PlantError(f"advance duration is {duration}, expected >= 0")
        if duration == 0:
            return
        dl = self._vl * duration
        dr = self._vr * duration
        fwd, side, dth = body_motion(*self.truth.coefficients, dl, dr)
        self._x, self._y, self._h = step_pose(self._x, self._y, self._h, fwd, side, dth, True)
        self._sl += dl
        self._sr += dr
        self._t += duration

    def encoder_counts(self) -> tuple[int, int]:
        left = math.floor(self._sl / self.truth.left_metres_per_tick)
        right = math.floor(self._sr / self.truth.right_metres_per_tick)
        if self._modulus is not None:
            left %= self._modulus
            right %= self._modulus
        return left, right

    @property
    def true_pose(self) -> Pose:
        theta = wrap_angle(self._h)
        return Pose(self._t, self._x, self._y, theta, self._h)
