"""odolab: honest wheel odometry.

Turn wheel-encoder counts into a pose (streaming or batch), run and record the experiments that
measure how wrong it is, characterize systematic and random error, correct the kinematic model,
and report. Units are SI (m, rad, s) throughout.
"""

from __future__ import annotations

from odolab.errors import (
    EncoderJumpError,
    LogFormatError,
    OdolabError,
    ParamsError,
)
from odolab.kinematics import Method, wrap_angle
from odolab.odometry import Odometry, integrate, integrate_increments
from odolab.params import PRESETS, RobotParams, load_params, save_params
from odolab.trajectory import Pose, Trajectory
from odolab.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

__version__ = "0.1.0"

__all__ = [
    "PRESETS",
    "Command",
    "EncoderJumpError",
    "EncoderLog",
    "LogFormatError",
    "Measurement",
    "Method",
    "MotionKind",
    "OdolabError",
    "Odometry",
    "ParamsError",
    "Pose",
    "RobotParams",
    "Trajectory",
    "Trial",
    "TrialStatus",
    "__version__",
    "integrate",
    "integrate_increments",
    "load_params",
    "save_params",
    "wrap_angle",
]
