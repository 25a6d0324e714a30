"""The compiled pose-step functions of :mod:`odolab.core.kinematics` (numba), in their own module so
that importing :mod:`odolab.core.kinematics` does not import numba: reach them through
``odolab.core.kinematics`` (``from odolab.core.kinematics import step_pose``), which loads this on first use.
"""

from __future__ import annotations

import math

from odolab.core._angles import SMALL_ANGLE
from odolab.core._angles import TWO_PI as _TWO_PI
from odolab.core._jit import njit

__all__ = ["body_motion", "chord", "chord_derivative", "step_pose", "wrap"]


@njit(cache=True, inline="always")
def chord(dtheta: float, arc: bool) -> float:  # pragma: no cover - compiled
    """Ratio chord/arc length for one step: 1 (midpoint) or ``sin(u)/u``, ``u = dtheta/2`` (arc)."""
    if not arc:
        return 1.0
    u = 0.5 * dtheta
    if abs(u) < SMALL_ANGLE:
        return 1.0 - u * u / 6.0
    return math.sin(u) / u


@njit(cache=True, inline="always")
def chord_derivative(dtheta: float, arc: bool) -> float:  # pragma: no cover - compiled
    """d chord / d dtheta: 0 (midpoint) or ``(u cos u - sin u) / (2 u^2)`` (arc, series near 0)."""
    if not arc:
        return 0.0
    u = 0.5 * dtheta
    if abs(u) < SMALL_ANGLE:
        return -u / 6.0
    return 0.5 * (u * math.cos(u) - math.sin(u)) / (u * u)


@njit(cache=True, inline="always")
def body_motion(  # pragma: no cover - compiled
    w_left: float,
    w_right: float,
    e_left: float,
    e_right: float,
    denominator: float,
    lateral: float,
    ds_left: float,
    ds_right: float,
) -> tuple[float, float, float]:
    """(d_forward, d_lateral, d_theta) from wheel displacements and a model's six coefficients.

    The coefficients are :class:`odolab.core.models.ModelCoefficients` in order; for the differential
    drive this is eqs. (3.3), (3.4) with the same floating-point operations."""
    dth = (e_right * ds_right - e_left * ds_left) / denominator
    return w_left * ds_left + w_right * ds_right, lateral * dth, dth


@njit(cache=True, inline="always")
def step_pose(  # pragma: no cover - compiled
    x: float, y: float, heading: float, forward: float, lateral: float, dtheta: float, arc: bool
) -> tuple[float, float, float]:
    """The pose after one cycle's body motion (heading unwrapped): eqs. (3.5), (3.6) generalised."""
    c = chord(dtheta, arc)
    m = heading + 0.5 * dtheta
    cs = math.cos(m)
    sn = math.sin(m)
    fx = forward * c
    fy = lateral * c
    return x + (fx * cs - fy * sn), y + (fx * sn + fy * cs), heading + dtheta


@njit(cache=True, inline="always")
def wrap(angle: float) -> float:  # pragma: no cover - compiled
    """Compiled :func:`wrap_angle` for one float."""
    a = angle + math.pi
    w = a - _TWO_PI * math.floor(a / _TWO_PI) - math.pi
    if w <= -math.pi:
        w += 2.0 * math.pi
    return w
