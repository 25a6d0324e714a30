"""One recorded run: wheel increments, optional ground truth, optional nominal parameters."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError
from odolab.core.kinematics import Method
from odolab.core.params import RobotParams
from odolab.core.trajectory import Trajectory, check_times

__all__ = ["MAX_WHEEL_SPEED_M_S", "OdometryRun", "ReadOptions"]

#: Fastest a wheel's rim may move between two samples of a run (m/s): far past any wheeled lab
#: robot (the Jaguar's top speed is about 1.5 m/s). Increments past it are damage, or counts
#: of a different unit; a run whose parameters are known is refused for them.
MAX_WHEEL_SPEED_M_S = 20.0


@dataclass(frozen=True)
class ReadOptions:
    """What a reader needs beyond the path (every field has a default).

    * ``ground_truth``: a trajectory file (CSV or TUM) to use as ground truth, overriding what the
      reader finds by itself.
    * ``modulus``: encoder counter modulus for raw-counter CSV logs (None: they never wrap).
    * Bags: ``joint_topic`` (sensor_msgs/JointState), ``joint_names`` (left, right),
      ``ground_truth_topic`` (geometry_msgs/PoseStamped or nav_msgs/Odometry),
      ``odometry_topic`` (nav_msgs/Odometry, read as an estimate), and ``ticks_per_rev``: wheel
      angles (rad) become ticks as ``angle * ticks_per_rev / (2 pi)``; the default 2 pi makes one
      tick one radian.
    * Bags without joint states: the wheel increments are the robot's own odometry
      (``nav_msgs/Odometry`` on ``odometry_topic``, default ``/odom``) turned back into wheel
      turns with ``params`` (default: a virtual robot with 1 m wheels and a 1 m track); the run
      carries those parameters, so integrating it with them gives the robot's odometry back.
    """

    ground_truth: str | None = None
    modulus: int | None = None
    joint_topic: str = "/joint_states"
    joint_names: tuple[str, str] = ("left_wheel_joint", "right_wheel_joint")
    ground_truth_topic: str = "/ground_truth"
    odometry_topic: str | None = None
    ticks_per_rev: float = 2.0 * math.pi
    params: RobotParams | None = None


@dataclass(frozen=True, eq=False)
class OdometryRun:
    """A run as every reader returns it.

    ``t`` (s), ``dticks_left``, ``dticks_right``: shape (n,), increments from sample i-1 to i
    (``dticks[0]`` = 0). ``ground_truth``: the actual trajectory where the log has one (any
    stamps; associate before comparing). ``params``: nominal parameters when the log carries them
    (OptiOdom metadata). ``estimate``: a trajectory the robot itself logged (bags' Odometry).
    """

    name: str
    source: str
    t: NDArray[np.float64]
    dticks_left: NDArray[np.float64]
    dticks_right: NDArray[np.float64]
    ground_truth: Trajectory | None = None
    params: RobotParams | None = None
    estimate: Trajectory | None = None
    kind: str = ""
    meta: dict[str, float | str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=np.float64)
        dl = np.asarray(self.dticks_left, dtype=np.float64)
        dr = np.asarray(self.dticks_right, dtype=np.float64)
        if not (t.ndim == dl.ndim == dr.ndim == 1 and t.size == dl.size == dr.size):
            raise LogFormatError(
                f"{self.source}: t, dticks_left and dticks_right must be 1-D of one length, got "
                f"{t.shape}, {dl.shape}, {dr.shape}"
            )
        if t.size < 2:
            raise LogFormatError(f"{self.source}: {t.size} samples; expected at least two")
        # file readers check their times first and name the line; here only the sample (from 1)
        check_times(t, self.source, row_offset=1, what="sample")
        for side, d in (("left", dl), ("right", dr)):
            if not np.isfinite(d).all():
                i = int(np.argmax(~np.isfinite(d)))
                raise LogFormatError(
                    f"{self.source}: sample {i + 1}, the {side} increment is {d[i]}; expected a "
                    "number of counts"
                )
        if self.params is not None:
            _check_wheel_speeds(self.source, t, dl, dr, self.params)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "dticks_left", dl)
        object.__setattr__(self, "dticks_right", dr)

    def __len__(self) -> int:
        return int(self.t.size)

    def odometry(
        self,
        params: RobotParams | None = None,
        method: Method | str = Method.MIDPOINT,
        *,
        start: tuple[float, float, float] | None = None,
    ) -> Trajectory:
        """Compatibility alias of :func:`odolab.core.prediction.trajectory_from_increments`."""
        from odolab.core.prediction import trajectory_from_increments

        return trajectory_from_increments(self, params, method, start=start)

    def require_ground_truth(self) -> Trajectory:
        """The ground truth, or a :class:`LogFormatError` naming the run.

        Raises:
            LogFormatError: the run has no ground truth (the reason is given).
        """
        if self.ground_truth is None:
            why = self.meta.get("no_ground_truth", "no ground truth in this run; expected one")
            raise LogFormatError(f"{self.source}: {why}")
        return self.ground_truth


def _check_wheel_speeds(
    source: str,
    t: NDArray[np.float64],
    dl: NDArray[np.float64],
    dr: NDArray[np.float64],
    params: RobotParams,
) -> None:
    """Refuse increments that move a wheel's rim faster than :data:`MAX_WHEEL_SPEED_M_S` over
    their sample's interval (at least the run's median spacing, so that a repeated time stamp
    is not an infinite speed)."""
    dt = np.diff(t)
    floor = float(np.median(dt))
    span = np.maximum(dt, floor)
    for side, d, per_tick in (
        ("left", dl, params.left_metres_per_tick),
        ("right", dr, params.right_metres_per_tick),
    ):
        speed = np.abs(d[1:]) * per_tick / span
        fast = ~(speed <= MAX_WHEEL_SPEED_M_S)
        if fast.any():
            i = int(np.argmax(fast))
            raise LogFormatError(
                f"{source}: sample {i + 2}, the {side} increment of {d[i + 1]:.10g} counts moves "
                f"the wheel {abs(d[i + 1]) * per_tick:.4g} m in {dt[i]:.4g} s ({speed[i]:.4g} "
                f"m/s with the run's parameters, {params.ticks_per_rev:g} counts per revolution); "
                f"expected at most {MAX_WHEEL_SPEED_M_S:g} m/s"
            )
