"""The virtual robot's true behaviour, :class:`TrueParams`: what the ground does with what the
wheels turn (the physics that uses it: :mod:`odolab.sim.physics`).

A module of its own, without the compiled physics, so that what only names or checks a truth
(the truth presets, ``odolab robot drive --truth``) does not load numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from odolab.core.errors import SimError
from odolab.core.models import DIFF_DRIVE, KinematicModel, is_kinematic_model
from odolab.core.params import RobotParams

__all__ = ["TrueParams"]


@dataclass(frozen=True)
class TrueParams:
    """The robot's true behaviour on the reference surface (indoor tile), SI units.

    Radii are effective radii (the distance the robot's side moves per radian of sprocket
    rotation), per side and per direction of travel. ``track_width`` is the effective track width
    (skid-steer turning makes it wider than a ruler says). ``k_left``/``k_right`` (m): per-wheel
    slip variance per metre rolled. ``k_scrub`` (rad): heading variance per commanded radian of
    differential turning. ``align_sigma`` (rad): sigma of the start heading offset of each run.
    ``track_sigma``: relative sigma of a per-run factor on the effective track width.
    ``speed_slip`` (s/m): fractional loss of effective radius per m/s of wheel speed.
    ``stop_slide`` (s^2/m): extra slide of each side at an abrupt stop per (m/s)^2.
    ``terrain_radius_scale``: pairs (terrain name, factor) multiplying every effective radius on
    that terrain (how this robot's tracks bite into it); terrains not named use 1.
    ``model``: the true kinematic model (:mod:`odolab.core.models`; a tracked vehicle is an
    :class:`~odolab.core.models.IcrModel`); the differential drive of ``track_width`` by default.
    ``turn_slip`` (``gamma``): how the true model's turning denominator (the ICR spread, the
    effective track) depends on how sharply the robot turns. With the turn ratio
    ``s = |dn_r - dn_l| / (|dn_r| + |dn_l|)`` of the commanded wheel motion (1 in place or on a
    pivot, ``b / (2 R)`` on a curve of radius R, 0 straight) the denominator is
    ``denominator * (1 - gamma * (1 - s))``: the tracks skid most when turning in place, so a
    wide curve turns closer to what the wheels say (Mandow et al. 2007 found the ICRs move
    outwards with the turn rate).
    """

    left_radius_forward: float
    left_radius_reverse: float
    right_radius_forward: float
    right_radius_reverse: float
    track_width: float
    k_left: float = 0.0
    k_right: float = 0.0
    k_scrub: float = 0.0
    align_sigma: float = 0.0
    track_sigma: float = 0.0
    speed_slip: float = 0.0
    stop_slide: float = 0.0
    terrain_radius_scale: tuple[tuple[str, float], ...] = ()
    name: str = "truth"
    model: KinematicModel = DIFF_DRIVE
    turn_slip: float = 0.0

    def __post_init__(self) -> None:
        pairs = []
        for item in self.terrain_radius_scale:
            if (
                not isinstance(item, tuple)
                or len(item) != 2
                or not isinstance(item[0], str)
                or isinstance(item[1], bool)
                or not isinstance(item[1], int | float)
                or not math.isfinite(item[1])
                or item[1] <= 0
            ):
                raise SimError(
                    f"terrain_radius_scale entries must be (terrain name, factor > 0), got {item!r}"
                )
            pairs.append((item[0], float(item[1])))
        object.__setattr__(self, "terrain_radius_scale", tuple(pairs))
        for f in fields(self):
            if f.name in ("name", "terrain_radius_scale", "model"):
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise SimError(f"true parameter {f.name} must be a number, got {value!r}")
            if not math.isfinite(value) or value < 0:
                raise SimError(f"true parameter {f.name} must be finite and >= 0, got {value!r}")
            object.__setattr__(self, f.name, float(value))
        for key in (
            "left_radius_forward",
            "left_radius_reverse",
            "right_radius_forward",
            "right_radius_reverse",
            "track_width",
        ):
            if getattr(self, key) <= 0:
                raise SimError(f"true parameter {key} must be > 0")
        if not is_kinematic_model(self.model):
            raise SimError(f"true model must be a kinematic model, got {self.model!r}")
        if self.turn_slip >= 1.0:
            raise SimError(f"true parameter turn_slip must be < 1, got {self.turn_slip!r}")

    @classmethod
    def from_nominal(cls, nominal: RobotParams, **changes: Any) -> TrueParams:
        """Truth equal to the nominal model (no noise), with optional changes."""
        base = cls(
            left_radius_forward=nominal.left_wheel_radius,
            left_radius_reverse=nominal.left_wheel_radius,
            right_radius_forward=nominal.right_wheel_radius,
            right_radius_reverse=nominal.right_wheel_radius,
            track_width=nominal.track_width,
            name="ideal",
        )
        return replace(base, **changes)

    def radius_scale_on(self, terrain: str) -> float:
        """This robot's effective-radius factor on a terrain (1 where none is given)."""
        return dict(self.terrain_radius_scale).get(terrain, 1.0)

    def with_(self, **changes: Any) -> TrueParams:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @property
    def noiseless(self) -> TrueParams:
        """The same systematic behaviour without any random term."""
        return replace(self, k_left=0.0, k_right=0.0, k_scrub=0.0, align_sigma=0.0, track_sigma=0.0)
