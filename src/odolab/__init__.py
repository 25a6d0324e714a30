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

from odolab.core import _aliases
from odolab.core.errors import (
    EncoderJumpError,
    LogFormatError,
    OdolabError,
    ParamsError,
)
from odolab.core.params import PRESETS, RobotParams, load_params, save_params

#: the old names (odolab.kinematics, odolab.models, odolab.lab, ...) keep working for a release
_aliases.install(
    {
        "_encoders_jit": "odolab.core._encoders_jit",
        "_fastmath": "odolab.core._fastmath",
        "_jit": "odolab.core._jit",
        "_kinematics_jit": "odolab.core._kinematics_jit",
        "_odometry_kernels": "odolab.core._odometry_kernels",
        "defaults": "odolab.core.defaults",
        "encoders": "odolab.core.encoders",
        "errors": "odolab.core.errors",
        "extras": "odolab.core.extras",
        "kinematics": "odolab.core.kinematics",
        "measurement": "odolab.core.measurement",
        "models": "odolab.core.models",
        "motion": "odolab.core.motion",
        "numfmt": "odolab.core.numfmt",
        "odometry": "odolab.core.odometry",
        "params": "odolab.core.params",
        "prediction": "odolab.core.prediction",
        "progress": "odolab.core.progress",
        "regression": "odolab.core.regression",
        "slip_uncertainty": "odolab.core.slip_uncertainty",
        "text": "odolab.core.text",
        "trajectory": "odolab.core.trajectory",
        "trials": "odolab.core.trials",
        "uncertainty": "odolab.core.uncertainty",
        "writing": "odolab.core.writing",
        "lab": "odolab.app.demo",
    }
)

if TYPE_CHECKING:  # imported on first use (numpy, numba): `odolab --help` stays instant
    from odolab.core.kinematics import Method, wrap_angle
    from odolab.core.odometry import Odometry, integrate, integrate_increments
    from odolab.core.trajectory import Pose, Trajectory
    from odolab.core.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

_LAZY = {
    "Method": "odolab.core.kinematics",
    "wrap_angle": "odolab.core.kinematics",
    "Odometry": "odolab.core.odometry",
    "integrate": "odolab.core.odometry",
    "integrate_increments": "odolab.core.odometry",
    "Pose": "odolab.core.trajectory",
    "Trajectory": "odolab.core.trajectory",
    "Command": "odolab.core.trials",
    "EncoderLog": "odolab.core.trials",
    "Measurement": "odolab.core.trials",
    "MotionKind": "odolab.core.trials",
    "Trial": "odolab.core.trials",
    "TrialStatus": "odolab.core.trials",
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
