"""The extended differential drive: per-side scale factors and an effective track width.

A differential drive whose wheels (tracks) move the body by a fixed fraction of what their
radii say (``scale_left``, ``scale_right``: actual/predicted, the lab's ratios), and which turns
as if its track were ``track_scale`` times the ``[robot]`` table's track width (a skid-steer robot
turns as if its track were wider)::

    d_forward = (scale_left * ds_l + scale_right * ds_r) / 2
    d_theta   = (scale_right * ds_r - scale_left * ds_l) / (track_scale * track_width)

All three are dimensionless and 1 is neutral: with ``scale_left = scale_right = track_scale = 1``
it is the differential drive. In a fit the scales are not identifiable together with the wheel
radii (they multiply them); :mod:`odolab.calibration.lsq` fits them with the radii held.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from odolab.core.errors import ParamsError
from odolab.core.models.base import ModelCoefficients
from odolab.core.models.registry import register

__all__ = ["ExtendedDiffDrive"]


@register
@dataclass(frozen=True)
class ExtendedDiffDrive:
    """Differential drive with per-side scales and an effective track (all ratios, 1 neutral)."""

    scale_left: float = 1.0
    scale_right: float = 1.0
    track_scale: float = 1.0
    kind: ClassVar[str] = "extended"
    KEYS: ClassVar[tuple[str, ...]] = ("scale_left", "scale_right", "track_scale")
    #: Plausible range of each ratio: a wheel that moves the body by a tenth (or ten times) of
    #: what its radius says is a wrong file, not slip.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {k: (0.1, 10.0) for k in KEYS}

    def __post_init__(self) -> None:
        for key in self.KEYS:
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ParamsError(f"{key} must be a number (a ratio), got {value!r}")
            if not (math.isfinite(value) and value > 0):
                raise ParamsError(f"{key} must be a finite ratio > 0, got {value!r}")
            lo, hi = self.RANGES[key]
            if not lo <= value <= hi:
                raise ParamsError(
                    f"{key} = {value:.6g} is outside the plausible {lo:g} to {hi:g} "
                    "(a ratio actual/predicted; 1 is neutral)"
                )
            object.__setattr__(self, key, float(value))

    def coefficients(self, track_width: float) -> ModelCoefficients:
        sl, sr = self.scale_left, self.scale_right
        return ModelCoefficients(0.5 * sl, 0.5 * sr, sl, sr, self.track_scale * track_width, 0.0)

    def to_dict(self) -> dict[str, float]:
        return {
            "scale_left": self.scale_left,
            "scale_right": self.scale_right,
            "track_scale": self.track_scale,
        }

    @property
    def is_differential_drive(self) -> bool:
        return self.scale_left == 1.0 and self.scale_right == 1.0 and self.track_scale == 1.0
