"""The differential drive of the lab report (eqs. 3.3, 3.4): the default kinematic model.

``d_forward = (ds_r + ds_l) / 2``, ``d_theta = (ds_r - ds_l) / track_width``, no sideways motion.
It has no keys of its own: the radii and the track width are in the ``[robot]`` table.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from odolab.core.models.base import ModelCoefficients
from odolab.core.models.registry import register

__all__ = ["DiffDrive"]


@register
@dataclass(frozen=True)
class DiffDrive:
    """Differential drive: each wheel rolls without slip, the body turns about the axle's middle."""

    kind: ClassVar[str] = "diff"
    KEYS: ClassVar[tuple[str, ...]] = ()

    def coefficients(self, track_width: float) -> ModelCoefficients:
        return ModelCoefficients(0.5, 0.5, 1.0, 1.0, float(track_width), 0.0)

    def to_dict(self) -> dict[str, float]:
        return {}

    @property
    def is_differential_drive(self) -> bool:
        return True
