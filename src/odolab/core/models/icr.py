"""The instantaneous-centres-of-rotation (ICR) model of a tracked or skid-steer vehicle.

Mandow et al. (2007), "Experimental kinematics for wheeled skid-steer mobile robots"; Pentzer et
al. (2014). Body frame x forward, y left. ``y_icr_left > 0`` and ``y_icr_right < 0`` are the
lateral coordinates of the instantaneous centres of rotation of the left and right track (where
the ground under each track does not move relative to the body), ``x_icr`` the longitudinal
coordinate of the vehicle's ICR. With track surface displacements ``ds_l``, ``ds_r`` in one cycle::

    d_theta   = (ds_r - ds_l) / (y_icr_left - y_icr_right)
    d_forward = (y_icr_left * ds_r - y_icr_right * ds_l) / (y_icr_left - y_icr_right)
    d_lateral = -x_icr * d_theta

``y_icr_left = -y_icr_right = track_width / 2`` and ``x_icr = 0`` is the differential drive.
The model ignores the ``[robot]`` table's track width: its geometry is its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from odolab.core.errors import ParamsError
from odolab.core.models.base import ModelCoefficients, check_number
from odolab.core.models.registry import register

__all__ = ["IcrModel"]


@register
@dataclass(frozen=True)
class IcrModel:
    """Skid-steer ICR model: the tracks' ICRs at ``y_icr_left``, ``y_icr_right``, the body's at
    ``x_icr`` (metres, body frame x forward, y left)."""

    y_icr_left: float
    y_icr_right: float
    x_icr: float = 0.0
    kind: ClassVar[str] = "icr"
    #: the unit of its keys, in words (:func:`odolab.core.models.model_words`)
    UNIT: ClassVar[str] = " m"
    KEYS: ClassVar[tuple[str, ...]] = ("y_icr_left", "y_icr_right", "x_icr")
    #: Plausible range of each coordinate (m): a track's ICR from 1 mm to 80 m beside the body
    #: (up to 4 times the widest track of :data:`odolab.core.params.RANGES`), the body's ICR at most
    #: 40 m ahead or behind.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "y_icr_left": (1e-3, 80.0),
        "y_icr_right": (-80.0, -1e-3),
        "x_icr": (-40.0, 40.0),
    }

    def __post_init__(self) -> None:
        for key in self.KEYS:
            value = getattr(self, key)
            check_number(key, value, " of metres")
            object.__setattr__(self, key, float(value))
        if not self.y_icr_left > 0:
            raise ParamsError(f"y_icr_left must be > 0 m (left of the body), got {self.y_icr_left}")
        if not self.y_icr_right < 0:
            raise ParamsError(
                f"y_icr_right must be < 0 m (right of the body), got {self.y_icr_right}"
            )
        for key, (lo, hi) in self.RANGES.items():
            value = getattr(self, key)
            if not lo <= value <= hi:
                raise ParamsError(
                    f"{key} = {value:.6g} m is outside the plausible {lo:g} to {hi:g} m"
                )

    @classmethod
    def from_track(cls, track_width: float, x_icr: float = 0.0) -> IcrModel:
        """The ICR model that is the differential drive of ``track_width`` (plus ``x_icr``)."""
        return cls(track_width / 2.0, -track_width / 2.0, x_icr)

    @classmethod
    def neutral(cls, track_width: float) -> IcrModel:
        """The ICR model that is the differential drive of ``track_width``."""
        return cls.from_track(track_width)

    @property
    def spread(self) -> float:
        """``y_icr_left - y_icr_right`` (m): the track width the vehicle turns as if it had."""
        return self.y_icr_left - self.y_icr_right

    def coefficients(self, track_width: float) -> ModelCoefficients:
        d = self.spread
        return ModelCoefficients(
            -self.y_icr_right / d, self.y_icr_left / d, 1.0, 1.0, d, -self.x_icr
        )

    def to_dict(self) -> dict[str, float]:
        return {"y_icr_left": self.y_icr_left, "y_icr_right": self.y_icr_right, "x_icr": self.x_icr}

    @property
    def is_differential_drive(self) -> bool:
        return self.x_icr == 0.0 and self.y_icr_left == -self.y_icr_right
