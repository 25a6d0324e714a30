"""Predictions from recorded counters: what odometry says a stored log or a read run did.

Records (a notebook trial, an :class:`odolab.io.run.OdometryRun`) hold data; they do not
integrate themselves. Re-predicting a trial with other parameters, or integrating a run's
increments, is done here, on top of the public :mod:`odolab.core.odometry` API.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError, opt
from odolab.core.kinematics import Method
from odolab.core.odometry import integrate, integrate_increments
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose, Trajectory
from odolab.core.trials import EncoderLog

__all__ = ["Increments", "final_pose_from_log", "trajectory_from_increments"]


class Increments(Protocol):
    """A recorded drive as per-cycle wheel increments (``dticks[i]``: counts from i-1 to i)."""

    @property
    def t(self) -> NDArray[np.float64]: ...
    @property
    def dticks_left(self) -> NDArray[np.float64]: ...
    @property
    def dticks_right(self) -> NDArray[np.float64]: ...
    @property
    def params(self) -> RobotParams | None: ...
    @property
    def source(self) -> str: ...


def final_pose_from_log(
    log: EncoderLog, params: RobotParams, method: Method | str = Method.MIDPOINT, *, source: str
) -> Pose:
    """The final pose odometry gives for the raw counters of ``log`` with ``params``.

    ``source`` names the log in errors (e.g. "trial T00001"). An empty log is refused.
    """
    if len(log) == 0:
        raise LogFormatError(f"{source}: its encoder log is empty")
    traj = integrate(log.t, log.left_ticks, log.right_ticks, params, method, source=source)
    return traj.final


def trajectory_from_increments(
    run: Increments,
    params: RobotParams | None = None,
    method: Method | str = Method.MIDPOINT,
    *,
    start: tuple[float, float, float] | None = None,
) -> Trajectory:
    """Integrate a run's increments with ``params`` (default: the run's own nominal ones)."""
    p = params or run.params
    if p is None:
        raise LogFormatError(
            f"{run.source}: no robot parameters in the log; expected parameters ({opt('params')})"
        )
    return integrate_increments(
        run.t, run.dticks_left, run.dticks_right, p, method, start=start, source=run.source
    )
