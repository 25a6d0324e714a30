"""Kinematic models as values: how a robot's left and right wheel (track) motion moves its body.

Every model answers one question for one control cycle: given the distances ``ds_l``, ``ds_r``
(m) that the left and right wheel surfaces rolled (eqs. 3.1, 3.2 of the lab report), how far did
the body move forward, sideways and in heading? The kinematic models are *linear* in ``ds_l``,
``ds_r`` and are written with six coefficients (:class:`ModelCoefficients`); the slip model is
time-dependent and gives its linear part as six coefficients too::

    d_forward = w_left * ds_l + w_right * ds_r
    d_theta   = (e_right * ds_r - e_left * ds_l) / denominator
    d_lateral = lateral * d_theta

The differential drive of the lab report (eqs. 3.3, 3.4) is ``w = 1/2, e = 1, denominator =
track_width, lateral = 0``. The pose step that turns a body motion into a new pose (midpoint or
exact arc, with one small-angle rule) is :func:`odolab.core.kinematics.step_pose`; batch and streaming
odometry, the simulator and the virtual board all call it with these coefficients.

Adding a model is one new module in this package with a frozen dataclass that has a ``kind``
class attribute and the methods of :class:`KinematicModel`, registered with
:func:`~odolab.core.models.registry.register`, plus one import line below. A model whose body motion
depends on each cycle's duration adds the methods of :class:`TimedModel`, one with its own pose
covariance those of :class:`CovarianceModel` (:mod:`odolab.core.models.base`); the rest of odolab asks
those capabilities (:func:`timed_model`, :func:`own_covariance`), never a model's kind.
In a parameters TOML a model is the ``[model]`` table: ``kind = "<name>"`` and the model's own
keys (metres, radians); a file without ``[model]`` means the differential drive.

This module imports neither numpy nor numba (``odolab --help`` stays instant).
"""

from __future__ import annotations

from odolab.core.models.base import (
    CovarianceModel,
    CovarianceStepperLike,
    KinematicModel,
    ModelCoefficients,
    TimedModel,
    is_kinematic_model,
    model_words,
    own_covariance,
    timed_model,
)

# the kinds: each registers itself in MODELS (a new model adds one line here)
from odolab.core.models.diff import DiffDrive
from odolab.core.models.extended import ExtendedDiffDrive
from odolab.core.models.icr import IcrModel
from odolab.core.models.registry import MODELS, model_from_mapping, neutral_values, register
from odolab.core.models.slip import SlipModel

__all__ = [
    "DIFF_DRIVE",
    "MODELS",
    "CovarianceModel",
    "CovarianceStepperLike",
    "DiffDrive",
    "ExtendedDiffDrive",
    "IcrModel",
    "KinematicModel",
    "ModelCoefficients",
    "SlipModel",
    "TimedModel",
    "is_kinematic_model",
    "model_from_mapping",
    "model_words",
    "neutral_values",
    "own_covariance",
    "register",
    "timed_model",
]

#: The default model.
DIFF_DRIVE = DiffDrive()
