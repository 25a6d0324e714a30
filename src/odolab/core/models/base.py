"""What a kinematic model is: the protocol every kind provides, the optional capabilities a kind
may add (a body motion that depends on each cycle's duration, its own covariance), and the
functions the rest of odolab asks them through.

Code outside :mod:`odolab.core.models` never asks which kind a model is: it asks a capability
(:func:`timed_model`, :func:`own_covariance`) or the model itself (:func:`model_words`). A kind
that has neither capability is a *linear* model: its six :class:`ModelCoefficients` are the whole
model, and odometry, the covariance of the ``[noise]`` table, the simulator and every export use
them.

This module imports neither numpy nor numba (``odolab --help`` stays instant).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar, NamedTuple, Protocol, runtime_checkable

from odolab.core.errors import ParamsError

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]

__all__ = [
    "CovarianceModel",
    "CovarianceStepperLike",
    "KinematicModel",
    "ModelCoefficients",
    "RobotLike",
    "TimedModel",
    "check_number",
    "is_kinematic_model",
    "model_words",
    "own_covariance",
    "timed_model",
]


class ModelCoefficients(NamedTuple):
    """The six numbers of a linear kinematic model (see :mod:`odolab.core.models`)."""

    w_left: float
    w_right: float
    e_left: float
    e_right: float
    denominator: float
    lateral: float

    def body_motion(self, ds_left: float, ds_right: float) -> tuple[float, float, float]:
        """(d_forward, d_lateral, d_theta) for wheel surface displacements (m)."""
        fwd = self.w_left * ds_left + self.w_right * ds_right
        dth = (self.e_right * ds_right - self.e_left * ds_left) / self.denominator
        return fwd, self.lateral * dth, dth


@runtime_checkable
class KinematicModel(Protocol):
    """What every kinematic model provides."""

    kind: ClassVar[str]

    def coefficients(self, track_width: float) -> ModelCoefficients:
        """The linear map from wheel displacements to body motion for this robot.

        ``track_width`` is the ``[robot]`` table's track (m); models with their own geometry
        (the ICR model) may ignore it. A time-dependent model (:class:`TimedModel`) gives its
        linear part here."""
        ...

    def to_dict(self) -> dict[str, float]:
        """The model's own keys for the ``[model]`` table (without ``kind``), in file order."""
        ...

    @property
    def is_differential_drive(self) -> bool:
        """True when the model, with these values, is exactly the plain differential drive."""
        ...


class RobotLike(Protocol):
    """What a model's own covariance reads of a parameter set (:class:`odolab.core.params.RobotParams`
    has it; the models do not import the parameters, which import them)."""

    @property
    def model(self) -> KinematicModel: ...

    @property
    def track_width(self) -> float: ...

    @property
    def left_metres_per_tick(self) -> float: ...

    @property
    def right_metres_per_tick(self) -> float: ...


@runtime_checkable
class TimedModel(KinematicModel, Protocol):
    """A model whose body motion depends on each cycle's duration (the slip model: its slip is
    a function of the speeds). Batch and streaming odometry integrate the whole model through
    these methods; everything that needs six linear coefficients sees :meth:`coefficients`.
    A class is one when it sets ``time_dependent = True``."""

    time_dependent: ClassVar[bool]

    def body_motion(
        self, ds_left: float, ds_right: float, dt: float, track_width: float
    ) -> tuple[float, float, float]:
        """(d_forward, d_lateral, d_theta) of one cycle of ``dt`` s (streaming odometry)."""
        ...

    def body_motion_arrays(
        self,
        ds_left: FloatArray,
        ds_right: FloatArray,
        dt: FloatArray,
        track_width: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`body_motion` for arrays of cycles (batch odometry)."""
        ...

    @property
    def is_linear(self) -> bool:
        """True when, with these values, :meth:`coefficients` is the whole model."""
        ...

    def speed_slip_gain(self, v_low: float, v_high: float) -> tuple[float, float, float]:
        """How much more the robot slips driving straight at ``v_high`` than at ``v_low``, with
        its 95 % interval (the lab's speed question)."""
        ...


class CovarianceStepperLike(Protocol):
    """A model's own covariance, one cycle at a time (streaming odometry)."""

    @property
    def terms(self) -> tuple[float, float, float, float, float, float]: ...

    def reset(self) -> None: ...

    def step(self, heading: float, ds_left: float, ds_right: float, dt: float) -> None: ...


@runtime_checkable
class CovarianceModel(KinematicModel, Protocol):
    """A model that carries its own pose covariance (the slip model's predictive variance); a
    ``[noise]`` table does not apply to it. A class is one when it sets ``covariance_name``
    (the name :func:`odolab.core.params.covariance_source` gives, kept in exports)."""

    covariance_name: ClassVar[str]

    def describe_covariance(self) -> str:
        """What the covariance is made of, in words, for every face that uses it."""
        ...

    def covariance_stepper(self, params: RobotLike) -> CovarianceStepperLike:
        """The covariance one cycle at a time (streaming odometry)."""
        ...

    def propagate_covariance(
        self,
        t: FloatArray,
        dticks_left: FloatArray,
        dticks_right: FloatArray,
        params: RobotLike,
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> tuple[FloatArray, FloatArray]:
        """Poses (n, 3) and their covariance (n, 3, 3) along a run of count increments."""
        ...

    def pose_covariance(
        self,
        t: FloatArray,
        ds_left: FloatArray,
        ds_right: FloatArray,
        params: RobotLike,
        start: tuple[float, float, float],
    ) -> FloatArray:
        """The pose covariance (n, 3, 3) along a stretch of track motion (m per cycle)."""
        ...

    def step_variance(
        self,
        ds_left: FloatArray,
        ds_right: FloatArray,
        dt: FloatArray,
        track_width: float,
        tick_turn: float = 0.0,
    ) -> FloatArray:
        """Each cycle's own body-motion variance, shape (n, 3) (the exports' twist)."""
        ...

    def straight_turn_sd(self, speed: float) -> float | None:
        """The standard deviation (rad per metre) of the heading change of a straight run at
        ``speed`` m/s that the coefficients' uncertainty gives; None when it is not known."""
        ...


def check_number(key: str, value: object, kind: str = "") -> None:
    """Refuse a model's value ``key`` that is not a finite number (a bool is not one), with
    :class:`ParamsError`; ``kind`` words what it must be a number of (``" of metres"``)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ParamsError(f"{key} must be a number{kind}, got {value!r}")
    if not math.isfinite(value):
        raise ParamsError(f"{key} must be finite, got {value!r}")


def is_kinematic_model(value: object) -> bool:
    """Whether ``value`` is a kinematic model (provides :class:`KinematicModel`)."""
    return isinstance(value, KinematicModel)


def timed_model(model: KinematicModel) -> TimedModel | None:
    """The model as a :class:`TimedModel` when its body motion depends on each cycle's duration,
    else None (its :meth:`~KinematicModel.coefficients` are the whole model)."""
    if getattr(model, "time_dependent", False) and isinstance(model, TimedModel):
        return model
    return None


def own_covariance(model: KinematicModel) -> CovarianceModel | None:
    """The model as a :class:`CovarianceModel` when it carries its own pose covariance, else
    None (the ``[noise]`` table gives the covariance, if any)."""
    if getattr(model, "covariance_name", None) and isinstance(model, CovarianceModel):
        return model
    return None


def model_words(model: KinematicModel) -> str:
    """The model in words, for every face that shows a parameter set (``kind (key value, ...)``
    unless the kind words itself through a ``words()`` method)."""
    words = getattr(model, "words", None)
    if callable(words):
        return str(words())
    unit = getattr(model, "UNIT", "")
    keys = ", ".join(f"{k} {v:g}" for k, v in model.to_dict().items())
    return f"{model.kind} ({keys}{unit})"
