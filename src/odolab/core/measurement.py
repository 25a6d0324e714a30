"""Measurements in the lab's own terms: compass readings and counted turns, meterstick x and y.

Compass sign convention
-----------------------
The analog compass reads degrees **clockwise from north**, in ``[0, 360)``. The robot's heading
is counter-clockwise positive. So a counter-clockwise (positive) rotation *decreases* the
reading: turning ccw by 30 deg from a reading of 100 deg gives 70 deg.

A person counts the *whole* turns the robot made (``turns``, an integer >= 0) and reads the
compass before and after. For a counter-clockwise rotation the actual rotation is::

    rotation = turns * 2 pi + radians((initial - final) mod 360)          (>= 0)

and for a clockwise one (``direction="cw"``, or a negative commanded angle)::

    rotation = -(turns * 2 pi + radians((final - initial) mod 360))       (<= 0)

Each reading has a standard uncertainty ``sigma_reading_rad`` (0.05 rad by default, the lab
report's compass figure); the difference of two readings has ``sqrt(2)`` times that. The whole
turns are counted, hence exact.

Every refusal is an :class:`~odolab.core.errors.StoreError` whose message says what was wrong.
(This module was ``odolab.store.entry``, which still re-exports it: the notebook stores
measurements; this core module is how they are made from readings.)
"""

from __future__ import annotations

import math
from typing import Literal

from odolab.core.errors import StoreError
from odolab.core.trials import MAX_POSITION_M, Measurement

__all__ = [
    "COMPASS_SIGMA_RAD",
    "MAX_POSITION_M",
    "METERSTICK_SIGMA_M",
    "check_compass_reading",
    "check_position",
    "check_reading",
    "count_turns",
    "rotation_from_compass",
    "rotation_measurement_from_compass",
    "translation_measurement",
]

#: Standard uncertainty of one compass reading (rad): the lab report's 0.05 rad.
COMPASS_SIGMA_RAD = 0.05
#: Below this (rad, no whole turn counted) a rotation against the command is a stall read a hair
#: the other way, not a contradiction.
_HAIR_RAD = 0.5 * math.pi
#: Standard uncertainty of a position read with a meterstick against floor tape (m).
METERSTICK_SIGMA_M = 0.005


def check_reading(value: object, name: str) -> float:
    """``value`` as a finite float, or a :class:`StoreError` naming ``name``."""
    if isinstance(value, bool):
        raise StoreError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as err:
        raise StoreError(f"{name} must be a number, got {value!r}") from err
    if not math.isfinite(x):
        raise StoreError(f"{name} must be a finite number, got {value!r}")
    return x


def check_position(value: object, name: str) -> float:
    """``value`` (m) as a float if it is a measured position within :data:`MAX_POSITION_M`.

    The one range check of a measured x or y: ``trials add``/``measure``, CSV and JSON import.
    """
    x = check_reading(value, name)
    if abs(x) > MAX_POSITION_M:
        raise StoreError(
            f"{name} is {x:g} m; a measured position must be within {MAX_POSITION_M:g} m "
            "(was it typed in cm or mm?)"
        )
    return x


def check_compass_reading(value: object, name: str = "compass reading") -> float:
    """``value`` (deg) as a float if it is a compass reading in [0, 360), else refuse."""
    x = check_reading(value, name)
    if not 0.0 <= x < 360.0:
        raise StoreError(
            f"{name} is {x:g} deg; a compass reads from 0 up to (not including) 360 deg"
        )
    return x


def _check_turns(value: object) -> int:
    x = check_reading(value, "turns")
    if x < 0 or not x.is_integer():
        raise StoreError(f"turns is {x:g}; expected a whole number of turns, 0 or more")
    return int(x)


def rotation_from_compass(
    initial_deg: float, final_deg: float, turns: int, direction: Literal["ccw", "cw"] = "ccw"
) -> float:
    """Signed total rotation (rad, ccw positive) from two compass readings and whole turns.

    Inputs are not validated here; see :func:`rotation_measurement_from_compass`.
    """
    if direction == "ccw":
        frac = (initial_deg - final_deg) % 360.0
        return turns * 2.0 * math.pi + math.radians(frac)
    frac = (final_deg - initial_deg) % 360.0
    return -(turns * 2.0 * math.pi + math.radians(frac))


def count_turns(
    initial_deg: float, final_deg: float, true_change: float
) -> tuple[int, Literal["ccw", "cw"]]:
    """How an operator who watched the robot counts a rotation: the whole turns and the
    direction in which the rest is read off two compass readings (deg, clockwise from north),
    for a true signed heading change ``true_change`` (rad, ccw positive).

    The direction is the way the robot truly turned; when it (almost) did not turn and the
    readings lie a hair the other way, that way, with no whole turn. So
    ``rotation_from_compass(initial_deg, final_deg, turns, direction)`` is ``true_change`` up to
    the reading errors, never a whole turn off. The one counting rule of the virtual
    instruments (:mod:`odolab.sim.instruments`, ``trials measure --virtual``, the lab's runs).
    """
    direction: Literal["ccw", "cw"] = "cw" if true_change < 0 else "ccw"
    rest = abs(rotation_from_compass(initial_deg, final_deg, 0, direction))
    turns = round((abs(true_change) - rest) / (2.0 * math.pi))
    if turns < 0:  # the rest, read the robot's way, is more than it turned: read the other way
        return 0, "ccw" if direction == "cw" else "cw"
    return turns, direction


def rotation_measurement_from_compass(
    initial_deg: float,
    final_deg: float,
    turns: int,
    *,
    commanded_angle: float | None = None,
    direction: Literal["ccw", "cw"] | None = None,
    sigma_reading_rad: float = COMPASS_SIGMA_RAD,
    max_relative_error: float = 0.5,
    instrument: str = "compass",
    predicted_angle: float | None = None,
) -> Measurement:
    """A rotation :class:`Measurement` from compass readings (deg, clockwise from north).

    ``direction`` defaults to the sign of ``commanded_angle`` (rad), else counter-clockwise; a
    direction against the command is refused unless the robot hardly turned (no whole turn and
    under a quarter turn: a stall whose readings lie a hair the other way, see :func:`count_turns`).
    With ``commanded_angle`` the result is refused when it is off from the command by more than
    ``max(pi, max_relative_error * |commanded_angle|)`` (a miscounted turn, a swapped reading):
    the message says which number of turns would fit what the odometry saw
    (``predicted_angle``, the trial's predicted heading change, when given; else the command).
    """
    initial = check_compass_reading(initial_deg, "compass initial reading")
    final = check_compass_reading(final_deg, "compass final reading")
    n = _check_turns(turns)
    sigma = check_reading(sigma_reading_rad, "sigma_reading_rad")
    if sigma <= 0:
        raise StoreError(f"sigma_reading_rad must be positive, got {sigma:g}")
    if direction is None:
        direction = "cw" if commanded_angle is not None and commanded_angle < 0 else "ccw"
    if direction not in ("ccw", "cw"):
        raise StoreError(f"direction is {direction!r}; expected 'ccw' or 'cw'")
    rotation = rotation_from_compass(initial, final, n, direction)
    if commanded_angle is not None:
        cmd = check_reading(commanded_angle, "commanded angle")
        hair = n == 0 and abs(rotation) < _HAIR_RAD  # a stall, its readings a hair the other way
        if cmd != 0 and (cmd > 0) != (direction == "ccw") and not hair:
            raise StoreError(f"direction {direction} contradicts the commanded angle {cmd:.4g} rad")
        tol = max(math.pi, max_relative_error * abs(cmd))
        if abs(rotation - cmd) > tol:
            frac = abs(rotation) - 2.0 * math.pi * n
            seen = cmd if predicted_angle is None else check_reading(predicted_angle, "predicted")
            fit = max(0, round((abs(seen) - frac) / (2.0 * math.pi)))
            what = (
                "the commanded angle"
                if predicted_angle is None
                else f"the {seen:.3f} rad odometry saw"
            )
            raise StoreError(
                f"rotation of {rotation:.3f} rad ({n} turn{'' if n == 1 else 's'} + "
                f"{math.degrees(frac):.1f} deg) is {abs(rotation - cmd):.3f} rad off the "
                f"commanded {cmd:.3f} rad (more than {tol:.3f} rad); check the counted turns "
                f"(about {fit} would fit {what}) and the readings"
            )
    return Measurement(
        instrument=instrument,
        rotation=rotation,
        sigma_rotation=math.sqrt(2.0) * sigma,
        raw={"compass_initial_deg": initial, "compass_final_deg": final, "turns": float(n)},
    )


def translation_measurement(
    x: float,
    y: float,
    *,
    sigma: float = METERSTICK_SIGMA_M,
    commanded_distance: float | None = None,
    max_relative_error: float = 0.5,
    min_tolerance: float = 0.25,
    instrument: str = "meterstick",
) -> Measurement:
    """A position :class:`Measurement` (x, y in m, start frame) read with a meterstick.

    Refused: non-numbers, positions beyond 100 m, and, with ``commanded_distance`` (m), an end
    point farther than ``max(min_tolerance, max_relative_error * |commanded_distance|)`` from
    ``(commanded_distance, 0)`` (a swapped sign, centimetres typed as metres).
    """
    xv = check_position(x, "x")
    yv = check_position(y, "y")
    s = check_reading(sigma, "sigma")
    if s <= 0:
        raise StoreError(f"sigma must be positive, got {s:g} m")
    if commanded_distance is not None:
        d = check_reading(commanded_distance, "commanded distance")
        tol = max(min_tolerance, max_relative_error * abs(d))
        off = math.hypot(xv - d, yv)
        if off > tol:
            raise StoreError(
                f"measured end point ({xv:g}, {yv:g}) m is {off:.3f} m from the commanded "
                f"({d:g}, 0) m (more than {tol:.3f} m); check the signs and the unit (metres)"
            )
    return Measurement(instrument=instrument, x=xv, y=yv, sigma_xy=s, raw={"x_m": xv, "y_m": yv})
