"""odolab: honest wheel odometry.

Turn wheel-encoder counts into a pose (streaming or batch), run and record the experiments that
measure how wrong it is, characterize systematic and random error, correct the kinematic model,
and report. Units are SI (m, rad, s) throughout.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

#: numba colours the messages of its compile errors through colorama, which swaps sys.stdout and
#: sys.stderr while it formats them and then puts back the streams it saw first: on the thread
#: that loads the kernels in the background, that clobbered whatever stream the program had set
#: meanwhile (a test's captured stderr lost an error message). Plain messages: set before numba
#: loads; a value you set wins.
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")

from odolab.errors import (
    EncoderJumpError,
    LogFormatError,
    OdolabError,
    ParamsError,
)
from odolab.params import PRESETS, RobotParams, load_params, save_params

if TYPE_CHECKING:  # imported on first use (numpy, numba): `odolab --help` stays instant
    from odolab.kinematics import Method, wrap_angle
    from odolab.odometry import Odometry, integrate, integrate_increments
    from odolab.trajectory import Pose, Trajectory
    from odolab.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

_LAZY = {
    "Method": "odolab.kinematics",
    "wrap_angle": "odolab.kinematics",
    "Odometry": "odolab.odometry",
    "integrate": "odolab.odometry",
    "integrate_increments": "odolab.odometry",
    "Pose": "odolab.trajectory",
    "Trajectory": "odolab.trajectory",
    "Command": "odolab.trials",
    "EncoderLog": "odolab.trials",
    "Measurement": "odolab.trials",
    "MotionKind": "odolab.trials",
    "Trial": "odolab.trials",
    "TrialStatus": "odolab.trials",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'odolab' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


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
