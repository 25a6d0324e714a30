"""The pose step's kernels as plain Python, the one source of both ways they run.

:mod:`odolab.core._kinematics_jit` compiles each of them with numba (its twin, made from this
source: :func:`odolab.core._jit.twin`), and the batch passes and the simulator inline those; the
streaming odometry (:class:`odolab.core.odometry.Odometry`, one cycle at a time) and the virtual
board's plant call them here, as Python: a cycle costs a few microseconds, and a process that
drives a robot over a link (without a covariance) does not load numba (its import and its kernels' load: 0.5-1 s of CPU). Floats
only, and only what numba compiles the same way (``math``, no numpy), so both ways give the same
numbers for finite inputs (tests/core/test_one_maths.py); on an infinite angle ``math`` raises
where numba gives NaN, and the Python callers check their inputs first.
"""

from __future__ import annotations

import math

from odolab.core._angles import SMALL_ANGLE
from odolab.core._angles import TWO_PI as _TWO_PI

__all__ = ["body_motion", "chord", "chord_derivative", "step_pose", "wrap"]


def chord(dtheta: float, arc: bool) -> float:
    """Ratio chord/arc length for one step: 1 (midpoint) or ``sin(u)/u``, ``u = dtheta/2`` (arc)."""
    if not arc:
        return 1.0
    u = 0.5 * dtheta
    if abs(u) < SMALL_ANGLE:
        return 1.0 - u * u / 6.0
    return math.sin(u) / u


def chord_derivative(dtheta: float, arc: bool) -> float:
    """d chord / d dtheta: 0 (midpoint) or ``(u cos u - sin u) / (2 u^2)`` (arc, series near 0)."""
    if not arc:
        return 0.0
    u = 0.5 * dtheta
    if abs(u) < SMALL_ANGLE:
        return -u / 6.0
    return 0.5 * (u * math.cos(u) - math.sin(u)) / (u * u)


def body_motion(
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


def step_pose(
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


def wrap(angle: float) -> float:
    """One float wrapped to (-pi, pi], as :func:`odolab.core.kinematics.wrap_angle` does."""
    a = angle + math.pi
    w = a - _TWO_PI * math.floor(a / _TWO_PI) - math.pi
    if w <= -math.pi:
        w += 2.0 * math.pi
    return w
