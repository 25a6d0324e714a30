"""The lab report's kinematic model as pure functions (eqs. 3.1-3.6).

Convention: x forward, y left, heading counter-clockwise positive (radians). ``track_width`` is
``2 * L_robot``. Every function works on floats or numpy arrays of the same shape (element-wise).

The pose step moves the robot by the chord of the arc it drove in one cycle::

    dx = ds * f(dtheta) * cos(heading + dtheta / 2)
    dy = ds * f(dtheta) * sin(heading + dtheta / 2)

with ``f = 1`` for the lab's midpoint rule (3.5, 3.6) and ``f = sin(dtheta/2) / (dtheta/2)`` for
the exact circular arc (the chord of an arc of length ``ds`` turning ``dtheta``).
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Method",
    "body_motion_from_wheel_displacements",
    "chord_factor",
    "pose_step",
    "wheel_displacements_from_dticks",
    "wrap_angle",
]

FloatOrArray = TypeVar("FloatOrArray", float, NDArray[np.float64])


class Method(StrEnum):
    """How one cycle's motion moves the pose."""

    MIDPOINT = "midpoint"  #: the lab's rule (3.5, 3.6): straight step at the mid-cycle heading
    ARC = "arc"  #: exact circular arc at constant wheel speeds


def wheel_displacements_from_dticks(
    dticks_left: FloatOrArray,
    dticks_right: FloatOrArray,
    left_wheel_radius: float,
    right_wheel_radius: float,
    ticks_per_rev: float,
) -> tuple[FloatOrArray, FloatOrArray]:
    """Eqs. (3.1), (3.2): distance rolled by each wheel, ``2*pi*r*dticks/ticks_per_rev`` (m)."""
    kl = 2.0 * math.pi * left_wheel_radius / ticks_per_rev
    kr = 2.0 * math.pi * right_wheel_radius / ticks_per_rev
    return dticks_left * kl, dticks_right * kr


def body_motion_from_wheel_displacements(
    ds_left: FloatOrArray, ds_right: FloatOrArray, track_width: float
) -> tuple[FloatOrArray, FloatOrArray]:
    """Eqs. (3.4), (3.3): ``ds = (ds_r + ds_l) / 2`` and ``dtheta = (ds_r - ds_l) / track_width``."""
    return (ds_right + ds_left) * 0.5, (ds_right - ds_left) / track_width


def chord_factor(dtheta: float, method: Method | str) -> float:
    """Ratio chord/arc length for one step: 1 for midpoint, ``sin(u)/u`` (u = dtheta/2) for arc."""
    if Method(method) is Method.MIDPOINT:
        return 1.0
    u = 0.5 * dtheta
    if abs(u) < 1e-4:
        return 1.0 - u * u / 6.0
    return math.sin(u) / u


def pose_step(
    x: float, y: float, heading: float, ds: float, dtheta: float, method: Method | str = "midpoint"
) -> tuple[float, float, float]:
    """Eqs. (3.5), (3.6) and the heading update: the pose after one cycle (heading unwrapped)."""
    c = ds * chord_factor(dtheta, method)
    mid = heading + 0.5 * dtheta
    return x + c * math.cos(mid), y + c * math.sin(mid), heading + dtheta


def wrap_angle(angle: FloatOrArray) -> FloatOrArray:
    """Wrap an angle (rad) to (-pi, pi]; works on floats and arrays."""
    if isinstance(angle, np.ndarray):
        a = angle + np.pi
        w = a - 2.0 * np.pi * np.floor(a / (2.0 * np.pi)) - np.pi
        w = np.where(w <= -np.pi, w + 2.0 * np.pi, w)
        return w.astype(np.float64)
    if not math.isfinite(angle):
        return math.nan  # as the array branch gives (math.floor would raise)
    a = angle + math.pi
    w = a - 2.0 * math.pi * math.floor(a / (2.0 * math.pi)) - math.pi
    if w <= -math.pi:
        w += 2.0 * math.pi
    return w
