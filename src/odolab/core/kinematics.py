"""The kinematic model's one pose step, compiled once, used by every part of odolab.

Convention: x forward, y left, heading counter-clockwise positive (radians). ``track_width`` is
``2 * L_robot``. Wheel (track) surface displacements ``ds_l``, ``ds_r`` (eqs. 3.1, 3.2) become a
body motion ``(d_forward, d_lateral, d_theta)`` through the robot's kinematic model (a value from
:mod:`odolab.core.models`; the lab's differential drive, eqs. 3.3, 3.4, by default), and the pose step
moves the robot by the chord of the arc it drove in one cycle::

    dx = f(dtheta) * (d_forward * cos(m) - d_lateral * sin(m))
    dy = f(dtheta) * (d_forward * sin(m) + d_lateral * cos(m))      m = heading + dtheta / 2

with ``f = 1`` for the lab's midpoint rule (3.5, 3.6) and ``f = sin(dtheta/2) / (dtheta/2)`` for
the exact circular arc (constant body velocity over the cycle). One small-angle rule,
:data:`SMALL_ANGLE`, decides when the series ``1 - u^2/6`` replaces ``sin(u)/u``.

:func:`body_motion` and :func:`step_pose` are numba-compiled and inlined into the batch kernels
(:mod:`odolab.core.odometry`, :mod:`odolab.sim.physics`). Their source is plain Python,
:mod:`odolab.core._step_kernels`, and one cycle at a time (streaming odometry, the virtual board,
:func:`pose_step`) runs that source as Python: the same operations, the same numbers, and no
numba in a process that drives a robot over a link without a covariance. The compiled functions
live in :mod:`odolab.core._kinematics_jit` and are loaded on first use of their names here
(``from odolab.core.kinematics import step_pose``), so importing this module does not import
numba.

The maths has one plain statement each, here: the step :func:`odometry_step` (its chord
:func:`chord_factors`) and the wrap :func:`wrap_angle`, in numpy; the compiled :func:`step_pose`,
:func:`chord` and :func:`wrap` are their twins, tested equal (tests/core/test_one_maths.py). The
counter rollover's is :func:`odolab.core.encoders.counter_delta`.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray

from odolab.core import _angles

__all__ = [
    "SMALL_ANGLE",
    "Method",
    "body_motion",
    "body_motion_from_wheel_displacements",
    "chord",
    "chord_derivative",
    "chord_factor",
    "chord_factors",
    "odometry_step",
    "pose_step",
    "step_pose",
    "wheel_displacements_from_dticks",
    "wrap",
    "wrap_angle",
]

if TYPE_CHECKING:
    from odolab.core._kinematics_jit import body_motion, chord, chord_derivative, step_pose, wrap

#: The compiled functions, defined in odolab.core._kinematics_jit (numba is imported on first use).
_COMPILED = frozenset({"body_motion", "chord", "chord_derivative", "step_pose", "wrap"})


def __getattr__(name: str) -> object:
    """The compiled functions, loaded on first use (importing them imports numba)."""
    if name in _COMPILED:
        from odolab.core import _kinematics_jit

        return getattr(_kinematics_jit, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Below this |dtheta/2| the arc's chord factor uses its series ``1 - u^2/6`` (error < 1e-17).
SMALL_ANGLE = _angles.SMALL_ANGLE
_TWO_PI = _angles.TWO_PI

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
    from odolab.core._step_kernels import chord

    d, arc = float(dtheta), Method(method) is Method.ARC
    if arc and not math.isfinite(d):  # NaN, as numpy and the compiled chord give (math raises)
        return math.nan
    return float(chord(d, arc))


def chord_factors(dtheta: FloatOrArray, arc: bool = True) -> NDArray[np.float64]:
    """The chord factor of every step in numpy: the plain twin of the compiled :func:`chord`
    (same operations; ``1`` for the midpoint rule, ``sin(u)/u`` with ``u = dtheta/2`` for the arc,
    its series below :data:`SMALL_ANGLE`)."""
    d = np.asarray(dtheta, dtype=np.float64)
    if not arc:
        return np.ones(d.shape)
    u = 0.5 * d
    small = np.abs(u) < SMALL_ANGLE
    safe = np.where(small, 1.0, u)
    out: NDArray[np.float64] = np.where(small, 1.0 - u * u / 6.0, np.sin(safe) / safe)
    return out


def odometry_step(
    x: FloatOrArray,
    y: FloatOrArray,
    heading: FloatOrArray,
    forward: FloatOrArray,
    lateral: FloatOrArray,
    dtheta: FloatOrArray,
    arc: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The pose after one cycle's body motion (heading unwrapped), in numpy on floats or arrays:
    the one plain statement of the step, eqs. (3.5), (3.6) generalised (see the module's
    docstring). The compiled :func:`step_pose` is its twin, tested equal to it
    (tests/core/test_kinematics.py); numpy's batch paths use its parts (:func:`chord_factors`)."""
    c = chord_factors(dtheta, arc)
    m = np.add(heading, 0.5 * np.asarray(dtheta, dtype=np.float64))
    cs, sn = np.cos(m), np.sin(m)
    fx, fy = np.multiply(forward, c), np.multiply(lateral, c)
    return (
        np.add(x, fx * cs - fy * sn),
        np.add(y, fx * sn + fy * cs),
        np.add(heading, dtheta, dtype=np.float64),
    )


def pose_step(
    x: float,
    y: float,
    heading: float,
    ds: float,
    dtheta: float,
    method: Method | str = "midpoint",
    lateral: float = 0.0,
) -> tuple[float, float, float]:
    """Eqs. (3.5), (3.6) and the heading update: the pose after one cycle (heading unwrapped).

    ``ds`` is the forward motion of the body, ``lateral`` its sideways motion (models with a
    lateral ICR offset), ``dtheta`` its heading change; all for one cycle."""
    from odolab.core._step_kernels import step_pose

    args = (float(x), float(y), float(heading), float(ds), float(lateral), float(dtheta))
    arc = Method(method) is Method.ARC
    if not all(math.isfinite(v) for v in args):  # NaN or inf out, as the compiled step gives
        with np.errstate(invalid="ignore"):  # (math's sin and cos raise on infinity)
            ax, ay, ah = odometry_step(*args, arc)
        return float(ax), float(ay), float(ah)
    nx, ny, nh = step_pose(*args, arc)
    return float(nx), float(ny), float(nh)


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
