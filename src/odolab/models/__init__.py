"""Kinematic models as values: how a robot's left and right wheel (track) motion moves its body.

Every model answers one question for one control cycle: given the distances ``ds_l``, ``ds_r``
(m) that the left and right wheel surfaces rolled (eqs. 3.1, 3.2 of the lab report), how far did
the body move forward, sideways and in heading? All models here are *linear* in ``ds_l``, ``ds_r``
and are written with six coefficients (:class:`ModelCoefficients`)::

    d_forward = w_left * ds_l + w_right * ds_r
    d_theta   = (e_right * ds_r - e_left * ds_l) / denominator
    d_lateral = lateral * d_theta

The differential drive of the lab report (eqs. 3.3, 3.4) is ``w = 1/2, e = 1, denominator =
track_width, lateral = 0``. The pose step that turns a body motion into a new pose (midpoint or
exact arc, with one small-angle rule) is :func:`odolab.kinematics.step_pose`; batch and streaming
odometry, the simulator and the virtual board all call it with these coefficients.

Adding a model is one new module in this package with a frozen dataclass that has a ``kind``
class attribute and the methods of :class:`KinematicModel`, plus one line in :data:`MODELS`.
In a parameters TOML a model is the ``[model]`` table: ``kind = "<name>"`` and the model's own
keys (metres, radians); a file without ``[model]`` means the differential drive.

This module imports neither numpy nor numba (``odolab --help`` stays instant).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, NamedTuple, Protocol, runtime_checkable

from odolab.errors import ParamsError
from odolab.models.diff import DiffDrive
from odolab.models.extended import ExtendedDiffDrive
from odolab.models.icr import IcrModel
from odolab.models.slip import SlipModel

__all__ = [
    "DIFF_DRIVE",
    "MODELS",
    "ExtendedDiffDrive",
    "IcrModel",
    "KinematicModel",
    "ModelCoefficients",
    "SlipModel",
    "model_from_mapping",
]


class ModelCoefficients(NamedTuple):
    """The six numbers of a linear kinematic model (see the module docstring)."""

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
        (the ICR model) may ignore it."""
        ...

    def to_dict(self) -> dict[str, float]:
        """The model's own keys for the ``[model]`` table (without ``kind``), in file order."""
        ...

    @property
    def is_differential_drive(self) -> bool:
        """True when the model, with these values, is exactly the plain differential drive."""
        ...


#: The default model.
DIFF_DRIVE = DiffDrive()

#: Every model by its ``kind`` in the TOML. A new model adds one line here.
MODELS: dict[str, type[Any]] = {
    DiffDrive.kind: DiffDrive,
    ExtendedDiffDrive.kind: ExtendedDiffDrive,
    IcrModel.kind: IcrModel,
    SlipModel.kind: SlipModel,
}


def model_from_mapping(data: dict[str, Any], *, source: str = "parameters") -> KinematicModel:
    """Build a model from a ``[model]`` table (``kind`` and the model's keys), naming ``source``."""
    if not isinstance(data, dict):
        raise ParamsError(f"{source}: [model] must be a table, got {type(data).__name__}")
    kind = data.get("kind", DiffDrive.kind)
    if not isinstance(kind, str) or kind not in MODELS:
        raise ParamsError(
            f"{source}: unknown model kind {kind!r} in [model]; expected one of "
            f"{', '.join(sorted(MODELS))}"
        )
    cls = MODELS[kind]
    keys = {k: v for k, v in data.items() if k not in ("kind", "posterior")}
    extra: dict[str, Any] = {}
    if "posterior" in data:
        extra["posterior"] = _posterior(data["posterior"], cls, kind, source)
    allowed = tuple(getattr(cls, "KEYS", ()))
    unknown = sorted(set(keys) - set(allowed))
    if unknown:
        expected = ", ".join(allowed) if allowed else "no other keys"
        raise ParamsError(
            f"{source}: unknown key {unknown[0]!r} in [model] of kind {kind!r}; expected {expected}"
        )
    missing = [k for k in allowed if k not in keys and k not in _defaults(cls)]
    if missing:
        raise ParamsError(f"{source}: missing key {missing[0]!r} in [model] of kind {kind!r}")
    for key, value in keys.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ParamsError(f"{source}: [model] {key} must be a finite number, got {value!r}")
    try:
        model: KinematicModel = cls(**{k: float(v) for k, v in keys.items()}, **extra)
    except ParamsError as err:
        raise ParamsError(f"{source}: [model] {err}") from err
    except TypeError as err:
        raise ParamsError(f"{source}: [model] of kind {kind!r}: {err}") from err
    return model


def _posterior(value: Any, cls: type[Any], kind: str, source: str) -> tuple[float, ...]:
    """A ``[model]`` ``posterior`` (the slip model's coefficient covariance, row-major):
    checked to be a list of finite numbers of the model's size."""
    size = len(getattr(cls, "COEF_KEYS", ())) ** 2
    if not size:
        raise ParamsError(f"{source}: unknown key 'posterior' in [model] of kind {kind!r}")
    if not isinstance(value, list) or len(value) != size:
        got = f"{len(value)} values" if isinstance(value, list) else type(value).__name__
        raise ParamsError(
            f"{source}: [model] posterior has {got}; expected a list of {size} numbers"
        )
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ParamsError(
                f"{source}: [model] posterior[{i}] must be a finite number, got {v!r}"
            )
    return tuple(float(v) for v in value)


def _defaults(cls: type[Any]) -> set[str]:
    """The fields of a model class that have a default value (may be left out of the table)."""
    return {
        f.name
        for f in dataclasses.fields(cls)
        if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
    }
